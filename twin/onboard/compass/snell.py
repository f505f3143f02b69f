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

1. **Distortion correction** (§2.4). The paper undistorts with a Zhang pinhole model, which cannot
   hold rays beyond 90° off-axis (a 185° lens tilted 50° sees the window out to 98.6°). Here the
   calibration's own ray model (``CameraCalibration.project``) resamples the frame onto an ideal
   equidistant image centred on the *zenith* and levelled with the roll and pitch the method has
   just measured. In that image eq. 6 holds as printed: the AoE is the AoP minus the pixel's
   polar angle about the image centre, and the solar meridian is a straight line through the
   centre. (Without levelling, the meridian of a tilted camera would not pass through the image
   centre, and eq. 6 would measure the E-vector against the camera's, not the sky's, meridians.)
2. **Window centre** (§3.2, eq. 12). The centre of the thresholded pixels is taken on the sphere:
   the solid-angle-weighted mean of their unit rays, which for a whole window is exactly the
   zenith (a pixel centroid of the elliptical image of a tilted window is not). Where the window
   runs off the 185° field (tilt > ~44°) only pixels whose mirror image about the current axis is
   also in the field are kept (two iterations), which removes the truncation bias. Then the
   rim is fitted (``edge_refine``): the sun's forward-scattering glow spills past the window on
   the sun's side and passes the threshold, pulling the centroid by up to ~7° in Jerlov II.
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

Quality: ``pixels_used`` = window pixels (thresholded Stokes-grid pixels); ``residual`` = the spread
(rad, 1σ) of the selected Hough lines' directions about the meridian after the symmetry pairing;
no eigenproblem (``eigen_gap`` None). Covariance of ``sun_body`` (rad², tangent plane): in the
horizontal frame, azimuth variance σ_az² = max(residual²/n_lines, (Δθ_Hough)²/12) + a floor
(``azimuth_floor_deg``)² scaled by cos²(elevation) along the horizontal tangent, and the
tilt variance (``tilt_sigma_deg``, default the paper's 0.7° roll/pitch MAE) along the vertical
tangent; rotated to the body frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from twin.frames import euler_to_dcm
from twin.onboard.calibration import CameraCalibration, StokesGrid
from twin.onboard.compass.base import (
    CompassContext,
    CompassFix,
    FloatArray,
    finish_fix,
    no_fix,
    register,
)
from twin.onboard.ephemeris import sun_direction_enu
from twin.onboard.polarization import PolarizationImage, stokes_from_mosaic

_NIGHT_ELEVATION_RAD = math.radians(-0.833)


# ---- helpers shared with roia.py ---------------------------------------------------------------
def check_raw(raw: object, calibration: CameraCalibration, method: str) -> NDArray[np.generic]:
    """Validate a raw mosaic against the calibration; a clear ValueError otherwise."""
    if not isinstance(calibration, CameraCalibration):
        raise ValueError(
            f"{method}: calibration must be a CameraCalibration, got {type(calibration).__name__}"
        )
    if not isinstance(raw, np.ndarray):
        raise ValueError(f"{method}: raw must be a numpy array, got {type(raw).__name__}")
    if raw.ndim != 2 or raw.shape != (calibration.height_px, calibration.width_px):
        raise ValueError(
            f"{method}: raw.shape = {raw.shape}; allowed: "
            f"({calibration.height_px}, {calibration.width_px}) as the calibration states"
        )
    if raw.dtype.kind not in "uif":
        raise ValueError(f"{method}: raw.dtype = {raw.dtype}; allowed: an integer or float mosaic")
    if raw.dtype.kind == "f" and not np.isfinite(raw).all():
        raise ValueError(f"{method}: raw holds NaN or infinite values")
    return raw


def to_stokes(
    raw: NDArray[np.generic], calibration: CameraCalibration, grid: StokesGrid = "interpolate"
) -> PolarizationImage:
    """The shared raw → Stokes derivation (``grid`` as ``stokes_from_mosaic``'s method)."""
    r = raw
    if r.dtype.kind in "ui" and r.dtype not in (np.uint8, np.uint16):
        r = r.astype(np.float64)
    return stokes_from_mosaic(
        r,
        calibration.layout_deg,
        method=grid,
        black_level_dn=calibration.black_level_dn,
        saturation_dn=calibration.saturation_dn,
    )


def sun_enu_for(ctx: CompassContext) -> FloatArray:
    """Ephemeris solar vector (ENU, unit): the context's, else NREL SPA for its time and place."""
    if ctx.sun_enu is not None:
        s = np.asarray(ctx.sun_enu, dtype=np.float64).reshape(3)
        return s / np.linalg.norm(s)
    return sun_direction_enu(ctx.utc, ctx.latitude_deg, ctx.longitude_deg)


def meridian_basis(d: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Local-meridian basis (e_θ, e_φ) of unit directions d (..., 3) in a z-up frame.

    e_θ points along increasing zenith angle in the vertical plane through d, e_φ along
    increasing (counter-clockwise) azimuth; (e_θ, e_φ, d) is right-handed. This is the basis of
    R_i^b (fang2024 eq. 17, its first two columns).
    """
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    rxy = np.hypot(x, y)
    safe = np.maximum(rxy, 1e-12)
    cphi = np.where(rxy > 1e-12, x / safe, 1.0)
    sphi = np.where(rxy > 1e-12, y / safe, 0.0)
    e_theta = np.stack([z * cphi, z * sphi, -rxy], axis=-1)
    e_phi = np.stack([-sphi, cphi, np.zeros_like(x)], axis=-1)
    return e_theta, e_phi


def pixel_solid_angle(calibration: CameraCalibration, theta: FloatArray) -> FloatArray:
    """Solid angle per unit pixel area at off-axis angle θ: sin θ / (ρ · dρ/dθ)."""
    h = 1e-5
    t = np.maximum(theta, 2 * h)
    drho = (calibration.rho_of_theta(t + h) - calibration.rho_of_theta(t - h)) / (2 * h)
    rho = calibration.rho_of_theta(t)
    return np.sin(t) / np.maximum(rho * drho, 1e-12)


def evectors_h(
    pol: PolarizationImage,
    calibration: CameraCalibration,
    c_c_h: FloatArray,
    aop_error_poly_deg: tuple[float, ...] = (),
    grid: StokesGrid = "interpolate",
) -> tuple[FloatArray, FloatArray]:
    """Per super-pixel unit rays and 3-D E-vectors, both in the horizontal (levelled) frame.

    ``aop_error_poly_deg`` (xin2024 §2.3): residual lens AoP error δψ(θ) in degrees, a polynomial
    in the incidence angle θ (degrees, highest power first as ``numpy.polyval``), subtracted from
    the measured AoP before lifting.
    """
    rays_c, _ = calibration.rays(grid)
    aop = pol.aop.astype(np.float64)
    if aop_error_poly_deg:
        theta_deg = np.degrees(np.arctan2(np.hypot(rays_c[..., 0], rays_c[..., 1]), rays_c[..., 2]))
        aop = aop - np.radians(np.polyval(np.asarray(aop_error_poly_deg), theta_deg))
    e_c = calibration.evectors(aop, grid)
    return rays_c @ c_c_h.T, e_c @ c_c_h.T


# ---- the method ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class SnellConfig:
    """Parameters of the Snell-window method (xin2024; values the paper leaves open are marked).

    Attributes:
        stokes_grid: ``"interpolate"`` (full-resolution Stokes) or ``"superpixel"`` (the
            papers' 2×2 units). The super-pixel AoP is biased by ~1° where the DoP is low and S0
            has a gradient (its four analysers sample different points), e.g. near the zenith
            with the sun at 60°; the interpolated one by ~0.01°. [ours]
        grey_fraction: Keep pixels in the brightest fraction of the log grey range (§3.2: 70 %).
        min_window_contrast: Median grey inside / outside the window below which the window is
            not distinct (deep or turbid water, night) ⇒ no fix. [not in the paper]
        min_window_pixels: Fewest window super-pixels for a fix. [not in the paper]
        min_signal_dn: Median window S0 (DN) below which the frame is too dark. [not in the paper]
        symmetric_truncation: Drop window pixels whose mirror about the zenith is outside the
            field (removes the centroid bias of a window cut by the image circle). [ours]
        edge_refine: Refine the centroid by fitting the window's rim: the zenith that maximises
            the log-grey step across a cone of half-angle θ_c = arcsin(1/n_w) (Nelder–Mead from
            the centroid). The sun's forward-scattering glow spills past the rim on the sun's
            side and passes the grey threshold, pulling a plain centroid by up to several
            degrees in Jerlov II water; the rim is sharp, the glow smooth. [ours]
        edge_band_deg: Width of the inner and outer bands of that step. [ours]
        level_scale: Pixels per radian of the levelled equidistant image, as a multiple of the
            calibration's (super-pixel) focal length. [ours]
        window_margin_deg: Keep the characteristic region this far inside the window edge,
            where the refraction-polarization pattern is steep and noisy. [ours]
        median_ksize: Median filter aperture (§2.4; 3 or 5, OpenCV float limit). [not stated]
        gauss_ksize: Gaussian filter aperture (§2.4). [not stated]
        gauss_sigma_px: Gaussian σ. [not stated]
        meridian_band_deg: |AoE| ≥ 90° − this is the solar-meridian characteristic region.
            [not stated; compyss's Hough decoder uses 0.1 rad]
        min_dop: Pixels with a lower DoP carry no AoE. [not stated]
        canny_low: Canny thresholds on the 0/255 region mask (§2.4). [not stated]
        canny_high: ″
        hough_theta_deg: Hough angular resolution. [not stated]
        hough_votes_frac: Hough accumulator threshold as a fraction of the window radius (px).
        hough_center_frac: Keep lines passing within this fraction of the window radius of the
            zenith (the meridian is a line through it).
        hough_max_lines: Strongest lines used.
        aop_error_poly_deg: Bench-fitted residual lens AoP error vs incidence angle (§2.3).
        max_sun_elevation_deg: Above this the meridian is undefined ⇒ no fix.
        min_ambiguity_margin: Smallest brightness asymmetry that decides the 180° ambiguity.
        azimuth_floor_deg: 1σ floor of the meridian direction in the covariance.
        tilt_sigma_deg: 1σ of roll/pitch in the covariance (paper: MAE 0.75°/0.62°).
    """

    stokes_grid: StokesGrid = "interpolate"
    grey_fraction: float = 0.7
    min_window_contrast: float = 2.0
    min_window_pixels: int = 200
    min_signal_dn: float = 20.0
    symmetric_truncation: bool = True
    edge_refine: bool = True
    edge_band_deg: float = 3.0
    level_scale: float = 1.0
    window_margin_deg: float = 4.0
    median_ksize: int = 5
    gauss_ksize: int = 5
    gauss_sigma_px: float = 1.0
    meridian_band_deg: float = 8.0
    min_dop: float = 0.02
    canny_low: float = 50.0
    canny_high: float = 150.0
    hough_theta_deg: float = 0.25
    hough_votes_frac: float = 0.25
    hough_center_frac: float = 0.08
    hough_max_lines: int = 12
    aop_error_poly_deg: tuple[float, ...] = ()
    max_sun_elevation_deg: float = 87.0
    min_ambiguity_margin: float = 0.01
    azimuth_floor_deg: float = 0.3
    tilt_sigma_deg: float = 0.7

    def __post_init__(self) -> None:
        checks = (
            ("grey_fraction", self.grey_fraction, 0.05, 0.99),
            ("min_window_contrast", self.min_window_contrast, 1.0, 1e6),
            ("level_scale", self.level_scale, 0.25, 4.0),
            ("window_margin_deg", self.window_margin_deg, 0.0, 30.0),
            ("gauss_sigma_px", self.gauss_sigma_px, 0.0, 20.0),
            ("meridian_band_deg", self.meridian_band_deg, 0.5, 45.0),
            ("min_dop", self.min_dop, 0.0, 1.0),
            ("hough_theta_deg", self.hough_theta_deg, 0.01, 5.0),
            ("hough_votes_frac", self.hough_votes_frac, 0.01, 2.0),
            ("hough_center_frac", self.hough_center_frac, 0.0, 1.0),
            ("max_sun_elevation_deg", self.max_sun_elevation_deg, 0.0, 90.0),
            ("min_ambiguity_margin", self.min_ambiguity_margin, 0.0, 1.0),
            ("azimuth_floor_deg", self.azimuth_floor_deg, 0.0, 90.0),
            ("tilt_sigma_deg", self.tilt_sigma_deg, 0.0, 90.0),
        )
        for name, v, lo, hi in checks:
            if not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"SnellConfig.{name}: {v!r}; allowed [{lo:g}, {hi:g}]")
        if self.stokes_grid not in ("interpolate", "superpixel"):
            raise ValueError(
                f"SnellConfig.stokes_grid: {self.stokes_grid!r}; "
                "allowed: 'interpolate', 'superpixel'"
            )
        if self.median_ksize not in (3, 5):
            raise ValueError(f"SnellConfig.median_ksize: {self.median_ksize!r}; allowed: 3, 5")
        if self.gauss_ksize < 1 or self.gauss_ksize % 2 == 0:
            raise ValueError(f"SnellConfig.gauss_ksize: {self.gauss_ksize!r}; allowed: odd >= 1")
        if self.min_window_pixels < 10 or self.hough_max_lines < 1:
            raise ValueError("SnellConfig: min_window_pixels >= 10 and hough_max_lines >= 1")


@dataclass(frozen=True)
class WindowCentre:
    """Result of the window-centre step (eqs. 12–14)."""

    zenith_body: FloatArray
    roll_rad: float
    pitch_rad: float
    pixels: int
    contrast: float
    mask: NDArray[np.bool_]


@register
class SnellWindowMethod:
    """Snell-window attitude (roll, pitch from the window centre) and Hough solar-meridian yaw."""

    name = "snell"

    def __init__(self, config: SnellConfig | None = None, **overrides: object) -> None:
        base = config if config is not None else SnellConfig()
        if overrides:
            import dataclasses

            base = dataclasses.replace(base, **overrides)  # type: ignore[arg-type]
        self.config = base

    # ---- step 1: the window centre ⇒ roll, pitch (§3, eqs. 12–15) --------------------------------
    def window_centre(
        self, pol: PolarizationImage, calibration: CameraCalibration, water_index: float = 1.34
    ) -> WindowCentre | str:
        """Zenith in the body frame from the grey-threshold window; a reason string on failure."""
        cfg = self.config
        rays_c, valid = calibration.rays(cfg.stokes_grid)
        grey = 0.5 * pol.s0.astype(np.float64)  # eq. 15 averaged over the analyser angle φ
        g = grey[valid]
        if g.size == 0:
            return "no valid pixels in the image circle"
        lo = max(float(np.percentile(g, 1.0)), 1.0)
        hi = max(float(np.percentile(g, 99.9)), 1.0)
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
        theta = np.arctan2(np.hypot(rays_c[..., 0], rays_c[..., 1]), rays_c[..., 2])
        omega = pixel_solid_angle(calibration, theta)
        d = rays_c[mask]
        w = omega[mask]
        z_c = (w[:, None] * d).sum(0)
        z_c /= np.linalg.norm(z_c)
        if cfg.symmetric_truncation:
            tmax = calibration.max_field_angle_rad
            for _ in range(2):
                mirror = 2.0 * (d @ z_c)[:, None] * z_c[None, :] - d
                keep = np.arctan2(np.hypot(mirror[:, 0], mirror[:, 1]), mirror[:, 2]) <= tmax
                if keep.sum() < cfg.min_window_pixels:
                    break
                z_new = (w[keep, None] * d[keep]).sum(0)
                z_c = z_new / np.linalg.norm(z_new)
        if cfg.edge_refine and water_index > 1.0:
            z_c = self._fit_rim(rays_c, valid, grey, z_c, math.asin(1.0 / water_index))
        n_b = calibration.c_c_b @ z_c  # eq. 12: N = R_{A→B} (0, 0, 1)ᵀ
        pitch = math.asin(max(-1.0, min(1.0, float(n_b[1]))))  # eq. 13
        roll = math.atan2(-float(n_b[0]), float(n_b[2]))  # eq. 14 (atan2 keeps |γ| > 90° apart)
        return WindowCentre(n_b, roll, pitch, n, contrast, mask)

    def _fit_rim(
        self,
        rays_c: FloatArray,
        valid: NDArray[np.bool_],
        grey: FloatArray,
        z0: FloatArray,
        theta_c: float,
    ) -> FloatArray:
        """Zenith (camera frame) maximising the log-grey step across the window's rim."""
        from scipy.optimize import minimize

        band = math.radians(self.config.edge_band_deg)
        near = valid & (rays_c @ z0 >= math.cos(theta_c + 4 * band))
        near &= rays_c @ z0 <= math.cos(max(theta_c - 4 * band, 0.0))
        d = rays_c[near]
        lg = np.log(np.maximum(grey[near], 1.0))
        # Tangent basis at z0 for the two unknowns.
        t1 = np.cross(z0, [1.0, 0.0, 0.0] if abs(z0[0]) < 0.9 else [0.0, 1.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(z0, t1)
        cin, cmid, cout = math.cos(theta_c - band), math.cos(theta_c), math.cos(theta_c + band)

        def zen(x: FloatArray) -> FloatArray:
            z = z0 + x[0] * t1 + x[1] * t2
            return z / np.linalg.norm(z)

        def cost(x: FloatArray) -> float:
            c = d @ zen(x)
            inner = (c >= cmid) & (c < cin)
            outer = (c < cmid) & (c >= cout)
            if inner.sum() < 10 or outer.sum() < 10:
                return 0.0
            return -float(lg[inner].mean() - lg[outer].mean())

        res = minimize(
            cost,
            np.zeros(2),
            method="Nelder-Mead",
            options={
                "xatol": 1e-5,
                "fatol": 1e-7,
                "initial_simplex": [[0, 0], [0.02, 0], [0, 0.02]],
            },
        )
        return zen(res.x) if np.isfinite(res.fun) and res.fun < cost(np.zeros(2)) else z0

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
        (columns) the body's level starboard axis and −rows its level forward axis.
        """
        cfg = self.config
        c_c_h = c_b_h @ calibration.c_c_b
        d_h, e_h = evectors_h(pol, calibration, c_c_h, cfg.aop_error_poly_deg, cfg.stokes_grid)
        e_th, e_ph = meridian_basis(d_h)
        # eq. 6 in 3-D: the E-vector's angle from the local (true) meridian at each source pixel.
        aoe = np.arctan2(np.sum(e_h * e_ph, -1), np.sum(e_h * e_th, -1))
        ok = (pol.dop >= cfg.min_dop) & ~pol.saturated & (pol.s0 > 0)
        c2 = np.where(ok, np.cos(2 * aoe), 0.0).astype(np.float32)
        s2 = np.where(ok, np.sin(2 * aoe), 0.0).astype(np.float32)
        wgt = ok.astype(np.float32)
        grey = (0.5 * pol.s0).astype(np.float32)
        # Output grid: equidistant about the zenith, radius = the window (+ a little).
        sub = 2.0 if cfg.stokes_grid == "superpixel" else 1.0
        k = cfg.level_scale * calibration.focal_px / sub  # Stokes-grid px per rad
        half = math.ceil(k * (theta_c + math.radians(2.0))) + 2
        n = 2 * half + 1
        vv, uu = np.mgrid[0:n, 0:n].astype(np.float64)
        x = (uu - half) / k
        y = -(vv - half) / k
        th = np.hypot(x, y)
        ph = np.arctan2(y, x)
        d_out = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
        d_cam = d_out @ c_c_h  # h → camera (c_c_h orthonormal: inverse = transpose)
        u_raw, v_raw, valid = calibration.project(d_cam)
        # Raw frame coordinates → the Stokes grid (super-pixel (i, j) is centred at raw 2j + ½).
        off = 0.5 if cfg.stokes_grid == "superpixel" else 0.0
        map_x = ((u_raw - off) / sub).astype(np.float32)
        map_y = ((v_raw - off) / sub).astype(np.float32)

        def remap(a: NDArray[np.float32]) -> FloatArray:
            return cv2.remap(
                a, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0
            ).astype(np.float64)

        w_o = remap(wgt)
        inside = valid & (th <= theta_c - math.radians(cfg.window_margin_deg)) & (w_o > 0.5)
        safe = np.maximum(w_o, 1e-6)
        c2_o = np.where(inside, remap(c2) / safe, 0.0)
        s2_o = np.where(inside, remap(s2) / safe, 0.0)
        grey_o = np.where(valid & (th <= theta_c), remap(grey), 0.0)
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
        """Axis through the centre about which (cos 2AoE, sin 2AoE) is (even, odd); rms misfit."""
        cfg = self.config
        n = c.shape[0]
        half = (n - 1) / 2.0
        vv, uu = np.mgrid[0:n, 0:n].astype(np.float64)
        x, y = uu - half, -(vv - half)
        r = np.hypot(x, y)
        a = np.arctan2(y, x)
        c32, s32 = c.astype(np.float32), s.astype(np.float32)
        ins32 = inside.astype(np.float32)
        base = inside & (r > 2.0)

        def cost(m: float) -> float:
            am = 2.0 * m - a
            mx = (half + r * np.cos(am)).astype(np.float32)
            my = (half - r * np.sin(am)).astype(np.float32)
            cm = cv2.remap(c32, mx, my, cv2.INTER_LINEAR)
            sm = cv2.remap(s32, mx, my, cv2.INTER_LINEAR)
            im = cv2.remap(ins32, mx, my, cv2.INTER_LINEAR)
            sel = base & (im > 0.999)
            if sel.sum() < 20:
                return math.inf
            return float(np.mean((c[sel] - cm[sel]) ** 2 + (s[sel] + sm[sel]) ** 2))

        step = math.radians(cfg.hough_theta_deg)
        span = 2.0 * math.radians(cfg.meridian_band_deg)
        grid = m0 + np.arange(-span, span + 0.5 * step, step)
        costs = np.array([cost(float(g)) for g in grid])
        i = int(np.argmin(costs))
        m = float(grid[i])
        if 0 < i < len(grid) - 1 and np.all(np.isfinite(costs[i - 1 : i + 2])):
            c_l, c_0, c_r = costs[i - 1 : i + 2]
            den = c_l - 2 * c_0 + c_r
            if den > 0:
                m += 0.5 * step * (c_l - c_r) / den
        return m, math.sqrt(max(float(costs[i]), 0.0)) / 2.0

    # ---- the whole method ----------------------------------------------------------------------
    def solve(
        self, raw: NDArray[np.generic], calibration: CameraCalibration, ctx: CompassContext
    ) -> CompassFix:
        cfg = self.config
        raw = check_raw(raw, calibration, self.name)
        if not isinstance(ctx, CompassContext):
            raise ValueError(f"{self.name}: ctx must be a CompassContext")
        sun_enu = sun_enu_for(ctx)
        el = math.asin(max(-1.0, min(1.0, float(sun_enu[2]))))
        if el < _NIGHT_ELEVATION_RAD:
            return no_fix(self.name, f"night (sun elevation {math.degrees(el):.1f}°)")
        if el > math.radians(cfg.max_sun_elevation_deg):
            return no_fix(self.name, "sun near the zenith: no solar meridian")
        pol = to_stokes(raw, calibration, cfg.stokes_grid)
        wc = self.window_centre(pol, calibration, ctx.water_index)
        if isinstance(wc, str):
            return no_fix(self.name, wc)
        c_b_h = euler_to_dcm(wc.roll_rad, wc.pitch_rad, 0.0)
        n_w = ctx.water_index
        theta_c = math.asin(1.0 / n_w) if n_w > 1.0 else math.pi / 2
        c2, s2, grey, inside, k = self.levelled_aoe(pol, calibration, c_b_h, theta_c)
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
        )
