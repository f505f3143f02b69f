"""Bubbles under a wind-driven sea: unresolved, bright, depolarizing points in the camera's view.

World side. Breaking waves inject air bubbles that stay within a metre or two of the surface. Seen
from a camera in that layer, each bubble lit by the sun is a point source far smaller than a
pixel: most are too faint to notice, and a few large, near ones are spots several times brighter
than the water around them — outliers for a compass that reads intensity or polarization pixel
by pixel. This module draws, per frame, the bubbles bright enough to matter and says where each
lands in the image and how much light it sends there.

**Population** (Hall 1989, as modified by Novarini, Keiffer & Norton 1998, IEEE J. Oceanic Eng.
23(4):423–438; the form quoted in Ainslie 2010, *Principles of Sonar Performance Modelling*,
§8.4.2 [uncertain: transcribed from the secondary source]). The number of bubbles per m³ per m of
radius a at depth z under a wind U (m/s at 10 m):

    n(a, z, U) = 1.6·10¹⁰ (U/13)³ exp(−z/L(U)) G(a, z),
    L(U) = 0.4 m (U ≤ 7.5 m/s), 0.4 + 0.115 (U − 7.5) m above,
    G = (a_ref/a)² for 10 µm ≤ a < a_ref, (a_ref/a)⁴ for a_ref ≤ a ≤ 1000 µm,
    a_ref = 54.4 µm + 1.984 µm/m · z.

Its void fraction at the surface at 13 m/s is 2·10⁻⁶ and its bubbles' scattering coefficient
0.03 m⁻¹, the range measured under breaking seas (Vagle & Farmer 1992; Terrill, Melville &
Stramski 2001). The twin's wind is Cox & Munk's at 12.5 m; the 2.5 m between the anemometer
heights changes U by ~1 % in a neutral boundary layer, which is ignored.

**Light.** A bubble is lit by the refracted sun beam at its depth, E(z) = E_sun e^(−c z/μ_s), and
sends I = E(z) σ p(Θ) towards the camera, Θ the angle between the beam and the bubble–camera line.
σ = πa²: a large bubble's extinction cross-section is 2πa², half of it diffraction into a lobe
of width ~λ/a (< 1° for a ≥ 30 µm) that stays in the sun's own image and is not drawn. p is a
Henyey–Greenstein phase function with g = 0.84 [uncertain: geometric-optics scattering by an air
bubble in water is dominated by total external reflection into deflections below 83° (Davis 1955,
J. Opt. Soc. Am. 45:572; Zhang, Lewis & Johnson 1998, Appl. Opt. 37:6525); g is the twin's
reading of those curves, not a fitted number]. The light is unpolarized [uncertain: reflection
near the critical angle polarizes it partly (Marston); over a population of sizes and angles
the twin takes the issue's "depolarizing" at its word]. On the way to the camera it is attenuated
by e^(−c r). The sky's diffuse light on bubbles is not drawn (under a clear sky the sun gives
~80 % of the downwelling light).

**A point in a pixel.** An unresolved point of intensity I at range r gives the camera the
irradiance I/r², which a pixel of solid angle Ω reads as the radiance I/(r² Ω).

**Which bubbles are drawn.** A bubble's signal goes as a²/r². Only bubbles with a/r ≥ a_max/reach
are drawn: a bubble of radius a within r ≤ reach·a/a_max of the camera (the largest, 1 mm, within
``reach_m`` = 4 m; a 50 µm one within 0.2 m). Every undrawn bubble is fainter than a 1 mm bubble
at 4 m, which even seen forward (Θ = 30°) is < 4 % of a pixel's path radiance in clear water.
Bubbles below ``a_min`` = 50 µm are not drawn either: within their 0.2 m they are one pixel's
< 4 % too; together they are a smooth haze (b = 0.012 m⁻¹ at the surface at 13 m/s) that the
twin does not add to the water's own particles. Sampling is exact for the population above the
threshold: radii are drawn with weight n(a) a³ (the volume in which a bubble of radius a is
drawn goes as a³), positions uniformly in that ball, and depth by thinning (the density is
bounded by its value at the ball's top and a_ref's at the ball's bottom).

Not modelled: bubble clouds' patchiness (the population is the mean, Poisson in space), caustics
on the bubbles, bubbles inside the housing's dome radius (r < 5 cm), and the hull's shadow.
Randomness comes only from the Generator passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from twin.core import options
from twin.core.arrays import row_norms

BubbleModel = Literal["hall_novarini", "ideal"]
BUBBLE_MODELS = options.BUBBLE_MODELS  # declared in twin.core.options (the scenario offers it)

_K_PER_M4 = 1.6e10  # Hall–Novarini amplitude, bubbles per m³ per m of radius at U = 13 m/s
_U_REF_MPS = 13.0
_A_REF0_M = 54.4e-6  # a_ref at the surface
_A_REF_SLOPE = 1.984e-6  # a_ref's growth per metre of depth
A_MAX_M = 1.0e-3  # the population's largest radius
HG_G = 0.84  # bubble phase function's asymmetry (module docstring, [uncertain])
_R_MIN_M = 0.05  # nearer than this is inside the housing's dome


def e_folding_depth_m(wind_speed_mps: float) -> float:
    """L(U): the population's e-folding depth (Hall–Novarini)."""
    u = float(wind_speed_mps)
    return 0.4 if u <= 7.5 else 0.4 + 0.115 * (u - 7.5)


def a_ref_m(depth_m: float) -> float:
    """a_ref(z), the radius where the size spectrum steepens from a⁻² to a⁻⁴."""
    return _A_REF0_M + _A_REF_SLOPE * float(depth_m)


def hg_phase(cos_theta: NDArray[np.float64], g: float = HG_G) -> NDArray[np.float64]:
    """Henyey–Greenstein phase function (sr⁻¹), normalised over the sphere."""
    return (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * cos_theta) ** 1.5)


class BubbleDraw(NamedTuple):
    """One frame's drawn bubbles, relative to the camera.

    Attributes:
        offsets_m: (N, 3) ENU offsets from the camera, m.
        radii_m: (N,) radii, m.
        depths_m: (N,) depths below the mean surface, m.
    """

    offsets_m: NDArray[np.float64]
    radii_m: NDArray[np.float64]
    depths_m: NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class BubblePopulation:
    """The Hall–Novarini bubbles under a wind, and the threshold of what is drawn.

    Attributes:
        wind_speed_mps: Wind speed (m/s); 0 = no breaking waves, no bubbles.
        a_min_m: Smallest radius drawn (module docstring).
        reach_m: Range within which the largest bubble (1 mm) is drawn; a bubble of radius a
            within ``reach_m · a / 1 mm``.
    """

    wind_speed_mps: float
    a_min_m: float = 50e-6
    reach_m: float = 4.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.wind_speed_mps) and self.wind_speed_mps >= 0):
            raise ValueError(f"wind_speed_mps: {self.wind_speed_mps!r}; allowed: >= 0 m/s")
        if not (10e-6 <= self.a_min_m < _A_REF0_M):
            raise ValueError(
                f"a_min_m: {self.a_min_m!r}; allowed: 10 µm to {_A_REF0_M * 1e6:.1f} µm"
            )
        if not (math.isfinite(self.reach_m) and self.reach_m > 0):
            raise ValueError(f"reach_m: {self.reach_m!r}; allowed: > 0 m")

    @property
    def amplitude_per_m4(self) -> float:
        """1.6·10¹⁰ (U/13)³: bubbles per m³ per m of radius at a_ref, at the surface."""
        return _K_PER_M4 * (self.wind_speed_mps / _U_REF_MPS) ** 3

    def spectrum(self, a_m: NDArray[np.float64], depth_m: NDArray[np.float64]) -> NDArray:
        """n(a, z) in bubbles per m³ per m of radius (zero outside 10 µm … 1 mm)."""
        a = np.asarray(a_m, dtype=np.float64)
        z = np.asarray(depth_m, dtype=np.float64)
        ar = _A_REF0_M + _A_REF_SLOPE * z
        g = np.where(a < ar, (ar / a) ** 2, (ar / a) ** 4)
        g = np.where((a >= 10e-6) & (a <= A_MAX_M), g, 0.0)
        return self.amplitude_per_m4 * np.exp(-z / e_folding_depth_m(self.wind_speed_mps)) * g

    def number_density_per_m3(self, depth_m: float, a_lo_m: float | None = None) -> float:
        """Bubbles per m³ with radius ≥ ``a_lo_m`` (default ``a_min_m``) at a depth."""
        lo = self.a_min_m if a_lo_m is None else a_lo_m
        a = np.geomspace(lo, A_MAX_M, 4001)
        n = self.spectrum(a, np.full_like(a, depth_m))
        return float(np.trapezoid(n, a))

    def draw(self, depth_m: float, rng: np.random.Generator) -> BubbleDraw:
        """The bubbles above the brightness threshold around a camera at ``depth_m``.

        Args:
            depth_m: Camera depth below the mean surface (> 0).
            rng: This frame's draw (the polarimeter's own bubble stream).
        """
        empty = BubbleDraw(np.zeros((0, 3)), np.zeros(0), np.zeros(0))
        if self.wind_speed_mps <= 0.0 or depth_m <= 0.0:
            return empty
        lfold = e_folding_depth_m(self.wind_speed_mps)
        z_top = max(0.0, depth_m - self.reach_m)  # the shallowest depth any drawn bubble has
        ar = _A_REF0_M + _A_REF_SLOPE * (depth_m + self.reach_m)  # a_ref's bound (the deepest)
        k = self.amplitude_per_m4 * math.exp(-z_top / lfold)
        # Proposal: n_bound(a) = k G(a; ar), a bubble of radius a drawn in a ball of radius
        # R(a) = reach a / a_max, so the proposal's count is ∫ n_bound (4/3)π R(a)³ da.
        scale = (4.0 / 3.0) * math.pi * (self.reach_m / A_MAX_M) ** 3
        lo = self.a_min_m
        w1 = ar**2 * (ar**2 - lo**2) / 2.0  # ∫_lo^ar (ar/a)² a³ da
        w2 = ar**4 * math.log(A_MAX_M / ar)  # ∫_ar^amax (ar/a)⁴ a³ da
        mean = k * scale * (w1 + w2)
        count = int(rng.poisson(mean))
        if count == 0:
            return empty
        u = rng.random(count)
        first = rng.random(count) < w1 / (w1 + w2)
        # Segment 1: density ∝ a, CDF ∝ a² − lo²; segment 2: density ∝ 1/a (log-uniform).
        a = np.where(
            first,
            np.sqrt(lo**2 + u * (ar**2 - lo**2)),
            ar * (A_MAX_M / ar) ** u,
        )
        r_ball = self.reach_m * a / A_MAX_M
        v = rng.standard_normal((count, 3))
        v /= row_norms(v)[:, None]
        r = r_ball * rng.random(count) ** (1.0 / 3.0)
        off = v * r[:, None]
        z = depth_m - off[:, 2]  # ENU up is +z: a bubble above the camera is shallower
        keep = (z > 0.0) & (r >= _R_MIN_M)
        # Thinning to the true density: exp(−z/L)/exp(−z_top/L) and G(a; a_ref(z))/G(a; ar).
        ar_z = _A_REF0_M + _A_REF_SLOPE * np.maximum(z, 0.0)
        g_true = np.where(a < ar_z, (ar_z / a) ** 2, (ar_z / a) ** 4)
        g_bound = np.where(a < ar, (ar / a) ** 2, (ar / a) ** 4)
        p = np.exp(-(np.maximum(z, 0.0) - z_top) / lfold) * g_true / g_bound
        keep &= rng.random(count) < p
        return BubbleDraw(off[keep], a[keep], z[keep])


def bubble_radiance(
    draw: BubbleDraw,
    sun_look: NDArray[np.float64],
    e_sun_normal: float,
    c_per_m: float,
    *,
    g: float = HG_G,
    albedo: float = 1.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each drawn point's radiant intensity towards the camera and its range.

    Args:
        draw: The frame's bubbles (or other point scatterers:
            ``sensors.polarimeter.optics.particles``).
        sun_look: (3,) ENU direction towards the refracted sun (in water).
        e_sun_normal: The refracted beam's normal irradiance just below the surface.
        c_per_m: The water's beam attenuation.
        g: The points' Henyey–Greenstein asymmetry (a bubble's by default).
        albedo: Their single-scattering albedo (an air bubble absorbs nothing).

    Returns:
        (I e^(−c r) per bubble, in the irradiance's units per sr; r in m).
    """
    r = row_norms(draw.offsets_m)
    if r.size == 0 or e_sun_normal <= 0.0:
        return np.zeros(r.size), r
    s = np.asarray(sun_look, dtype=np.float64).reshape(3)
    mu_s = max(float(s[2]), 1e-3)
    d = draw.offsets_m / r[:, None]  # camera → bubble
    # Beam travels along −s; the light to the camera along −d: cos Θ = s · d.
    cos_t = np.clip(d @ s, -1.0, 1.0)
    e_z = e_sun_normal * np.exp(-c_per_m * draw.depths_m / mu_s)
    intensity = e_z * albedo * math.pi * draw.radii_m**2 * hg_phase(cos_t, g)
    return intensity * np.exp(-c_per_m * r), r


__all__ = [
    "A_MAX_M",
    "BUBBLE_MODELS",
    "HG_G",
    "BubbleDraw",
    "BubbleModel",
    "BubblePopulation",
    "a_ref_m",
    "bubble_radiance",
    "e_folding_depth_m",
    "hg_phase",
]
