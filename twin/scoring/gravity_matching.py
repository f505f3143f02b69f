"""The Monte Carlo of SITAN along a path (wang2023 §5): the truth side of the gravity study.

It simulates what the vehicle does not know — the true path, the INS's increment errors, the
gravimeter's readings of the true map — feeds them to the onboard filter
(:func:`twin.onboard.gravity.sitan.sitan_update`) and scores its estimates against the truth.
Vectorised over runs with numpy: a run is 100 steps of a 2-state filter, microseconds of work,
so a process per run (the campaign machinery) would spend its time starting processes; the runs
are seeded from one Generator so the result is the same at any batch size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twin.core.gravity_map import GravityGrid
from twin.onboard.gravity.pcrb import GainsModel, pcrb_along, rmse_bound_m
from twin.onboard.gravity.sitan import sitan_update


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
    if runs < 1:
        raise ValueError(f"runs: {runs!r}; allowed: >= 1")
    pts = np.asarray(path_m, dtype=np.float64)
    truth.require_on_map(pts[:, 0], pts[:, 1], "path")
    n = pts.shape[0]
    steps = np.r_[0.0, np.linalg.norm(np.diff(pts, axis=0), axis=1)]
    q = model.q_for(steps)
    x = pts[0] + rng.standard_normal((runs, 2)) * math.sqrt(model.p0_m2)
    p = np.broadcast_to(np.eye(2) * model.p0_m2, (runs, 2, 2)).copy()
    err2 = np.empty((runs, n))
    for k in range(n):
        if k > 0:
            ins = (pts[k] - pts[k - 1]) + rng.standard_normal((runs, 2)) * math.sqrt(q[k])
            x = x + ins
            p = p + np.eye(2) * q[k]
        y = truth.value(pts[k, 0], pts[k, 1]) + rng.standard_normal(runs) * model.sigma_mgal
        x, p = sitan_update(x, p, y, stored, model.r_mgal2, max_half_window)
        err2[:, k] = np.sum((x - pts[k]) ** 2, axis=1)
    bound = rmse_bound_m(pcrb_along(truth, pts, model))
    rmse = np.sqrt(err2.mean(axis=0))
    return MonteCarloResult(rmse, bound, runs, err2 if keep_errors else None)


__all__ = ["MonteCarloResult", "monte_carlo"]
