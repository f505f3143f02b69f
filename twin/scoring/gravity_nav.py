"""Gravity-aided navigation scored against truth and against its bound (wang2023 §2).

World side (sees truth and the vehicle's map). Over a run with a stored gravity map it keeps the
true path and every variant's position error at the truth rate; at the end it computes the
posterior Cramér–Rao bound along the *flown* true path — the paper's model (eqs. 17, 20–21): a
position random walk with a variance rate Q_t, the *true* field's gradient at the stored map's
node spacing as H (the stored map's node errors are noise, counted in R, not information) and
the matcher's R (eq. 3), one measurement per node spacing flown (the map's error is drawn per
node: closer looks are not independent) — and sets the RMSE of each variant that fused the map
beside it (a variant that fused none has no map-aided bound to meet).

The bound is given at the planner's declared Q_t and at each rate of
:data:`BOUND_Q_GRID_M2_PER_S`, so that a study can place it at the Q_t the INS actually flew
(``validation/gravity_aided_twin.py`` measures that from the map-free runs).

What the comparison can and cannot say: the bound is the paper's two-state model, not the
15-state INS the filter runs, so it bounds a filter whose position error grows as Q_t says. An
RMSE below the bound means the INS drifted less than Q_t assumes (the bound is then loose, not
broken); above it, the filter lost what the map offered or the INS drifted more. One
run is one draw: the benchmark (``validation/gravity_aided_twin.py``) takes RMSE over seeds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.core.mission import PlannedMission
from twin.onboard.gravity.pcrb import GainsModel, pcrb_along, rmse_bound_m
from twin.world.gravity_area import field_at_stored_spacing, gravity_field

if TYPE_CHECKING:
    from twin.scoring.navigation import VariantScore
    from twin.scoring.observer import RunScorer
    from twin.sim.step import Simulation
    from twin.world.truth import Truth

#: The planner's default Q_t (per axis), for missions that do not declare one.
DEFAULT_Q_RATE_M2_PER_S = 100.0
#: The rates (m²/s per axis) the bound is also computed at, for studies that measure Q_t.
BOUND_Q_GRID_M2_PER_S: tuple[float, ...] = (10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0)


@dataclass
class GravityScore:
    """The true path (map coordinates) and each variant's position error, at the truth rate."""

    t: list[float] = field(default_factory=list)
    path_m: list[tuple[float, float]] = field(default_factory=list)
    # When the vehicle declared a planned mission done, and how far from the goal it truly was.
    arrived_s: float | None = None
    goal_miss_m: float | None = None
    # The scorer's variants, whose samples are this score's (set by the first kept sample).
    _variants: dict[str, VariantScore] = field(default_factory=dict, repr=False)

    @property
    def errors(self) -> dict[str, list[float]]:
        """Each variant's horizontal position error at the kept samples (m)."""
        return {name: v.pos_err for name, v in self._variants.items()}

    def add(self, sim: Simulation, truth: Truth, scorer: RunScorer) -> None:
        """Keep this truth sample (a run with a stored map only); ``scorer`` has just scored it.

        Every truth sample of such a run is kept, so the variants' own error series are this
        score's, sample for sample.
        """
        stored = sim.stored_map
        if stored is None:
            return
        self._variants = scorer.variants
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

    def declared_q(self, sim: Simulation) -> float:
        """The planner's Q_t (m²/s per axis)."""
        m = sim.scenario.mission
        return m.q_rate_m2_per_s if isinstance(m, PlannedMission) else DEFAULT_Q_RATE_M2_PER_S

    @staticmethod
    def _p0_m2(sim: Simulation) -> float:
        """The filters' initial position variance per axis (m²; the first variant's)."""
        if not sim.navigators:
            return 1.0e6
        nav = next(iter(sim.navigators.values()))
        return float(max(nav.config.eskf.p0_position_m)) ** 2

    def bound_m(self, sim: Simulation, q: float | None = None) -> np.ndarray:
        """√tr P of the PCRB at every kept truth sample (m), at Q_t = ``q`` (default declared)."""
        stored = sim.stored_map
        assert stored is not None
        pts = np.asarray(self.path_m)
        q = self.declared_q(sim) if q is None else q
        field = gravity_field(sim.scenario)
        assert field is not None
        true = field_at_stored_spacing(sim.scenario, field)
        # Q_n = Q_t d / V (eq. 25) with V the mean speed flown: Q grows with the time elapsed.
        flown = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        elapsed = self.t[-1] - self.t[0]
        speed = flown / elapsed if flown > 0 and elapsed > 0 else 1.0
        model = GainsModel(
            speed_mps=speed,
            p0_m2=max(self._p0_m2(sim), 1e-6),
            q_rate_m2_per_s=q,
            sigma_mgal=math.sqrt(stored.variance_mgal2),
        )
        inside = true.contains(pts[:, 0], pts[:, 1])
        if not bool(np.all(inside)):
            pts = pts[: int(np.argmin(inside))]  # up to where the vehicle left the map
        if len(pts) < 2:
            return np.zeros(len(pts))
        spacing = float(min(true.spacing_m))
        return rmse_bound_m(pcrb_along(true, pts, model, update_spacing_m=spacing))

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
            "scored_s": round(self.t[-1] - self.t[0], 1),
            "p0_position_m2": round(self._p0_m2(sim), 3),
            "pcrb_q_rate_m2_per_s": self.declared_q(sim),
            "pcrb_map": "the true field at the stored map's spacing",
            "pcrb_rms_m_at_q": {
                f"{q:g}": round(float(np.sqrt(np.mean(self.bound_m(sim, q) ** 2))), 2)
                for q in BOUND_Q_GRID_M2_PER_S
            },
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
            fused = any(m.applied for m in matches)
            variants[name] = {
                "position_rmse_m": round(rmse, 2) if err.size else None,
                "position_final_m": round(float(err[-1]), 2) if err.size else None,
                # A variant that fused no map has no map-aided bound to meet.
                "rmse_over_pcrb": round(rmse / bound_rms, 3) if fused and bound_rms > 0 else None,
                "map_updates": sum(1 for m in matches if m.applied),
                "map_skipped": sum(1 for m in matches if not m.applied),
            }
        out["variants"] = variants
        return out


__all__ = ["GravityScore"]
