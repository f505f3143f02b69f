"""The run loop: simulate a scenario, record it to Rerun, write metrics.

Outputs, in ``out_dir``:
  * ``recording.rrd``: the Rerun recording (open with ``rerun recording.rrd``).
  * ``metrics.json``: the summary. It is written as ``"complete": false`` when the run starts and
    rewritten at the end, so even a killed run leaves a file that says it is incomplete.

Ctrl-C or an exception stops the loop; the recording is closed (footer written) and the metrics
are written with ``"complete": false`` and the reason, before the exception propagates.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from scenarios.schema import Scenario
from sensors.polarimeter import images
from sensors.polarimeter.render import Polarimeter
from twin.actuators import ActuatorCommand
from twin.autopilot import Setpoint
from twin.frames import wrap_deg180
from twin.guidance import GuidanceStatus
from twin.messages import Reading
from twin.navscore import VariantScore
from twin.onboard.navigator import CompassEvent
from twin.onboard.polarization import stokes_from_mosaic
from twin.recorder import Recorder
from twin.world import World, build_world

# Keep running this long after the last leg is done, so the recording shows the vehicle settle.
_MISSION_COMPLETE_TAIL_S = 5.0
# Tracking counts as "steady" this long after a leg switch (a 90 deg REMUS turn takes ~40 s).
_SETTLE_S = 45.0


@dataclass
class _Stats:
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
    # The same errors on settled legs only (>= _SETTLE_S after a leg switch): the autopilot's
    # tracking, without the corner turns that dominate the totals.
    n_steady: int = 0
    depth_err_sq_steady: float = 0.0
    heading_err_sq_steady: float = 0.0
    cross_track_sq_steady: float = 0.0
    max_depth_m: float = 0.0
    min_depth_m: float = math.inf
    nav: dict[str, VariantScore] = field(default_factory=dict)


def _write_json_atomic(path: Path, payload: dict[str, Any]) -> None:
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(payload, indent=2, sort_keys=False, default=str) + "\n")
    os.replace(tmp, path)


class ChaseCamera:
    """MuJoCo's view of the vehicle rendered offscreen, if a GL context can be had.

    Uses the scene's ``overview`` camera when it has one (the tank: the vehicle's chase camera
    would sit outside the walls), else the vehicle's ``chase`` camera.

    Without one (no ``MUJOCO_GL``, no EGL/OSMesa), :attr:`available` is False and the reason is in
    :attr:`reason`; the run goes on without images.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int):
        self.available = False
        self.reason = ""
        self._renderer: mujoco.Renderer | None = None
        self.camera = (
            "overview"
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "overview") >= 0
            else "chase"
        )
        # The offscreen buffer must be at least the image size.
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        try:
            self._renderer = mujoco.Renderer(model, height=height, width=width)
            self.available = True
        except Exception as exc:
            self.reason = f"{type(exc).__name__}: {exc}".strip()

    def render(self, data: mujoco.MjData) -> np.ndarray:
        assert self._renderer is not None
        self._renderer.update_scene(data, camera=self.camera)
        return self._renderer.render()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _versions() -> dict[str, str]:
    from importlib import metadata

    out = {"mujoco": mujoco.__version__, "numpy": np.__version__}
    for dist in ("auv-twin", "rerun-sdk"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:  # running from a source tree without install
            out[dist] = "unknown"
    return out


def _progress(total_s: float, enabled: bool):
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=round(total_s), unit="sim s", desc="sea trial", file=sys.stderr, leave=True)


def run_scenario(
    scenario: Scenario,
    out_dir: Path | str,
    *,
    seed: int | None = None,
    progress: bool = False,
    camera: bool | None = None,
    on_message: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run one sea trial and write its recording and metrics.

    Args:
        scenario: A validated scenario.
        out_dir: Output folder (created).
        seed: Root seed; defaults to the scenario's.
        progress: Show a progress bar on stderr.
        camera: Render the chase camera; ``None`` follows the scenario's recording settings.
        on_message: Called with one-line notices (e.g. "no GL context"); default: stderr.

    Returns:
        The metrics dict (also written to ``out_dir/metrics.json``).
    """
    say = on_message or (lambda msg: print(msg, file=sys.stderr))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    metrics_path = out / "metrics.json"
    world = build_world(scenario, seed)
    seed_used = world.seed
    base = {
        "scenario": scenario.name,
        "seed": seed_used,
        "complete": False,
        "status": "running",
        "recording": "recording.rrd",
        "versions": _versions(),
        # Every setting, defaults written out: parse_scenario(this) rebuilds the scenario.
        "scenario_config": scenario.to_dict(),
    }
    _write_json_atomic(metrics_path, base)

    rec = Recorder(
        out / "recording.rrd",
        recording_id=f"{scenario.name}-seed{seed_used}",
        start_utc=scenario.start_utc,
    )
    want_camera = scenario.recording.camera if camera is None else camera
    cam: ChaseCamera | None = None
    if want_camera:
        cam = ChaseCamera(
            world.plant.model, scenario.recording.camera_width, scenario.recording.camera_height
        )
        if not cam.available:
            say(f"note: no GL context for the chase camera ({cam.reason}); continuing without it")
            cam = None

    stats = _Stats()
    status_text = "running"
    error: str | None = None
    wall0 = time.perf_counter()
    bar = _progress(scenario.duration_s, progress)
    try:
        _log_scene(rec, world)
        status_text = _loop(world, rec, cam, stats, bar)
    except KeyboardInterrupt:
        status_text, error = "interrupted", "KeyboardInterrupt"
        raise
    except Exception as exc:
        status_text, error = "error", f"{type(exc).__name__}: {exc}"
        raise
    finally:
        wall = time.perf_counter() - wall0
        if bar is not None:
            bar.close()
        if cam is not None:
            cam.close()
        try:
            rec.log_text(
                world.plant.t, f"run ended: {status_text}" + (f" ({error})" if error else "")
            )
        finally:
            rec.close()
        metrics = {
            **base,
            "complete": status_text in ("mission_complete", "duration_reached"),
            "status": status_text,
            **({"error": error} if error else {}),
            **_summarize(world, stats, wall),
        }
        _write_json_atomic(metrics_path, metrics)
    return metrics


def _log_scene(rec: Recorder, world: World) -> None:
    wps = world.guidance.waypoints_en
    depths = [leg.depth_m for leg in world.guidance.legs if hasattr(leg, "to_m")]
    waypoints = (
        np.array([[e, n, -d] for (e, n), d in zip(wps, depths, strict=False)]) if wps else None
    )
    seabed = world.scenario.water.seabed_depth_m
    rec.log_static_scene(
        waypoints_n=waypoints,
        vehicle_half_sizes=(0.095, 0.8, 0.095),
        surface_z=world.plant.surface_z_m,
        seabed_z=-seabed if seabed is not None else None,
        tank_half_sizes=(6.0, 3.0, 2.0) if world.scenario.scene == "tank" else None,
    )


def _loop(world: World, rec: Recorder, cam: ChaseCamera | None, stats: _Stats, bar) -> str:
    sc = world.scenario
    plant, suite, guidance, autopilot = world.plant, world.suite, world.guidance, world.autopilot
    dt = world.physics_dt
    n_steps = round(sc.duration_s / dt)
    every_ap = max(1, round(1.0 / (sc.autopilot.rate_hz * dt)))
    every_truth = max(1, round(1.0 / (sc.recording.truth_rate_hz * dt)))
    every_cam = max(1, round(1.0 / (sc.recording.camera_rate_hz * dt)))
    every_bar = max(1, round(1.0 / dt))
    cmd = ActuatorCommand()
    sp = Setpoint(0.0, 0.0, 0.0)
    status = GuidanceStatus(0, 0, False, 0.0)
    complete_at: float | None = None
    leg_started_at = 0.0
    next_pol_log_t = 0.0
    readings_count = stats.readings
    navigators = world.navigators
    for name in navigators:
        stats.nav[name] = VariantScore(name)

    for k in range(n_steps):
        t = plant.t
        if k % every_ap == 0:
            nav = world.nav.nav_state()
            prev_leg = status.leg
            sp, status = guidance.update(nav, t)
            if status.leg != prev_leg:
                leg_started_at = t
            cmd = autopilot.update(nav, sp, every_ap * dt)
            rec.log_scalars(
                "/control/actuators",
                t,
                np.array(
                    [
                        math.degrees(cmd.rudder_rad),
                        math.degrees(cmd.stern_rad),
                        cmd.propeller_rps * 60,
                    ]
                ),
                names=["rudder_deg", "stern_deg", "propeller_rpm"],
            )
            rec.log_scalars(
                "/control/setpoint",
                t,
                np.array([sp.speed_mps, sp.depth_m, math.degrees(sp.heading_rad) % 360.0]),
                names=["speed_mps", "depth_m", "heading_deg"],
            )
            if status.complete and complete_at is None:
                complete_at = t
                rec.log_text(t, "mission complete")
        plant.step(cmd)
        readings = suite.poll(plant)
        for name, event in world.deliver(readings):
            _log_compass_event(rec, name, event)
        for reading in readings:
            rec.log_reading(reading)
            readings_count[reading.sensor] = readings_count.get(reading.sensor, 0) + 1
            if reading.sensor == "polarimeter" and reading.t >= next_pol_log_t:
                _log_polarimeter(rec, reading, suite[reading.sensor])
                next_pol_log_t = reading.t + 1.0 / sc.recording.polarimeter_log_rate_hz - 1e-9
        if (k + 1) % every_truth == 0:
            truth = plant.truth()
            rec.log_truth(
                truth.t,
                position_n=truth.position_n,
                quat_wxyz=truth.quat_wxyz,
                velocity_n=truth.velocity_n,
                rpy_deg=np.degrees([truth.roll_rad, truth.pitch_rad, truth.yaw_rad]),
                heading_deg=truth.heading_deg,
                depth_m=truth.depth_m,
            )
            _accumulate(
                stats, truth, sp, status, complete_at is None, truth.t - leg_started_at >= _SETTLE_S
            )
            for name, nav in navigators.items():
                _log_nav_sample(rec, name, truth.t, stats.nav[name].add(nav, truth))
        if cam is not None and (k + 1) % every_cam == 0:
            rec.log_image("/camera/chase", plant.t, cam.render(plant.data))
        if bar is not None and (k + 1) % every_bar == 0:
            bar.update(1)
        if complete_at is not None and plant.t - complete_at >= _MISSION_COMPLETE_TAIL_S:
            return "mission_complete"
    return "duration_reached"


def _log_polarimeter(rec: Recorder, reading: Reading, cam: Polarimeter) -> None:
    """Intensity, AoP (cyclic colormap) and DoP images of a frame, as onboard code derives them."""
    cal = cam.calibration()
    pol = stokes_from_mosaic(
        reading["raw"],
        cal.layout_deg,
        black_level_dn=cal.black_level_dn,
        saturation_dn=cal.saturation_dn,
    )
    mask = images.signal_mask(pol)
    rec.log_image("/polarimeter/intensity", reading.t, images.intensity_u8(pol.s0))
    rec.log_image("/polarimeter/aop", reading.t, images.aop_rgb(pol.aop, mask))
    rec.log_image("/polarimeter/dop", reading.t, images.dop_rgb(pol.dop, mask))
    # Truth layer (truth channel, for people only): where the refracted sun really is, drawn over
    # the intensity image (super-pixel grid: raw pixel (u, v) sits at ((u − ½)/2, (v − ½)/2)).
    tr = cam.truth
    if tr is not None and abs(tr.t - reading.t) < 1e-9:
        sun = (
            np.array([[(tr.sun_pixel[0] - 0.5) / 2, (tr.sun_pixel[1] - 0.5) / 2]])
            if tr.sun_pixel is not None
            else np.zeros((0, 2))
        )
        rec.log_points2d("/polarimeter/intensity/true_sun", reading.t, sun, label="true sun")


def _log_nav_sample(rec: Recorder, name: str, t: float, s: dict[str, float]) -> None:
    """Estimated heading, its error against truth with ±3σ bounds, NEES: time series."""
    rec.log_scalars(f"/nav/heading_deg/{name}", t, np.array([s["heading_deg"]]), names=[name])
    sig3 = 3.0 * s["heading_sigma_deg"]
    rec.log_scalars(
        f"/nav/{name}/heading_error_deg",
        t,
        np.array([s["heading_err_deg"], sig3, -sig3]),
        names=["error", "+3 sigma", "-3 sigma"],
    )
    rec.log_scalars(
        f"/nav/{name}/attitude_error_deg",
        t,
        np.array([s["roll_err_deg"], s["pitch_err_deg"]]),
        names=["roll", "pitch"],
    )
    rec.log_scalars(f"/nav/{name}/position_error_m", t, np.array([s["position_err_m"]]))
    rec.log_scalars(f"/nav/{name}/nees_attitude", t, np.array([s["nees"]]))


def _log_compass_event(rec: Recorder, name: str, event: CompassEvent) -> None:
    """A processed frame: the fix's heading, or a marked rejection / no-fix."""
    fix, up = event.fix, event.update
    if fix.ok and fix.heading_deg is not None:
        rec.log_scalars(
            f"/nav/{name}/compass_heading_deg", event.t, np.array([fix.heading_deg]), names=[name]
        )
    if up is not None and not up.applied:
        rec.log_text(
            event.t, f"{name}: sun update rejected ({up.reason}, NIS {up.nis:.1f})", "WARN"
        )
        rec.log_scalars(f"/nav/{name}/rejected_nis", event.t, np.array([up.nis]))
    elif not fix.ok:
        rec.log_text(event.t, f"{name}: no compass fix ({fix.reason})", "DEBUG")


def _accumulate(
    stats: _Stats, truth, sp: Setpoint, status: GuidanceStatus, active: bool, settled: bool
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


def _summarize(world: World, stats: _Stats, wall_s: float) -> dict[str, Any]:
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
            "settle_after_leg_switch_s": _SETTLE_S,
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
        **(
            {
                "navigation": {
                    "steering_on": world.scenario.navigation.steering_variant
                    if world.scenario.autopilot.attitude_source == "estimate"
                    else "truth",
                    "variants": {
                        name: stats.nav[name].summary(nav)
                        for name, nav in world.navigators.items()
                        if name in stats.nav
                    },
                }
            }
            if world.navigators
            else {}
        ),
    }


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
    if "error" in m:
        lines.append(f"  error: {m['error']}")
    return "\n".join(lines)
