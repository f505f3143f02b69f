"""Ocean current: constant, a depth profile, or a mean plus Gauss–Markov gusts.

Currents are horizontal and given in the navigation frame (ENU). The vehicle feels them through its
velocity relative to the water (twin.world.hydrodynamics works on ν_r = ν − ν_c).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from scenarios.schema import CURRENT_KINDS


def _toward_to_en(speed_mps: float, toward_deg: float) -> tuple[float, float]:
    """(East, North) components of a current flowing toward a compass direction."""
    a = math.radians(toward_deg)
    return speed_mps * math.sin(a), speed_mps * math.cos(a)


@dataclass(frozen=True, slots=True)
class CurrentProfilePoint:
    """One point of a current profile: speed and direction at a depth."""

    depth_m: float
    speed_mps: float
    toward_deg: float


class Current:
    """A horizontal current field c(z, t) in ENU, advanced by :meth:`step`.

    Args:
        kind: "none", "constant", "profile" or "gauss_markov".
        speed_mps: Mean speed (constant, gauss_markov).
        toward_deg: Compass direction the water flows toward (constant, gauss_markov).
        profile: Depth profile points (profile), depths strictly increasing; linear in between,
            held constant beyond the ends.
        sigma_mps: Gust standard deviation on each horizontal axis (gauss_markov).
        tau_s: Gust correlation time (gauss_markov).
        rng: Generator for the gusts (gauss_markov); required for that kind.
    """

    KINDS = CURRENT_KINDS

    def __init__(
        self,
        kind: str = "none",
        *,
        speed_mps: float = 0.0,
        toward_deg: float = 0.0,
        profile: Sequence[CurrentProfilePoint] = (),
        sigma_mps: float = 0.0,
        tau_s: float = 60.0,
        rng: np.random.Generator | None = None,
    ):
        if kind not in self.KINDS:
            raise ValueError(f"current.kind = {kind!r}: allowed {', '.join(self.KINDS)}")
        if kind == "profile":
            depths = [p.depth_m for p in profile]
            if len(depths) < 2 or any(b <= a for a, b in itertools.pairwise(depths)):
                raise ValueError("current.profile needs >= 2 points with increasing depth_m")
        if kind == "gauss_markov":
            if rng is None:
                raise ValueError("a gauss_markov current needs a numpy Generator")
            if not (tau_s > 0 and sigma_mps >= 0):
                raise ValueError("current.tau_s must be > 0 and current.sigma_mps >= 0")
        self.kind = kind
        self._mean = np.array([*_toward_to_en(speed_mps, toward_deg), 0.0])
        self._depths = np.array([p.depth_m for p in profile], dtype=float)
        en = [_toward_to_en(p.speed_mps, p.toward_deg) for p in profile]
        self._prof_e = np.array([e for e, _ in en], dtype=float)
        self._prof_n = np.array([n for _, n in en], dtype=float)
        self._sigma = sigma_mps
        self._tau = tau_s
        self._rng = rng
        self._gust = np.zeros(3)
        if kind == "gauss_markov":
            # Start in the stationary distribution so statistics hold from t = 0.
            self._gust[:2] = rng.normal(0.0, sigma_mps, 2)

    def step(self, dt: float) -> None:
        """Advance the gusts by dt (exact first-order Gauss–Markov discretisation)."""
        if self.kind != "gauss_markov":
            return
        phi = math.exp(-dt / self._tau)
        self._gust[:2] = phi * self._gust[:2] + self._sigma * math.sqrt(
            1 - phi * phi
        ) * self._rng.normal(0.0, 1.0, 2)

    def velocity_n(self, depth_m: float) -> np.ndarray:
        """Current velocity (ENU, m/s) at a depth now."""
        if self.kind == "none":
            return np.zeros(3)
        if self.kind == "profile":
            return np.array(
                [
                    float(np.interp(depth_m, self._depths, self._prof_e)),
                    float(np.interp(depth_m, self._depths, self._prof_n)),
                    0.0,
                ]
            )
        return self._mean + self._gust
