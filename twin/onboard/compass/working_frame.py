"""The working frame of the window methods (Snell, ROI-A): binning, calibration, Stokes, rays.

A frame larger than a method's working size is binned by same orientation
(:func:`bin_mosaic`, registered so that the four analysers of a binned super-pixel sample one
point) with the matching calibration (:func:`binned_calibration`); then the Stokes grid
(:func:`to_stokes`), each pixel's solid angle, and the E-vectors in 3-D (:func:`evectors_at`,
:func:`evectors_h`) in the meridian basis of each ray
(:func:`~twin.onboard.compass.geometry.meridian_basis`). The reasons for each choice are in
:mod:`twin.onboard.compass.snell`'s notes (decision 0).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import cv2
import numpy as np
from numpy.typing import NDArray

from twin.core.calibration import CameraCalibration, StokesGrid
from twin.onboard.compass.base import (
    FloatArray,
)
from twin.onboard.lens import compensate_grid
from twin.onboard.polarization import PolarizationImage, stokes_from_mosaic


def to_stokes(
    raw: NDArray[np.generic],
    calibration: CameraCalibration,
    grid: StokesGrid = "interpolate",
    origin: tuple[int, int] = (0, 0),
) -> PolarizationImage:
    """The shared raw → Stokes derivation (``grid`` as ``stokes_from_mosaic``'s method).

    The lens's bench-measured polarization is undone when the calibration carries it
    (:func:`twin.onboard.lens.compensate`); ``origin`` is the (u, v) of ``raw``'s first pixel
    when it is a crop of the frame.
    """
    r = raw
    if r.dtype.kind in "ui" and r.dtype not in (np.uint8, np.uint16):
        r = r.astype(np.float64)
    img = stokes_from_mosaic(
        r,
        calibration.layout_deg,
        method=grid,
        black_level_dn=calibration.black_level_dn,
        saturation_dn=calibration.saturation_dn,
    )
    if not calibration.lens_table:
        return img
    return compensate_grid(img, calibration, grid, origin)


def pixel_solid_angle(calibration: CameraCalibration, theta: FloatArray) -> FloatArray:
    """Solid angle per unit pixel area at off-axis angle θ: sin θ / (ρ · dρ/dθ)."""
    h = 1e-5
    t = np.maximum(theta, 2 * h)
    drho = (calibration.rho_of_theta(t + h) - calibration.rho_of_theta(t - h)) / (2 * h)
    rho = calibration.rho_of_theta(t)
    return np.sin(t) / np.maximum(rho * drho, 1e-12)


def evectors_at(calibration: CameraCalibration, rays_c: FloatArray, aop: FloatArray) -> FloatArray:
    """3-D unit E-vectors (camera frame) of AoPs measured along arbitrary camera rays (..., 3).

    :meth:`CameraCalibration.evectors` for rays that are not a whole Stokes grid (a crop, or the
    rays of a resampled image); the same two lens mappings, evaluated at ``rays_c``.
    """
    a = np.asarray(aop, dtype=np.float64)
    x, y, z = rays_c[..., 0], rays_c[..., 1], rays_c[..., 2]
    ca, sa = np.cos(a), np.sin(a)
    if calibration.polarization_mapping == "meridional":
        # cos ψ · r_s + sin ψ · t_s with r_s, t_s of CameraCalibration.sensor_axes.
        den = np.maximum(1.0 + z, 1e-12)
        xd, yd = x / den, y / den
        return np.stack(
            [
                ca * (1.0 - x * xd) + sa * (x * yd),
                -ca * (x * yd) - sa * (1.0 - y * yd),
                -ca * x + sa * y,
            ],
            axis=-1,
        )
    # Orthographic: the sensor-plane direction (cos ψ, −sin ψ, 0) lifted ⟂ to the ray.
    ez = -(ca * x - sa * y) / np.maximum(z, 1e-12)
    e = np.stack([ca, -sa, ez], axis=-1)
    return e / np.linalg.norm(e, axis=-1, keepdims=True)


def evectors_h(
    rays_c: FloatArray,
    aop: FloatArray,
    calibration: CameraCalibration,
    c_c_h: FloatArray,
    aop_error_poly_deg: tuple[float, ...] = (),
) -> tuple[FloatArray, FloatArray]:
    """Unit rays and 3-D E-vectors of AoPs measured along camera rays, in the horizontal frame.

    ``aop_error_poly_deg`` (xin2024 §2.3): residual lens AoP error δψ(θ) in degrees, a polynomial
    in the incidence angle θ (degrees, highest power first as ``numpy.polyval``), subtracted from
    the measured AoP before lifting.
    """
    aop = np.asarray(aop, dtype=np.float64)
    if aop_error_poly_deg:
        theta_deg = np.degrees(np.arctan2(np.hypot(rays_c[..., 0], rays_c[..., 1]), rays_c[..., 2]))
        aop = aop - np.radians(np.polyval(np.asarray(aop_error_poly_deg), theta_deg))
    e_c = evectors_at(calibration, rays_c, aop)
    return rays_c @ c_c_h.T, e_c @ c_c_h.T


def grid_coords(
    calibration: CameraCalibration, dirs_c: FloatArray, grid: StokesGrid
) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.bool_]]:
    """``cv2.remap`` maps onto the ``grid`` Stokes image of camera-frame directions; validity."""
    u, v, valid = calibration.project(dirs_c)
    if grid == "superpixel":  # super-pixel (i, j) is centred at raw (2j + ½, 2i + ½)
        return ((u - 0.5) / 2.0).astype(np.float32), ((v - 0.5) / 2.0).astype(np.float32), valid
    return u.astype(np.float32), v.astype(np.float32), valid


def binning_for(calibration: CameraCalibration, max_px: int | None) -> int:
    """Smallest power-of-two same-orientation binning b that brings the frame to ≤ ``max_px``.

    Limited to binnings that divide the frame into whole binned super-pixels (2b | H, W).
    """
    b = 1
    if max_px is None:
        return b
    w, h = calibration.width_px, calibration.height_px
    while max(w, h) / b > max_px and w % (4 * b) == 0 and h % (4 * b) == 0:
        b *= 2
    return b


@functools.lru_cache(maxsize=8)
def binned_calibration(calibration: CameraCalibration, b: int) -> CameraCalibration:
    """The calibration of a frame binned b×b by same orientation (``bin_mosaic``).

    The convention of the world's on-sensor binning (``sensors.polarimeter.unit.camera``): binned
    pixel
    k sits at frame coordinate b·k + (b − 1)/2, so f → f/b and c → (c − (b − 1)/2)/b; the
    ±(b − 1)/2 offset of each orientation's b×b centroid is neglected, as there.
    """
    if b == 1:
        return calibration
    cu, cv = calibration.principal_point_px
    off = (b - 1) / 2.0
    return dataclasses.replace(
        calibration,
        width_px=calibration.width_px // b,
        height_px=calibration.height_px // b,
        focal_px=calibration.focal_px / b,
        principal_point_px=((cu - off) / b, (cv - off) / b),
        pixel_pitch_um=calibration.pixel_pitch_um * b,
    )


def _centred_box(b: int, phase: int) -> tuple[NDArray[np.float32], int]:
    """Sub-lattice kernel of a b-sample mean centred on the binned pixel's nominal position.

    Returns the weights on one orientation's sub-lattice and the anchor (index of offset 0).

    Binned pixel k sits at frame coordinate b·k + (b − 1)/2 (``binned_calibration``), but the
    plain mean of the b same-orientation pixels is centred (b − 1)(phase − ½) frame pixels away
    from that: ∓1.5 px at b = 4, the two orientations of a row 3 px apart. The mean is taken of
    the sub-lattice linearly interpolated at the b nominal sample positions instead.
    """
    start = (b - 1) * (phase - 0.5) / 2.0  # sub-lattice index of the first sample (bI + start)
    k_min = min(math.floor(start), 0)  # the kernel starts at or before offset 0 (the anchor)
    w = np.zeros(2 * b + 2, np.float64)
    for m in range(b):
        x = start + m - k_min
        n = math.floor(x)
        f = x - n
        w[n] += 1.0 - f
        w[n + 1] += f
    w = w[: np.flatnonzero(w > 1e-12).max() + 1] / b
    return w.astype(np.float32), -k_min


def bin_mosaic(
    raw: NDArray[np.generic], b: int, saturation_dn: float | None = None
) -> NDArray[np.float32]:
    """Same-orientation b×b binning of a 2×2 DoFP mosaic (the mean, in DN; float32).

    Within every 2b×2b block the b×b pixels behind the same micro-polarizer are averaged, so the
    result is again a 2×2 mosaic, (H/b)×(W/b), whose pixel k sits at frame coordinate
    b·k + (b − 1)/2 as ``binned_calibration`` states. The four orientations are registered: each
    is averaged about that nominal position (``_centred_box``), not about its own pixels' centroid,
    which lies ±(b − 1)/2 frame pixels off, alternating with the phase; unregistered, the four
    analysers of a binned super-pixel see points 3 px apart (b = 4), which biases the AoP where
    S0 has a gradient (~0.4° of yaw in the Snell benchmark). A binned pixel any of whose sources
    (the kernel's b + 1 per axis) is at or above ``saturation_dn`` is set to ``saturation_dn`` so
    that it stays flagged as clipped.
    """
    h, w = raw.shape
    hb, wb = h // (2 * b), w // (2 * b)
    out = np.empty((h // b, w // b), np.float32)
    sat = saturation_dn is not None and float(raw.max()) >= saturation_dn
    for r in (0, 1):
        ky, ay = _centred_box(b, r)
        for c in (0, 1):
            kx, ax = _centred_box(b, c)
            q = raw[r::2, c::2].astype(np.float32)
            f = cv2.sepFilter2D(
                q, cv2.CV_32F, kx, ky, anchor=(ax, ay), borderType=cv2.BORDER_REPLICATE
            )
            out[r::2, c::2] = f[: hb * b : b, : wb * b : b]
            if sat:  # any clipped source under the kernel
                clip = (q >= saturation_dn).astype(np.float32)
                hit = cv2.sepFilter2D(
                    clip, cv2.CV_32F, kx, ky, anchor=(ax, ay), borderType=cv2.BORDER_REPLICATE
                )
                out[r::2, c::2][hit[: hb * b : b, : wb * b : b] > 0] = np.float32(saturation_dn)
    return out
