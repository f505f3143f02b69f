"""Marine snow: suspended aggregates as bright, depolarizing points in the camera's view.

World side; the companion of :mod:`sensors.polarimeter.optics.bubbles` (same drawing, same light,
same
way into a pixel). Marine snow — aggregates of detritus, mucus and plankton larger than 0.5 mm —
drifts through the whole mixed layer. A sun-lit aggregate near the camera is an unresolved point
brighter than the water behind it, an outlier for a compass that reads pixels.

**Population** [uncertain: ocean-to-ocean and seasonal spread of an order of magnitude]:

* abundance: N(d ≥ 0.5 mm) = 3 aggregates per litre, within the 1–10 per litre that Alldredge &
  Silver (1988, Prog. Oceanogr. 20:41–82) report as typical of surface waters outside blooms;
* size: a power-law (Junge) number spectrum n(d) ∝ d⁻⁴ between 0.5 and 5 mm diameter, the slope
  of marine particle size distributions (Bader 1970, J. Mar. Res. 28:154; Stemmann & Boss 2012,
  Annu. Rev. Mar. Sci. 4:263, slopes 3–4.5);
* depth: uniform (the mixed layer's aggregates; no surface source as for bubbles).

**Light.** As a bubble: lit by the refracted sun beam at its depth, scattering the non-diffracted
half of its 2πa² extinction cross-section, times its single-scattering albedo ω₀ = 0.9
[uncertain: aggregates carry absorbing detritus and phytoplankton; oceanic particle albedos are
0.8–0.95 (Mobley 1994, *Light and Water*, §3.7)], with Petzold's average particle phase
function's asymmetry g = 0.924 (Mobley 1994, Table 3.10) in a Henyey–Greenstein form; unpolarized
(the issue's "depolarizing"; large irregular aggregates depolarize strongly). The diffraction
half stays within ~λ/a of the sun's own image and is not drawn.

**What is drawn.** A point's signal goes as a²/r²: an aggregate of radius a is drawn within
``reach_m`` · a / a_max of the camera (the largest, 2.5 mm, within 4 m), as for bubbles; the
radius density of the drawn population is then ∝ n(a) a³ ∝ 1/a, log-uniform. None in a tank
(tap water or milk: no aggregates), none in air.

Randomness comes only from the Generator passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from sensors.polarimeter.optics.bubbles import BubbleDraw
from twin.core import options
from twin.core.arrays import row_norms
from twin.core.fields import Range, check_ranges

ParticleModel = Literal["marine_snow", "ideal"]
PARTICLE_MODELS = options.PARTICLE_MODELS  # declared in twin.core.options (the scenario offers it)

HG_G = 0.924  # Petzold's average particle phase function (Mobley 1994, Table 3.10)
ALBEDO = 0.9  # single-scattering albedo of an aggregate (module docstring, [uncertain])
_R_MIN_M = 0.05  # nearer than this is inside the housing's dome


@dataclass(frozen=True, slots=True)
class MarineSnow:
    """The aggregates' population, and the threshold of what is drawn.

    Attributes:
        per_litre: Aggregates of diameter ≥ ``d_min_m`` per litre.
        slope: Exponent of the number spectrum n(d) ∝ d^(−slope).
        d_min_m: Smallest diameter (the "marine snow" definition: 0.5 mm).
        d_max_m: Largest diameter.
        reach_m: Range within which the largest aggregate is drawn.
    """

    per_litre: float = 3.0
    slope: float = 4.0
    d_min_m: float = 0.5e-3
    d_max_m: float = 5.0e-3
    reach_m: float = 4.0

    def __post_init__(self) -> None:
        checks = (
            ("per_litre", self.per_litre, 0.0, 1e4),
            ("slope", self.slope, 1.5, 6.0),
            ("d_min_m", self.d_min_m, 1e-5, 1e-2),
            ("reach_m", self.reach_m, 1e-3, 100.0),
        )
        check_ranges("MarineSnow", ((n, v, Range(lo, hi)) for n, v, lo, hi in checks))
        if not (self.d_min_m < self.d_max_m <= 0.05):
            raise ValueError(
                f"MarineSnow.d_max_m: {self.d_max_m!r}; allowed: ({self.d_min_m:g}, 0.05] m"
            )

    @property
    def a_max_m(self) -> float:
        return self.d_max_m / 2.0

    def number_density_per_m3(self, d_lo_m: float | None = None) -> float:
        """Aggregates per m³ with diameter ≥ ``d_lo_m`` (default ``d_min_m``)."""
        lo = self.d_min_m if d_lo_m is None else max(float(d_lo_m), self.d_min_m)
        if lo >= self.d_max_m:
            return 0.0
        k = self.slope - 1.0
        cum = lambda d: d ** (-k) - self.d_max_m ** (-k)  # noqa: E731 ∝ N(≥ d) within the range
        return self.per_litre * 1e3 * cum(lo) / cum(self.d_min_m)

    def draw(self, depth_m: float, rng: np.random.Generator) -> BubbleDraw:
        """The aggregates above the brightness threshold around a camera at ``depth_m``.

        Exact for the population: a Poisson count over the balls R(a) = reach · a / a_max (the
        count's mean is ∫ n(a) (4/3)π R(a)³ da), radii from n(a) a³, positions uniform in the
        ball, those above the surface or inside the dome dropped.
        """
        empty = BubbleDraw(np.zeros((0, 3)), np.zeros(0), np.zeros(0))
        if self.per_litre <= 0.0 or depth_m <= 0.0:
            return empty
        a_lo, a_hi = self.d_min_m / 2.0, self.a_max_m
        k = self.slope - 1.0
        # n(a) in per m³ per m of radius: N_total k a_lo^k a^−(k+1) / (1 − (a_lo/a_hi)^k).
        n_tot = self.number_density_per_m3()
        amp = n_tot * k * a_lo**k / (1.0 - (a_lo / a_hi) ** k)
        scale = (4.0 / 3.0) * math.pi * (self.reach_m / a_hi) ** 3
        p = 3.0 - k  # ∫ a^(2−k) da: the drawn radius density ∝ a^(2−k)
        if abs(p) < 1e-12:
            integral = math.log(a_hi / a_lo)
        else:
            integral = (a_hi**p - a_lo**p) / p
        mean = amp * scale * integral
        count = int(rng.poisson(mean))
        if count == 0:
            return empty
        u = rng.random(count)
        if abs(p) < 1e-12:
            a = a_lo * (a_hi / a_lo) ** u
        else:
            a = (a_lo**p + u * (a_hi**p - a_lo**p)) ** (1.0 / p)
        r_ball = self.reach_m * a / a_hi
        v = rng.standard_normal((count, 3))
        v /= row_norms(v)[:, None]
        r = r_ball * rng.random(count) ** (1.0 / 3.0)
        off = v * r[:, None]
        z = depth_m - off[:, 2]
        keep = (z > 0.0) & (r >= _R_MIN_M)
        return BubbleDraw(off[keep], a[keep], z[keep])


__all__ = ["ALBEDO", "HG_G", "PARTICLE_MODELS", "MarineSnow", "ParticleModel"]
