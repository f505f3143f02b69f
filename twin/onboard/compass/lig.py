"""LIG: solar vector from the light-intensity gradient inside Snell's window (Hu et al. 2024, §2).

Hu, Liu, Yang, Yu, Xu, Guo, "Underwater autonomous orientation using submarine light intensity
gradient", Mechatronics 98:103134 (2024), doi:10.1016/j.mechatronics.2023.103134. The premise: the
radiance falls off with the scattering angle, so at every sky point the intensity gradient g, the
observation vector l and the solar vector s are coplanar; the plane normals v = l × g are all ⟂ s
(the "LIG model", the analogue of the Rayleigh E-vector field), and s is the eigenvector of
Σ v vᵀ with the smallest eigenvalue (eqs. 13–15).

Pipeline per frame (equation numbers of the paper):

1. Intensity I = (I0 + I45 + I90 + I135)/2 (eq. 5), black level subtracted, on an *analysis grid*
   of m×m raw blocks (m even, the smallest with ≤ ``analysis_max_width_px`` columns): the block
   mean of the super-pixel S0 of :func:`twin.onboard.polarization.stokes_from_mosaic` (identical
   for any 0/45/90/135° layout — a test checks it), computed as 2 × the block mean of the raw
   mosaic because that is ~10× cheaper at full resolution. This is where the method subsamples:
   the paper's estimator is a per-pixel least-squares sum, so a coarser pixel set changes only
   the noise, and the block mean is the denoising a binning camera would do anyway.
2. 2-D median filter (the paper's pre-processing; kernel size not given, 5 here), then the image
   gradient (3×3 Sobel) → the LIG angle γ and magnitude of each pixel.
3. In-window pixels (eqs. 6–7): l^h = C_b^h Θ(m, n) with the INS roll/pitch hint (the only use of
   the attitude hint, as in the paper: the window and the refraction are about the true
   vertical); r = atan(√(l1² + l2²)/l3) ≤ arcsin(n_a/n_w), n_w = ``ctx.water_index``. In ``lig``
   a margin (``window_margin_rad``) keeps the median/Sobel support off the window's edge, whose
   radial step is not a skylight gradient [deviation: the paper, and ``lig_paper``, use every
   in-window pixel].
4. Plane normals (eqs. 8–12): the paper maps the image angle γ̂ = γ − φ onto the air-side
   celestial sphere at the refracted-back incidence angle i = arcsin(n_w sin r / n_a) (eq. 11),
   through C_l^h (eq. 10). Here the same map is done with the exact chain rule: the image
   gradient (∂I/∂u, ∂I/∂v) is the covector of the sphere gradient G through the Jacobian of
   pixel → in-water ray (lens model, numerical derivative, cached) → air direction (Snell, in the
   level frame: meridian stretch n cos r / cos i, azimuthal stretch sin i / sin r); v = d_air × G.
   For a conformal lens and no refraction this is eq. 12 verbatim; the paper's use of γ̂ as the
   angle on the air sphere ignores the anisotropic stretch of refraction and of the equidistant
   fisheye. This map is the twin's variant (``lig``), not the paper's method: ``lig_paper``
   (:data:`LIG_PAPER`) runs eqs. 9–12 as written, and on the same frames its zenith error is
   often much smaller (ideal camera, II, 5 m, sun 30–70°: within 0.4° against the variant's
   +9…+25°), so the variant is not a refinement there. Normals are unit vectors (the paper: "the
   LIG vectors ... are regarded as unit vectors").
5. s^h = eigenvector of V Vᵀ for κ_min (eqs. 13–15).
6. Sun/anti-sun (the paper's rule): project ±s^h on the horizontal plane; the one pointing at the
   half of the window with the higher mean intensity is the sun. When the two halves differ by
   less than ``ambiguity_min_contrast`` (a sun near the zenith), the sign with s^h_z > 0 (a
   daytime sun is above the horizon) decides; ``extras`` record both.

Pixels excluded beyond the paper: saturated raw values (and the filter support around them: a
clipped sun disc has no gradient), pixels outside the lens's image circle, and pixels whose
gradient is below ``gradient_snr_min`` times the gradient noise (estimated each frame from the
median filter's residual, MAD). Without the last, noise-dominated gradients, whose normals are
spread over the plane ⟂ l, vote for the zenith and bias the elevation upwards in dim frames.

Quality figures: ``pixels_used`` = normals in V; ``residual`` = √(κ_min / N), the RMS of vᵀs
(≈ the RMS angle, rad, by which the planes miss the sun); ``eigen_gap`` = κ_2/κ_min.
Covariance (tangent plane of s, rad²): first-order perturbation of the smallest eigenvector,
cov = σ² Σ_{k=2,3} e_k e_kᵀ / κ_k with σ² = κ_min/(N − 2) the per-normal residual variance, scaled
by the number of analysis pixels one filter footprint correlates (N_eff = N / footprint), plus
an isotropic floor ``sigma_floor_rad``² for the model error the residual cannot see; rotated to
the body frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from twin.core.arrays import Float64Array as FloatArray
from twin.onboard.compass import kernels
from twin.onboard.compass.analysis_grid import (
    AnalysisGeometry,
    block_intensity,
    dilate,
    eigen_from_moments,
    frame_prologue,
    level_rotation,
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
from twin.onboard.compass.geometry import (
    meridian_basis,
    refract_back,
    refract_to_air,
)

_MAD_TO_SIGMA = 1.4826


# ------------------------------------------------------------------------------------------------
# LIG
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LigConfig:
    """LIG settings (paper defaults where it gives any).

    Attributes:
        median_ksize: 2-D median filter kernel (the paper's pre-filter; size not stated). 3 or 5
            (OpenCV's limit for float images).
        analysis_max_width_px: Columns of the analysis grid at most (module docstring, step 1).
        window_margin_rad: Pixels within this of Snell's window edge are left out (filter
            support off the edge step) [not in the paper].
        gradient_snr_min: Keep pixels whose gradient is ≥ this × the gradient noise.
        min_pixels: Fewer usable normals ⇒ no fix.
        min_signal_dn: Mean in-window I (DN above black) below this ⇒ "too dark" no fix.
        min_eigen_gap: κ_2/κ_min below this ⇒ ill-conditioned, no fix.
        ambiguity_min_contrast: Relative intensity difference of the two window halves below
            which the sign falls back to s^h_z > 0.
        sigma_floor_rad: Isotropic floor of the covariance (model error), rad.
        sphere: ``"air"`` — the paper: normals on the air-side celestial sphere through the
            refraction of eq. 11; ``"water"`` — normals on the in-water sphere, the refracted sun
            found first and refracted back to air (a variant for scattering-dominated water).
        weighting: ``"unit"`` — the paper's unit normals; ``"gradient"`` — weighted by the
            relative gradient |∇I|/I on the sphere (a variant).
        mapping: ``"jacobian"`` — the twin's refinement: the image gradient carried to the air
            sphere through the lens's and the refraction's Jacobian (module docstring, step 4);
            ``"paper"`` — eqs. 9–12 as the paper writes them: the LIG angle γ of the image
            gradient, γ̂ = γ − φ with φ the pixel's azimuth from its coordinates,
            χ = arctan(tan(γ̂ − 90°)) (eq. 9), i = arcsin(n_w sin r) (eq. 11) and
            v^h = C_l^h (cos χ, sin χ, 0)ᵀ (eqs. 8, 10).
        eq12_as_printed: With ``mapping="paper"``: take eq. 12's first row as printed,
            cos i cos φ − sin φ sin χ, which lacks the factor cos χ that C_l^h v^l gives it
            (a misprint, measured by switching it); False: the product of eqs. 10 and 8.
        exclude_saturated: Leave out clipped pixels and the filter support around them [not in
            the paper].
    """

    median_ksize: int = 5
    analysis_max_width_px: int = 640
    window_margin_rad: float = math.radians(4.0)
    gradient_snr_min: float = 3.0
    min_pixels: int = 200
    min_signal_dn: float = 8.0
    min_eigen_gap: float = 1.5
    ambiguity_min_contrast: float = 0.02
    sigma_floor_rad: float = math.radians(0.5)
    sphere: str = "air"
    weighting: str = "unit"
    mapping: str = "jacobian"
    eq12_as_printed: bool = False
    exclude_saturated: bool = True

    def __post_init__(self) -> None:
        if self.mapping not in ("jacobian", "paper"):
            raise ValueError(f"LigConfig.mapping: {self.mapping!r}; allowed: 'jacobian', 'paper'")
        if self.sphere not in ("air", "water"):
            raise ValueError(f"LigConfig.sphere: {self.sphere!r}; allowed: 'air', 'water'")
        if self.weighting not in ("unit", "gradient"):
            raise ValueError(
                f"LigConfig.weighting: {self.weighting!r}; allowed: 'unit', 'gradient'"
            )
        if self.median_ksize not in (1, 3, 5):
            raise ValueError(f"LigConfig.median_ksize: {self.median_ksize!r}; allowed: 1, 3, 5")
        if not (isinstance(self.analysis_max_width_px, int) and self.analysis_max_width_px >= 16):
            raise ValueError(
                f"LigConfig.analysis_max_width_px: {self.analysis_max_width_px!r}; "
                "allowed: an integer >= 16"
            )
        for name, lo, hi in (
            ("window_margin_rad", 0.0, 0.5),
            ("gradient_snr_min", 0.0, 1e3),
            ("min_signal_dn", 0.0, 1e9),
            ("min_eigen_gap", 1.0, 1e9),
            ("ambiguity_min_contrast", 0.0, 1.0),
            ("sigma_floor_rad", 0.0, 1.0),
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"LigConfig.{name}: {v!r}; allowed: [{lo:g}, {hi:g}]")
        if not (isinstance(self.min_pixels, int) and self.min_pixels >= 3):
            raise ValueError(f"LigConfig.min_pixels: {self.min_pixels!r}; allowed: >= 3")


class LigCompass(CompassMethod):
    """Light-intensity-gradient solar tracking (Hu et al. 2024, §2, eqs. 5–15)."""

    name = "lig"
    config_type = LigConfig

    def solve_frame(self, frame: Frame) -> CompassFix:
        cfg = self.config
        calibration, ctx = frame.calibration, frame.ctx
        pro = frame_prologue(frame, cfg.analysis_max_width_px)
        raw, sun_enu, n_w, geo = pro.raw, pro.sun_enu, pro.water_index, pro.geometry

        # Eqs. 6–7: in-window pixels from the attitude hint.
        c_c_h = level_rotation(calibration, ctx)
        in_window, core = snell_window(geo, c_c_h, n_w, cfg.window_margin_rad)
        n_window = int(in_window.sum())
        if n_window < cfg.min_pixels:
            return no_fix(self.name, "Snell's window is (almost) out of view", n_window)
        # Everything below works on the window's box: the in-window pixels' rows and columns
        # widened by the filters' support (a quarter of the image at 10 m). Every value the method
        # reads is the whole image's: the intensity (each pixel its own raw block), the median at
        # the window's pixels (an order statistic of the same neighbours), the gradient and the
        # excluded neighbourhoods at the core's (_filtered_box; tests/onboard/compass/
        # test_window_box.py).
        k = max(cfg.median_ksize, 1)
        box = _box(in_window, cfg.median_ksize)
        inten_b, sat_b = block_intensity(raw, calibration, geo, box)
        win_b, core_b = in_window[box], core[box]
        mean_i = float(inten_b[win_b].mean())
        if not (mean_i >= cfg.min_signal_dn):
            return no_fix(
                self.name,
                f"too dark: mean in-window intensity {mean_i:.3g} DN < {cfg.min_signal_dn:g}",
                n_window,
                mean_intensity_dn=mean_i,
            )

        # Median filter, then the image gradient (the LIG vectors, §2).
        filt_b, gx_b, gy_b = _filtered(inten_b, cfg.median_ksize)
        # Noise: MAD of the median filter's residual in the window; the Sobel (scale 1/8) of a
        # k×k median has a per-component std ≈ σ · √(12)/8 · √(π/2)/k (median of k² ≈ 1.25σ/k).
        resid = (inten_b - filt_b)[core_b]
        sigma = _MAD_TO_SIGMA * float(np.median(np.abs(resid - np.median(resid))))
        sigma_g = sigma * math.sqrt(12.0) / 8.0 * math.sqrt(math.pi / 2.0) / k
        gmag2 = gx_b * gx_b + gy_b * gy_b
        radius = k // 2 + 1  # median + Sobel support
        bad = dilate(~geo.valid[box], radius)
        if cfg.exclude_saturated:
            bad = bad | dilate(sat_b, radius)
        use = np.zeros(core.shape, dtype=bool)
        use[box] = core_b & ~bad & (gmag2 > (cfg.gradient_snr_min * sigma_g) ** 2) & (gmag2 > 0)
        filt, gx, gy = (_whole(a, box, core.shape) for a in (filt_b, gx_b, gy_b))
        idx = np.flatnonzero(use)
        if idx.size < cfg.min_pixels:
            return no_fix(
                self.name,
                f"too few pixels with a usable gradient: {idx.size} < {cfg.min_pixels}",
                int(idx.size),
            )

        if cfg.mapping == "paper":
            p_c = geo.rays.reshape(-1, 3)[idx]
            p_h = p_c @ c_c_h.T
            normals = _paper_normals(
                p_c, p_h, gx.reshape(-1)[idx], gy.reshape(-1)[idx], n_w, cfg.eq12_as_printed
            )
            if len(normals) < cfg.min_pixels:
                return no_fix(self.name, "too few pixels with a usable gradient", len(normals))
            weights = None
            if cfg.weighting == "gradient":  # |n| = 1 here: 1 / I
                weights = 1.0 / np.maximum(filt.reshape(-1)[idx].astype(np.float64), 1e-6)
            sol = smallest_eigenvector(normals, weights)  # eqs. 13–15
        else:
            # The Jacobian mapping, compiled (kernels.lig_moments = _jacobian_normals summed).
            mat, wsum, n_ok = kernels.lig_moments(
                idx, geo.rays.reshape(-1, 3), geo.du.reshape(-1, 3), geo.dv.reshape(-1, 3),
                gx.reshape(-1), gy.reshape(-1), filt.reshape(-1), c_c_h,
                n_w if cfg.sphere == "air" else 1.0, cfg.weighting == "gradient",
            )  # fmt: skip
            if n_ok < cfg.min_pixels:
                return no_fix(self.name, "too few pixels with a usable gradient", n_ok)
            sol = eigen_from_moments(mat, wsum, n_ok)  # eqs. 13–15
        return self._finish(sol, cfg, frame, in_window, geo, c_c_h, filt, sun_enu, k, sigma_g,
                            mean_i)  # fmt: skip

    def _finish(self, sol, cfg, frame, in_window, geo, c_c_h, filt, sun_enu, k, sigma_g, mean_i):
        """Eqs. 13–15's solution → the fix (the sign by intensity, the covariance)."""
        ctx = frame.ctx
        n_w = float(ctx.water_index)
        if not (sol.eigen_gap >= cfg.min_eigen_gap):
            return no_fix(
                self.name,
                f"ill-conditioned: eigen gap {sol.eigen_gap:.3g} < {cfg.min_eigen_gap:g}",
                sol.n,
                eigen_gap=sol.eigen_gap,
            )
        win_idx = np.flatnonzero(in_window)
        s_h, contrast, by_intensity = resolve_by_intensity_at(
            sol.s,
            geo.rays,
            win_idx,
            c_c_h,
            filt.reshape(-1)[win_idx],
            cfg.ambiguity_min_contrast,
        )
        if cfg.sphere == "water" and cfg.mapping == "jacobian":
            s_h = refract_back(s_h, n_w)
        c_b_h = ctx.c_b_h
        sun_body = c_b_h.T @ s_h
        footprint = float((k + 2) ** 2)  # analysis pixels sharing one median+Sobel support
        cov_h = sol.covariance(footprint, cfg.sigma_floor_rad)
        cov_b = c_b_h.T @ cov_h @ c_b_h
        return finish_fix(
            self.name,
            sun_body,
            ctx,
            sun_enu,
            cov_b,
            pixels_used=sol.n,
            residual=sol.residual,
            eigen_gap=sol.eigen_gap,
            ambiguity_contrast=contrast,
            ambiguity_by_intensity=float(by_intensity),
            ambiguity_agrees_with_elevation=float(s_h[2] >= 0),
            analysis_block_px=float(geo.m),
            gradient_noise_dn=sigma_g,
            mean_intensity_dn=mean_i,
        )


def _box(in_window: NDArray[np.bool_], ksize: int) -> tuple[slice, slice]:
    """LIG's box: the window's, widened by the median's and the Sobel's support and one more."""
    return window_box(in_window, max(ksize, 1) // 2 + 2)


def _filtered_box(
    intensity: NDArray[np.float32], in_window: NDArray[np.bool_], ksize: int
) -> tuple[tuple[slice, slice], NDArray[np.float32], NDArray[np.float32], NDArray[np.float32]]:
    """The window's box (LIG's) and :func:`_filtered` of the whole image's ``intensity`` there.

    The median is the whole image's at every in-window pixel, the gradient at every in-window
    pixel whose 3×3 neighbours are in the window (``tests/onboard/compass/test_window_box.py``).
    """
    box = _box(in_window, ksize)
    return (box, *_filtered(intensity[box], ksize))


def _filtered(
    intensity: NDArray[np.float32], ksize: int
) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float32]]:
    """The median-filtered intensity and the Sobel gradients (gx, gy) of that."""
    filt = cv2.medianBlur(intensity, ksize) if ksize > 1 else intensity
    gx = cv2.Sobel(filt, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)
    gy = cv2.Sobel(filt, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)
    return filt, gx, gy


def _whole(part: NDArray[np.float32], box: tuple[slice, slice], shape: tuple[int, int]):
    """A box's values in a whole-image array, zero outside it."""
    out = np.zeros(shape, dtype=part.dtype)
    out[box] = part
    return out


def _paper_normals(
    p_c: FloatArray, p_h: FloatArray, gx: FloatArray, gy: FloatArray, n_w: float, printed: bool
) -> FloatArray:
    """Eqs. 8–12 as the paper writes them (LigConfig.mapping = "paper").

    γ: the image gradient's angle from the image's zero direction, taken in the camera's x–y
    plane (the image's u axis is camera +x, v is camera −y, so the gradient is (g_u, −g_v));
    φ: the pixel's azimuth from its coordinates, i.e. of its ray in the camera frame (the lens
    model Θ); r from l^h (eq. 7), i from eq. 11 (clipped at 90°).
    """
    gamma = np.arctan2(-gy.astype(np.float64), gx.astype(np.float64))
    phi = np.arctan2(p_c[:, 1], p_c[:, 0])
    chi = np.arctan(np.tan(gamma - phi - 0.5 * math.pi))  # eq. 9, χ ∈ [−90°, 90°]
    sin_r = np.hypot(p_h[:, 0], p_h[:, 1])
    sin_i = np.minimum(n_w * sin_r, 1.0)  # eq. 11
    cos_i = np.sqrt(np.maximum(1.0 - sin_i * sin_i, 0.0))
    cp, sp, cc, sc = np.cos(phi), np.sin(phi), np.cos(chi), np.sin(chi)
    first = cos_i * cp - sp * sc if printed else cos_i * cp * cc - sp * sc
    v = np.stack([first, cos_i * sp * cc + cp * sc, -sin_i * cc], axis=-1)  # eq. 12
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _jacobian_normals(
    geo: AnalysisGeometry,
    idx: NDArray[np.intp],
    c_c_h: FloatArray,
    p_h: FloatArray,
    gx: NDArray[np.float32],
    gy: NDArray[np.float32],
    n_w: float,
    sphere: str,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """The twin's refinement of eqs. 8–12 (module docstring, step 4): (normals, |n|, kept).

    With numpy: the reference :func:`twin.onboard.compass.kernels.lig_moments` (what the method
    runs) is tested against.
    """
    # Eqs. 8–12 by the chain rule: image covector → sphere gradient on the air side → normal.
    du_h = geo.du.reshape(-1, 3)[idx] @ c_c_h.T
    dv_h = geo.dv.reshape(-1, 3)[idx] @ c_c_h.T
    n_sphere = n_w if sphere == "air" else 1.0
    d_air, sin_r, sin_i = refract_to_air(p_h, n_sphere)
    e_t, e_p = meridian_basis(p_h)  # same azimuth ⇒ e_φ is shared by water and air sides
    cos_r_s = p_h[:, 2]
    cos_i = d_air[:, 2]
    # Meridian stretch di/dr = n cos r / cos i, azimuthal stretch sin i / sin r (eq. 11).
    st = n_sphere * cos_r_s / np.maximum(cos_i, 1e-6)
    sp = np.divide(sin_i, sin_r, out=np.full_like(sin_r, n_sphere), where=sin_r > 1e-9)
    a1 = np.einsum("ij,ij->i", du_h, e_t) * st
    a2 = np.einsum("ij,ij->i", du_h, e_p) * sp
    b1 = np.einsum("ij,ij->i", dv_h, e_t) * st
    b2 = np.einsum("ij,ij->i", dv_h, e_p) * sp
    gu = gx.reshape(-1)[idx].astype(np.float64)
    gv = gy.reshape(-1)[idx].astype(np.float64)
    det = a1 * b2 - a2 * b1
    g1 = (gu * b2 - gv * a2) / det  # sphere gradient along e_i (air meridian)
    g2 = (a1 * gv - b1 * gu) / det  # along e_φ
    e_i, _ = meridian_basis(d_air)
    normals = g1[:, None] * e_p - g2[:, None] * e_i  # d × (g1 e_i + g2 e_φ), (d, e_i, e_φ) RH
    nn = np.linalg.norm(normals, axis=1)
    ok = np.isfinite(nn) & (nn > 0)
    return normals[ok] / nn[ok, None], nn, ok


#: LIG as the paper writes it: eqs. 9–12 (``mapping="paper"``), every in-window pixel (no margin,
#: no gradient-noise threshold, clipped pixels kept, no conditioning threshold), the paper's
#: median pre-filter. (Kept from the twin: the 5×5 median, whose size the paper does not give, the
#: Sobel gradient, and the too-dark / too-few-pixels guards.)
LIG_PAPER = LigConfig(
    mapping="paper",
    window_margin_rad=0.0,
    gradient_snr_min=0.0,
    exclude_saturated=False,
    min_eigen_gap=1.0,
)


class LigPaperCompass(LigCompass):
    """LIG exactly as Hu et al. (2024) write it (:data:`LIG_PAPER`); ``lig`` is the twin's."""

    name = "lig_paper"

    def __init__(self, config: LigConfig | None = None, **overrides: object) -> None:
        super().__init__(config if config is not None else LIG_PAPER, **overrides)
