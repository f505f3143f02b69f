"""SITAN: the gravity-matching filter of wang2023 §4, and its Monte Carlo along a path.

SITAN (Hostetler & Andreas 1983) is an extended Kalman filter whose measurement matrix is not
the map's gradient at one point but a slope fitted over the INS's confidence region
(stochastic linearisation). The paper's fit (eqs. 36–37) over the (2L+1)² nodes around the
INS-indicated node (i, j):

    h_λ = [Σ_{n=i+1..i+L, m=j−L..j+L} Δg_M − Σ_{n=i−L..i−1, m=j−L..j+L} Δg_M] / (L(2L+1)(L+1)δ),

and h_φ alike along the other axis: the difference of the mean anomaly on the two sides
divided by the distance between their centroids, (L+1)δ. L comes from the position covariance:
L = ⌈√(max eigenvalue of P)/δ⌉, at least 1 and at most ``max_half_window``. (The paper prints
the left-minus-right difference; with its z = h(x̂) − y and x̂ = x_INS − Δx that is the same
slope with the sign carried by the state; here the state is the position and H = +∂h/∂x.)

:func:`monte_carlo` runs the filter along a path for many runs at once (vectorised over runs
with numpy: a run is 100 steps of a 2-state filter, microseconds of work, so a process per run —
the campaign machinery — would spend its time starting processes; the runs are seeded from one
Generator so the result is the same at any batch size).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twin.core.gravity_map import GravityGrid
from twin.onboard.gravity.pcrb import GainsModel, riccati_update


def sitan_slope(
    grid: GravityGrid, east_m: NDArray, north_m: NDArray, half_window: NDArray
) -> NDArray[np.float64]:
    """Eqs. 36–37 at the nearest nodes of points (N,), windows of half-width L (N,): (N, 2)."""
    i, j = grid.nearest_node(east_m, north_m)
    L = np.asarray(half_window, dtype=np.int64)
    de, dn = grid.spacing_m
    rows = (j - L, j + L + 1)
    cols = (i - L, i + L + 1)
    right = grid.window_sum(*rows, i + 1, i + L + 1)
    left = grid.window_sum(*rows, i - L, i)
    up = grid.window_sum(j + 1, j + L + 1, *cols)
    down = grid.window_sum(j - L, j, *cols)
    norm = L * (2 * L + 1) * (L + 1)
    return np.stack([(right - left) / (norm * de), (up - down) / (norm * dn)], axis=-1)


@dataclass(frozen=True, slots=True)
class MonteCarloResult:
    """Position errors of the runs along a path.

    Attributes:
        rmse_m: (N,) RMSE over runs at each point (the paper's RMSE, eq. 33).
        bound_m: (N,) √tr of the PCRB along the path.
        runs: Number of runs.
        errors_m2: (runs, N) each run's squared position error, when kept.
    """

    rmse_m: NDArray[np.float64]
    bound_m: NDArray[np.float64]
    runs: int
    errors_m2: NDArray[np.float64] | None = None

    @property
    def sum_rmse_m(self) -> float:
        return float(self.rmse_m.sum())


def monte_carlo(
    truth: GravityGrid,
    stored: GravityGrid,
    path_m: ArrayLike,
    model: GainsModel,
    rng: np.random.Generator,
    *,
    runs: int = 1000,
    max_half_window: int = 10,
    keep_errors: bool = False,
) -> MonteCarloResult:
    """SITAN along a path, ``runs`` times: the INS error, the gravimeter noise, the start.

    Each run: x̂₀ = x₀ + N(0, P₀); at every point the filter predicts with the INS increment
    (the true one plus N(0, Q_n), eq. 25), reads y = h_true(x) + N(0, σ²), fits H by SITAN at
    its own x̂ over its own confidence region, and updates with y − h_stored(x̂).
    """
    from twin.onboard.gravity.pcrb import pcrb_along, rmse_bound_m

    pts = np.asarray(path_m, dtype=np.float64)
    truth.require_on_map(pts[:, 0], pts[:, 1], "path")
    n = pts.shape[0]
    steps = np.r_[0.0, np.linalg.norm(np.diff(pts, axis=0), axis=1)]
    q = model.q_for(steps)
    r = model.r_mgal2
    x = pts[0] + rng.standard_normal((runs, 2)) * math.sqrt(model.p0_m2)
    p = np.broadcast_to(np.eye(2) * model.p0_m2, (runs, 2, 2)).copy()
    if runs < 1:
        raise ValueError(f"runs: {runs!r}; allowed: >= 1")
    err2 = np.empty((runs, n))
    delta = min(stored.spacing_m)
    e0, e1, n0, n1 = stored.extent_m
    for k in range(n):
        if k > 0:
            ins = (pts[k] - pts[k - 1]) + rng.standard_normal((runs, 2)) * math.sqrt(q[k])
            x = x + ins
            p = p + np.eye(2) * q[k]
        y = truth.value(pts[k, 0], pts[k, 1]) + rng.standard_normal(runs) * model.sigma_mgal
        # An estimate pushed off the map is held at its edge for the map look-up.
        xe = np.clip(x[:, 0], e0, e1)
        xn = np.clip(x[:, 1], n0, n1)
        sig = np.sqrt(np.linalg.eigvalsh(p)[:, -1])
        half = np.clip(np.ceil(sig / delta), 1, max_half_window)
        h = sitan_slope(stored, xe, xn, half)
        innov = y - stored.value(xe, xn)
        ph = np.einsum("nij,nj->ni", p, h)
        s = np.einsum("ni,ni->n", h, ph) + r
        x = x + ph * (innov / s)[:, None]
        p = riccati_update(p, h, r)
        err2[:, k] = np.sum((x - pts[k]) ** 2, axis=1)
    bound = rmse_bound_m(pcrb_along(truth, pts, model))
    rmse = np.sqrt(err2.mean(axis=0))
    return MonteCarloResult(rmse, bound, runs, err2 if keep_errors else None)


__all__ = ["MonteCarloResult", "monte_carlo", "sitan_slope"]
