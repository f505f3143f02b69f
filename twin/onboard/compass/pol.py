"""POL: the E-vector solar vector with refraction compensation inside Snell's window.

The baseline of the LIG paper (Hu et al. 2024, Mechatronics 98:103134, its ref. [22]: Hu, Yang,
Guo, Yu, Li, "Solar-tracking methodology based on refraction-polarization in Snell's window for
underwater navigation", Chin. J. Aeronaut. 35(3):380–389, 2022). Ref. [22] itself is not in the
seeds; what the LIG paper says of it (Remark 1: the refraction is compensated "from two aspects":
the bending of the ray by Snell's law and the deflection of the polarization plane by the Fresnel
equations) and optics.md §2.7 (inverting the full Fresnel (I, Q, U) block is exact, correcting
only the AoP is biased for partially polarized light) define the method implemented here:

1. Stokes S0, S1, S2 (:func:`twin.onboard.polarization.stokes_planes_from_mosaic`) on the
   analysis grid (the raw mosaic binned m/2 × m/2 per analyser phase first, which equals the
   block mean of the super-pixel Stokes because the inversion is linear — and costs a quarter);
   at the in-window pixels of step 2 the lens's polarization undone and AoP, DoP derived
   (:func:`window_stokes`).
2. In-window pixels with the attitude hint, eqs. 6–7 of the LIG paper (as in LIG; same margin).
3. Each pixel's AoP → 3-D E-vector in the camera frame (``CameraCalibration.evectors``, the lens's
   polarization mapping) → level frame (C_b^h C_c^b) → its angle ψ_w from the in-water meridian
   plane (the plane of incidence at the surface) → normalised Stokes (Q, U)/I = P(cos 2ψ_w,
   sin 2ψ_w) → the air-side Stokes by the inverse of the Fresnel transmission block
   [[A, B], [B, A]] ⊕ t_p t_s (A, B = (t_p² ± t_s²)/2, eq. 11's incidence angle i; optics.md §2.2):
   (Q_a, U_a) ∝ (A Q − B, t_p t_s U), ψ_a = ½ atan2(U_a, Q_a) → the air E-vector
   cos ψ_a e_i + sin ψ_a e_φ at the pixel's air direction (Snell: same azimuth, sin i = n sin r).
4. Rayleigh: every air E-vector ⟂ s; s^h = the eigenvector of Σ e eᵀ for the smallest eigenvalue
   (the same estimator as the LIG paper's eqs. 13–15; its ref. [15]).
5. Sun/anti-sun: the E-vector constraint is blind to the sign; a daytime sun is above the horizon,
   so s^h_z > 0. The LIG paper's intensity rule is evaluated too and reported in ``extras``
   (``ambiguity_contrast``; ``ambiguity_agrees_with_intensity``).

Pixels used: in the window (margin as LIG), not saturated, DoP ≥ ``min_dop`` (the AoP of a nearly
unpolarised pixel is noise). Unit constraints by default (as eq. 13; ``weighting="dop"`` weights
by the measured DoP). Multiply scattered light in the world's water (a radiative-transfer
solution, docs/polarimeter.md) does not follow the single-scattering E-vector pattern this method
assumes, so its elevation is biased in deep or turbid water by whatever the transport gives —
the effect the LIG paper reports, measured here rather than assumed
(validation/results/campaigns/compass_underwater/report.md).

Quality figures as in :mod:`~twin.onboard.compass.lig` (``residual`` = RMS of eᵀs, ``eigen_gap``
= κ_2/κ_min, covariance from the eigen-perturbation with one analysis pixel per independent
constraint plus the floor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from twin.core.calibration import CameraCalibration
from twin.onboard.compass import kernels
from twin.onboard.compass.analysis_grid import (
    AnalysisGeometry,
    block_saturation,
    box_indices,
    eigen_from_moments,
    frame_prologue,
    level_rotation,
    raw_blocks,
    resolve_by_intensity_at,
    smallest_eigenvector,
    snell_window,
    window_box,
)
from twin.onboard.compass.base import (
    CompassFix,
    CompassMethod,
    Frame,
    finish_fix,
    no_fix,
)
from twin.onboard.compass.geometry import meridian_basis, refract_to_air
from twin.onboard.lens import compensate_at, compensate_gathered
from twin.onboard.polarization import PolarizationImage, StokesPlanes, stokes_planes_from_mosaic


@dataclass(frozen=True)
class PolConfig:
    """POL settings.

    Attributes:
        analysis_max_width_px: Columns of the analysis grid at most.
        window_margin_rad: Pixels within this of the window edge are left out (as LIG).
        min_dop: Pixels with a lower DoP are left out.
        fresnel: Invert the Fresnel (I, Q, U) block (ref. [22]'s second aspect); False keeps
            only the Snell bending of the ray (an ablation).
        weighting: ``"unit"`` (as eq. 13) or ``"dop"``.
        min_pixels: Fewer usable pixels ⇒ no fix.
        min_signal_dn: Mean in-window S0 below this ⇒ "too dark".
        min_eigen_gap: κ_2/κ_min below this ⇒ ill-conditioned.
        sigma_floor_rad: Isotropic covariance floor (model error), rad.
        exclude_saturated: Leave out clipped pixels (their Stokes vector is wrong) [not in the
            LIG paper's description of POL].
    """

    analysis_max_width_px: int = 640
    window_margin_rad: float = math.radians(4.0)
    min_dop: float = 0.02
    fresnel: bool = True
    weighting: str = "unit"
    min_pixels: int = 200
    min_signal_dn: float = 8.0
    min_eigen_gap: float = 1.5
    sigma_floor_rad: float = math.radians(0.5)
    exclude_saturated: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.analysis_max_width_px, int) and self.analysis_max_width_px >= 16):
            raise ValueError(
                f"PolConfig.analysis_max_width_px: {self.analysis_max_width_px!r}; "
                "allowed: an integer >= 16"
            )
        if self.weighting not in ("unit", "dop"):
            raise ValueError(f"PolConfig.weighting: {self.weighting!r}; allowed: 'unit', 'dop'")
        for name, lo, hi in (
            ("window_margin_rad", 0.0, 0.5),
            ("min_dop", 0.0, 1.0),
            ("min_signal_dn", 0.0, 1e9),
            ("min_eigen_gap", 1.0, 1e9),
            ("sigma_floor_rad", 0.0, 1.0),
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"PolConfig.{name}: {v!r}; allowed: [{lo:g}, {hi:g}]")
        if not (isinstance(self.min_pixels, int) and self.min_pixels >= 3):
            raise ValueError(f"PolConfig.min_pixels: {self.min_pixels!r}; allowed: >= 3")


def binned_stokes(
    raw: NDArray[np.generic],
    calibration: CameraCalibration,
    geo: AnalysisGeometry,
    box: tuple[slice, slice] | None = None,
) -> StokesPlanes:
    """S0–S2 on the analysis grid: bin each analyser phase m/2 × m/2, then the shared inversion.

    No angles, and the lens's polarization not undone: :func:`window_stokes` does both at the
    pixels the method uses. ``box`` (rows, columns of the analysis grid): that part only, the
    whole grid's numbers there (each analysis pixel is its own m × m raw block; tested).
    """
    m = geo.m
    r = raw_blocks(raw, geo, box)
    h, w = r.shape[0] // m, r.shape[1] // m
    kwargs = {"layout_deg": calibration.layout_deg, "black_level_dn": calibration.black_level_dn}
    if m == 2:
        return stokes_planes_from_mosaic(np.ascontiguousarray(r), **kwargs)
    mos = np.empty((2 * h, 2 * w), np.float32)
    for i in range(2):
        for j in range(2):
            plane = r[i::2, j::2].astype(np.float32)
            mos[i::2, j::2] = cv2.resize(plane, (w, h), interpolation=cv2.INTER_AREA)
    return stokes_planes_from_mosaic(mos, **kwargs)


def window_stokes(
    pol: StokesPlanes,
    calibration: CameraCalibration,
    geo: AnalysisGeometry,
    idx: NDArray[np.integer],
    box: tuple[slice, slice] | None = None,
) -> PolarizationImage:
    """The analysis grid's Stokes at flat pixels ``idx``, the lens's polarization undone (1-D).

    ``pol`` is the whole grid's, or its ``box``'s (:func:`binned_stokes`); ``idx`` index the whole
    grid either way.
    """
    # Output (i, j) is the mean of raw block (m i … m i + m − 1, m j …): centred at m j + (m − 1)/2.
    if box is None:
        return compensate_at(pol, calibration, idx, "block", block=geo.m)
    shape = (geo.cal.height_px, geo.cal.width_px)
    at = box_indices(np.asarray(idx, dtype=np.intp), box, shape[1])
    planes = StokesPlanes(*(x.reshape(-1)[at] for x in (pol.s0, pol.s1, pol.s2, pol.saturated)))
    return compensate_gathered(planes, calibration, shape, idx, "block", block=geo.m)


def fresnel_amplitudes(cos_i: NDArray, cos_r: NDArray, n_w: float) -> tuple[NDArray, NDArray]:
    """Air → water amplitude transmission (t_s, t_p) at incidence i, refraction r (optics §2.2)."""
    t_s = 2.0 * cos_i / (cos_i + n_w * cos_r)
    t_p = 2.0 * cos_i / (n_w * cos_i + cos_r)
    return t_s, t_p


class PolCompass(CompassMethod):
    """E-vector solar tracking with Snell + Fresnel compensation (LIG paper's ref. [22])."""

    name = "pol"
    config_type = PolConfig

    def solve_frame(self, frame: Frame) -> CompassFix:
        cfg = self.config
        calibration, ctx = frame.calibration, frame.ctx
        pro = frame_prologue(frame, cfg.analysis_max_width_px)
        raw, sun_enu, n_w, geo = pro.raw, pro.sun_enu, pro.water_index, pro.geometry

        c_c_h = level_rotation(calibration, ctx)
        in_window, core = snell_window(geo, c_c_h, n_w, cfg.window_margin_rad)
        win_idx = np.flatnonzero(in_window)
        n_window = int(win_idx.size)
        if n_window < cfg.min_pixels:
            return no_fix(self.name, "Snell's window is (almost) out of view", n_window)
        # Stokes on the window's box only (a quarter of the grid at 10 m); 1-D at its pixels.
        box = window_box(in_window, 0)
        pw = window_stokes(
            binned_stokes(raw, calibration, geo, box), calibration, geo, win_idx, box
        )
        mean_i = float(pw.s0.mean())
        if not (mean_i >= cfg.min_signal_dn):
            return no_fix(
                self.name,
                f"too dark: mean in-window intensity {mean_i:.3g} DN < {cfg.min_signal_dn:g}",
                n_window,
                mean_intensity_dn=mean_i,
            )
        use = core.reshape(-1)[win_idx] & (pw.s0 > 0) & (pw.dop >= cfg.min_dop)
        if cfg.exclude_saturated:
            sat = block_saturation(raw, calibration, geo, box)
            use &= ~sat.reshape(-1)[box_indices(win_idx, box, geo.cal.width_px)]
        idx = win_idx[use]
        if idx.size < cfg.min_pixels:
            return no_fix(
                self.name,
                f"too few polarized pixels: {idx.size} < {cfg.min_pixels} with DoP >= "
                f"{cfg.min_dop:g}",
                int(idx.size),
            )

        aop = pw.aop[use].astype(np.float64)
        dop = pw.dop[use].astype(np.float64)
        if geo.cal.polarization_mapping == "meridional":
            r_s, t_s = geo.cal.sensor_axes("interpolate")
            mat, wsum = kernels.pol_moments(
                idx, aop, dop, geo.rays.reshape(-1, 3), r_s.reshape(-1, 3), t_s.reshape(-1, 3),
                geo.cal.rays("interpolate")[0].reshape(-1, 3), c_c_h, n_w, cfg.fresnel,
                calibration.housing == "flat", cfg.weighting == "dop",
            )  # fmt: skip
            sol = eigen_from_moments(mat, wsum, int(idx.size))
        else:
            evec = pol_constraints(geo, calibration, idx, aop, dop, c_c_h, n_w, cfg.fresnel)
            sol = smallest_eigenvector(evec, dop if cfg.weighting == "dop" else None)
        if not (sol.eigen_gap >= cfg.min_eigen_gap):
            return no_fix(
                self.name,
                f"ill-conditioned: eigen gap {sol.eigen_gap:.3g} < {cfg.min_eigen_gap:g}",
                sol.n,
                eigen_gap=sol.eigen_gap,
            )
        s_h = sol.s if sol.s[2] >= 0 else -sol.s  # daytime: the sun is above the horizon
        _, contrast, _ = resolve_by_intensity_at(s_h, geo.rays, win_idx, c_c_h, pw.s0, 0.0)
        c_b_h = ctx.c_b_h
        cov_b = c_b_h.T @ sol.covariance(1.0, cfg.sigma_floor_rad) @ c_b_h
        return finish_fix(
            self.name,
            c_b_h.T @ s_h,
            ctx,
            sun_enu,
            cov_b,
            pixels_used=sol.n,
            residual=sol.residual,
            eigen_gap=sol.eigen_gap,
            ambiguity_contrast=contrast,
            ambiguity_agrees_with_intensity=float(contrast >= 0),
            analysis_block_px=float(geo.m),
            mean_dop=float(dop.mean()),
            mean_intensity_dn=mean_i,
        )


def pol_constraints(
    geo: AnalysisGeometry,
    calibration: CameraCalibration,
    idx: NDArray[np.intp],
    aop: NDArray[np.float64],
    dop: NDArray[np.float64],
    c_c_h: NDArray[np.float64],
    n_w: float,
    fresnel: bool,
) -> NDArray[np.float64]:
    """POL's air-side E-vectors (k, 3) of the pixels ``idx`` (step 3), with numpy.

    The reference for :func:`twin.onboard.compass.kernels.pol_moments` (which the method runs
    for the meridional mapping), and the path for the orthographic one.
    """
    # AoP → 3-D E-vector (lens mapping), camera frame; through a flat port the components
    # in the camera-meridional basis are carried over to the bent ray (port Fresnel ignored).
    lens_rays = geo.cal.rays("interpolate")[0].reshape(-1, 3)[idx]
    e_c = _evectors_at(geo.cal, aop, idx)
    p_c = geo.rays.reshape(-1, 3)[idx]
    if calibration.housing == "flat":
        lt, lp = meridian_basis(lens_rays)
        wt, wp = meridian_basis(p_c)
        a = np.einsum("ij,ij->i", e_c, lt)
        b = np.einsum("ij,ij->i", e_c, lp)
        e_c = a[:, None] * wt + b[:, None] * wp
    p_h = p_c @ c_c_h.T
    e_h = e_c @ c_c_h.T
    e_t, e_p = meridian_basis(p_h)
    psi_w = np.arctan2(np.einsum("ij,ij->i", e_h, e_p), np.einsum("ij,ij->i", e_h, e_t))
    d_air, _, _ = refract_to_air(p_h, n_w)
    if fresnel:
        t_s, t_p = fresnel_amplitudes(d_air[:, 2], p_h[:, 2], n_w)
        big_a = 0.5 * (t_p * t_p + t_s * t_s)
        big_b = 0.5 * (t_p * t_p - t_s * t_s)
        q_a = big_a * dop * np.cos(2 * psi_w) - big_b
        u_a = t_p * t_s * dop * np.sin(2 * psi_w)
        psi_a = 0.5 * np.arctan2(u_a, q_a)
    else:
        psi_a = psi_w
    e_i, e_phi = meridian_basis(d_air)
    return np.cos(psi_a)[:, None] * e_i + np.sin(psi_a)[:, None] * e_phi


#: POL as the LIG paper describes it (its eqs. 6–7 and Remark 1; ref. [22] itself is not in the
#: seeds): every in-window pixel's E-vector (no rim margin, no DoP threshold, clipped pixels
#: kept, no conditioning threshold), Snell + Fresnel compensation, unit constraints. Kept from
#: the twin: the analysis grid, the sun-above-the-horizon sign (ref. [22]'s rule is not known)
#: and the too-dark / too-few-pixels guards.
POL_PAPER = PolConfig(
    window_margin_rad=0.0, min_dop=0.0, exclude_saturated=False, min_eigen_gap=1.0
)


class PolPaperCompass(PolCompass):
    """POL as the LIG paper describes it (:data:`POL_PAPER`); ``pol`` is the twin's."""

    name = "pol_paper"

    def __init__(self, config: PolConfig | None = None, **overrides: object) -> None:
        super().__init__(config if config is not None else POL_PAPER, **overrides)


def _evectors_at(cal: CameraCalibration, aop: NDArray, idx: NDArray) -> NDArray:
    """``cal.evectors`` at the selected analysis pixels only (the calibration's own mapping)."""
    if cal.polarization_mapping == "meridional":
        # evectors' own formula, cos ψ r_s + sin ψ t_s, on the cached axes of the chosen pixels.
        r_s, t_s = cal.sensor_axes("interpolate")
        r_s, t_s = r_s.reshape(-1, 3)[idx], t_s.reshape(-1, 3)[idx]
        return np.cos(aop)[:, None] * r_s + np.sin(aop)[:, None] * t_s
    full = np.zeros(cal.height_px * cal.width_px)
    full[idx] = aop
    return cal.evectors(full.reshape(cal.height_px, cal.width_px), "interpolate").reshape(-1, 3)[
        idx
    ]
