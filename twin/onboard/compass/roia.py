"""ROI-A: attitude-adaptive zenith region + light-vector superposition (Fang et al. 2024), "roia".

J. Meas. Sci. Instrum. 15(2):157–165. The steps, with the paper's equation numbers:

1. Stokes and AoP (eqs. 1–3) by the shared :func:`~twin.onboard.polarization.stokes_from_mosaic`,
   on a crop of the mosaic around the zenith region only (``zenith_crop``: 2×2 phase kept, a
   margin for the demosaicing kernel, so its pixels equal the whole frame's);
   the AoP is referred to the local meridian (eq. 2's ``b``) through the calibration's 3-D
   E-vectors, in the *levelled* frame given by the INS roll/pitch hint.
2. **Zenith region** (eqs. 4–8): the tilt β = arccos(cos α cos γ) (eq. 4); the region is centred on
   the image of the true zenith (eq. 5) and has radius r (eq. 6), pixels within r (eq. 7); the
   tilt is usable up to FOV/2 − m (eq. 8), m = the region's angular radius.
3. **Fresnel conversion to air** (eqs. 9–11): per pixel, A_p = in-water zenith angle, I_p =
   arcsin(n_w sin A_p / n_a) the air incidence, and
   P_air = arctan[(n_a cos I_p + n_w cos A_p)/(n_w cos I_p + n_a cos A_p) · tan ψ_p] (eq. 11) —
   i.e. tan ψ_air = (t_p/t_s) tan ψ_water, ψ from the plane of incidence (optics.md §2.2).
4. **Superposition** (eqs. 12–18): the Rayleigh E-vector of light scattered in the water from the
   refracted sun, P_sca (eq. 12, needs the sun's azimuth relative to the pixel: taken from the
   previous iterate), the weight k = sin(ψ_p − P_air)/sin(P_sca − ψ_p) (eq. 15) that makes
   E = E_air + k·E_sca (eqs. 13, 14, 16) lie along the measured E-vector, and R_i^b (eq. 17).
5. **Solar vector** ("P_air of pixel polarized vectors for cross-product operation", before
   eq. 19): the vector ⟂ to every air E-vector, as the eigenvector of Σ w E E^T with the smallest
   eigenvalue (the least-squares form of the pairwise cross products); ψ_s (eq. 19); heading
   (eqs. 20–22) via the ephemeris, in :func:`~twin.onboard.compass.base.finish_fix`.

How this implementation reads the paper (decisions):

* **Eq. 5 and eq. 6 as printed are not used literally.** Eq. 5 moves the centre by tan β·sin δ
  with the *yaw* δ (the zenith's image position depends on roll and pitch, not on yaw) and is not
  a projection of any lens; eq. 6, r = (d/2)·|π/2 − FOV/2 − β|, grows with the tilt (2.5° + β for a
  185° lens), so at β ≳ 10° the "zenith region" would reach the edge of Snell's window. Kept: the
  intent — the region is the sky around the *true* zenith, wherever it falls in the image. The
  centre is the zenith direction from the INS roll/pitch (C_b^h) projected through the
  calibration; the region is a cone about it (eq. 7 on the sphere, so it is the same piece of sky
  at every tilt and binning); its radius is eq. 6 at β = 0 converted to an angle through the lens
  model (the paper's camera: d/2 = 1596 px, r = 69.6 px ≈ 7.6°), or ``zenith_radius_deg``.
* **ψ_p** in the paper names both the azimuth of the observation direction and the underwater AoP.
  Here φ_p is the azimuth (counter-clockwise from the level body x axis, as in eq. 17) and ψ_p the
  AoP from the local meridian e_θ towards e_φ.
* **Eq. 12** needs ψ_s0 − ψ_p, the sun's azimuth relative to the pixel in the *body* frame — the
  unknown. It is iterated: pass 0 with k = 0 (pure Fresnel conversion), then ``iterations`` passes
  with the relative azimuth from the previous solar vector and A_s = the refracted ephemeris
  zenith, arcsin(sin θ_sun / n_w).
* **What the superposition does.** By eq. 15, E (eq. 16) is parallel to the *measured* E-vector by
  construction; |E| = |sin(P_sca − P_air) / sin(P_sca − ψ_p)| is the only new information. With
  E_air of unit length, 1/(1 + |k|) is the share of the superposed vector that the transmitted
  skylight accounts for; it multiplies each pixel's weight, so pixels whose polarization the
  in-water scattering explains count less. |k| is capped at ``k_max`` (eq. 15 diverges where
  ψ_p = P_sca).
* **Solar vector.** The E-vectors whose cross products give the sun are the air E-vectors
  E_air = R_i^b(I_p, φ_p)·[cos P_air, sin P_air, 0]ᵀ (eqs. 13, 17 evaluated at the *air* zenith
  angle I_p, where the Rayleigh condition E ⟂ s holds); eq. 18 evaluated at A_p (the in-water
  direction) is what the measured vector is, and is reported only through k.
* **Eq. 22's 180° ambiguity** (ψ = ψ_s0 − ψ_s or + π): the eigenvector is signed so that the sun is
  above the horizon (s_z > 0 in the levelled frame). Near the zenith the E-vectors' vertical
  components are first order in the off-zenith angle, so the elevation (and hence the sign) is
  determined; a vector within ``min_elevation_deg`` of the horizon is refused as ambiguous.
* Weights: w = DoP²·S0, the inverse AoP variance under shot noise (σ_ψ = 1/(2P√S0), optics.md §3.3).

Quality: ``pixels_used`` = zenith-region Stokes-grid pixels; ``residual`` = weighted rms of E_air·s
(rad); ``eigen_gap`` = λ2/λ1. Covariance of ``sun_body``: σ²·(Σ E Eᵀ restricted to the tangent
plane of s)⁻¹ with σ² = Σ w r² / Σ w · N/(N − 2), rotated to the body frame. It ignores the spatial
correlation of the noise (optimistic) and any model bias (the elevation carries the refraction and
multiple-scattering bias of optics.md §2.7; the azimuth does not).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from twin.core.calibration import CameraCalibration, StokesGrid
from twin.core.fields import Range, check_ranges
from twin.onboard.compass.base import (
    CompassFix,
    CompassMethod,
    FloatArray,
    Frame,
    finish_fix,
    no_fix,
)
from twin.onboard.compass.geometry import meridian_basis
from twin.onboard.compass.working_frame import evectors_h, to_stokes
from twin.onboard.polarization import PolarizationImage


@dataclass(frozen=True)
class RoiaConfig:
    """Parameters of ROI-A (fang2024; values the paper leaves open are marked).

    Attributes:
        zenith_radius_deg: Angular radius of the zenith region; None = eq. 6 at β = 0 through the
            calibration's lens model (7.6° for the paper's 2448×2048, 185° camera).
        stokes_grid: ``"interpolate"`` or ``"superpixel"`` (see ``SnellConfig.stokes_grid``: the
            super-pixel AoP is biased by ~1° near the zenith where the DoP is low). [ours]
        fov_deg: Lens field of view for eqs. 6 and 8 (the paper's FE185C057HA-1: 185°).
        n_air: Refractive index of air (eqs. 9–11).
        iterations: Superposition passes after the first, Fresnel-only, pass. [ours]
        k_max: Cap on |k| (eq. 15). [ours]
        min_pixels: Fewest usable zenith-region Stokes-grid pixels. [not in the paper]
        min_dop: Pixels with a lower DoP carry no E-vector. [not in the paper]
        min_signal_dn: Median S0 (DN) of the region below which the frame is too dark.
        min_elevation_deg: A solar vector closer to the horizon is refused (sign ambiguous).
        region: ``"cone"`` — the twin's reading: a cone of ``zenith_radius_deg`` about the true
            zenith (module docstring); ``"printed"`` — eqs. 6–7 as printed: a pixel circle of
            radius |(d/2)(π/2 − FOV/2 − β)| (growing with the tilt β) about the zenith's image.
            (Eq. 5 as printed places the centre with the yaw δ, which is what the method
            measures, so no configuration can run it; both readings centre on the zenith's
            image, eq. 5's intent.)
        weighting: ``"shot_noise"`` — w = DoP²·S0, the inverse AoP variance [ours]; ``"unit"`` —
            every pixel's E-vector counts once (the paper's cross products).
    """

    zenith_radius_deg: float | None = None
    stokes_grid: StokesGrid = "interpolate"
    fov_deg: float = 185.0
    n_air: float = 1.0003
    iterations: int = 2
    k_max: float = 10.0
    min_pixels: int = 30
    min_dop: float = 0.02
    min_signal_dn: float = 20.0
    min_elevation_deg: float = 2.0
    region: str = "cone"
    weighting: str = "shot_noise"

    def __post_init__(self) -> None:
        if self.region not in ("cone", "printed"):
            raise ValueError(f"RoiaConfig.region: {self.region!r}; allowed: 'cone', 'printed'")
        if self.weighting not in ("shot_noise", "unit"):
            raise ValueError(
                f"RoiaConfig.weighting: {self.weighting!r}; allowed: 'shot_noise', 'unit'"
            )
        checks = [
            ("fov_deg", self.fov_deg, 10.0, 360.0),
            ("n_air", self.n_air, 1.0, 1.1),
            ("k_max", self.k_max, 0.0, 1e6),
            ("min_dop", self.min_dop, 0.0, 1.0),
            ("min_signal_dn", self.min_signal_dn, 0.0, 1e9),
            ("min_elevation_deg", self.min_elevation_deg, 0.0, 45.0),
        ]
        if self.zenith_radius_deg is not None:
            checks.append(("zenith_radius_deg", self.zenith_radius_deg, 0.5, 45.0))
        check_ranges("RoiaConfig", ((n, v, Range(lo, hi)) for n, v, lo, hi in checks))
        if self.stokes_grid not in ("interpolate", "superpixel"):
            raise ValueError(f"RoiaConfig.stokes_grid: {self.stokes_grid!r}")
        if not (isinstance(self.iterations, int) and 0 <= self.iterations <= 10):
            raise ValueError(f"RoiaConfig.iterations: {self.iterations!r}; allowed 0..10")
        if not (isinstance(self.min_pixels, int) and self.min_pixels >= 3):
            raise ValueError(f"RoiaConfig.min_pixels: {self.min_pixels!r}; allowed >= 3")


def zenith_radius_rad(calibration: CameraCalibration, fov_deg: float = 185.0) -> float:
    """Eq. 6 at β = 0 — r = (d/2)·|π/2 − FOV/2| pixels — as an angle through the lens model."""
    d = math.hypot(calibration.width_px, calibration.height_px)
    r_px = 0.5 * d * abs(math.pi / 2 - math.radians(fov_deg) / 2)
    return float(calibration.theta_of_rho(r_px))


def printed_radius_px(calibration: CameraCalibration, beta_rad: float, fov_deg: float) -> float:
    """Eq. 6 as printed: r = |(d/2)(π/2 − FOV/2 − β)| pixels, d the image diagonal."""
    d = math.hypot(calibration.width_px, calibration.height_px)
    return 0.5 * d * abs(math.pi / 2 - math.radians(fov_deg) / 2 - beta_rad)


def zenith_crop(
    calibration: CameraCalibration, zen_c: FloatArray, radius: float, margin_px: int = 4
) -> tuple[int, int, int, int]:
    """Rows v0:v1 and columns u0:u1 of the raw frame holding the cone of ``radius`` about zen_c.

    The box of the cone's image (its rim sampled every 5°, and its centre) plus ``margin_px``
    (≥ the demosaicing kernel's reach), clipped to the frame; all bounds even, so the crop is a
    whole number of 2×2 super-pixels in the frame's phase.
    """
    z = np.asarray(zen_c, dtype=np.float64)
    t1 = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(z, t1)
    a = np.radians(np.arange(0.0, 360.0, 5.0))[:, None]
    ring = math.cos(radius) * z + math.sin(radius) * (np.cos(a) * t1 + np.sin(a) * t2)
    u, v, _ = calibration.project(np.vstack([ring, z]))
    w, h = calibration.width_px, calibration.height_px
    u0 = min(max(math.floor(float(u.min())) - margin_px, 0), w - 2) & ~1
    v0 = min(max(math.floor(float(v.min())) - margin_px, 0), h - 2) & ~1
    u1 = max(min(math.ceil(float(u.max())) + margin_px + 1, w), u0 + 2)
    v1 = max(min(math.ceil(float(v.max())) + margin_px + 1, h), v0 + 2)
    return v0, v1 + (v1 - v0) % 2, u0, u1 + (u1 - u0) % 2


def _pixel_box(
    calibration: CameraCalibration, u: float, v: float, r_px: float, margin_px: int = 4
) -> tuple[int, int, int, int]:
    """Rows and columns of the raw frame holding a pixel circle (even bounds, as zenith_crop)."""
    w, h = calibration.width_px, calibration.height_px
    u0 = min(max(math.floor(u - r_px) - margin_px, 0), w - 2) & ~1
    v0 = min(max(math.floor(v - r_px) - margin_px, 0), h - 2) & ~1
    u1 = max(min(math.ceil(u + r_px) + margin_px + 1, w), u0 + 2)
    v1 = max(min(math.ceil(v + r_px) + margin_px + 1, h), v0 + 2)
    return v0, v1 + (v1 - v0) % 2, u0, u1 + (u1 - u0) % 2


def tilt_rad(roll_rad: float, pitch_rad: float) -> float:
    """Eq. 4: β = arccos(cos α cos γ), the optical axis' angle from the vertical."""
    return math.acos(max(-1.0, min(1.0, math.cos(pitch_rad) * math.cos(roll_rad))))


def _air_evector(theta: FloatArray, phi: FloatArray, p: FloatArray) -> FloatArray:
    """R_i^b (eq. 17) at zenith angle θ and azimuth φ times [cos P, sin P, 0]ᵀ (eqs. 13, 18)."""
    ct, st, cp, sp = np.cos(theta), np.sin(theta), np.cos(phi), np.sin(phi)
    a, b = np.cos(p), np.sin(p)
    return np.stack([cp * ct * a - sp * b, sp * ct * a + cp * b, -st * a], axis=-1)


def p_scattered(a_s: float, a_p: FloatArray, dphi: FloatArray) -> FloatArray:
    """Eq. 12: AoP (from e_θ) of in-water Rayleigh scattering of the refracted sun.

    a_s: refracted solar zenith; a_p: pixel zenith; dphi = ψ_s0 − φ_p (sun minus pixel azimuth).
    The quadrant is kept with atan2 (the result is an orientation, mod π).
    """
    num = math.cos(a_s) * np.sin(a_p) - math.sin(a_s) * np.cos(a_p) * np.cos(dphi)
    den = math.sin(a_s) * np.sin(dphi)
    return np.arctan2(num, den)


class _Region(NamedTuple):
    """The zenith region of one frame (eqs. 4–8) and the geometry the later stages need."""

    pol: PolarizationImage
    rays_c: FloatArray
    region: NDArray[np.bool_]
    radius: float
    beta: float
    c_b_h: FloatArray
    c_c_h: FloatArray


class RoiaMethod(CompassMethod):
    """ROI-A: attitude-adaptive zenith region, Fresnel to air, superposition, E-vector sun."""

    name = "roia"

    config_type = RoiaConfig

    def solve_frame(self, frame: Frame) -> CompassFix:
        region = self._zenith_region(frame)
        if isinstance(region, CompassFix):
            return region
        ev = self._region_evectors(frame, region)
        if isinstance(ev, CompassFix):
            return ev
        n_use, w0, psi_p, a_p, phi_p = ev
        # ---- Fresnel to air (eqs. 9–11) --------------------------------------------------------
        n_w, n_a = frame.ctx.water_index, self.config.n_air
        if n_w > n_a:
            i_p = np.arcsin(np.clip(n_w / n_a * np.sin(a_p), -1.0, 1.0))
            ratio = (n_a * np.cos(i_p) + n_w * np.cos(a_p)) / (
                n_w * np.cos(i_p) + n_a * np.cos(a_p)
            )
            # The refracted solar zenith.
            a_s = math.asin(min(1.0, math.cos(frame.sun_elevation_rad) * n_a / n_w))
        else:  # camera in air: nothing to convert, no in-water scattering
            i_p, ratio, a_s = a_p, np.ones_like(a_p), math.pi / 2 - frame.sun_elevation_rad
        p_air = np.arctan2(ratio * np.sin(psi_p), np.cos(psi_p))  # eq. 11, quadrant kept
        e_air = _air_evector(i_p, phi_p, p_air)  # eqs. 13, 17 at the air direction
        # ---- solar vector, then superposition passes (eqs. 12–18) --------------------------------
        w = w0
        k = np.zeros_like(w0)
        s, lam, vecs = self._eigen(e_air, w)
        for _ in range(self.config.iterations if n_w > n_a else 0):
            phi_s = math.atan2(float(s[1]), float(s[0]))
            p_sca = p_scattered(a_s, a_p, phi_s - phi_p)  # eq. 12
            den = np.sin(p_sca - psi_p)
            k = np.sin(psi_p - p_air) / np.where(np.abs(den) < 1e-9, 1e-9, den)  # eq. 15
            k = np.clip(k, -self.config.k_max, self.config.k_max)
            w = w0 / (1.0 + np.abs(k))
            s, lam, vecs = self._eigen(e_air, w)
        return self._fix(frame, region, n_use, e_air, w, k, s, lam, vecs)

    def _zenith_region(self, frame: Frame) -> _Region | CompassFix:
        """Eqs. 4–8: the zenith region's pixels and their Stokes, or why there is none."""
        cfg, calibration, ctx = self.config, frame.calibration, frame.ctx
        radius = radius0 = (
            math.radians(cfg.zenith_radius_deg)
            if cfg.zenith_radius_deg is not None
            else zenith_radius_rad(calibration, cfg.fov_deg)
        )
        c_b_h = ctx.c_b_h
        c_c_h = c_b_h @ calibration.c_c_b
        zen_c = c_c_h.T @ np.array([0.0, 0.0, 1.0])  # the true zenith in the camera frame
        beta = math.acos(max(-1.0, min(1.0, float(zen_c[2]))))  # eq. 4 for any mount
        beta_max = min(math.radians(cfg.fov_deg) / 2, calibration.max_field_angle_rad) - radius
        if beta > beta_max:  # eq. 8
            return no_fix(
                self.name,
                f"tilt {math.degrees(beta):.1f}° beyond eq. 8's limit "
                f"{math.degrees(beta_max):.1f}°",
            )
        # Stokes only around the zenith region: a crop of the mosaic (2×2 phase kept) with a
        # margin for the demosaicing kernel, so its pixels are those of the whole frame's.
        if cfg.region == "printed":
            # Eqs. 6–7 as printed: a pixel circle whose radius grows with the tilt, about the
            # zenith's image; its angular size (for eq. 8 and the crop) through the lens model.
            r_px = printed_radius_px(calibration, beta, cfg.fov_deg)
            radius = float(calibration.theta_of_rho(r_px))
            if beta > beta_max + radius0 - radius:  # eq. 8 with eq. 6's radius
                return no_fix(
                    self.name,
                    f"tilt {math.degrees(beta):.1f}° beyond eq. 8's limit with eq. 6's radius",
                )
            zu, zv, _ = calibration.project(zen_c[None, :])
            zu_px, zv_px = float(zu[0]), float(zv[0])
            v0, v1, u0, u1 = _pixel_box(calibration, zu_px, zv_px, r_px)
        else:
            v0, v1, u0, u1 = zenith_crop(calibration, zen_c, radius)
        pol = to_stokes(frame.raw[v0:v1, u0:u1], calibration, cfg.stokes_grid, origin=(u0, v0))
        if cfg.stokes_grid == "superpixel":
            jj, ii = np.arange((u1 - u0) // 2), np.arange((v1 - v0) // 2)
            uu, vv = np.meshgrid(u0 + 2.0 * jj + 0.5, v0 + 2.0 * ii + 0.5)
        else:
            uu, vv = np.meshgrid(
                np.arange(u0, u1, dtype=np.float64), np.arange(v0, v1, dtype=np.float64)
            )
        rays_c, valid = calibration.pixel_to_ray(uu, vv)
        if cfg.region == "printed":
            region = valid & (np.hypot(uu - zu_px, vv - zv_px) <= r_px)  # eq. 7
        else:
            region = valid & (rays_c @ zen_c >= math.cos(radius))  # eq. 7 on the sphere
        return _Region(pol, rays_c, region, radius, beta, c_b_h, c_c_h)

    def _region_evectors(
        self, frame: Frame, rg: _Region
    ) -> tuple[int, FloatArray, FloatArray, FloatArray, FloatArray] | CompassFix:
        """The usable pixels' weights and E-vectors in the level frame, or why too few."""
        cfg, pol, region = self.config, rg.pol, rg.region
        n_region = int(region.sum())
        if n_region < cfg.min_pixels:
            return no_fix(self.name, f"zenith region has {n_region} pixels < {cfg.min_pixels}")
        s0 = pol.s0[region].astype(np.float64)
        if float(np.median(s0)) < cfg.min_signal_dn:
            return no_fix(
                self.name,
                f"frame too dark (zenith-region median {float(np.median(s0)):.1f} DN)",
                n_region,
            )
        use = region & (pol.dop >= cfg.min_dop) & ~pol.saturated & (pol.s0 > 0)
        n_use = int(use.sum())
        if n_use < cfg.min_pixels:
            return no_fix(
                self.name, f"too few polarized zenith pixels ({n_use} < {cfg.min_pixels})", n_use
            )
        d, e = evectors_h(rg.rays_c[use], pol.aop[use], frame.calibration, rg.c_c_h)
        dop = pol.dop[use].astype(np.float64)
        if cfg.weighting == "unit":
            w0 = np.ones_like(dop)
        else:
            w0 = dop * dop * pol.s0[use].astype(np.float64)  # 1/σ_ψ² (shot noise)
            w0 = w0 / w0.mean()
        e_th, e_ph = meridian_basis(d)
        psi_p = np.arctan2(np.sum(e * e_ph, -1), np.sum(e * e_th, -1))  # AoP from the meridian
        a_p = np.arccos(np.clip(d[:, 2], -1.0, 1.0))
        phi_p = np.arctan2(d[:, 1], d[:, 0])
        return n_use, w0, psi_p, a_p, phi_p

    def _fix(
        self,
        frame: Frame,
        rg: _Region,
        n_use: int,
        e_air: FloatArray,
        w: FloatArray,
        k: FloatArray,
        s: FloatArray,
        lam: FloatArray,
        vecs: FloatArray,
    ) -> CompassFix:
        """The fix from the solar vector: its ambiguity, quality and covariance."""
        el_est = math.asin(max(-1.0, min(1.0, float(s[2]))))
        if el_est < math.radians(self.config.min_elevation_deg):
            return no_fix(
                self.name,
                f"solar vector at the horizon (elevation {math.degrees(el_est):.1f}°): "
                "eq. 22's 180° ambiguity undecided",
                n_use,
            )
        r = e_air @ s
        n = r.size
        sigma2 = float(np.sum(w * r * r) / np.sum(w)) * n / max(n - 2, 1)
        info = (e_air.T * w) @ e_air / float(np.mean(w))  # Σ E Eᵀ in units of mean weight
        t1, t2 = vecs[:, 1], vecs[:, 2]  # tangent plane of s
        tb = np.stack([t1, t2], axis=1)
        j = tb.T @ info @ tb
        try:
            cov_t = sigma2 * np.linalg.inv(j)
        except np.linalg.LinAlgError:
            return no_fix(self.name, "singular zenith-region geometry", n_use)
        cov_h = tb @ cov_t @ tb.T
        c_h_b = rg.c_b_h.T
        sun_body = c_h_b @ s
        cov_b = c_h_b @ cov_h @ c_h_b.T
        gap = float(lam[1] / lam[0]) if lam[0] > 0 else float("inf")
        return finish_fix(
            self.name,
            sun_body,
            frame.ctx,
            frame.sun_enu,
            cov_b,
            pixels_used=n_use,
            residual=math.sqrt(max(sigma2, 0.0)),
            eigen_gap=gap if math.isfinite(gap) else 1e12,
            zenith_radius_rad=rg.radius,
            tilt_rad=rg.beta,
            mean_abs_k=float(np.mean(np.abs(k))),
            elevation_est_rad=el_est,
        )

    @staticmethod
    def _eigen(e: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Smallest-eigenvalue eigenvector of Σ w e eᵀ (signed: z ≥ 0), eigenvalues, vectors."""
        m = (e.T * w) @ e
        lam, vecs = np.linalg.eigh(m)
        s = vecs[:, 0]
        if s[2] < 0:
            s = -s
        return s, np.maximum(lam, 0.0), vecs


#: ROI-A as the paper prints it: eqs. 6–7 as printed (``region="printed"``), the solar vector
#: from the cross products of the pixels' P_air vectors ("P_air of pixel polarized vectors for
#: cross-product operation", before eq. 19: unweighted, ``iterations=0`` — the superposition's k
#: enters no estimate), every region pixel with an AoP (``min_dop=0``). Kept from the twin: the
#: zenith's image as eq. 5's centre (eq. 5 as printed needs the yaw the method measures), the
#: least-squares form of the cross products, the sun-above-the-horizon sign for eq. 22's 180°
#: ambiguity, and the too-dark / too-few-pixels guards.
ROIA_PAPER = RoiaConfig(region="printed", weighting="unit", iterations=0, min_dop=0.0)


class RoiaPaperMethod(RoiaMethod):
    """ROI-A as Fang et al. (2024) print it (:data:`ROIA_PAPER`); ``roia`` is the twin's."""

    name = "roia_paper"

    def __init__(self, config: RoiaConfig | None = None, **overrides: object) -> None:
        super().__init__(config if config is not None else ROIA_PAPER, **overrides)
