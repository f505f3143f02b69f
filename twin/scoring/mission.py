"""The mission scored against truth: tracking errors, distance, and the run's metrics summary.

World side (it sees truth). :class:`MissionScore` accumulates at the truth rate;
:func:`summarize` turns it, the filter variants' scores (:mod:`twin.scoring.navigation`) and the
run's facts into the metrics dict that ``metrics.json`` holds; :func:`format_summary` prints it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.core.frames import wrap_deg180
from twin.onboard.control.autopilot import Setpoint
from twin.onboard.control.guidance import GuidanceStatus

if TYPE_CHECKING:
    from twin.scoring.observer import RunScorer
    from twin.sim.step import Simulation

# Tracking counts as "steady" this long after a leg switch (a 90 deg REMUS turn takes ~40 s).
SETTLE_S = 45.0


@dataclass
class MissionScore:
    """Running sums for the metrics (cheap to update in the loop)."""

    n: int = 0
    depth_err_sq: float = 0.0
    depth_err_max: float = 0.0
    heading_err_sq: float = 0.0
    cross_track_sq: float = 0.0
    cross_track_max: float = 0.0
    distance_m: float = 0.0
    last_pos: np.ndarray | None = None
    readings: dict[str, int] = field(default_factory=dict)
    # The same errors on settled legs only (>= SETTLE_S after a leg switch): the autopilot's
    # tracking, without the corner turns that dominate the totals.
    n_steady: int = 0
    depth_err_sq_steady: float = 0.0
    heading_err_sq_steady: float = 0.0
    cross_track_sq_steady: float = 0.0
    max_depth_m: float = 0.0
    min_depth_m: float = math.inf


def accumulate(
    stats: MissionScore, truth, sp: Setpoint, status: GuidanceStatus, active: bool, settled: bool
) -> None:
    pos = truth.position_n
    if stats.last_pos is not None:
        stats.distance_m += float(np.linalg.norm(pos - stats.last_pos))
    stats.last_pos = pos
    stats.max_depth_m = max(stats.max_depth_m, truth.depth_m)
    stats.min_depth_m = min(stats.min_depth_m, truth.depth_m)
    if not active:
        return
    stats.n += 1
    e_d = truth.depth_m - sp.depth_m
    stats.depth_err_sq += e_d * e_d
    stats.depth_err_max = max(stats.depth_err_max, abs(e_d))
    e_h = float(wrap_deg180(truth.heading_deg - math.degrees(sp.heading_rad)))
    stats.heading_err_sq += e_h * e_h
    stats.cross_track_sq += status.cross_track_m**2
    stats.cross_track_max = max(stats.cross_track_max, abs(status.cross_track_m))
    if settled:
        stats.n_steady += 1
        stats.depth_err_sq_steady += e_d * e_d
        stats.heading_err_sq_steady += e_h * e_h
        stats.cross_track_sq_steady += status.cross_track_m**2


def summarize(world: Simulation, scorer: RunScorer, wall_s: float) -> dict[str, Any]:
    """The run's metrics: mission tracking, sensors, every filter variant and its compass fixes."""
    stats = scorer.mission
    plant = world.plant
    truth = plant.truth()
    n = max(stats.n, 1)
    ns = max(stats.n_steady, 1)
    sim_s = plant.t
    g = world.guidance
    legs_total = len(g.legs)
    return {
        "sim_time_s": round(sim_s, 6),
        "wall_time_s": round(wall_s, 3),
        "real_time_factor": round(sim_s / wall_s, 2) if wall_s > 0 else None,
        "mission": {
            "kind": world.scenario.mission.kind,
            "legs_total": legs_total,
            "legs_completed": g.legs_completed,
        },
        "distance_travelled_m": round(stats.distance_m, 3),
        "mean_speed_over_ground_mps": round(stats.distance_m / sim_s, 4) if sim_s > 0 else 0.0,
        "depth_error_rms_m": round(math.sqrt(stats.depth_err_sq / n), 4),
        "depth_error_max_m": round(stats.depth_err_max, 4),
        "heading_error_rms_deg": round(math.sqrt(stats.heading_err_sq / n), 3),
        "cross_track_rms_m": round(math.sqrt(stats.cross_track_sq / n), 3),
        "cross_track_max_m": round(stats.cross_track_max, 3),
        "steady_tracking": {
            "samples": stats.n_steady,
            "settle_after_leg_switch_s": SETTLE_S,
            "depth_error_rms_m": round(math.sqrt(stats.depth_err_sq_steady / ns), 4),
            "heading_error_rms_deg": round(math.sqrt(stats.heading_err_sq_steady / ns), 3),
            "cross_track_rms_m": round(math.sqrt(stats.cross_track_sq_steady / ns), 3),
        },
        "depth_range_m": [round(stats.min_depth_m, 3), round(stats.max_depth_m, 3)]
        if stats.min_depth_m != math.inf
        else None,
        "final": {
            "east_m": round(float(truth.position_n[0]), 3),
            "north_m": round(float(truth.position_n[1]), 3),
            "depth_m": round(truth.depth_m, 3),
            "heading_deg": round(truth.heading_deg, 3),
        },
        "sensor_readings": dict(sorted(stats.readings.items())),
        "sensors": [s.describe() for s in world.suite.sensors],
        "physics_timestep_s": world.physics_dt,
        "mujoco_warnings": int(plant.data.warning.number.sum()),
        **({"gravity": gravity} if (gravity := scorer.gravity.summary(world)) is not None else {}),
        **(
            {
                "navigation": {
                    "steering_on": world.scenario.navigation.steering_variant
                    if world.scenario.autopilot.attitude_source == "estimate"
                    else "truth",
                    "variants": {
                        name: {
                            **scorer.variants[name].summary(nav),
                            **(
                                {"compass_fix_errors": scorer.fixes[name].summary()}
                                if name in scorer.fixes
                                else {}
                            ),
                        }
                        for name, nav in world.navigators.items()
                    },
                }
            }
            if world.navigators
            else {}
        ),
    }


#: A compass variant that fuses fewer of its fixes than this is flagged: it is (nearly) its INS.
FUSION_WARN_FRACTION = 0.1


def fusion_warnings(metrics: dict[str, Any], nav: Any) -> list[str]:
    """A line for each compass variant that fused none or few of its fixes, naming the cause.

    Args:
        metrics: The run's metrics (``navigation.variants``).
        nav: The scenario's ``[navigation]`` table (gate and measurement kind, for the cause).
    """
    out = []
    for name, v in (metrics.get("navigation") or {}).get("variants", {}).items():
        comp = v.get("compass")
        if not comp or comp["frames"] == 0:
            continue
        fixes, fused = comp["fixes"], comp["sun_updates_applied"]
        if fixes == 0:
            out.append(
                f"{name}: the compass gave no fix in {comp['frames']} frames (night, or the "
                f"method found no sun): {name} ran as an INS-only filter"
            )
            continue
        if fused >= FUSION_WARN_FRACTION * fixes:
            continue
        rejected = comp["sun_updates_rejected"]
        cause = (
            f"the NIS gate (gate_probability {nav.gate_probability:g}) rejected {rejected} "
            f"{nav.sun_measurement!r} sun measurements"
            if rejected
            else "the filter skipped them"
        )
        hint = (
            "; sun_measurement = 'vector' fuses the compass's elevation, whose bias under water "
            "fails the gate: try sun_measurement = 'azimuth' or gate_probability = 1.0"
            if rejected and nav.sun_measurement == "vector"
            else ""
        )
        out.append(
            f"{name}: fused {fused} of {fixes} compass fixes ({100 * fused / fixes:.0f} %, under "
            f"{100 * FUSION_WARN_FRACTION:.0f} %): {cause}{hint}; its estimate is close to the "
            "INS alone"
        )
    return out


def format_summary(metrics: dict[str, Any]) -> str:
    """A human-readable summary of a metrics dict (what the CLI prints)."""
    m = metrics
    lines = [
        f"scenario {m['scenario']} (seed {m['seed']}): {m['status']}"
        + ("" if m["complete"] else "  [INCOMPLETE]"),
        f"  sim time {m.get('sim_time_s', 0):.1f} s in {m.get('wall_time_s', 0):.1f} s wall "
        f"({m.get('real_time_factor')}x real time)",
    ]
    if "mission" in m:
        ms = m["mission"]
        lines.append(
            f"  mission {ms['kind']}: legs {ms['legs_completed']}/{ms['legs_total']}, "
            f"distance {m['distance_travelled_m']:.1f} m"
        )
        lines.append(
            f"  depth error rms {m['depth_error_rms_m']:.3f} m (max {m['depth_error_max_m']:.3f}), "
            f"heading error rms {m['heading_error_rms_deg']:.2f} deg, "
            f"cross-track rms {m['cross_track_rms_m']:.2f} m"
        )
        st = m["steady_tracking"]
        if st["samples"]:
            lines.append(
                f"  settled legs (>{st['settle_after_leg_switch_s']:.0f} s after a switch): depth "
                f"{st['depth_error_rms_m']:.3f} m, heading {st['heading_error_rms_deg']:.2f} deg, "
                f"cross-track {st['cross_track_rms_m']:.2f} m rms"
            )
        lines.append(f"  sensor readings: {m['sensor_readings']}")
    nav = m.get("navigation")
    if nav:
        lines.append(f"  navigation (autopilot steering on {nav['steering_on']}):")
        for name, v in nav["variants"].items():
            if not v.get("samples"):
                continue
            comp = v.get("compass")
            extra = (
                f", fixes {comp['fixes']}/{comp['frames']}, sun updates "
                f"{comp['sun_updates_applied']} (+{comp['sun_updates_rejected']} rejected)"
                if comp
                else ""
            )
            lines.append(
                f"    {name:>5}: heading rmse {v['heading_rmse_deg']:.2f} deg "
                f"(mae {v['heading_mae_deg']:.2f}, max {v['heading_max_deg']:.2f}, final "
                f"{v['heading_final_deg']:+.2f}), roll/pitch rmse {v['roll_rmse_deg']:.2f}/"
                f"{v['pitch_rmse_deg']:.2f} deg, drift {v['position_drift_final_m']:.1f} m, "
                f"NEES {v['nees_attitude_mean']:.2f}{extra}"
            )
    for w in m.get("warnings", []):
        lines.append(f"  WARNING: {w}")
    if "error" in m:
        lines.append(f"  error: {m['error']}")
    return "\n".join(lines)
