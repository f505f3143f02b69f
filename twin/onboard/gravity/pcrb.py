"""The posterior Cramér–Rao bound of gravity-aided navigation along a path (wang2023 §2).

The model of the paper (eqs. 1–2): position x_{t+1} = x_t + u_t + v_t, v_t ~ N(0, Q_t), the INS
increment u_t known; the gravimeter sees y_t = h(x_t) + ε_t + w_t with h the stored map's bilinear
interpolation. With Gaussian noises the bound's recursion (eqs. 20–21) is the Kalman Riccati
recursion linearised about the true path, H_t = ∇h(x_t):

    P_{t+1|t} = P_{t|t} + Q_t,
    P_{t+1|t+1} = P_{t+1|t} − P_{t+1|t} Hᵀ (H P_{t+1|t} Hᵀ + R)⁻¹ H P_{t+1|t}.

Along a path the INS noise grows with the distance sailed (eq. 25): Q_n = Q_t · d / V, with
Q_t the variance rate (m²/s) and V the speed. The navigation-information map (eq. 19) is
M = tr(Hᵀ R⁻¹ H) = |∇h|²/R.

Units inside: metres, seconds, mGal (R in mGal², H in mGal/m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twin.core.arrays import Float64Array as FloatArray
from twin.core.gravity_map import GravityGrid

#: Table 1's Q_t = diag(0.01², 0.01²) under its two readings, per axis (m²/s). The paper prints
#: "m²/s"; the twin read km²/s before. One scalar look a step leaves the INS's variance growth
#: in the unseen direction, so Σ√tr P ≥ :func:`floor_sum_rmse_m`: under the km²/s reading every
#: path of Test 1 sums to at least 12.3 km, while Table 2's R = 1 row holds 8.1–10.0 km. The
#: paper's own tables therefore rule that reading out, and the literal one is the default
#: (tests/onboard/test_gravity_nav.py).
Q_T_READINGS: dict[str, float] = {"as_printed": 1.0e-4, "km2_per_s": 100.0}


@dataclass(frozen=True, slots=True)
class GainsModel:
    """The paper's Table 1 parameters (SI): what the bound, the planner and SITAN assume.

    Attributes:
        speed_mps: Vehicle speed V (Table 1: 5 m/s).
        p0_m2: Initial position variance per axis (Table 1: diag(1, 1) km² → 1e6 m²).
        q_rate_m2_per_s: INS position variance rate per axis, Q_t (Table 1: diag(0.01², 0.01²)
            m²/s as printed; :data:`Q_T_READINGS` holds both readings and why this one).
        sigma_mgal: Total observation noise σ, R = σ² (Table 2–3: 1–4 mGal).
    """

    speed_mps: float = 5.0
    p0_m2: float = 1.0e6
    q_rate_m2_per_s: float = Q_T_READINGS["as_printed"]
    sigma_mgal: float = 2.0

    def __post_init__(self) -> None:
        for name in ("speed_mps", "p0_m2", "q_rate_m2_per_s", "sigma_mgal"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"GainsModel.{name}: {v!r}; allowed: > 0")

    @property
    def r_mgal2(self) -> float:
        return self.sigma_mgal**2

    def q_for(self, distance_m: ArrayLike) -> FloatArray:
        """Eq. 25: the per-axis INS variance added over a leg of ``distance_m``."""
        return self.q_rate_m2_per_s * np.asarray(distance_m, dtype=np.float64) / self.speed_mps


def observation_variance(
    sigma_map_mgal: float, c0_mgal2: float, beta_per_m2: float, delta_m: float, sigma_g_mgal: float
) -> float:
    """Eq. 3: R = σ_m² + C₀ β² δ⁴ / 4 + σ_g² (mGal²): map error, map resolution, gravimeter."""
    return sigma_map_mgal**2 + c0_mgal2 * beta_per_m2**2 * delta_m**4 / 4.0 + sigma_g_mgal**2


def information_map(grid: GravityGrid, sigma_mgal: float) -> FloatArray:
    """Eq. 19 at every node: M = |∇h|² / σ² (m⁻²), ∇h by central differences."""
    ee, nn = np.meshgrid(grid.east_m, grid.north_m)
    g = grid.node_gradient(ee, nn)
    return (g[..., 0] ** 2 + g[..., 1] ** 2) / sigma_mgal**2


def riccati_update(p: FloatArray, h: FloatArray, r: float) -> FloatArray:
    """Eq. 21 for one scalar measurement, batched: P (..., 2, 2), H (..., 2)."""
    ph = np.einsum("...ij,...j->...i", p, h)
    s = np.einsum("...i,...i->...", h, ph) + r
    return p - ph[..., :, None] * ph[..., None, :] / s[..., None, None]


def pcrb_along(
    grid: GravityGrid, path_m: ArrayLike, model: GainsModel, *, update_spacing_m: float = 0.0
) -> FloatArray:
    """The bound P_{k|k} (N, 2, 2) at each point of a path (N, 2) (m), the first updated too.

    Args:
        grid: The map (its gradient is H).
        path_m: The path's points (N, 2) in map coordinates (m).
        model: The paper's parameters.
        update_spacing_m: Take a measurement only where the path has covered at least this
            distance since the last one (0: at every point, the paper's paths of 100 points).
            Each measurement's R holds a map error drawn per node, so looks closer than a node
            spacing are not independent: a densely sampled path (a flown one, at the truth rate)
            is bounded with the node spacing here, one independent look per node.
    """
    if not (math.isfinite(update_spacing_m) and update_spacing_m >= 0):
        raise ValueError(f"pcrb_along update_spacing_m: {update_spacing_m!r}; allowed: >= 0 m")
    pts = np.asarray(path_m, dtype=np.float64)
    grid.require_on_map(pts[:, 0], pts[:, 1], "path")
    h = grid.node_gradient(pts[:, 0], pts[:, 1])
    steps = np.r_[0.0, np.linalg.norm(np.diff(pts, axis=0), axis=1)]
    q = model.q_for(steps)
    out = np.empty((pts.shape[0], 2, 2))
    p = np.eye(2) * model.p0_m2
    since = math.inf  # the first point is measured
    for k in range(pts.shape[0]):
        p = p + np.eye(2) * q[k]
        since += steps[k]
        if since >= update_spacing_m:
            p = riccati_update(p, h[k], model.r_mgal2)
            since = 0.0
        out[k] = p
    return out


def floor_sum_rmse_m(path_m: ArrayLike, model: GainsModel) -> float:
    """A floor under Σ_k √tr P_{k|k} along a path, whatever the map (m).

    Each step adds Q_n I (eq. 25) and one scalar look takes information along one direction
    only: a rank-one downdate of a 2 × 2 matrix keeps its largest eigenvalue above the smallest
    eigenvalue before it (Weyl's interlacing), and that is at least Q_n. So √tr P_{k|k} ≥ √Q_n
    at every step after the first, and ≥ √P0 at the first (its P_{0|0} keeps P0 along the
    direction it does not see).
    """
    pts = np.asarray(path_m, dtype=np.float64)
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    return math.sqrt(model.p0_m2) + float(np.sqrt(model.q_for(steps)).sum())


def rmse_bound_m(p: FloatArray) -> FloatArray:
    """√tr P: the bound on the position RMSE (m)."""
    return np.sqrt(np.trace(p, axis1=-2, axis2=-1))


__all__ = [
    "Q_T_READINGS",
    "GainsModel",
    "floor_sum_rmse_m",
    "information_map",
    "observation_variance",
    "pcrb_along",
    "riccati_update",
    "rmse_bound_m",
]
