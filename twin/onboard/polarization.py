"""Stokes images from a raw division-of-focal-plane (DoFP) mosaic: the one shared derivation.

Onboard code (the compass methods) and the renderer's derived debug layers both call
:func:`stokes_from_mosaic`, so what the vehicle computes and what the twin shows are the same
numbers. This module is on the onboard side: it imports only numpy, OpenCV and the standard library.

Conventions:

* Layout: ``layout_deg[r][c]`` is the analyser angle of raw pixel (r, c) of every 2×2 super-pixel,
  in degrees. Default :data:`IMX250MZR_LAYOUT_DEG`: (0,0)=90°, (0,1)=45°, (1,0)=135°, (1,1)=0°
  (Sony IMX250MZR/IMX264MZR; ``elerac/polanalyser:polanalyser/demosaicing.py``). A camera that
  reads out with a one-pixel ROI offset or a flipped image has another phase or sense: declare it.
* Angles (analyser angles and the AoP) are measured from the image +u axis (increasing column)
  towards +v (increasing row): clockwise on a display with row 0 at the top. That is the sense
  of ``sensors.polarimeter.stokes`` (right-handed about the direction the light travels) in the
  twin's image frame, where (``sensors.polarimeter.unit.camera``) v runs along camera −y, light
  reaches the sensor along −z and the sensor-plane reference is +x = +u. The twin's image is the
  sky drawn as a map seen from above — the mirror image of what a physical upward-looking camera
  delivers — so on a real camera's own, unmirrored frame the same physical sense is
  counter-clockwise. Frames and layouts from real hardware must be mirrored to the twin's
  convention first: a left-right flip turns the IMX250MZR layout into ((45, 90), (0, 135)) if
  Sony's labels count counter-clockwise on the camera's own image [uncertain: not checked
  against Sony's datasheet drawing].
* Units: S0, S1, S2 in DN above the black level. Each pixel sees
  ``I_k = ½ (S0 + S1 cos 2α_k + S2 sin 2α_k)``, so an unpolarised field of ``v`` DN per pixel has
  S0 = 2v. For the standard four angles the least-squares inverse is ``S0 = ½ ΣI_k``,
  ``S1 = I0 − I90``, ``S2 = I45 − I135`` (optics.md §3.2).

Methods:
* ``"superpixel"``: one Stokes vector per 2×2 block (half resolution): output (i, j) belongs to
  raw rows 2i..2i+1 and columns 2j..2j+1, its centre is at raw (2i + ½, 2j + ½) — mind that
  when mapping it back to the lens model. No interpolation error, at the price of the four
  analysers looking at points up to a pixel apart (an AoP/DoP error where the intensity changes
  steeply, e.g. at the edge of Snell's window).
* ``"interpolate"``: full resolution, output (r, c) at raw pixel (r, c). Each analyser channel
  is bilinearly interpolated from its own 2×2-periodic lattice (the interpolation polanalyser's
  ``COLOR_PolarMono`` does through OpenCV's Bayer conversion), and the channels are combined.
  Both steps are linear, so the code filters the weighted raw mosaic once per Stokes component
  instead of demosaicing four channels: three 3×3 filters. Borders use reflect-101 padding,
  which keeps the 2×2 phase.

AoP is in [−π/2, π/2). DoP is ``√(S1² + S2²) / S0`` clipped to [0, 1]; it is 0 where S0 ≤ 0
(black-level-subtracted dark pixels) and never NaN. Noise biases the DoP of dim, weakly polarised
pixels upwards (the estimator is a norm) and can push it past 1, where it is clipped.

Speed, one thread of the shared dev VM (best of 20, the spread is the VM's load): 2448×2048
superpixel 17–24 ms, interpolate 67–105 ms; 612×512 superpixel 1.0–1.9 ms, interpolate 4–6 ms.

Saturated pixels: a clipped analyser channel makes S1/S2/S0 wrong, so AoP and DoP there are
biased (a fully saturated super-pixel reads DoP = 0). Pass ``saturation_dn`` (e.g. 4095 for a
12-bit camera) to get a ``saturated`` mask of every output pixel that used a clipped raw value.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np
from numpy.typing import NDArray

#: Sony IMX250MZR / IMX264MZR super-pixel: analyser angle (deg) of raw pixel (row, col).
IMX250MZR_LAYOUT_DEG: tuple[tuple[float, float], tuple[float, float]] = ((90.0, 45.0), (135.0, 0.0))

Layout = tuple[tuple[float, float], tuple[float, float]]
Method = Literal["superpixel", "interpolate"]

_ACCEPTED_DTYPES = (np.uint8, np.uint16, np.float32, np.float64)
_PI_F32 = np.float32(math.pi)
_TINY = 1e-30  # a positive floor for S0 in the DoP division
_BAND_PIXELS = 1 << 18  # raw pixels a band: the temporaries of a band fit in L2
# Bilinear interpolation of a 2×2-periodic lattice: the value itself at its own sites, the mean of
# 2 at edge neighbours, of 4 at diagonal ones.
_BILINEAR = np.array([[1.0, 2.0, 1.0], [2.0, 4.0, 2.0], [1.0, 2.0, 1.0]], np.float32) / 4.0


@dataclass(frozen=True, slots=True)
class PolarizationImage:
    """Linear Stokes images of one frame, float32, all the same shape.

    Attributes:
        s0: Total intensity, DN above black level (``½ ΣI_k``).
        s1: ``I0 − I90`` equivalent, DN (reference: the image +u axis).
        s2: ``I45 − I135`` equivalent, DN.
        aop: Angle of polarization (rad) from the image +u axis (columns) towards +v (rows),
            in [−π/2, π/2).
        dop: Degree of linear polarization in [0, 1]; 0 where S0 ≤ 0.
        saturated: Bool mask of output pixels computed from a raw value ≥ ``saturation_dn``
            (all False when no saturation level was given).
    """

    s0: NDArray[np.float32]
    s1: NDArray[np.float32]
    s2: NDArray[np.float32]
    aop: NDArray[np.float32]
    dop: NDArray[np.float32]
    saturated: NDArray[np.bool_]

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of every layer."""
        return self.s0.shape  # type: ignore[return-value]


@dataclass(frozen=True, slots=True)
class StokesPlanes:
    """S0, S1, S2 of one frame without the angles (float32, DN above black level).

    What a method that derives AoP and DoP at a few pixels only (after its own corrections)
    starts from: :func:`stokes_planes_from_mosaic`; the layers mean what
    :class:`PolarizationImage`'s do.
    """

    s0: NDArray[np.float32]
    s1: NDArray[np.float32]
    s2: NDArray[np.float32]
    saturated: NDArray[np.bool_]

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of every layer."""
        return self.s0.shape  # type: ignore[return-value]


def analysis_pinv(layout_deg: Layout = IMX250MZR_LAYOUT_DEG) -> NDArray[np.float64]:
    """The (3, 2, 2) least-squares weights W so that ``S_j = Σ_rc W[j, r, c] · I[r, c]``.

    Computed once per layout (a fresh copy each call: a caller may change it).

    Rows of the measurement matrix are ``½ [1, cos 2α, sin 2α]`` for the layout's four analysers;
    W is its Moore–Penrose inverse. For any arrangement of 0/45/90/135° it is exactly
    ``S0 = ½ΣI``, ``S1 = I0 − I90``, ``S2 = I45 − I135``.

    Raises:
        ValueError: If the layout is not 2×2 of finite angles or cannot determine S1 and S2.
    """
    try:
        key = tuple(tuple(float(x) for x in row) for row in layout_deg)
        hash(key)
    except (TypeError, ValueError):
        key = None  # not a 2×2 of numbers: the check below says what is wrong
    if key is not None and len(key) == 2 and all(len(r) == 2 for r in key):
        return _cached_pinv(key).copy()
    return _pinv(layout_deg)


def _pinv(layout_deg: Layout) -> NDArray[np.float64]:
    a = np.asarray(layout_deg, dtype=np.float64)
    if a.shape != (2, 2) or not np.all(np.isfinite(a)):
        raise ValueError(f"layout_deg = {layout_deg!r}: must be 2×2 finite analyser angles (deg)")
    two_alpha = 2.0 * np.deg2rad(a.ravel())
    m = 0.5 * np.stack([np.ones(4), np.cos(two_alpha), np.sin(two_alpha)], axis=1)
    if np.linalg.matrix_rank(m, tol=1e-9) < 3:
        raise ValueError(
            f"layout_deg = {layout_deg!r}: needs at least three distinct analyser angles (mod 180°)"
        )
    w = np.linalg.pinv(m)  # (3, 4)
    w[np.abs(w) < 1e-12] = 0.0  # exact zeros let the fast paths skip terms
    return w.reshape(3, 2, 2)


_cached_pinv = functools.lru_cache(maxsize=16)(_pinv)


def _check_raw(raw: np.ndarray) -> None:
    if not isinstance(raw, np.ndarray):
        raise TypeError(f"raw must be a numpy array, got {type(raw).__name__}")
    if raw.dtype not in _ACCEPTED_DTYPES:
        raise TypeError(
            f"raw.dtype = {raw.dtype}: must be one of uint8, uint16, float32, float64 "
            "(a raw DoFP mosaic)"
        )
    if raw.ndim != 2:
        raise ValueError(f"raw.shape = {raw.shape}: must be 2-D (rows, columns), one mosaic")
    h, w = raw.shape
    if h < 2 or w < 2 or h % 2 or w % 2:
        raise ValueError(
            f"raw.shape = {raw.shape}: rows and columns must be even and >= 2 "
            "(whole 2×2 super-pixels)"
        )
    if raw.dtype.kind == "f" and not np.isfinite(raw).all():
        raise ValueError("raw holds NaN or infinite values: a mosaic must be finite")


def _as_cv(raw: np.ndarray) -> np.ndarray:
    # Everything downstream is float32: convert a float64 mosaic once (DN need no more digits).
    if raw.dtype == np.float64:
        raw = raw.astype(np.float32)
    return np.ascontiguousarray(raw)


def _sub_lattices(raw: np.ndarray) -> list[list[np.ndarray]]:
    """The four analyser planes [r][c], each (H/2, W/2) and contiguous.

    Copying the strided views once (numpy) and then doing the arithmetic with OpenCV's
    converting, SIMD ``add``/``addWeighted`` was the fastest of six variants measured.
    """
    h, w = raw.shape
    blocks = raw.reshape(h // 2, 2, w // 2, 2)
    return [[np.ascontiguousarray(blocks[:, r, :, c]) for c in (0, 1)] for r in (0, 1)]


def _pair(a: np.ndarray, wa: float, b: np.ndarray, wb: float) -> tuple[np.ndarray, float]:
    """``(x, f)`` with ``f·x = wa·a + wb·b`` in float32, in one converting OpenCV pass."""
    if wa == wb:
        return cv2.add(a, b, dtype=cv2.CV_32F), wa
    if wa == -wb:  # subtract the negative one: no negation pass (and x − x = +0, never −0)
        if wa > 0:
            return cv2.subtract(a, b, dtype=cv2.CV_32F), wa
        return cv2.subtract(b, a, dtype=cv2.CV_32F), wb
    return cv2.addWeighted(a, wa, b, wb, 0.0, dtype=cv2.CV_32F), 1.0


def _weighted_sum(terms: list[tuple[np.ndarray, float]], offset: float) -> NDArray[np.float32]:
    """``Σ w·plane + offset`` in float32 (2–4 terms: pairs first, then one fused combine)."""
    partial = [
        _pair(a, wa, b, wb) for (a, wa), (b, wb) in zip(terms[0::2], terms[1::2], strict=False)
    ]
    if len(terms) % 2:
        a, wa = terms[-1]
        partial.append((a.astype(np.float32), wa))
    if len(partial) == 1:
        x, f = partial[0]
        x = x if x.dtype == np.float32 else x.astype(np.float32)
        if f != 1.0:
            x *= np.float32(f)
            x += np.float32(offset)  # even when 0: turns the −0 of a negative factor into +0
        elif offset != 0.0:
            x += np.float32(offset)
        return x
    (x, fx), (y, fy) = partial
    return cv2.addWeighted(x, fx, y, fy, offset, dtype=cv2.CV_32F)


def _superpixel(
    planes: list[list[np.ndarray]], w: NDArray[np.float64], black_level_dn: float
) -> list[NDArray[np.float32]]:
    out = []
    for j in range(3):
        terms = [
            (planes[r][c], float(w[j, r, c])) for r in (0, 1) for c in (0, 1) if w[j, r, c] != 0.0
        ]
        out.append(_weighted_sum(terms, -black_level_dn * float(w[j].sum())))
    return out


@functools.lru_cache(maxsize=4)
def _weight_map(shape: tuple[int, int], wj: tuple[float, float, float, float]) -> np.ndarray:
    """Full-size float32 map of a 2×2-periodic weight pattern.

    Cached (S1's and S2's for two frame sizes: 80 MB at 2448×2048) because multiplying by a map
    is one SIMD pass while numpy's broadcast over a (H/2, 2, W/2, 2) view is several times slower.
    """
    h, w = shape
    return np.tile(np.asarray(wj, np.float32).reshape(2, 2), (h // 2, w // 2))


def _interpolate(
    raw: np.ndarray, w: NDArray[np.float64], black_level_dn: float
) -> list[NDArray[np.float32]]:
    rawf = raw if raw.dtype == np.float32 else raw.astype(np.float32)
    out = []
    for j in range(3):
        wj = w[j]
        if np.all(wj == wj[0, 0]):
            # Constant weight (S0 of the standard layouts): fold it into the kernel.
            src, kernel = rawf, _BILINEAR * np.float32(wj[0, 0])
        else:
            key = tuple(float(v) for v in wj.ravel())
            src, kernel = cv2.multiply(rawf, _weight_map(rawf.shape, key)), _BILINEAR
        s = cv2.filter2D(src, cv2.CV_32F, kernel, borderType=cv2.BORDER_REFLECT_101)
        offset = black_level_dn * float(wj.sum())
        if offset != 0.0:
            s -= np.float32(offset)
        out.append(s)
    return out


def _aop_dop(
    s0: NDArray[np.float32],
    s1: NDArray[np.float32],
    s2: NDArray[np.float32],
    aop: NDArray[np.float32],
    dop: NDArray[np.float32],
) -> None:
    """Write AoP and DoP of one band into ``aop`` and ``dop`` (contiguous, same shape)."""
    # S1 is never −0 here (see _pair/_weighted_sum), so no signal gives atan2(0, +0) = AoP 0.
    np.arctan2(s2, s1, out=aop)  # numpy's float32 arctan2 is SIMD and exact to ~1 ulp
    # atan2 is in [−π, π]; +π (S2 = +0, S1 < 0) is the same axis as −π: keep [−π, π).
    wrap = np.flatnonzero(aop >= _PI_F32)
    if wrap.size:
        aop.reshape(-1)[wrap] = -_PI_F32
    aop *= np.float32(0.5)
    # DoP = min(|S_lin|, S0⁺) / max(S0, tiny): clipped to [0, 1] and 0 where S0 <= 0 with SIMD
    # passes, no NaN (np.hypot and a masked np.divide are ~10× slower on float32, measured).
    # Not cv2.magnitude: its result changes by an ulp with the buffers' alignment (measured), and
    # the same frame must give the same numbers in every run.
    lin = np.multiply(s1, s1)
    lin += np.multiply(s2, s2)
    np.sqrt(lin, out=lin)
    np.minimum(lin, np.maximum(s0, np.float32(0.0)), out=lin)
    np.divide(lin, np.maximum(s0, np.float32(_TINY)), out=dop)


def _band_rows(width: int) -> int:
    """Rows (even) of a band of about ``_BAND_PIXELS`` raw pixels."""
    return max(2, (_BAND_PIXELS // width) & ~1)


def _superpixel_image(
    raw: np.ndarray,
    w: NDArray[np.float64],
    black_level_dn: float,
    saturation_dn: float | None,
    angles: bool = True,
) -> PolarizationImage | StokesPlanes:
    # Band by band, so the four planes and the temporaries stay in cache (25 % faster, measured).
    # Without ``angles``: S0–S2 and the mask only (StokesPlanes).
    h, wd = raw.shape
    s0, s1, s2 = (np.empty((h // 2, wd // 2), np.float32) for _ in range(3))
    aop, dop = (np.empty((h // 2, wd // 2) if angles else 0, np.float32) for _ in range(2))
    sat = np.zeros((h // 2, wd // 2), bool)
    step = _band_rows(wd)
    for r0 in range(0, h, step):
        r1 = min(r0 + step, h)
        out = slice(r0 // 2, r1 // 2)
        planes = _sub_lattices(raw[r0:r1])
        b0, b1, b2 = _superpixel(planes, w, black_level_dn)
        s0[out], s1[out], s2[out] = b0, b1, b2
        if angles:
            _aop_dop(b0, b1, b2, aop[out], dop[out])
        if saturation_dn is not None:
            p = planes
            brightest = cv2.max(cv2.max(p[0][0], p[0][1]), cv2.max(p[1][0], p[1][1]))
            sat[out] = brightest >= saturation_dn
    if not angles:
        return StokesPlanes(s0, s1, s2, sat)
    return PolarizationImage(s0=s0, s1=s1, s2=s2, aop=aop, dop=dop, saturated=sat)


def aop_dop(
    s0: NDArray[np.float32], s1: NDArray[np.float32], s2: NDArray[np.float32]
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """AoP and DoP of float32 Stokes layers (any shape), as :func:`stokes_from_mosaic` has them."""
    s0, s1, s2 = (np.ascontiguousarray(x, dtype=np.float32) for x in (s0, s1, s2))
    aop, dop = np.empty_like(s0), np.empty_like(s0)
    _aop_dop(s0, s1, s2, aop, dop)
    return aop, dop


def stokes_planes_from_mosaic(
    raw: np.ndarray,
    layout_deg: Layout = IMX250MZR_LAYOUT_DEG,
    black_level_dn: float = 0.0,
    saturation_dn: float | None = None,
) -> StokesPlanes:
    """:func:`stokes_from_mosaic`'s super-pixel S0, S1, S2 without AoP and DoP (same checks).

    For a method that needs the angles at some pixels only (:func:`aop_dop` there): the angles
    are a third of the super-pixel inversion's time.
    """
    _check_raw(raw)
    if not math.isfinite(black_level_dn):
        raise ValueError(f"black_level_dn = {black_level_dn!r}: must be finite")
    planes = _superpixel_image(
        _as_cv(raw), analysis_pinv(layout_deg), black_level_dn, saturation_dn, angles=False
    )
    assert isinstance(planes, StokesPlanes)
    return planes


def _interpolated_image(
    raw: np.ndarray, w: NDArray[np.float64], black_level_dn: float, saturation_dn: float | None
) -> PolarizationImage:
    s0, s1, s2 = _interpolate(raw, w, black_level_dn)
    h, wd = raw.shape
    aop, dop = np.empty((h, wd), np.float32), np.empty((h, wd), np.float32)
    step = _band_rows(wd)
    for r0 in range(0, h, step):
        b = slice(r0, min(r0 + step, h))
        _aop_dop(s0[b], s1[b], s2[b], aop[b], dop[b])
    if saturation_dn is None:
        sat = np.zeros((h, wd), bool)
    else:
        # A full-resolution output pixel uses raw values from its 3×3 neighbourhood.
        hit = (raw >= saturation_dn).view(np.uint8)
        sat = cv2.dilate(hit, np.ones((3, 3), np.uint8)).view(bool)
    return PolarizationImage(s0=s0, s1=s1, s2=s2, aop=aop, dop=dop, saturated=sat)


def stokes_from_mosaic(
    raw: np.ndarray,
    layout_deg: Layout = IMX250MZR_LAYOUT_DEG,
    method: Method = "superpixel",
    black_level_dn: float = 0.0,
    saturation_dn: float | None = None,
) -> PolarizationImage:
    """Turn a raw DoFP mosaic into S0, S1, S2, AoP and DoP images.

    Args:
        raw: (H, W) raw frame, H and W even; uint8/uint16 counts or float32/float64 DN.
        layout_deg: Analyser angle (deg) of raw pixel (r, c) of each 2×2 super-pixel
            (default IMX250MZR: ((90, 45), (135, 0))). Angles from the image +u axis (columns)
            towards +v (rows).
        method: ``"superpixel"`` (H/2 × W/2, one estimate per 2×2 block) or ``"interpolate"``
            (H × W, per-channel bilinear demosaicing).
        black_level_dn: DN subtracted from every raw value before the Stokes inversion (the
            camera's black level / pedestal).
        saturation_dn: (optional) Raw value at and above which a pixel counts as clipped
            (e.g. 4095 for a 12-bit ADC); sets the ``saturated`` mask.

    Returns:
        A :class:`PolarizationImage` (float32 layers; S in DN above black level).

    Raises:
        TypeError: If ``raw`` is not a numpy array of an accepted dtype.
        ValueError: If ``raw`` is not 2-D with even, non-zero sizes or holds non-finite values,
            the method is unknown, the layout is degenerate, or ``black_level_dn`` is not
            finite.
    """
    _check_raw(raw)
    if method not in ("superpixel", "interpolate"):
        raise ValueError(f"method = {method!r}: must be 'superpixel' or 'interpolate'")
    if not math.isfinite(black_level_dn):
        raise ValueError(f"black_level_dn = {black_level_dn!r}: must be finite")
    w = analysis_pinv(layout_deg)
    raw = _as_cv(raw)
    if method == "superpixel":
        img = _superpixel_image(raw, w, black_level_dn, saturation_dn)
        assert isinstance(img, PolarizationImage)
        return img
    return _interpolated_image(raw, w, black_level_dn, saturation_dn)
