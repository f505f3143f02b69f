"""The analysis grid of LIG and POL: its geometry, its intensity, the eigen-solution, the prologue.

A frame is analysed on a grid of m×m raw blocks (:func:`analysis_factor`, :func:`analysis_geometry`:
the calibration re-expressed on that grid, the rays through a flat port and their Jacobian);
both take Snell's window from the attitude hint (:func:`snell_window`) and work on its box
(:func:`window_box`: the whole grid's numbers there, for a quarter of the grid's time at 10 m),
solve for the sun as the smallest eigenvector of a weighted moment matrix (:class:`EigenSolution`,
lu2025 eqs. 13–15) and resolve the sun/anti-sun sign by intensity (:func:`resolve_by_intensity`,
the end of lu2025 §2).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from twin.core.arrays import Float64Array as FloatArray
from twin.core.calibration import CameraCalibration
from twin.onboard.compass import kernels
from twin.onboard.compass.base import (
    CompassContext,
    Frame,
)
from twin.onboard.compass.geometry import critical_angle


def analysis_factor(calibration: CameraCalibration, max_width_px: int) -> int:
    """Raw pixels per analysis pixel: the smallest even m giving ≤ ``max_width_px`` columns."""
    m = 2
    while calibration.width_px // m > max_width_px:
        m += 2
    return m


def _even(n: int) -> int:
    return n - (n % 2)


@dataclass(frozen=True)
class AnalysisGeometry:
    """Camera-side geometry of the analysis grid (cached per calibration, block size, port).

    Attributes:
        cal: The calibration re-expressed on the analysis grid (pixel j ↔ raw m·j + (m−1)/2),
            so that its ``"interpolate"`` grid, rays and E-vector axes are the analysis pixels'.
        m: Raw pixels per analysis pixel.
        rays: (H, W, 3) unit outward directions in the water (camera frame; bent by a flat port).
        du: (H, W, 3) ∂ray/∂u per analysis pixel.
        dv: (H, W, 3) ∂ray/∂v per analysis pixel.
        valid: (H, W) inside the image circle (and through the port).
    """

    cal: CameraCalibration
    m: int
    rays: FloatArray
    du: FloatArray
    dv: FloatArray
    valid: NDArray[np.bool_]


def _through_port(rays: FloatArray, cal: CameraCalibration, n_port: float) -> FloatArray:
    """Lens rays → directions in the water (a flat port bends them by Snell about camera z)."""
    if cal.housing != "flat" or n_port <= 1.0:
        return rays
    rxy = np.hypot(rays[..., 0], rays[..., 1])
    sin_w = rxy / n_port  # n_air sin θ_lens = n_w sin θ_w
    cos_w = np.sqrt(np.maximum(1.0 - sin_w * sin_w, 0.0))
    scale = np.divide(sin_w, rxy, out=np.zeros_like(rxy), where=rxy > 0)
    return np.stack([rays[..., 0] * scale, rays[..., 1] * scale, cos_w], axis=-1)


@functools.lru_cache(maxsize=16)
def analysis_geometry(
    calibration: CameraCalibration, m: int, n_port: float = 1.0
) -> AnalysisGeometry:
    """The analysis-grid calibration, rays and ray Jacobian (cached: calibrations are hashable)."""
    c = calibration
    w, h = _even(c.width_px // m), _even(c.height_px // m)
    shift = (m - 1) / 2.0
    cu, cv = c.principal_point_px
    cal_a = dataclasses.replace(
        c,
        width_px=w,
        height_px=h,
        focal_px=c.focal_px / m,
        principal_point_px=((cu - shift) / m, (cv - shift) / m),
        pixel_pitch_um=c.pixel_pitch_um * m,
    )
    u, v = cal_a.grid("interpolate")
    rays, valid = cal_a.pixel_to_ray(u, v)
    eps = 0.25  # analysis pixels: central differences, exact to O(eps²) for the smooth lens model
    rp = _through_port(cal_a.pixel_to_ray(u + eps, v)[0], c, n_port)
    rm = _through_port(cal_a.pixel_to_ray(u - eps, v)[0], c, n_port)
    du = (rp - rm) / (2 * eps)
    rp = _through_port(cal_a.pixel_to_ray(u, v + eps)[0], c, n_port)
    rm = _through_port(cal_a.pixel_to_ray(u, v - eps)[0], c, n_port)
    dv = (rp - rm) / (2 * eps)
    out = _through_port(rays, c, n_port)
    if c.housing == "flat":
        valid = valid & (rays[..., 2] > 1e-6)  # a flat port sees nothing beyond 90° off-axis
    for a in (out, du, dv, valid):
        a.setflags(write=False)
    return AnalysisGeometry(cal_a, m, out, du, dv, valid)


def block_intensity(
    raw: NDArray[np.generic],
    calibration: CameraCalibration,
    geo: AnalysisGeometry,
    box: tuple[slice, slice] | None = None,
) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """I (eq. 5) on the analysis grid, DN above black level, and its block-saturation mask.

    ``box`` (rows, columns of the grid): that part only, the whole grid's numbers there (each
    analysis pixel is the mean of its own m × m raw block; tested).
    """
    m = geo.m
    r = raw_blocks(raw, geo, box)
    h, w = r.shape[0] // m, r.shape[1] // m
    s0 = cv2.resize(r.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
    # S0 = ½ ΣI_k over one of each analyser = 2 × the block mean of the mosaic.
    s0 = 2.0 * (s0 - np.float32(calibration.black_level_dn))
    return s0, block_saturation(raw, calibration, geo, box)


def block_saturation(
    raw: NDArray[np.generic],
    calibration: CameraCalibration,
    geo: AnalysisGeometry,
    box: tuple[slice, slice] | None = None,
) -> NDArray[np.bool_]:
    """Analysis pixels whose m×m raw block holds a clipped value (≥ ``saturation_dn``)."""
    m = geo.m
    r = raw_blocks(raw, geo, box)
    h, w = r.shape[0] // m, r.shape[1] // m
    sat = (r >= calibration.saturation_dn).view(np.uint8) * np.uint8(255)
    # 255 per clipped pixel so that INTER_AREA's rounded block mean cannot round one away.
    return cv2.resize(sat, (w, h), interpolation=cv2.INTER_AREA) > 0


def raw_blocks(
    raw: NDArray[np.generic], geo: AnalysisGeometry, box: tuple[slice, slice] | None
) -> NDArray[np.generic]:
    """The raw pixels of the analysis grid's m × m blocks (of its ``box``'s only)."""
    m = geo.m
    r0, r1, c0, c1 = 0, geo.cal.height_px, 0, geo.cal.width_px
    if box is not None:
        r0, r1, c0, c1 = box[0].start, box[0].stop, box[1].start, box[1].stop
    return raw[m * r0 : m * r1, m * c0 : m * c1]


def window_box(in_window: NDArray[np.bool_], pad: int) -> tuple[slice, slice]:
    """The rows and columns of the in-window pixels, ``pad`` wider each way (within the grid).

    What POL makes its Stokes on and LIG filters (a quarter of the analysis grid at 10 m).
    """
    h, w = in_window.shape
    rows = np.flatnonzero(in_window.any(axis=1))
    cols = np.flatnonzero(in_window.any(axis=0))
    return (
        slice(max(int(rows[0]) - pad, 0), min(int(rows[-1]) + pad + 1, h)),
        slice(max(int(cols[0]) - pad, 0), min(int(cols[-1]) + pad + 1, w)),
    )


def box_indices(idx: NDArray[np.intp], box: tuple[slice, slice], width: int) -> NDArray[np.intp]:
    """Flat indices ``idx`` of a grid ``width`` wide, as flat indices into its ``box``."""
    r0, c0 = box[0].start, box[1].start
    bw = box[1].stop - c0
    return (idx // width - r0) * bw + (idx % width - c0)


def snell_window(
    geo: AnalysisGeometry, c_c_h: FloatArray, n_w: float, margin_rad: float
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Eqs. 6–7: the analysis pixels in Snell's window from the attitude hint, and its core.

    A valid pixel is in the window when its level-frame elevation cosine l^h(3) exceeds the
    critical angle's, in the core when it is ``margin_rad`` further inside (one compiled pass,
    ``kernels.window_and_core``).
    """
    theta_c = critical_angle(n_w)
    return kernels.window_and_core(
        geo.rays,
        geo.valid,
        c_c_h[2],
        math.cos(theta_c),
        math.cos(max(theta_c - margin_rad, 0.0)),
    )


def level_rotation(calibration: CameraCalibration, ctx: CompassContext) -> FloatArray:
    """C_c^h = C_b^h · C_c^b: camera → horizontal frame from the roll/pitch hint (eq. 6)."""
    return ctx.c_b_h @ calibration.c_c_b


@dataclass(frozen=True)
class EigenSolution:
    """Smallest-eigenvector solution of Σ w v vᵀ (eqs. 13–15)."""

    s: FloatArray
    eigenvalues: FloatArray  # ascending, of the normalised matrix (Σ w v vᵀ / Σ w)
    eigenvectors: FloatArray  # columns, matching eigenvalues
    n: int

    @property
    def residual(self) -> float:
        """RMS of vᵀs (weighted), ≈ the RMS angle by which the constraints miss s."""
        return float(math.sqrt(max(self.eigenvalues[0], 0.0)))

    @property
    def eigen_gap(self) -> float:
        """κ_2 / κ_min (≥ 1, large = well conditioned; capped at 1e12)."""
        return float(
            min(self.eigenvalues[1] / max(self.eigenvalues[0], 1e-12 * self.eigenvalues[1]), 1e12)
        )

    def covariance(self, footprint: float, sigma_floor_rad: float) -> FloatArray:
        """Tangent-plane covariance of s (rad²), first-order perturbation (module docstring)."""
        lam, e = self.eigenvalues, self.eigenvectors
        n_eff = max(self.n / max(footprint, 1.0), 3.0)
        sigma2 = max(lam[0], 0.0) * self.n / max(self.n - 2, 1)  # per-constraint variance
        cov = np.zeros((3, 3))
        for k in (1, 2):
            cov += np.outer(e[:, k], e[:, k]) * (sigma2 / (n_eff * max(lam[k], 1e-12)))
        t = np.eye(3) - np.outer(self.s, self.s)  # floor on the tangent plane only
        return cov + (sigma_floor_rad**2) * t


def smallest_eigenvector(vecs: FloatArray, weights: FloatArray | None = None) -> EigenSolution:
    """S minimising Σ w (vᵀs)² with |s| = 1 (eq. 14): eigenvector of κ_min (eq. 15)."""
    if weights is None:
        mat = vecs.T @ vecs / len(vecs)
    else:
        wsum = float(np.sum(weights))
        mat = (vecs * weights[:, None]).T @ vecs / wsum
    lam, e = np.linalg.eigh(mat)
    return EigenSolution(e[:, 0].copy(), lam, e, len(vecs))


def eigen_from_moments(mat: FloatArray, wsum: float, n: int) -> EigenSolution:
    """:func:`smallest_eigenvector` from Σ w v vᵀ and Σ w summed elsewhere (compiled kernels)."""
    lam, e = np.linalg.eigh(mat / wsum)
    return EigenSolution(e[:, 0].copy(), lam, e, n)


def dilate(mask: NDArray[np.bool_], radius: int) -> NDArray[np.bool_]:
    if radius <= 0 or not mask.any():
        return mask
    k = np.ones((2 * radius + 1, 2 * radius + 1), np.uint8)
    return cv2.dilate(mask.view(np.uint8), k).astype(bool)


def resolve_by_intensity(
    s_h: FloatArray, p_h: FloatArray, intensity: FloatArray, min_contrast: float
) -> tuple[FloatArray, float, bool]:
    """The paper's sun/anti-sun rule (end of §2); returns (s, contrast, decided_by_intensity).

    ``p_h`` are the in-window look directions (level frame) and ``intensity`` their values; the
    half of the window that s_p = (s1, s2) points at is compared with the other half.
    """
    sp = s_h[:2]
    if math.hypot(sp[0], sp[1]) < 1e-9:  # sun at the zenith: nothing to compare
        return (s_h if s_h[2] >= 0 else -s_h), 0.0, False
    return _resolve(s_h, p_h[:, :2] @ sp > 0, intensity, min_contrast)


def resolve_by_intensity_at(
    s_h: FloatArray,
    rays: FloatArray,
    idx: NDArray[np.intp],
    c_c_h: FloatArray,
    intensity: FloatArray,
    min_contrast: float,
) -> tuple[FloatArray, float, bool]:
    """:func:`resolve_by_intensity` with the look directions the analysis rays at ``idx``.

    The side of each ray from one compiled pass (``kernels.window_sides``), without the (N, 3)
    level-frame directions: the same halves but for a ray within ~1e-16 of the dividing plane.
    """
    sp = s_h[:2]
    if math.hypot(sp[0], sp[1]) < 1e-9:
        return (s_h if s_h[2] >= 0 else -s_h), 0.0, False
    side = np.empty(idx.size, dtype=np.bool_)
    kernels.window_sides(
        np.ascontiguousarray(rays).reshape(-1, 3),
        np.ascontiguousarray(idx, dtype=np.intp),
        np.ascontiguousarray(c_c_h, dtype=np.float64),
        float(sp[0]),
        float(sp[1]),
        side,
    )
    return _resolve(s_h, side, intensity, min_contrast)


def _resolve(
    s_h: FloatArray, side: NDArray[np.bool_], intensity: FloatArray, min_contrast: float
) -> tuple[FloatArray, float, bool]:
    """The rule given which in-window pixels lie on the side s_p points at."""
    n_pos, n_neg = int(side.sum()), int((~side).sum())
    if n_pos == 0 or n_neg == 0:
        return (s_h if s_h[2] >= 0 else -s_h), 0.0, False
    i_pos = float(intensity[side].mean())
    i_neg = float(intensity[~side].mean())
    contrast = (i_pos - i_neg) / max(i_pos + i_neg, 1e-30)
    if abs(contrast) < min_contrast:
        return (s_h if s_h[2] >= 0 else -s_h), contrast, False
    return (s_h if contrast > 0 else -s_h), contrast, True


@dataclass(frozen=True)
class FramePrologue:
    """What LIG and POL both start a frame with (input checks, the sun, the analysis grid)."""

    raw: NDArray[np.generic]
    sun_enu: FloatArray
    water_index: float
    geometry: AnalysisGeometry


def frame_prologue(frame: Frame, analysis_max_width_px: int) -> FramePrologue:
    """After the shared prologue (:meth:`CompassMethod.begin_frame`): the analysis grid."""
    calibration, ctx = frame.calibration, frame.ctx
    n_w = float(ctx.water_index)
    m = analysis_factor(calibration, analysis_max_width_px)
    geo = analysis_geometry(calibration, m, n_w if calibration.housing == "flat" else 1.0)
    return FramePrologue(frame.raw, frame.sun_enu, n_w, geo)
