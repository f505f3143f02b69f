"""Gravity-aided navigation scored against truth and against its bound (wang2023 §2).

World side (sees truth and the vehicle's map). Over a run with a stored gravity map it keeps the
true path and every variant's position error at the truth rate; at the end it computes the
posterior Cramér–Rao bound along the *flown* true path — the paper's model (eqs. 17, 20–21): a
position random walk with the planner's Q_t, the stored map's gradient at the true positions as
H and the matcher's R (eq. 3), one measurement per node spacing flown (the map's error is drawn
per node: closer looks are not independent) — and sets each variant's position RMSE beside it.

What the comparison can and cannot say: the bound is the paper's two-state model, not the
15-state INS the filter runs, so it bounds a filter whose position error grows as the declared
Q_t says. An RMSE below the bound means the INS drifted less than Q_t assumes (the bound is then
loose, not broken); above it, the filter lost what the map offered or the INS drifted more. One
run is one draw: the benchmark (``benchmarks/gravity_aided_twin.py``) takes RMSE over seeds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.core.mission import PlannedMission
from twin.onboard.gravity.pcrb import GainsModel, pcrb_along, rmse_bound_m

if TYPE_CHECKING:
    from twin.app.simulation import Simulation
    from twin.world.truth import Truth

#: The paper's Q_t ((10 m)² per second per axis), for missions that do not declare one.
DEFAULT_Q_RATE_M2_PER_S = 100.0


@dataclass
class GravityScore:
    """The true path (map coordinates) and each variant's position error, at the truth rate."""

    t: list[float] = field(default_factory=list)
    path_m: list[tuple[float, float]] = field(default_factory=list)
    errors: dict[str, list[float]] = field(default_factory=dict)
    # When the vehicle declared a planned mission done, and how far from the goal it truly was.
    arrived_s: float | None = None
    goal_miss_m: float | None = None

    def add(self, sim: Simulation, truth: Truth, samples: dict[str, dict[str, float]]) -> None:
        stored = sim.stored_map
        if stored is None:
            return
        e0, n0 = stored.launch_m
        self.t.append(truth.t)
        self.path_m.append((e0 + float(truth.position_n[0]), n0 + float(truth.position_n[1])))
        mission = sim.scenario.mission
        if self.arrived_s is None and isinstance(mission, PlannedMission) and sim.status.complete:
            # Guidance judged arrival on the navigation source: the miss is the truth's distance.
            self.arrived_s = float(truth.t)
            self.goal_miss_m = math.dist(
                (float(truth.position_n[0]), float(truth.position_n[1])), mission.goal_m
            )
        for name, s in samples.items():
            self.errors.setdefault(name, []).append(s["position_err_m"])

    def bound_m(self, sim: Simulation) -> np.ndarray:
        """√tr P of the PCRB at every kept truth sample (m)."""
        stored = sim.stored_map
        assert stored is not None
        pts = np.asarray(self.path_m)
        m = sim.scenario.mission
        q = m.q_rate_m2_per_s if isinstance(m, PlannedMission) else DEFAULT_Q_RATE_M2_PER_S
        # Q_n = Q_t d / V (eq. 25) with V the mean speed flown: Q grows with the time elapsed.
        flown = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        elapsed = self.t[-1] - self.t[0]
        speed = flown / elapsed if flown > 0 and elapsed > 0 else 1.0
        p0 = 1.0e6
        if sim.navigators:
            nav = next(iter(sim.navigators.values()))
            p0 = float(max(nav.config.eskf.p0_position_m)) ** 2
        model = GainsModel(
            speed_mps=speed,
            p0_m2=max(p0, 1e-6),
            q_rate_m2_per_s=q,
            sigma_mgal=math.sqrt(stored.variance_mgal2),
        )
        inside = stored.grid.contains(pts[:, 0], pts[:, 1])
        if not bool(np.all(inside)):
            pts = pts[: int(np.argmin(inside))]  # up to where the vehicle left the map
        if len(pts) < 2:
            return np.zeros(len(pts))
        spacing = float(min(stored.grid.spacing_m))
        return rmse_bound_m(pcrb_along(stored.grid, pts, model, update_spacing_m=spacing))

    def summary(self, sim: Simulation) -> dict[str, Any] | None:
        """The metrics.json ``gravity`` entry; None for a run without a stored map."""
        stored = sim.stored_map
        if stored is None or len(self.path_m) < 2:
            return None
        bound = self.bound_m(sim)
        n = len(bound)
        pts = np.asarray(self.path_m)
        out: dict[str, Any] = {
            "map": stored.grid.source,
            "map_r_mgal": round(math.sqrt(stored.variance_mgal2), 4),
            "flown_m": round(float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))), 1),
            "pcrb_rms_m": round(float(np.sqrt(np.mean(bound**2))), 2) if n else None,
            "pcrb_final_m": round(float(bound[-1]), 2) if n else None,
        }
        if sim.route is not None:
            out["planned_m"] = round(sim.route.length_m, 1)
            out["planner_s"] = round(sim.route.seconds, 4)
            out["arrived_s"] = None if self.arrived_s is None else round(self.arrived_s, 1)
            out["goal_miss_m"] = None if self.goal_miss_m is None else round(self.goal_miss_m, 1)
        variants = {}
        for name, nav in sim.navigators.items():
            err = np.asarray(self.errors.get(name, [])[:n])
            rmse = float(np.sqrt(np.mean(err**2))) if err.size else math.nan
            bound_rms = float(np.sqrt(np.mean(bound[: err.size] ** 2))) if err.size else math.nan
            matches = nav.map_matches
            variants[name] = {
                "position_rmse_m": round(rmse, 2) if err.size else None,
                "position_final_m": round(float(err[-1]), 2) if err.size else None,
                "rmse_over_pcrb": round(rmse / bound_rms, 3) if bound_rms > 0 else None,
                "map_updates": sum(1 for m in matches if m.applied),
                "map_skipped": sum(1 for m in matches if not m.applied),
            }
        out["variants"] = variants
        return out


__all__ = ["GravityScore"]
