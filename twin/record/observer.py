"""The recording as an observer of the stepping core: what a run writes to Rerun, step by step.

:class:`RunRecorder` hangs off :class:`twin.sim.step.Simulation` (``sim.observers``): each
step it logs the readings delivered (the polarimeter's images as onboard code derives them, with
the true sun drawn from the truth that travelled with the frame), the compass events, the truth and
every filter variant's errors at the truth rate (from the scorer), and the chase camera.
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from sensors.polarimeter.render import PolarimeterTruth
from twin.core.calibration import CameraCalibration
from twin.core.messages import ActuatorCommand, Reading
from twin.onboard.control.autopilot import Setpoint
from twin.onboard.navigator import CompassEvent
from twin.onboard.polarization import stokes_from_mosaic
from twin.record import images
from twin.record.gravity import log_gravity_sample, log_gravity_scene
from twin.record.recorder import Recorder

if TYPE_CHECKING:
    from twin.scoring.observer import RunScorer
    from twin.sim.step import Simulation, StepResult
    from twin.world.truth import Truth


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
        if (
            sys.platform.startswith("linux")
            and not os.environ.get("MUJOCO_GL")
            and not os.environ.get("DISPLAY")
        ):
            # MuJoCo would try GLFW, which needs a display: say how to render headless instead
            # of letting GLFW print its warnings.
            self.reason = "no display and MUJOCO_GL unset; MUJOCO_GL=egl renders headless"
            return
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


#: How often the gravity map's true position and the filters' ellipses are logged (sim s).
GRAVITY_LOG_PERIOD_S = 10.0


# Truth samples between two batches of the filters' samples in the recording (RunRecorder.log_nav).
NAV_BATCH_SAMPLES = 50


class RunRecorder:
    """Logs a run to a :class:`Recorder`, as an observer of the simulation's steps.

    Args:
        rec: The open recording.
        sim: The simulation (its scenario sets the rates).
        scorer: The run's scorer, whose per-sample errors are logged under ``/nav/**``.
        chase: The chase camera, or None.
    """

    def __init__(
        self, rec: Recorder, sim: Simulation, scorer: RunScorer, chase: ChaseCamera | None
    ):
        sc = sim.scenario
        dt = sim.physics_dt
        self.rec = rec
        self.scorer = scorer
        self.chase = chase
        self._every_truth = max(1, round(1.0 / (sc.recording.truth_rate_hz * dt)))
        self._every_cam = max(1, round(1.0 / (sc.recording.camera_rate_hz * dt)))
        self._pol_period = 1.0 / sc.recording.polarimeter_log_rate_hz
        self._next_pol_log_t = 0.0
        self._next_gravity_t = 0.0
        self._k = 0
        self._truth_samples = 0
        self._nav_logged: dict[str, int] = {}
        cam = next((s for s in sim.suite.sensors if s.kind == "polarimeter"), None)
        self._calibration: CameraCalibration | None = (
            cam.calibration() if cam is not None else None  # type: ignore[attr-defined]
        )

    def log_nav(self) -> None:
        """Log the filters' samples the scorer holds and the recording does not yet.

        Taken from the scorer's series (scored together, the one-sample path's numbers bit for
        bit) every :data:`NAV_BATCH_SAMPLES` truth samples, and by :meth:`close`: the same
        series, values and times as :func:`log_nav_sample` per sample, at a fraction of the
        cost (the recording's buffered series reach the file at its flushes either way).
        """
        for name, vs in self.scorer.variants.items():
            k = self._nav_logged.get(name, 0)
            t = vs.t[k:]
            if not t:
                continue
            log_nav_rows(
                self.rec, name, t, vs.heading[k:], vs.heading_err[k:], vs.heading_sigma[k:],
                vs.roll_err[k:], vs.pitch_err[k:], vs.pos_err[k:], vs.nees[k:],
            )  # fmt: skip
            self._nav_logged[name] = k + len(t)

    def close(self) -> None:
        """The samples not yet logged (call before the recording is closed)."""
        self.log_nav()

    def log_control(self, t: float, cmd: ActuatorCommand, sp: Setpoint) -> None:
        self.rec.log_scalars(
            "/control/actuators",
            t,
            np.array(
                [np.degrees(cmd.rudder_rad), np.degrees(cmd.stern_rad), cmd.propeller_rps * 60]
            ),
            names=["rudder_deg", "stern_deg", "propeller_rpm"],
        )
        self.rec.log_scalars(
            "/control/setpoint",
            t,
            np.array([sp.speed_mps, sp.depth_m, np.degrees(sp.heading_rad) % 360.0]),
            names=["speed_mps", "depth_m", "heading_deg"],
        )

    def quiet_steps(self, sim: Simulation) -> int:
        """The next steps with no truth sample or chase-camera picture to log: readings only."""
        k = self._k
        quiet = self._every_truth - k % self._every_truth - 1
        if self.chase is not None:
            quiet = min(quiet, self._every_cam - k % self._every_cam - 1)
        return quiet

    def on_quiet_steps(self, sim: Simulation, steps: int, readings: list[Reading]) -> None:
        """Quiet steps (no frame, no truth sample): :meth:`on_step` logs their readings only."""
        for reading in readings:
            self.rec.log_reading(reading)
        self._k += steps

    def on_step(self, sim: Simulation, result: StepResult) -> None:
        rec = self.rec
        for name, event in result.events:
            log_compass_event(rec, name, event)
            fs = self.scorer.fixes.get(name)
            if fs is not None and fs.t and fs.t[-1] == event.t:
                rec.log_scalars(
                    f"/nav/{name}/compass_fix_error_deg",
                    event.t,
                    np.array([fs.heading_err[-1], fs.sun_err[-1]]),
                    names=["heading", "sun vector"],
                )
        for reading, truth in zip(result.readings, result.truth, strict=True):
            rec.log_reading(reading)
            if (
                reading.sensor == "polarimeter"
                and self._calibration is not None
                and reading.t >= self._next_pol_log_t
            ):
                _log_polarimeter(rec, reading, self._calibration, truth)
                self._next_pol_log_t = reading.t + self._pol_period - 1e-9
        self._k += 1
        if self._k % self._every_truth == 0:
            truth = self.scorer.last_truth
            if truth is not None and truth.t == result.t:
                log_truth(rec, truth)
                self._truth_samples += 1
                if self._truth_samples % NAV_BATCH_SAMPLES == 0:
                    self.log_nav()
                if sim.stored_map is not None and truth.t >= self._next_gravity_t - 1e-9:
                    log_gravity_sample(rec, sim, truth)
                    self._next_gravity_t = truth.t + GRAVITY_LOG_PERIOD_S
        if self.chase is not None and self._k % self._every_cam == 0:
            rec.log_image("/camera/chase", sim.plant.t, self.chase.render(sim.plant.data))


def log_truth(rec: Recorder, truth: Truth) -> None:
    """One truth sample (the run's, or a replayed log's reference) into the recording."""
    rec.log_truth(
        truth.t,
        position_n=truth.position_n,
        quat_wxyz=truth.quat_wxyz,
        velocity_n=truth.velocity_n,
        rpy_deg=np.degrees([truth.roll_rad, truth.pitch_rad, truth.yaw_rad]),
        heading_deg=truth.heading_deg,
        depth_m=truth.depth_m,
    )


def log_scene(rec: Recorder, world: Simulation) -> None:
    log_gravity_scene(rec, world)
    _log_world_scene(rec, world)


def _log_world_scene(rec: Recorder, world: Simulation) -> None:
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


def _log_polarimeter(rec: Recorder, reading: Reading, cal: CameraCalibration, tr: object) -> None:
    """Intensity, AoP (cyclic colormap) and DoP images of a frame, as onboard code derives them."""
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
    if isinstance(tr, PolarimeterTruth):
        sun = (
            np.array([[(tr.sun_pixel[0] - 0.5) / 2, (tr.sun_pixel[1] - 0.5) / 2]])
            if tr.sun_pixel is not None
            else np.zeros((0, 2))
        )
        rec.log_points2d("/polarimeter/intensity/true_sun", reading.t, sun, label="true sun")


def log_nav_sample(rec: Recorder, name: str, t: float, s: dict[str, float]) -> None:
    """Estimated heading, its error against truth with ±3σ bounds, NEES: time series."""
    log_nav_rows(
        rec, name, [t], [s["heading_deg"]], [s["heading_err_deg"]], [s["heading_sigma_deg"]],
        [s["roll_err_deg"]], [s["pitch_err_deg"]], [s["position_err_m"]], [s["nees"]],
    )  # fmt: skip


def log_nav_rows(
    rec: Recorder,
    name: str,
    t: list[float],
    heading: list[float],
    heading_err: list[float],
    sigma: list[float],
    roll_err: list[float],
    pitch_err: list[float],
    pos_err: list[float],
    nees: list[float],
) -> None:
    """Estimated headings, their errors against truth with ±3σ bounds, NEES: many samples.

    The recording's ``/nav/**`` series of one filter, declared here only.
    """
    rec.log_scalar_rows(f"/nav/heading_deg/{name}", t, [[x] for x in heading], names=[name])
    rec.log_scalar_rows(
        f"/nav/{name}/heading_error_deg",
        t,
        [[e, 3.0 * s, -(3.0 * s)] for e, s in zip(heading_err, sigma, strict=True)],
        names=["error", "+3 sigma", "-3 sigma"],
    )
    rec.log_scalar_rows(
        f"/nav/{name}/attitude_error_deg",
        t,
        [[r, p] for r, p in zip(roll_err, pitch_err, strict=True)],
        names=["roll", "pitch"],
    )
    rec.log_scalar_rows(f"/nav/{name}/position_error_m", t, [[x] for x in pos_err])
    rec.log_scalar_rows(f"/nav/{name}/nees_attitude", t, [[x] for x in nees])


def log_compass_event(rec: Recorder, name: str, event: CompassEvent) -> None:
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
