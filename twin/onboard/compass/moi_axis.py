"""Liang et al. 2020's three axis methods on an AoP image: MOI, PATZ and HT (the solar meridian).

H. Liang, H. Bai, N. Liu, X. Sui, "Polarization Navigation Simulation System and Skylight Compass
Method Design Based upon Moment of Inertia", Math. Probl. Eng. 2020:4081269 (the liang2020 seed).
Three registered methods, all for a camera whose optical axis points at the zenith (the paper's
§2 assumption: the solar meridian then passes through the image centre):

* ``"moi"`` (§2, eqs. 1–8): the AoP image referenced to the local meridian (AOPLM, eq. 24) is a
  rigid body of mass density μ = |AOPLM| over a circular region P' about the image centre; the
  solar–antisolar meridian (SM-ASM) is the symmetry axis, where the moment of inertia is extremal
  (eqs. 3–8). Of the two perpendicular extremal axes (eq. 8) the SM-ASM is the one along which the
  E-vector is ⟂ the line, i.e. |AOPLM| ≈ 90° (the paper's closing sentence of §2).
* ``"patz"`` (§4, refs. 23–28, "polarization at the zenith"): the E-vector at the zenith is ⟂ the
  solar meridian. The zenith falls between pixels of an even-sized frame; the doubled-angle mean
  of the AoP of the pixels nearest the principal point (4 for the paper's imager) is used, which
  cancels the first-order variation of the AoP across them.
* ``"ht"`` (§4, refs. 31–32, Lu et al. 2015 Opt. Express 23:7248): binarise the pixels whose AOPLM
  is within a tolerance ε of ±90° (the SM-ASM band) and find the strongest straight line of that
  binary image with a Hough transform. The line is known to pass through the image centre, so only
  the ρ = 0 row of the (ρ, θ) accumulator is needed: each band pixel at polar angle φ and radius r
  votes for every θ whose line through the centre passes within ½ pixel of it, θ ∈ φ ± asin(½/r)
  — exactly the ρ = 0 bin of ``cv2.HoughLines`` (ρ resolution 1 px), computed with a difference
  array instead of stepping θ. A full ``cv2.HoughLines`` accumulator at the 0.01° θ resolution
  needed here would be 18 000 × 6 400 bins. The peak is refined to sub-bin precision by the
  centroid of the accumulator above half its maximum (a thick band gives a flat-topped peak, whose
  first maximum — what ``cv2.HoughLines`` reports — is biased by up to half the flat top).

Geometry and conventions (``twin.core.calibration``): image coordinates about the principal
point x = u − c_u, y = −(v − c_v) are the camera frame's x and y. AoP ψ is measured from +u towards
+v (``twin.onboard.polarization``). The local meridian of a zenith-pointing, radially symmetric
lens is the radial image direction, at image angle ξ = atan2(v − c_v, u − c_u) in the same sense,
so AOPLM = wrap(ψ − ξ) — the angle the paper's text defines for its eq. 25 (its printed
arctan(y/x) is the complement: optics.md §7). Only |AOPLM| enters, so the sense (and the mirror
convention of real frames) does not matter. Azimuths in the camera frame are clockwise from
camera +y (forward) looking down: α = atan2(x, y), the convention of ``base.heading_from_sun``.

Sun / anti-sun: every method measures the SM-ASM *line*; which end holds the sun is decided by a
Rayleigh model check (:func:`resolve_sun_side`): with the sun's elevation e from the ephemeris, the
two candidates (cos e·d, sin e) and (−cos e·d, sin e) predict different |AOPLM| fields (they are
one another's 180° rotation about the zenith, and the Rayleigh pattern is not 180°-symmetric
unless e = 0); the candidate with the smaller squared |AOPLM| residual on a sub-sample wins. Near
e = 0 the two fields coincide (the candidates become ±s, which the Rayleigh AoP cannot tell
apart); then, in :meth:`solve`, the brighter half of the region (S0: the circumsolar sky)
decides, and if that is inconclusive too there is no fix. The same residual, with the winning
candidate, is a whole-image Rayleigh consistency check that rejects frames with no sky pattern.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Literal

import cv2
import numpy as np
from numpy.typing import NDArray

from twin.core.arrays import Float64Array as FloatArray
from twin.core.calibration import CameraCalibration

Grid = Literal["superpixel", "interpolate"]
MethodName = Literal["moi", "patz", "ht"]

_HALF_PI = math.pi / 2
_AMBIGUITY_SAMPLES = 20000  # pixels of the sub-sample for the Rayleigh side check


@dataclass(frozen=True)
class Liang2020Config:
    """Settings of the three methods (one config: they share the region and the checks).

    Attributes:
        stokes_method: Grid of :func:`stokes_from_mosaic` in :meth:`solve`.
        radius_px: Radius of the circular region P' (frame pixels). None: the largest circle about
            the principal point inside the frame and the image circle (paper §2: "P' is a
            circular region with o_b as its origin").
        min_dop: Pixels below this DoP are not used (``solve`` only).
        min_s0_dn: Pixels below this S0 are not used (``solve`` only).
        min_pixels: Fewer usable pixels in P' ⇒ no fix.
        min_eigen_gap: MOI: ratio of the principal moments of |AOPLM| below this ⇒ the pattern
            has no symmetry axis (isotropic: sun at the zenith, noise) ⇒ no fix.
        max_line_residual_rad: MOI/HT: mean π/2 − |AOPLM| along the found SM-ASM above this
            ⇒ no fix (on the SM-ASM the E-vector is ⟂ the line).
        max_model_rms_rad: RMS |AOPLM| misfit of the Rayleigh model with the chosen sun above this
            ⇒ no fix (no sky pattern).
        min_side_margin: Relative residual difference of the two sun candidates below which the
            AoP cannot tell sun from anti-sun.
        min_intensity_contrast: Relative S0 difference of the two half-regions below which the
            intensity cannot either (⇒ no fix).
        min_sun_elevation_rad: Ephemeris sun below this ⇒ no fix (night).
        max_tilt_rad: Optical axis farther than this from the zenith (roll/pitch hint) ⇒ no fix.
        ht_tolerance_rad: HT: ε, pixels with |AOPLM| ≥ π/2 − ε form the SM-ASM band (Lu et al.'s
            threshold tolerance; 0.1 rad as in compyss, optics.md §4.1).
        ht_resolution_rad: HT: θ bin of the accumulator.
        ht_min_radius_px: HT: pixels closer than this to the centre do not vote (they vote for a
            wide fan of angles).
        ht_min_peak_contrast: HT: accumulator peak / median below this ⇒ no line ⇒ no fix.
        ht_peak: HT: ``"centroid"`` — the peak refined to the centroid of the accumulator above
            half its maximum [ours]; ``"first_max"`` — the first maximum's bin, what
            ``cv2.HoughLines`` (and the papers' Hough) report.
        patz_window_px: PATZ: radius of the zenith window for the coherence check (the estimate
            itself uses the pixels nearest the principal point).
        patz_min_coherence: PATZ: mean resultant length of the doubled AoP in the window below
            this ⇒ no fix.
        sigma_floor_rad: Lower bound of the reported 1σ azimuth (discretisation of P').
        elevation_sigma_rad: 1σ of the ephemeris/attitude elevation in the covariance.
    """

    stokes_method: Grid = "superpixel"
    radius_px: float | None = None
    min_dop: float = 0.02
    min_s0_dn: float = 1.0
    min_pixels: int = 500
    min_eigen_gap: float = 1.005
    max_line_residual_rad: float = 0.35
    max_model_rms_rad: float = 0.25
    min_side_margin: float = 0.05
    min_intensity_contrast: float = 0.01
    min_sun_elevation_rad: float = math.radians(-5.0)
    max_tilt_rad: float = math.radians(10.0)
    ht_tolerance_rad: float = 0.1
    ht_resolution_rad: float = math.radians(0.01)
    ht_min_radius_px: float = 4.0
    ht_min_peak_contrast: float = 2.0
    ht_peak: str = "centroid"
    patz_window_px: float = 8.0
    patz_min_coherence: float = 0.5
    sigma_floor_rad: float = 2e-4
    elevation_sigma_rad: float = math.radians(0.2)

    def __post_init__(self) -> None:
        if self.stokes_method not in ("superpixel", "interpolate"):
            raise ValueError(
                f"Liang2020Config.stokes_method: {self.stokes_method!r}; "
                "allowed: 'superpixel', 'interpolate'"
            )
        if self.radius_px is not None and not (
            math.isfinite(self.radius_px) and self.radius_px > 2
        ):
            raise ValueError(f"Liang2020Config.radius_px: {self.radius_px!r}; allowed: > 2 or None")
        if self.ht_peak not in ("centroid", "first_max"):
            raise ValueError(
                f"Liang2020Config.ht_peak: {self.ht_peak!r}; allowed: 'centroid', 'first_max'"
            )
        if not 0 < self.ht_tolerance_rad < _HALF_PI:
            raise ValueError(
                f"Liang2020Config.ht_tolerance_rad: {self.ht_tolerance_rad!r}; allowed (0, π/2)"
            )
        if not 0 < self.ht_resolution_rad <= math.radians(1.0):
            raise ValueError(
                f"Liang2020Config.ht_resolution_rad: {self.ht_resolution_rad!r}; allowed (0, 1°]"
            )


@dataclass(frozen=True)
class AxisEstimate:
    """What a method finds in one AoP image (camera frame, level camera assumed).

    Attributes:
        method: "moi", "patz" or "ht".
        ok: Whether a line was found; when False, ``reason`` says why.
        reason: Why not ("" when ok).
        axis_rad: Camera azimuth of the SM-ASM line, [0, π), clockwise from camera +y.
        sun_azimuth_rad: Camera azimuth of the sun, [0, 2π), after the sun/anti-sun decision;
            None when no elevation was given.
        side_margin: Relative residual difference of the two sun candidates (0: undecidable
            from the AoP).
        model_rms_rad: RMS |AOPLM| misfit of the Rayleigh model with the chosen sun.
        pixels_used: Pixels that entered the estimate.
        residual: MOI/HT: mean π/2 − |AOPLM| along the found line (rad); PATZ: 1 − resultant
            length of the zenith pixels' doubled AoP.
        sigma_rad: Approximate 1σ of ``axis_rad`` (method-specific, see the code).
        eigen_gap: MOI: ratio of the principal moments (≥ 1), else None.
        extras: Further diagnostics.
    """

    method: str
    ok: bool
    reason: str = ""
    axis_rad: float = math.nan
    sun_azimuth_rad: float | None = None
    side_margin: float = 0.0
    model_rms_rad: float = math.nan
    pixels_used: int = 0
    residual: float = math.nan
    sigma_rad: float = math.nan
    eigen_gap: float | None = None
    extras: dict[str, float] = field(default_factory=dict)


# ---- geometry shared by the three methods ------------------------------------------------------


@dataclass(frozen=True)
class _Geometry:
    shape: tuple[int, int]
    scale: float  # frame pixels per grid step
    i0: float  # principal point in grid index coordinates (row, column)
    j0: float
    radius_px: float
    xi: NDArray[np.float32]  # image angle of the local meridian (from +u towards +v)
    disc: NDArray[np.bool_]  # P'
    valid: NDArray[np.bool_]  # inside the image circle
    zenith: tuple[NDArray[np.intp], NDArray[np.intp]]  # grid pixels nearest the principal point
    sample: tuple[NDArray[np.intp], NDArray[np.intp]]  # sub-sample in P' for the side check
    sample_rays: FloatArray  # (n, 3) their camera rays


@functools.lru_cache(maxsize=4)
def _geometry(cal: CameraCalibration, kind: Grid, radius_px: float | None) -> _Geometry:
    u, v = cal.grid(kind)
    cu, cv = cal.principal_point_px
    scale = float(u[0, 1] - u[0, 0])
    h, w = u.shape
    _, valid = cal.pixel_to_ray(u, v)
    if radius_px is None:
        # Largest circle about the principal point inside the frame and the image circle.
        edge = min(cu + 0.5, cal.width_px - 0.5 - cu, cv + 0.5, cal.height_px - 0.5 - cv)
        circle = float(cal.rho_of_theta(cal.max_field_angle_rad))
        radius_px = min(edge, circle)
    du, dv = u - cu, v - cv
    r2 = du * du + dv * dv
    disc = (r2 <= radius_px * radius_px) & valid
    xi = np.arctan2(dv, du)
    xi = (np.mod(xi + _HALF_PI, math.pi) - _HALF_PI).astype(np.float32)  # lines: [−π/2, π/2)
    rmin = float(np.sqrt(r2.min()))
    zi, zj = np.nonzero(r2 <= (rmin * (1 + 1e-9) + 1e-9) ** 2)
    step = max(1, int(math.sqrt(disc.sum() / _AMBIGUITY_SAMPLES)))
    sub = np.zeros_like(disc)
    sub[step // 2 :: step, step // 2 :: step] = True
    si, sj = np.nonzero(sub & disc & (r2 > (2 * scale) ** 2))
    rays, _ = cal.pixel_to_ray(u[si, sj], v[si, sj])
    for a in (xi, disc, valid):
        a.setflags(write=False)
    return _Geometry(
        shape=(h, w),
        scale=scale,
        i0=(cv - float(v[0, 0])) / scale,
        j0=(cu - float(u[0, 0])) / scale,
        radius_px=float(radius_px),
        xi=xi,
        disc=disc,
        valid=valid,
        zenith=(zi, zj),
        sample=(si, sj),
        sample_rays=rays,
    )


def abs_aoplm(aop: NDArray[np.floating], xi: NDArray[np.floating]) -> NDArray[np.float32]:
    """|AOPLM| = |wrap(ψ − ξ)| in [0, π/2] (eq. 24) for ψ, ξ in [−π/2, π/2].

    With d = ψ − ξ ∈ [−π, π], |wrap_{π}(d)| = π/2 − ||d| − π/2|: no modulo, four SIMD passes.
    """
    d = np.subtract(aop, xi, dtype=np.float32)
    np.abs(d, out=d)
    d -= np.float32(_HALF_PI)
    np.abs(d, out=d)
    np.subtract(np.float32(_HALF_PI), d, out=d)
    return d


def _wrap_line(a: float) -> float:
    """An axis angle to [0, π)."""
    return a % math.pi


def _line_profile(mu: NDArray[np.float32], usable: NDArray[np.bool_], g: _Geometry, alpha: float):
    """Mean |AOPLM| and count of usable pixels along the line through the centre at azimuth α."""
    t = np.arange(-g.radius_px, g.radius_px + 0.5, g.scale)
    # Azimuth α: direction (sin α, cos α) in camera (x, y) = (sin α, −cos α) in (u, v).
    jj = np.rint(g.j0 + t * math.sin(alpha) / g.scale).astype(np.intp)
    ii = np.rint(g.i0 - t * math.cos(alpha) / g.scale).astype(np.intp)
    inside = (ii >= 0) & (ii < g.shape[0]) & (jj >= 0) & (jj < g.shape[1])
    ii, jj = ii[inside], jj[inside]
    keep = usable[ii, jj]
    if not keep.any():
        return 0.0, 0
    return float(mu[ii[keep], jj[keep]].mean()), int(keep.sum())


def rayleigh_abs_aoplm(
    rays: FloatArray, sun_cam: FloatArray, mapping: str = "orthographic"
) -> FloatArray:
    """|AOPLM| the single-scattering Rayleigh sky gives on the image of a level camera.

    E ∝ s × p (eq. 15); its angle to the local meridian tangent m̂ (towards the zenith) is kept by
    the meridional lens mapping, while the orthographic one (eqs. 22–23) shortens m̂'s image by
    cos θ and keeps the horizontal tangent ŵ: tan|AOPLM| = |E·ŵ| / (|E·m̂| · cos θ).
    """
    p = rays
    e = np.cross(sun_cam, p)
    rho = np.hypot(p[:, 0], p[:, 1])
    rho = np.maximum(rho, 1e-12)
    # ŵ = ẑ × p / |ẑ × p| (horizontal), m̂ = p × ŵ (towards the zenith).
    w = np.stack([-p[:, 1], p[:, 0], np.zeros_like(rho)], axis=1) / rho[:, None]
    m = np.cross(p, w)
    a_w = np.abs(np.sum(e * w, axis=1))
    a_m = np.abs(np.sum(e * m, axis=1))
    if mapping == "orthographic":
        a_m = a_m * np.abs(p[:, 2])
    return np.arctan2(a_w, a_m)


def resolve_sun_side(
    mu: NDArray[np.float32],
    usable: NDArray[np.bool_],
    g: _Geometry,
    axis_rad: float,
    elevation_rad: float,
    mapping: str,
) -> tuple[float, float, float]:
    """(sun camera azimuth, side margin, model RMS) for the SM-ASM line at ``axis_rad``.

    See the module docstring: the two sun candidates on the line, with the ephemeris elevation,
    are scored by their Rayleigh |AOPLM| misfit on a fixed sub-sample of P'.
    """
    si, sj = g.sample
    keep = usable[si, sj]
    rays = g.sample_rays[keep]
    meas = mu[si[keep], sj[keep]].astype(np.float64)
    ce, se = math.cos(elevation_rad), math.sin(elevation_rad)
    scores = []
    for az in (axis_rad, axis_rad + math.pi):
        s = np.array([ce * math.sin(az), ce * math.cos(az), se])
        pred = rayleigh_abs_aoplm(rays, s, mapping)
        scores.append(float(np.mean((meas - pred) ** 2)) if meas.size else math.inf)
    best = int(np.argmin(scores))
    lo, hi = scores[best], scores[1 - best]
    margin = (hi - lo) / (hi + lo) if math.isfinite(hi) and hi + lo > 0 else 0.0
    return (axis_rad + best * math.pi) % (2 * math.pi), margin, math.sqrt(lo)


# ---- the three methods on an AoP image ---------------------------------------------------------


def _moi(mu: NDArray[np.float32], usable: NDArray[np.bool_], g: _Geometry, cfg: Liang2020Config):
    """Eqs. 3–8 on the mass density μ = |AOPLM| over P'; returns (axis, extras) or a reason."""
    mass = np.where(usable, mu, np.float32(0.0))
    m = cv2.moments(mass, binaryImage=False)  # accumulates in double (float input)
    m00 = m["m00"]
    if m00 <= 0:
        return "no polarization signal in the region"
    i0, j0 = g.i0, g.j0
    # Second moments about the principal point, in camera (x, y) = scale·(j − j0, −(i − i0)).
    sxx = m["m20"] - 2 * j0 * m["m10"] + j0 * j0 * m00
    syy = m["m02"] - 2 * i0 * m["m01"] + i0 * i0 * m00
    sxy = -(m["m11"] - j0 * m["m01"] - i0 * m["m10"] + i0 * j0 * m00)
    # Eq. 3: I(α) about the line with direction (sin α, cos α) = Σμ(x cos α − y sin α)²; its
    # extrema (eqs. 4–7, W = Σμ(y² − x²), G = Σμxy) are the principal axes of [[sxx, sxy],
    # [sxy, syy]], which eq. 8 says are perpendicular. φ = ½ atan2(2G, −W) is the direction of
    # largest spread (smallest I) measured from +x; its perpendicular is the other extremum.
    phi = 0.5 * math.atan2(2 * sxy, sxx - syy)
    disc = math.hypot(sxx - syy, 2 * sxy)
    lam1, lam2 = 0.5 * (sxx + syy + disc), 0.5 * (sxx + syy - disc)
    gap = lam1 / lam2 if lam2 > 0 else math.inf
    if gap < cfg.min_eigen_gap:
        return f"no symmetry axis: principal moments differ by {gap - 1:.2e} (isotropic pattern)"
    # The two extremal axes as azimuths (clockwise from +y): direction (cos φ, sin φ) ⇒ α.
    cands = [_wrap_line(math.atan2(math.cos(a), math.sin(a))) for a in (phi, phi + _HALF_PI)]
    profiles = [_line_profile(mu, usable, g, a) for a in cands]
    # The SM-ASM is the extremal axis along which the E-vector is ⟂ the line (|AOPLM| → π/2).
    k = int(np.argmax([p[0] for p in profiles]))
    axis = cands[k]
    residual = _HALF_PI - profiles[k][0]
    # Approximate 1σ (first-order perturbation of eq. 7 by independent noise σ_μ on each μ):
    # δα = δG' / |Σμ(x'² − y'²)| with var(δG') = σ_μ² Σx'²y'², Σx'²y'² ≈ N·mean(r²)²/6 (a disc).
    n = int(np.count_nonzero(usable))
    sig_mu = _noise_sigma(mu, usable)
    mr2 = (sxx + syy) / m00 if m00 > 0 else 0.0
    sigma = sig_mu * math.sqrt(n * mr2 * mr2 / 6.0) / max(disc, 1e-300)
    return axis, {
        "n": n,
        "residual": residual,
        "sigma": sigma,
        "gap": gap,
        "other_line_abs_aoplm": profiles[1 - k][0],
    }


def _noise_sigma(mu: NDArray[np.float32], usable: NDArray[np.bool_]) -> float:
    """Robust per-pixel σ of μ from horizontal neighbour differences (every 8th row)."""
    a, b = mu[::8, 1:], mu[::8, :-1]
    ok = usable[::8, 1:] & usable[::8, :-1]
    if not ok.any():
        return 0.0
    d = np.abs(a[ok] - b[ok])
    return float(1.4826 * np.median(d) / math.sqrt(2.0))


def _ht(mu: NDArray[np.float32], usable: NDArray[np.bool_], g: _Geometry, cfg: Liang2020Config):
    """Hough transform (ρ = 0 row) of the SM-ASM band |AOPLM| ≥ π/2 − ε; (axis, extras)."""
    band = usable & (mu >= np.float32(_HALF_PI - cfg.ht_tolerance_rad))
    bi, bj = np.nonzero(band)
    x = (bj - g.j0) * g.scale
    y = -(bi - g.i0) * g.scale
    r = np.hypot(x, y)
    far = r >= max(cfg.ht_min_radius_px, 0.5 + 1e-6)
    x, y, r = x[far], y[far], r[far]
    if r.size < cfg.min_pixels // 10:
        return f"too few SM-ASM band pixels ({r.size})"
    nb = round(math.pi / cfg.ht_resolution_rad)
    res = math.pi / nb
    az = np.mod(np.arctan2(x, y), math.pi)  # camera azimuth of each pixel, as a line
    half = np.arcsin(0.5 / r)  # the lines through the centre within ½ px of the pixel
    # Bins whose centre θ_c = (k + ½)·res has signed distance r·sin(φ − θ_c) in [−½, ½): a
    # half-open ρ bin, so a lattice-aligned line through a half-integer centre collects one
    # pixel column, not the two at exactly ±½ px (a spurious peak of twice the height).
    lo = np.floor((az - half) / res - 0.5).astype(np.int64) + 1
    hi = np.floor((az + half) / res - 0.5).astype(np.int64)
    pad = math.ceil(math.asin(0.5 / float(r.min())) / res) + 2
    diff = np.bincount(lo + pad, minlength=nb + 2 * pad + 1) - np.bincount(
        hi + 1 + pad, minlength=nb + 2 * pad + 1
    )
    acc_ext = np.cumsum(diff)[: nb + 2 * pad]
    acc = acc_ext[pad : pad + nb].astype(np.float64)
    acc[:pad] += acc_ext[pad + nb : 2 * pad + nb]  # fold the wrap-around (lines mod π)
    acc[nb - pad :] += acc_ext[:pad]
    peak = int(np.argmax(acc))
    top = acc[peak]
    med = float(np.median(acc))
    if top <= 0 or top < cfg.ht_min_peak_contrast * max(med, 1.0):
        return f"no dominant line in the SM-ASM band (peak/median {top / max(med, 1.0):.2f})"
    # Sub-bin refinement: centroid of the contiguous run around the peak above half maximum.
    above = acc >= 0.5 * top
    k = np.arange(-nb // 2, nb // 2)
    idx = (peak + k) % nb
    run = above[idx]
    c = nb // 2  # position of the peak in the rolled window
    left = c - int(np.argmin(run[c::-1])) + 1 if not run[c::-1].all() else 0
    right = c + int(np.argmin(run[c:])) - 1 if not run[c:].all() else len(run) - 1
    sel = slice(left, right + 1)
    wts = acc[idx[sel]] - 0.5 * top
    offs = k[sel].astype(np.float64)
    centre = peak + float(np.sum(wts * offs) / np.sum(wts)) if cfg.ht_peak == "centroid" else peak
    axis = _wrap_line((centre + 0.5) * res)
    line_mu, _ = _line_profile(mu, usable, g, axis)
    hwhm = 0.5 * (right - left + 1) * res
    return axis, {
        "n": int(r.size),
        "residual": _HALF_PI - line_mu,
        "sigma": hwhm / math.sqrt(top),
        "peak_votes": top,
        "peak_contrast": top / max(med, 1.0),
    }


def _patz(aop: NDArray[np.floating], usable: NDArray[np.bool_], g: _Geometry, cfg: Liang2020Config):
    """E-vector at the zenith ⟂ the solar meridian; (axis, extras)."""
    zi, zj = g.zenith
    keep = usable[zi, zj]
    if not keep.any():
        return "the zenith pixels are not usable"
    two = 2.0 * aop[zi[keep], zj[keep]].astype(np.float64)
    c, s = float(np.cos(two).sum()), float(np.sin(two).sum())
    n = int(keep.sum())
    rbar = math.hypot(c, s) / n
    psi = 0.5 * math.atan2(s, c)
    # Image direction ψ (from +u towards +v) is (cos ψ, −sin ψ) in camera (x, y); the solar
    # meridian is ⟂ it: (sin ψ, cos ψ), whose azimuth atan2(x, y) is ψ itself.
    axis = _wrap_line(psi)
    # Coherence of the AoP in a small window about the zenith: a sky is smooth there, noise is not.
    rr = cfg.patz_window_px / g.scale
    i_lo, i_hi = max(0, int(g.i0 - rr)), min(g.shape[0], int(g.i0 + rr) + 2)
    j_lo, j_hi = max(0, int(g.j0 - rr)), min(g.shape[1], int(g.j0 + rr) + 2)
    win = aop[i_lo:i_hi, j_lo:j_hi].astype(np.float64)
    wok = usable[i_lo:i_hi, j_lo:j_hi]
    coh = float(np.abs(np.exp(2j * win[wok]).mean())) if wok.any() else 0.0
    if coh < cfg.patz_min_coherence:
        return f"incoherent AoP at the zenith (resultant length {coh:.2f})"
    sig_psi = math.sqrt(max(-2.0 * math.log(max(rbar, 1e-300)), 0.0)) / 2.0
    return axis, {
        "n": n,
        "residual": 1.0 - rbar,
        "sigma": sig_psi / math.sqrt(n),
        "zenith_coherence": coh,
    }


_METHODS = {"moi": _moi, "ht": _ht}


def estimate_axis(
    method: MethodName,
    aop: NDArray[np.floating],
    calibration: CameraCalibration,
    *,
    kind: Grid = "interpolate",
    mask: NDArray[np.bool_] | None = None,
    sun_elevation_rad: float | None = None,
    config: Liang2020Config | None = None,
) -> AxisEstimate:
    """Run one liang2020 method directly on an AoP image (the paper's noise study entry).

    Args:
        method: ``"moi"``, ``"patz"`` or ``"ht"``.
        aop: AoP image (rad, from +u towards +v, in [−π/2, π/2)), on the ``kind`` grid of
            ``calibration`` (``"interpolate"``: one value per raw pixel, as the paper's imager).
        calibration: The camera (its principal point is the zenith: a level camera).
        kind: The grid ``aop`` is on (``CameraCalibration.grid``).
        mask: Optional usable-pixel mask (True = use), same shape.
        sun_elevation_rad: Ephemeris elevation of the sun; when given, the sun/anti-sun side is
            decided (:func:`resolve_sun_side`) and the Rayleigh consistency computed.
        config: Settings (default :class:`Liang2020Config`).

    Returns:
        An :class:`AxisEstimate`; ``ok`` False with a reason on low signal, never NaN.
    """
    cfg = config or Liang2020Config()
    g = _geometry(calibration, kind, cfg.radius_px)
    a = np.asarray(aop)
    if a.shape != g.shape:
        raise ValueError(f"aop.shape = {a.shape}: must be {g.shape} (the {kind!r} grid)")
    usable = g.disc if mask is None else (g.disc & np.asarray(mask, dtype=bool))
    n_usable = int(np.count_nonzero(usable))
    if n_usable < cfg.min_pixels:
        return AxisEstimate(
            method, False, f"too few usable pixels ({n_usable})", pixels_used=n_usable
        )
    if method == "patz":
        out = _patz(a, usable, g, cfg)
        mu = None
    elif method in _METHODS:
        mu = abs_aoplm(a, g.xi)
        out = _METHODS[method](mu, usable, g, cfg)
    else:
        raise ValueError(f"method: {method!r}; allowed: 'moi', 'patz', 'ht'")
    if isinstance(out, str):
        return AxisEstimate(method, False, out, pixels_used=n_usable)
    axis, ex = out
    if method != "patz" and ex["residual"] > cfg.max_line_residual_rad:
        return AxisEstimate(
            method,
            False,
            f"E-vector not ⟂ the found line (mean π/2 − |AOPLM| = {ex['residual']:.2f} rad)",
            pixels_used=int(ex["n"]),
        )
    sun_az, margin, rms = None, 0.0, math.nan
    if sun_elevation_rad is not None:
        if mu is None:
            mu = abs_aoplm(a, g.xi)
        sun_az, margin, rms = resolve_sun_side(
            mu, usable, g, axis, sun_elevation_rad, calibration.polarization_mapping
        )
        if rms > cfg.max_model_rms_rad:
            return AxisEstimate(
                method,
                False,
                f"no Rayleigh sky pattern (|AOPLM| misfit {math.degrees(rms):.1f}° RMS)",
                pixels_used=int(ex["n"]),
                model_rms_rad=rms,
            )
    extras = {k: float(v) for k, v in ex.items() if k not in ("n", "residual", "sigma", "gap")}
    return AxisEstimate(
        method=method,
        ok=True,
        axis_rad=axis,
        sun_azimuth_rad=sun_az,
        side_margin=margin,
        model_rms_rad=rms,
        pixels_used=int(ex["n"]),
        residual=float(ex["residual"]),
        sigma_rad=max(float(ex["sigma"]), cfg.sigma_floor_rad),
        eigen_gap=float(ex["gap"]) if "gap" in ex else None,
        extras=extras,
    )
