"""Pictures of a polarimeter frame: intensity, AoP (cyclic colour map) and DoP, for people.

Used by ``auv-twin render`` (PNG files) and the Rerun recorder (images). The AoP map is OpenCV's
``TWILIGHT_SHIFTED``, a cyclic map, so that −90° and +90° (the same E-vector) get the same colour;
DoP uses ``VIRIDIS`` on [0, 1]; intensity is S0 scaled to its 99.5th percentile (the sun disc
saturates anyway) with a 1/2.2 gamma.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from twin.onboard.polarization import PolarizationImage


def intensity_u8(
    s0: NDArray[np.floating], *, percentile: float = 99.5, top: float | None = None
) -> NDArray[np.uint8]:
    """S0 as an 8-bit grey image (gamma 1/2.2); a dark frame stays black.

    Scaled to ``top`` (DN: a fixed scale across images) or else to the image's own percentile.
    """
    s = np.asarray(s0, dtype=np.float32)
    if top is None:
        top = percentile_of(s, percentile) if s.size else 0.0
    if not (math.isfinite(top) and top > 0):
        return np.zeros(s.shape, dtype=np.uint8)
    # Clipped below at 1e-30, not 0: numpy's float32 power takes a slow path at 0 (ten times a
    # pixel's time, and a fisheye frame is ~40 % black outside its circle), and any value under
    # 1e-30 reads 0 either way (1e-30 ** (1/2.2) · 255 + 0.5 rounds to 0.5 in float32).
    x = np.clip(s / top, 1e-30, 1.0) ** (1.0 / 2.2)
    return (x * 255.0 + 0.5).astype(np.uint8)


def percentile_of(a: NDArray[np.floating], q: float) -> float:
    """``np.percentile(a, q)`` (its default, linear method): the same number, faster for a high q.

    ``np.percentile`` partitions the whole array (0.7 ms for a 306×256 S0), yet the two order
    statistics it interpolates between lie in the top (100 − q) %. A threshold taken from a
    sixteenth of the pixels keeps a superset of them (about twice as many values as needed); the
    rest are all below it, so the order statistics keep their ranks, shifted by how many were
    dropped. The interpolation is numpy's own, operation for operation (``tests/test_images.py``
    holds it to ``np.percentile`` bit for bit); any array this does not suit (small, non-finite,
    a threshold that keeps too few) goes to ``np.percentile`` itself.
    """
    flat = np.ravel(a)
    n = flat.size
    qq = q / 100.0
    # numpy's virtual index for 'linear' (Hyndman & Fan's 7th: alpha = beta = 1), in its order.
    vi = n * qq + (1.0 + qq * (1.0 - 1.0 - 1.0)) - 1.0
    lo = math.floor(vi) if math.isfinite(vi) else -1
    if n < 4096 or not 0 <= lo < n - 1 or not math.isfinite(float(flat.sum())):
        return float(np.percentile(flat, q))
    need = n - lo  # the values at rank lo and above
    sample = flat[::16]
    k = len(sample) - 1 - min(len(sample) - 1, 2 * (need // 16) + 32)
    threshold = np.partition(sample, k)[k]
    candidates = flat[flat >= threshold]
    r = lo - (n - candidates.size)  # rank lo among the candidates
    if r < 0:
        return float(np.percentile(flat, q))
    part = np.partition(candidates, (r, r + 1))
    below, above = part[r], part[r + 1]
    gamma = vi - lo
    diff = above - below  # numpy's _lerp, in the array's dtype
    if gamma >= 0.5:
        return float(above - diff * (1 - gamma))
    return float(below + diff * gamma)


@functools.cache
def _colormap_rgb(colormap: int) -> NDArray[np.uint8]:
    """(256, 1, 3) the RGB colours of an OpenCV colour map, for ``cv2.LUT``.

    ``applyColorMap`` builds its table on every call (0.4 ms at 306×256) and is this table
    looked up: the image is the same byte for byte (``tests/test_images.py``).
    """
    bgr = cv2.applyColorMap(np.arange(256, dtype=np.uint8).reshape(256, 1), colormap)
    return np.ascontiguousarray(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))


def _mapped(idx: NDArray[np.uint8], colormap: int, mask: NDArray[np.bool_] | None) -> NDArray:
    """Colour indices through a map; masked-out pixels black.

    The mask is a copy under it (0.01 ms at 306×256, where the boolean assignment took 0.5 ms).
    """
    rgb = cv2.LUT(cv2.merge((idx, idx, idx)), _colormap_rgb(colormap))
    if mask is None:
        return rgb
    return cv2.copyTo(rgb, np.ascontiguousarray(mask, dtype=bool).view(np.uint8))


def _index(x: NDArray[np.float32]) -> NDArray[np.uint8]:
    """A colour index in [0, 255] (truncated) of ``x``, a temporary it overwrites; NaN → 0.

    ``np.clip`` keeps a NaN, and casting it to uint8 is undefined (numpy warns; x86 gives 0):
    it is set to 0 first, so every platform draws such a pixel in the map's first colour.
    (``np.fmax``/``np.fmin`` do both in one, at twice the time of this: 87 against 56 µs for
    306×256, measured.)
    """
    np.clip(x, 0.0, 255.0, out=x)
    np.copyto(x, 0.0, where=np.isnan(x))
    return x.astype(np.uint8)


def aop_rgb(aop: NDArray[np.floating], mask: NDArray[np.bool_] | None = None) -> NDArray[np.uint8]:
    """AoP in [−π/2, π/2) as RGB, a cyclic map; masked-out pixels black, NaN the first colour."""
    a = np.asarray(aop, dtype=np.float32)
    return _mapped(_index((a + math.pi / 2) / math.pi * 255.0), cv2.COLORMAP_TWILIGHT_SHIFTED, mask)


def dop_rgb(dop: NDArray[np.floating], mask: NDArray[np.bool_] | None = None) -> NDArray[np.uint8]:
    """DoP in [0, 1] as RGB (viridis); masked-out pixels black, NaN the first colour."""
    return _mapped(_index(np.asarray(dop, dtype=np.float32) * 255.0), cv2.COLORMAP_VIRIDIS, mask)


def signal_mask(pol: PolarizationImage, min_s0: float = 20.0) -> NDArray[np.bool_]:
    """Pixels bright enough for their AoP/DoP to mean something (S0 above ``min_s0`` DN)."""
    return np.asarray(pol.s0) > min_s0


def write_pngs(
    pol: PolarizationImage, out_dir: Path | str, stem: str, s0_max: float | None = None
) -> list[Path]:
    """Write ``{stem}_intensity.png``, ``_aop.png`` and ``_dop.png``; return the paths.

    ``s0_max`` fixes the intensity scale's top (DN); None scales each image to itself.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    mask = signal_mask(pol)
    images = {
        "intensity": intensity_u8(pol.s0, top=s0_max),
        "aop": cv2.cvtColor(aop_rgb(pol.aop, mask), cv2.COLOR_RGB2BGR),
        "dop": cv2.cvtColor(dop_rgb(pol.dop, mask), cv2.COLOR_RGB2BGR),
    }
    return write_planes(images, out, stem, "png")


def write_planes(planes: dict[str, np.ndarray], out: Path, stem: str, ext: str) -> list[Path]:
    """Write each image as ``{stem}_{name}.{ext}`` with OpenCV (8-bit PNG, 32-bit float TIFF).

    Raises:
        OSError: A file could not be written (naming it).
    """
    paths = []
    for name, img in planes.items():
        p = Path(out) / f"{stem}_{name}.{ext}"
        if not cv2.imwrite(str(p), img):
            raise OSError(f"could not write {p}")
        paths.append(p)
    return paths
