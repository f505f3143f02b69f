"""Onboard compensation of the lens's polarization error, from a bench calibration.

The Snell-window paper (xin2024 §2.3) measures its fisheye's AoP error against the incidence angle
on a bench (a telecentric, polarized source turned through 0–90° in 10° steps, the polarizer
through 0–170°) and compensates it. The vehicle here does the same with what its bench gave it:
:attr:`twin.core.calibration.CameraCalibration.lens_table`, the lens's measured transfer at those
incidence angles — the radial-frame Mueller matrix T̄ [[1, D, 0], [D, a, 0], [0, 0, c]] of the lens
and the analysers together — which :func:`compensate` inverts at every pixel, interpolating
linearly in field angle:

    in the radial frame of the pixel (angle φ from the principal point, +u towards +v),
    S0 = (a S0' − D S1') / (T̄ (a − D²)),  S1 = (S1' − D S0') / (T̄ (a − D²)),  S2 = S2' / (T̄ c).

The paper fits one AoP-error curve of the incidence angle; a radial diattenuator's AoP error also
depends on the light's own AoP and DoP (it is ≈ −D sin 2χ / (2p) for an AoP χ from the radial
direction), which one curve cannot hold, so the vehicle inverts the measured Mueller matrix
instead: the same bench data, the physically complete correction.

Onboard side: geometry from the onboard calibration only (its principal point and its radial
model give each pixel's field angle), so a calibration error shows up here too.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from twin.core.calibration import CameraCalibration
from twin.onboard.lens_kernel import undo_at
from twin.onboard.polarization import PolarizationImage, StokesPlanes, aop_dop


@dataclass(frozen=True, slots=True)
class LensInverse:
    """Per-pixel factors of the inverse lens transfer on one pixel grid (geometry only).

    ``cos2``, ``sin2``: cos 2φ, sin 2φ of each pixel's radial direction; ``a``, ``d``: the bench
    table's a and D at its field angle; ``k`` = 1 / (T̄ (a − D²)); ``tc`` = T̄ c.
    """

    cos2: NDArray[np.float64]
    sin2: NDArray[np.float64]
    a: NDArray[np.float64]
    d: NDArray[np.float64]
    k: NDArray[np.float64]
    tc: NDArray[np.float64]


def lens_inverse(
    calibration: CameraCalibration, u: NDArray[np.floating], v: NDArray[np.floating]
) -> LensInverse:
    """The inverse lens transfer's factors at frame coordinates (u, v) (calibration's table)."""
    tab = np.asarray(calibration.lens_table, dtype=np.float64)
    cu, cv = calibration.principal_point_px
    du, dv = np.asarray(u, np.float64) - cu, np.asarray(v, np.float64) - cv
    theta = calibration.theta_of_rho(np.hypot(du, dv))
    t, d, a, c = (np.interp(theta, tab[:, 0], tab[:, k]) for k in (1, 2, 3, 4))
    phi2 = 2.0 * np.arctan2(dv, du)
    return LensInverse(np.cos(phi2), np.sin(phi2), a, d, 1.0 / (t * (a - d * d)), t * c)


def compensate(
    img: PolarizationImage,
    calibration: CameraCalibration,
    u: NDArray[np.floating],
    v: NDArray[np.floating],
) -> PolarizationImage:
    """The Stokes images with the bench-measured lens transfer undone (unchanged if none).

    Args:
        img: Stokes images of a frame (or a crop of one).
        calibration: The onboard calibration (its ``lens_table`` and geometry).
        u: Frame column coordinate of each of ``img``'s pixels (same shape as its layers).
        v: Frame row coordinate of each.
    """
    if not calibration.lens_table:
        return img
    return apply_inverse(img, lens_inverse(calibration, u, v))


def compensate_grid(
    img: PolarizationImage,
    calibration: CameraCalibration,
    kind: str,
    origin: tuple[int, int] = (0, 0),
    block: int = 2,
) -> PolarizationImage:
    """:func:`compensate` on a :func:`grid_uv` grid, its factors computed once per calibration.

    The grid's geometry does not change from frame to frame, so its factors are kept in the
    calibration's cache (the same numbers as :func:`compensate` computes, bit for bit).
    """
    if not calibration.lens_table:
        return img
    return apply_inverse(img, _grid_inverse(calibration, img.shape, kind, origin, block))


def compensate_at(
    img: PolarizationImage | StokesPlanes,
    calibration: CameraCalibration,
    idx: NDArray[np.integer],
    kind: str,
    origin: tuple[int, int] = (0, 0),
    block: int = 2,
) -> PolarizationImage:
    """:func:`compensate_grid` at the flat pixel indices ``idx`` only: 1-D layers, in idx order.

    Reads S0, S1, S2 (and the saturation mask) only, so the angles of the whole image need not
    exist (:class:`~twin.onboard.polarization.StokesPlanes`): AoP and DoP are derived at
    ``idx``, after the lens is undone. A method that uses the pixels of Snell's window only
    pays for those (a quarter of the image circle at 10 m).
    """
    planes = StokesPlanes(*(x.reshape(-1)[idx] for x in (img.s0, img.s1, img.s2, img.saturated)))
    return compensate_gathered(planes, calibration, img.shape, idx, kind, origin, block)


def compensate_gathered(
    planes: StokesPlanes,
    calibration: CameraCalibration,
    shape: tuple[int, int],
    idx: NDArray[np.integer],
    kind: str,
    origin: tuple[int, int] = (0, 0),
    block: int = 2,
) -> PolarizationImage:
    """:func:`compensate_at` for Stokes already taken at the flat indices ``idx`` of a grid.

    ``planes`` holds 1-D S0–S2 and the saturation mask of the pixels ``idx`` (in that order) of a
    Stokes image of ``shape``: for a method that made its Stokes on part of the grid only.
    """
    s0, s1, s2, sat = planes.s0, planes.s1, planes.s2, planes.saturated
    if not calibration.lens_table:
        return PolarizationImage(s0, s1, s2, *aop_dop(s0, s1, s2), sat)
    inv = _grid_inverse(calibration, shape, kind, origin, block)
    n = len(idx)
    out = np.empty((3, n))
    # apply_inverse's algebra at idx in one compiled loop (lens_kernel), then its angles.
    undo_at(
        np.ascontiguousarray(s0), np.ascontiguousarray(s1), np.ascontiguousarray(s2),
        np.ascontiguousarray(idx, dtype=np.intp),
        *(getattr(inv, f.name).reshape(-1) for f in fields(LensInverse)), out[0], out[1], out[2],
    )  # fmt: skip
    return _with_angles(out[0], out[1], out[2], sat)


def _grid_inverse(
    calibration: CameraCalibration,
    shape: tuple[int, int],
    kind: str,
    origin: tuple[int, int],
    block: int,
) -> LensInverse:
    """The factors of one grid, kept in the calibration's cache (flat, C order)."""
    key = ("lens_inverse", shape, kind, origin, block)
    inv = calibration._cache.get(key)
    if inv is None:
        inv = lens_inverse(calibration, *grid_uv(shape, kind, origin, block))
        calibration._cache[key] = inv
    return inv


def apply_inverse(img: PolarizationImage | StokesPlanes, inv: LensInverse) -> PolarizationImage:
    """Undo the lens transfer (module docstring's equations) with precomputed factors.

    Reads S0–S2 and the saturation mask only; AoP and DoP are derived from the result.
    """
    cos2, sin2, a, d, k = inv.cos2, inv.sin2, inv.a, inv.d, inv.k
    s0m, s1m, s2m = (np.asarray(x, np.float64) for x in (img.s0, img.s1, img.s2))
    r1 = cos2 * s1m + sin2 * s2m  # radial frame
    r2 = -sin2 * s1m + cos2 * s2m
    s0 = (a * s0m - d * r1) * k
    q1 = (r1 - d * s0m) * k
    q2 = r2 / inv.tc
    s1 = cos2 * q1 - sin2 * q2
    s2 = sin2 * q1 + cos2 * q2
    return _with_angles(s0, s1, s2, img.saturated)


def _with_angles(
    s0: NDArray[np.float64], s1: NDArray[np.float64], s2: NDArray[np.float64], sat: NDArray
) -> PolarizationImage:
    """The compensated float64 Stokes as a float32 image, with their AoP and DoP."""
    lin = np.hypot(s1, s2)
    dop = np.clip(np.divide(lin, s0, out=np.zeros_like(s0), where=s0 > 0), 0.0, 1.0)
    aop = 0.5 * np.arctan2(s2, s1)
    aop = np.where(aop >= np.pi / 2, aop - np.pi, aop)
    f32 = np.float32
    return PolarizationImage(
        s0.astype(f32), s1.astype(f32), s2.astype(f32), aop.astype(f32), dop.astype(f32), sat
    )


def grid_uv(
    shape: tuple[int, int], kind: str, origin: tuple[int, int] = (0, 0), block: int = 2
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Frame (u, v) of a Stokes image's pixels.

    Args:
        shape: (rows, columns) of the Stokes image.
        kind: ``"interpolate"`` (one output pixel per raw pixel), ``"superpixel"`` (one per
            2×2) or ``"block"`` (one per ``block`` × ``block`` raw pixels, centred).
        origin: (u0, v0) of the raw crop the image was made from.
        block: Raw pixels per output pixel for ``"block"``.
    """
    r, c = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    u0, v0 = origin
    if kind == "interpolate":
        return c + u0, r + v0
    size = 2 if kind == "superpixel" else block
    if kind not in ("superpixel", "block"):
        raise ValueError(f"grid kind: {kind!r}; allowed: 'interpolate', 'superpixel', 'block'")
    return size * c + (size - 1) / 2.0 + u0, size * r + (size - 1) / 2.0 + v0


__all__ = [
    "LensInverse",
    "apply_inverse",
    "compensate",
    "compensate_at",
    "compensate_gathered",
    "compensate_grid",
    "grid_uv",
    "lens_inverse",
]
