"""Snell-window attitude and heading: Xin et al. 2024 (Opt. Precision Eng. 32(12):1801), "snell".

From one frame the method measures all three attitude angles:

* **roll and pitch** from the centre of Snell's window, which is the zenith (§3): a grey-level
  threshold keeps the bright window (§3.2, "the brightest 70 %"), the centre of the kept pixels is
  the zenith seen in the body frame N = (N_x, N_y, N_z) (eq. 12, N = R_{A→B}·(0, 0, 1)), and
  pitch ϑ = arcsin N_y (eq. 13), roll γ = arctan(−N_x / N_z) (eq. 14);
* **yaw** from the solar meridian (§2.2–2.4): AoP (eq. 5) → angle of the E-vector from the local
  meridian, the AoE (eq. 6), after a fisheye distortion correction and a polarization-error
  compensation that depends on the incidence angle (§2.3); median and Gaussian filtering; the
  "solar-meridian characteristic region" |AoE| ≈ 90° (points on the solar meridian have
  AoE = ±90°, §2.2); Canny edges of that region, Hough lines of the edges, and the symmetry of
  the two edges about the meridian give the angle ψ_SM between the solar meridian and the body
  axis; ψ = ψ_SM − ψ_s (eq. 7) with the ephemeris azimuth ψ_s.

How this implementation reads the paper (decisions, each marked in the code):

0. **Working frame** (not in the paper). A frame larger than ``max_work_px`` (640) is first binned
   by same orientation to at most that size (``bin_mosaic``; 2448×2048 → 612×512), registered so
   that the four analysers of a binned super-pixel sample one point, with the matching
   calibration (``binned_calibration``); everything below runs on that frame. The window is
   ~100 working pixels in radius and every step averages hundreds to thousands of pixels, so
   full resolution buys no accuracy here (validation/results/campaigns/snell_attitude: the same
   MAE at both resolutions, 2.5 s a run against 0.2 s).
1. **Distortion correction** (§2.4). The paper undistorts with a Zhang pinhole model, which cannot
   hold rays beyond 90° off-axis (a 185° lens tilted 50° sees the window out to 98.6°). Here the
   calibration's own ray model (``CameraCalibration.project``) resamples the frame onto an ideal
   equidistant image centred on the *zenith* and levelled with the roll and pitch the method has
   just measured. In that image eq. 6 holds as printed: the AoE is the AoP minus the pixel's
   polar angle about the image centre, and the solar meridian is a straight line through the
   centre. (Without levelling, the meridian of a tilted camera would not pass through the image
   centre, and eq. 6 would measure the E-vector against the camera's, not the sky's, meridians.)
   S0, S1 and S2 are resampled (they are linear in the radiance) and the AoE is formed per output
   pixel along its own ray.
2. **Window centre** (§3.2, eq. 12). The centre of the thresholded pixels is taken on the sphere:
   the solid-angle-weighted mean of their unit rays, which for a whole window is exactly the
   zenith (a pixel centroid of the elliptical image of a tilted window is not). Where the window
   runs off the 185° field (tilt > ~44°) only pixels whose mirror image about the current axis is
   also in the field are kept (two iterations), which removes the truncation bias. Then the
   rim is fitted (``edge_refine``): the sun's forward-scattering glow spills past the window on
   the sun's side and passes the threshold, pulling the centroid by 6–14° in Jerlov II with the
   sun at 35°. The rim is found per azimuth on a polar grid about the estimate (steepest outward
   fall of the log grey) and a circle fitted robustly, narrowing from ± ``rim_search_deg``.
   (An earlier fit maximised the mean log-grey step across a fixed cone by Nelder–Mead; its cost
   is piecewise constant in the zenith and it stalled 7–13° off on 3 of 114 benchmark frames.)
3. **Grey value** (eq. 15). As printed, eq. 15 has ``cos 2φ`` twice (``sin 2φ`` is meant) and
   depends on an analyser angle φ; its mean over φ, ½S0, is used so that the polarization
   pattern does not shift the centroid. "The brightest 70 %" is read as the brightest 70 % of the
   *logarithmic* grey range between the dark and the bright end of the image circle (1st and 99.9th
   percentiles): on a linear scale the sun's glow puts the threshold inside the window, and a
   70 % pixel quantile would select the dark surround (the window is ~25 % of the circle).
4. **Polarization-error compensation** (§2.3). The paper fits the lens's AoP error against the
   incidence angle on a telecentric bench. The calibration already carries the lens's ideal
   mapping of polarization (``CameraCalibration.evectors``); ``aop_error_poly_deg`` is the residual
   bench-fitted error δψ(θ) (degrees, polynomial in the incidence angle in degrees), subtracted
   before the E-vectors are lifted to 3-D. The twin's lens has no such error: default none.
5. **Filtering** (§2.4). The AoE wraps at ±90° — exactly on the solar meridian — so the median
   (5×5) and Gaussian (5×5, σ = 1 px) filters run on the doubled-angle components cos 2AoE and
   sin 2AoE, not on the angle.
6. **180° ambiguity.** The AoE is ±90° on the whole meridian, the sun's half and the anti-sun's
   half alike, so Hough gives ψ_SM only modulo 180°. It is resolved by brightness: the half of
   Snell's window towards the sun is brighter (the refracted sun and its forward-scattering glow),
   so the sun lies on the side of the S0-weighted centroid of the window (levelled image).
   ``extras["ambiguity_margin"]`` is that centroid's offset along the meridian over the window
   radius (near 0: undecided; the fix is refused below ``min_ambiguity_margin``).

Fix: the sun's azimuth in the levelled frame comes from the meridian, its elevation from the
ephemeris (the meridian carries none); the solar vector is built in the horizontal frame and
returned in the body frame with the method's own roll/pitch (``finish_fix(c_b_h=...)``).

Quality: ``pixels_used`` = window pixels (thresholded Stokes-grid pixels of the working frame);
``extras["rim_azimuths"]`` = azimuths the rim fit kept (0: the centroid stands),
``extras["work_binning"]`` = the working frame's binning; ``residual`` = the spread (rad, 1σ)
of the selected Hough lines' directions about the meridian after the symmetry pairing;
no eigenproblem (``eigen_gap`` None). Covariance of ``sun_body`` (rad², tangent plane): in the
horizontal frame, azimuth variance σ_az² = max(residual²/n_lines, (Δθ_Hough)²/12) + a floor
(``azimuth_floor_deg``)² scaled by cos²(elevation) along the horizontal tangent, and the
tilt variance (``tilt_sigma_deg``, default the paper's 0.7° roll/pitch MAE) along the vertical
tangent; rotated to the body frame.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from twin.core.calibration import CameraCalibration, StokesGrid
from twin.core.frames import euler_to_dcm
from twin.onboard.compass.base import (
    CompassFix,
    CompassMethod,
    FloatArray,
    Frame,
    finish_fix,
    no_fix,
)
from twin.onboard.compass.geometry import meridian_basis
from twin.onboard.compass.snell_config import SNELL_PAPER, SnellConfig
from twin.onboard.compass.working_frame import (
    bin_mosaic,
    binned_calibration,
    binning_for,
    evectors_h,
    grid_coords,
    pixel_solid_angle,
    to_stokes,
)
from twin.onboard.polarization import PolarizationImage


# ---- the method ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class WindowCentre:
    """Result of the window-centre step (eqs. 12–14)."""

    zenith_body: FloatArray
    roll_rad: float
    pitch_rad: float
    pixels: int
    contrast: float
    mask: NDArray[np.bool_]
    rim_azimuths: int = 0


@functools.lru_cache(maxsize=8)
def _grid_geometry(
    calibration: CameraCalibration, grid: StokesGrid
) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
    """Rays, validity and solid-angle weights of a Stokes grid (cached per calibration)."""
    rays_c, valid = calibration.rays(grid)
    theta = np.arctan2(np.hypot(rays_c[..., 0], rays_c[..., 1]), rays_c[..., 2])
    return rays_c, valid, pixel_solid_angle(calibration, theta)


@functools.lru_cache(maxsize=8)
def _level_grid(n: int, k: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Directions (h frame), zenith angles and meridian bases of the n×n levelled image."""
    half = (n - 1) // 2
    vv, uu = np.mgrid[0:n, 0:n].astype(np.float64)
    x = (uu - half) / k
    y = -(vv - half) / k
    th = np.hypot(x, y)
    ph = np.arctan2(y, x)
    d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    e_th, e_ph = meridian_basis(d)
    return d, th, e_th, e_ph


@functools.lru_cache(maxsize=8)
def _polar_maps(n: int, n_a: int) -> tuple[NDArray[np.float32], NDArray[np.float32], FloatArray]:
    """``cv2.remap`` maps of an n×n centred image onto (radius 3 … , n_a angles); radii."""
    half = (n - 1) / 2.0
    r = np.arange(3.0, half - 1.0)
    a = np.arange(n_a) * (2.0 * math.pi / n_a)
    mx = (half + r[:, None] * np.cos(a)[None, :]).astype(np.float32)
    my = (half - r[:, None] * np.sin(a)[None, :]).astype(np.float32)
    return mx, my, r


def robust_sinusoid(phi: FloatArray, y: FloatArray, floor: float) -> tuple[FloatArray, int] | None:
    """Robust fit y ≈ c0 + c1 cos φ + c2 sin φ: least median of squares, then Tukey IRLS.

    Candidates are the exact fits to triples of samples spread over the list (deterministic);
    ``floor`` bounds the residual scale from below. Returns (c, inliers) or None (< 12 samples).
    """
    n = y.size
    if n < 12:
        return None
    a = np.stack([np.ones_like(phi), np.cos(phi), np.sin(phi)], axis=1)
    i = np.arange(0, n, max(1, n // 60))
    trip = np.concatenate(
        [
            np.stack([i, (i + n // 3) % n, (i + 2 * n // 3) % n], 1),
            np.stack([i, (i + n // 4) % n, (i + n // 2) % n], 1),
            np.stack([i, (i + n // 6) % n, (i + n // 3) % n], 1),
        ]
    )
    m = a[trip]
    ok = np.abs(np.linalg.det(m)) > 1e-3
    if not ok.any():
        return None
    coef = np.linalg.solve(m[ok], y[trip[ok]][..., None])[..., 0]
    med = np.median(np.abs(a @ coef.T - y[:, None]), axis=0)
    c = coef[int(np.argmin(med))]
    for _ in range(10):
        r = y - a @ c
        s = max(1.4826 * float(np.median(np.abs(r))), floor)
        u = r / (4.685 * s)
        w = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        if np.count_nonzero(w) < 6:
            break
        aw = a * w[:, None]
        c_new = np.linalg.solve(aw.T @ a, aw.T @ y)
        done = np.max(np.abs(c_new - c)) < 1e-3 * floor
        c = c_new
        if done:
            break
    r = y - a @ c
    s = max(1.4826 * float(np.median(np.abs(r))), floor)
    return c, int(np.count_nonzero(np.abs(r) < 4.685 * s))


class SnellWindowMethod(CompassMethod):
    """Snell-window attitude (roll, pitch from the window centre) and Hough solar-meridian yaw."""

    name = "snell"

    config_type = SnellConfig

    # ---- step 0: the working frame --------------------------------------------------------------
    def working_frame(
        self, raw: NDArray[np.generic], calibration: CameraCalibration
    ) -> tuple[NDArray[np.generic], CameraCalibration, int]:
        """The frame binned to ``max_work_px`` (decision 0), its calibration and the binning."""
        b = binning_for(calibration, self.config.max_work_px)
        if b == 1:
            return raw, calibration, 1
        return (
            bin_mosaic(raw, b, calibration.saturation_dn),
            binned_calibration(calibration, b),
            b,
        )

    # ---- step 1: the window centre ⇒ roll, pitch (§3, eqs. 12–15) --------------------------------
    def window_centre(
        self, pol: PolarizationImage, calibration: CameraCalibration, water_index: float = 1.338
    ) -> WindowCentre | str:
        """Zenith in the body frame from the grey-threshold window; a reason string on failure."""
        cfg = self.config
        rays_c, valid, omega = _grid_geometry(calibration, cfg.stokes_grid)
        grey = 0.5 * pol.s0  # eq. 15 averaged over the analyser angle φ (float32)
        g = grey[valid]
        if g.size == 0:
            return "no valid pixels in the image circle"
        # The dark end of the *scene*: pixels at or below 1 DN are the floor the log range is
        # clamped to anyway, and they include the unlit ring that an onboard model with too long a
        # focal length believes inside its image circle (a 1 % error put 5 % of the "circle" at
        # 0 DN, dragged the 1st percentile to the floor and the threshold into the sea: roll 0°).
        g_lit = g[g > 1.0]
        p_lo, p_hi = np.percentile(g_lit if g_lit.size else g, [1.0, 99.9])
        lo, hi = max(float(p_lo), 1.0), max(float(p_hi), 1.0)
        if hi < cfg.min_signal_dn:
            return f"frame too dark (99.9th percentile {hi:.1f} DN < {cfg.min_signal_dn:g})"
        # Brightest `grey_fraction` of the log grey range (decision 3 in the module docstring).
        thr = math.exp(math.log(hi) - cfg.grey_fraction * (math.log(hi) - math.log(lo)))
        mask = valid & (grey >= thr)
        n = int(mask.sum())
        if n < cfg.min_window_pixels:
            return f"Snell's window not found ({n} bright pixels < {cfg.min_window_pixels})"
        inside = float(np.median(grey[mask]))
        outside_px = grey[valid & ~mask]
        outside = float(np.median(outside_px)) if outside_px.size else 0.0
        contrast = inside / max(outside, 1e-6)
        if contrast < cfg.min_window_contrast:
            return (
                f"Snell's window not distinct (contrast {contrast:.2f} "
                f"< {cfg.min_window_contrast:g})"
            )
        if inside < cfg.min_signal_dn:
            return f"frame too dark (window median {inside:.1f} DN < {cfg.min_signal_dn:g})"
        d = rays_c[mask]
        w = omega[mask]
        z_c = w @ d
        z_c /= np.linalg.norm(z_c)
        if cfg.symmetric_truncation:
            tmax = calibration.max_field_angle_rad
            for _ in range(2):
                mirror = 2.0 * (d @ z_c)[:, None] * z_c[None, :] - d
                keep = np.arctan2(np.hypot(mirror[:, 0], mirror[:, 1]), mirror[:, 2]) <= tmax
                if keep.sum() < cfg.min_window_pixels:
                    break
                z_new = w[keep] @ d[keep]
                z_c = z_new / np.linalg.norm(z_new)
        n_rim = 0
        if cfg.edge_refine and water_index > 1.0:
            lg = np.log(np.maximum(grey, 1.0)).astype(np.float32)
            rim = self._fit_rim(calibration, lg, z_c, math.asin(1.0 / water_index))
            if rim is not None:
                z_c, n_rim = rim
        n_b = calibration.c_c_b @ z_c  # eq. 12: N = R_{A→B} (0, 0, 1)ᵀ
        pitch = math.asin(max(-1.0, min(1.0, float(n_b[1]))))  # eq. 13
        roll = math.atan2(-float(n_b[0]), float(n_b[2]))  # eq. 14 (atan2 keeps |γ| > 90° apart)
        return WindowCentre(n_b, roll, pitch, n, contrast, mask, n_rim)

    def _fit_rim(
        self,
        calibration: CameraCalibration,
        lgrey: NDArray[np.float32],
        z0: FloatArray,
        theta_c: float,
    ) -> tuple[FloatArray, int] | None:
        """Zenith (camera frame) at the centre of the window's rim (``edge_refine``); inliers.

        None when the rim is not found (the centroid stands).
        """
        cfg = self.config
        sub = 2.0 if cfg.stokes_grid == "superpixel" else 1.0
        px = sub / calibration.focal_px  # rad per Stokes-grid pixel near the axis
        sigma = max(math.radians(cfg.rim_smooth_deg), px)
        tmax = calibration.max_field_angle_rad - 2.0 * px  # off the image circle's own edge
        n_phi = cfg.rim_azimuths
        phi = np.arange(n_phi) * (2.0 * math.pi / n_phi)
        cphi, sphi = np.cos(phi), np.sin(phi)
        z = z0 / np.linalg.norm(z0)
        n_in = 0
        found = False
        for half_deg in (cfg.rim_search_deg, 6.0, 3.0, 3.0):
            half = math.radians(half_deg)
            step = max(0.25 * px, half / 80.0)  # coarse while far, a quarter pixel when close
            pad = math.ceil(3.0 * sigma / step)
            ksize = 2 * pad + 1
            n_r = math.ceil(half / step)
            th = theta_c + np.arange(-n_r - pad, n_r + pad + 1) * step
            th = th[(th > 2 * sigma) & (th < math.pi)]
            t1 = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
            t1 /= np.linalg.norm(t1)
            t2 = np.cross(z, t1)
            radial = cphi[:, None] * t1 + sphi[:, None] * t2  # (n_phi, 3)
            dirs = np.cos(th)[:, None, None] * z + np.sin(th)[:, None, None] * radial[None]
            mx, my, ok = grid_coords(calibration, dirs, cfg.stokes_grid)
            ok &= np.arctan2(np.hypot(dirs[..., 0], dirs[..., 1]), dirs[..., 2]) <= tmax
            lp = cv2.remap(lgrey, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            lp = cv2.GaussianBlur(
                lp, (1, ksize), sigmaX=0.1, sigmaY=sigma / step, borderType=cv2.BORDER_REPLICATE
            )
            grad = np.diff(lp, axis=0) / step  # at (th[i] + th[i+1]) / 2
            # A gradient sample is usable when the smoothing kernel saw only valid samples.
            okc = np.cumsum(~ok, axis=0)
            lo_i = np.clip(np.arange(grad.shape[0]) - pad, 0, None)
            hi_i = np.clip(np.arange(grad.shape[0]) + pad + 1, None, ok.shape[0] - 1)
            bad = (okc[hi_i] - okc[lo_i] + (~ok)[lo_i]) > 0
            grad = np.where(bad, 0.0, grad)
            grad[: max(pad - 1, 0)] = 0.0
            grad[grad.shape[0] - pad :] = 0.0
            i = np.argmin(grad, axis=0)
            depth = -grad[i, np.arange(n_phi)]
            # Columns whose edge lies on the image circle's cut (rim beyond the field) or whose
            # steepest fall is weak (no rim in range) carry no rim.
            last_ok = ok.shape[0] - 1 - np.argmax(ok[::-1], axis=0)
            col = ok.any(axis=0) & (depth > 0) & (i + 1 + 2 * pad < last_ok)
            if col.sum() < 12:
                break
            col &= depth >= 0.25 * float(np.percentile(depth[col], 90))
            ic = np.clip(i, 1, grad.shape[0] - 2)
            gl, g0, gr = (grad[ic + o, np.arange(n_phi)] for o in (-1, 0, 1))
            den = gl - 2.0 * g0 + gr
            frac = np.where(den > 0, 0.5 * (gl - gr) / np.where(den > 0, den, 1.0), 0.0)
            t_edge = th[0] + (ic + 0.5 + np.clip(frac, -0.5, 0.5)) * step
            fit = robust_sinusoid(phi[col], t_edge[col], floor=0.5 * step)
            if fit is None:
                break
            (_r0, a, b), n_in = fit
            if n_in < max(12, 0.2 * n_phi):
                break
            delta = math.hypot(a, b)
            if delta > math.radians(cfg.rim_search_deg):
                break
            found = True
            if delta > 0:
                z = math.cos(delta) * z + math.sin(delta) * (a * t1 + b * t2) / delta
                z /= np.linalg.norm(z)
            if delta < 1e-5:
                break
        return (z, n_in) if found else None

    # ---- step 2: the levelled, undistorted AoE image (§2.2–2.4, eqs. 5–6) ---------------------
    def levelled_aoe(
        self,
        pol: PolarizationImage,
        calibration: CameraCalibration,
        c_b_h: FloatArray,
        theta_c: float,
    ) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_], float]:
        """Cos 2AoE, sin 2AoE, grey and the in-window mask on a level, zenith-centred grid.

        Returns (c2, s2, grey, inside, scale_px_per_rad); the image's centre is the zenith, +x
        (columns) the body's level starboard axis and −rows its level forward axis. S0, S1, S2 are
        resampled (bilinear, they are linear in the radiance) and the AoE is formed per output
        pixel along its own ray.
        """
        cfg = self.config
        c_c_h = c_b_h @ calibration.c_c_b
        # Output grid: equidistant about the zenith, radius = the window (+ a little).
        sub = 2.0 if cfg.stokes_grid == "superpixel" else 1.0
        k = cfg.level_scale * calibration.focal_px / sub  # Stokes-grid px per rad
        half = math.ceil(k * (theta_c + math.radians(2.0))) + 2
        n = 2 * half + 1
        d_out, th, e_th, e_ph = _level_grid(n, k)
        d_cam = d_out @ c_c_h  # h → camera (c_c_h orthonormal: inverse = transpose)
        map_x, map_y, valid = grid_coords(calibration, d_cam, cfg.stokes_grid)

        def remap(a: NDArray[np.generic]) -> NDArray[np.float32]:
            return cv2.remap(
                np.asarray(a, np.float32),
                map_x,
                map_y,
                cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=0,
            )

        s0, s1, s2 = remap(pol.s0), remap(pol.s1), remap(pol.s2)
        sat = remap(pol.saturated)
        grey_o = np.where(valid & (th <= theta_c), 0.5 * s0, 0.0)
        inside = (
            valid
            & (th <= theta_c - math.radians(cfg.window_margin_deg))
            & (sat == 0.0)
            & (s0 > 0.0)
            & (np.hypot(s1, s2) >= cfg.min_dop * s0)
        )
        aop = 0.5 * np.arctan2(s2[inside], s1[inside])
        _, e_h = evectors_h(d_cam[inside], aop, calibration, c_c_h, cfg.aop_error_poly_deg)
        # eq. 6 in 3-D: the E-vector's angle from the local (true) meridian of each output ray.
        aoe = np.arctan2(np.sum(e_h * e_ph[inside], -1), np.sum(e_h * e_th[inside], -1))
        c2_o = np.zeros((n, n))
        s2_o = np.zeros((n, n))
        c2_o[inside] = np.cos(2 * aoe)
        s2_o[inside] = np.sin(2 * aoe)
        return c2_o, s2_o, grey_o, inside, k

    # ---- step 3: characteristic region, Canny, Hough ⇒ ψ_SM (§2.4) -------------------------------
    def meridian(
        self, c2: FloatArray, s2: FloatArray, inside: NDArray[np.bool_], radius_px: float
    ) -> tuple[float, float, int] | str:
        """Solar-meridian direction (rad, math angle of the line in the levelled frame, mod π).

        Returns (angle, residual spread, lines used) or a reason string.
        """
        cfg = self.config
        c = cv2.medianBlur(c2.astype(np.float32), cfg.median_ksize)
        s = cv2.medianBlur(s2.astype(np.float32), cfg.median_ksize)
        ks = (cfg.gauss_ksize, cfg.gauss_ksize)
        c = cv2.GaussianBlur(c, ks, cfg.gauss_sigma_px)
        s = cv2.GaussianBlur(s, ks, cfg.gauss_sigma_px)
        aoe = 0.5 * np.arctan2(s, c)
        band = (np.abs(aoe) >= math.pi / 2 - math.radians(cfg.meridian_band_deg)) & inside
        region = band.astype(np.uint8) * 255
        edges = cv2.Canny(region, cfg.canny_low, cfg.canny_high)
        # Edges of the region only inside the window (the window rim is not a meridian edge).
        rim = cv2.erode(inside.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
        edges[~rim] = 0
        votes = max(int(cfg.hough_votes_frac * radius_px), 5)
        lines = cv2.HoughLines(edges, 1, math.radians(cfg.hough_theta_deg), votes)
        if lines is None:
            return "no solar-meridian line found (Hough)"
        n = c2.shape[0]
        cx = cy = (n - 1) / 2.0
        angles = []
        for rho, th in lines[:, 0, :]:
            if abs(cx * math.cos(th) + cy * math.sin(th) - rho) > cfg.hough_center_frac * radius_px:
                continue  # the meridian passes through the zenith
            # Direction of the line in image (col, row) is (−sin θ, cos θ); in the level frame
            # (x = col, y = −row) it is (−sin θ, −cos θ).
            angles.append(math.atan2(-math.cos(th), -math.sin(th)))
            if len(angles) >= cfg.hough_max_lines:
                break
        if not angles:
            return "no Hough line through the zenith"
        a = np.asarray(angles)
        m0 = 0.5 * math.atan2(np.sin(2 * a).sum(), np.cos(2 * a).sum())
        # Symmetry (§2.4, "according to the symmetric distribution"): the Hough lines are the
        # *edges* of the characteristic region, which lie symmetrically about the meridian but
        # only to within a pixel or two, i.e. ~1–2° at these radii. The meridian is the axis
        # about which the filtered AoE image is mirror-antisymmetric (AoE → −AoE): search it
        # within ± 2 band widths of the Hough estimate, then refine by a parabola.
        m, resid = self._symmetry_axis(c, s, inside, m0)
        return float(m), resid, int(a.size)

    def _symmetry_axis(
        self, c: FloatArray, s: FloatArray, inside: NDArray[np.bool_], m0: float
    ) -> tuple[float, float]:
        """Axis through the centre about which (cos 2AoE, sin 2AoE) is (even, odd); rms misfit.

        The misfit of the mirror about the axis at angle m is the mean over pixels p (both p and
        its mirror p' inside the window) of (c(p) − c(p'))² + (s(p) + s(p'))². On a polar grid
        (radius r, angle a; weight r for the area) the mirror of a is 2m − a, so the misfit of
        every axis m = jΔa/2 is a sum of circular convolutions along a: one FFT pass gives all.
        The minimum within ± 2 band widths of the Hough estimate is refined by a parabola.
        """
        cfg = self.config
        n = c.shape[0]
        n_a = 2 * round(math.pi / math.radians(cfg.hough_theta_deg))
        step = 2.0 * math.pi / n_a
        mx, my, r = _polar_maps(n, n_a)

        def polar(a: NDArray[np.generic]) -> NDArray[np.float32]:
            return cv2.remap(np.asarray(a, np.float32), mx, my, cv2.INTER_LINEAR)

        m_in = (polar(inside) > 0.999).astype(np.float64)
        cp = polar(c).astype(np.float64) * m_in
        sp = polar(s).astype(np.float64) * m_in
        q = (cp * cp + sp * sp) * m_in
        fm, fc, fs, fq = (np.fft.rfft(x, axis=1) for x in (m_in, cp, sp, q))
        w = r[:, None]
        num = np.fft.irfft((w * (2.0 * fq * fm - 2.0 * fc * fc + 2.0 * fs * fs)).sum(0), n_a)
        den = np.fft.irfft((w * fm * fm).sum(0), n_a)
        cnt = np.fft.irfft((fm * fm).sum(0), n_a)
        costs = np.where((cnt > 19.5) & (den > 0), num / np.maximum(den, 1e-12), np.inf)
        m_grid = np.arange(n_a) * (step / 2.0)  # the axis of mirror index j: a → j·Δa − a
        off = (m_grid - m0 + math.pi / 2) % math.pi - math.pi / 2
        span = 2.0 * math.radians(cfg.meridian_band_deg)
        cand = np.flatnonzero(np.abs(off) <= span + 1e-12)
        j = int(cand[np.argmin(costs[cand])])
        m = m0 + float(off[j])
        c_l, c_0, c_r = costs[(j - 1) % n_a], costs[j], costs[(j + 1) % n_a]
        if np.all(np.isfinite([c_l, c_0, c_r])):
            den2 = c_l - 2 * c_0 + c_r
            if den2 > 0:
                m += 0.5 * (step / 2.0) * (c_l - c_r) / den2
        return m, math.sqrt(max(float(c_0), 0.0)) / 2.0 if math.isfinite(c_0) else math.inf

    # ---- the whole method ----------------------------------------------------------------------
    def solve_frame(self, frame: Frame) -> CompassFix:
        cfg = self.config
        raw, calibration, ctx, sun_enu = frame.raw, frame.calibration, frame.ctx, frame.sun_enu
        el = frame.sun_elevation_rad
        if el > math.radians(cfg.max_sun_elevation_deg):
            return no_fix(self.name, "sun near the zenith: no solar meridian")
        raw_w, cal_w, binning = self.working_frame(raw, calibration)
        pol = to_stokes(raw_w, cal_w, cfg.stokes_grid)
        wc = self.window_centre(pol, cal_w, ctx.water_index)
        if isinstance(wc, str):
            return no_fix(self.name, wc)
        c_b_h = euler_to_dcm(wc.roll_rad, wc.pitch_rad, 0.0)
        n_w = ctx.water_index
        theta_c = math.asin(1.0 / n_w) if n_w > 1.0 else math.pi / 2
        c2, s2, grey, inside, k = self.levelled_aoe(pol, cal_w, c_b_h, theta_c)
        radius_px = k * theta_c
        mer = self.meridian(c2, s2, inside, radius_px)
        if isinstance(mer, str):
            return no_fix(self.name, mer, wc.pixels)
        m, resid, n_lines = mer
        # 180° ambiguity: the sun's half of the window is the brighter one (decision 6).
        n = grey.shape[0]
        half = (n - 1) / 2.0
        vv, uu = np.mgrid[0:n, 0:n].astype(np.float64)
        x, y = uu - half, -(vv - half)
        tot = float(grey.sum())
        if tot <= 0:
            return no_fix(self.name, "window is dark in the levelled image", wc.pixels)
        cx, cy = float((grey * x).sum() / tot), float((grey * y).sum() / tot)
        along = (cx * math.cos(m) + cy * math.sin(m)) / radius_px
        if abs(along) < cfg.min_ambiguity_margin:
            return no_fix(
                self.name,
                "solar-meridian 180° ambiguity undecided (window brightness symmetric)",
                wc.pixels,
                ambiguity_margin=abs(along),
            )
        phi_sun = m if along > 0 else m + math.pi  # math azimuth of the sun in the level frame
        sun_h = np.array(
            [math.cos(el) * math.cos(phi_sun), math.cos(el) * math.sin(phi_sun), math.sin(el)]
        )
        sun_body = c_b_h.T @ sun_h
        # Covariance (module docstring), built in h then rotated to b.
        var_az = max(resid**2 / max(n_lines, 1), math.radians(cfg.hough_theta_deg) ** 2 / 12.0)
        var_az += math.radians(cfg.azimuth_floor_deg) ** 2
        t_az = np.array([-math.sin(phi_sun), math.cos(phi_sun), 0.0])
        t_el = np.cross(sun_h, t_az)
        cov_h = (math.cos(el) ** 2) * var_az * np.outer(t_az, t_az)
        cov_h += math.radians(cfg.tilt_sigma_deg) ** 2 * np.outer(t_el, t_el)
        cov_b = c_b_h.T @ cov_h @ c_b_h
        return finish_fix(
            self.name,
            sun_body,
            ctx,
            sun_enu,
            cov_b,
            pixels_used=wc.pixels,
            residual=resid,
            roll_rad=wc.roll_rad,
            pitch_rad=wc.pitch_rad,
            c_b_h=c_b_h,
            ambiguity_margin=abs(along),
            hough_lines=n_lines,
            window_contrast=wc.contrast,
            meridian_rad=m,
            rim_azimuths=wc.rim_azimuths,
            work_binning=binning,
        )


class SnellPaperMethod(SnellWindowMethod):
    """The Snell-window method as Xin et al. (2024) write it (:data:`SNELL_PAPER`)."""

    name = "snell_paper"

    def __init__(self, config: SnellConfig | None = None, **overrides: object) -> None:
        super().__init__(config if config is not None else SNELL_PAPER, **overrides)
