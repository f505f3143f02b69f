"""A run as ROS 2 messages in an MCAP file: what an AUV engineer's tools (Foxglove, ros2 bag) open.

With ``auv-twin run … --mcap`` (``run_scenario(mcap=True)``) a run also writes ``OUT/run.mcap``:
the ``ros2`` profile, CDR-encoded messages with their ``ros2msg`` schemas (written by
``mcap-ros2-support``; the definitions of the standard types come from rosbags' ROS 2 Humble type
store, so they are the published ones). No ROS installation is needed to write or read it.

Topics (stamps: the run's UTC start plus the reading's sampling time; log time: when the vehicle
computer received it):

================================ =========================== ==================================
topic                            type                        what
================================ =========================== ==================================
``/imu``                         sensor_msgs/msg/Imu          angular rate (rad/s) and specific
                                                              force (m/s²) in ``imu_link``; no
                                                              orientation (covariance[0] = −1)
``/depth/pressure``              sensor_msgs/msg/FluidPressure absolute pressure (Pa)
``/polarimeter/image_raw``       sensor_msgs/msg/Image        the raw DoFP mosaic, ``mono16``
``/polarimeter/camera_info``     sensor_msgs/msg/CameraInfo   the onboard calibration, each frame
``/polarimeter/dofp_layout``     auv_twin_msgs/msg/DofpLayout the 2×2 analyser angles (once)
``/gravimeter``                  auv_twin_msgs/msg/Gravity    the reading (mGal), if flown
``/truth/odom``                  nav_msgs/msg/Odometry        the true state (truth rate)
``/nav/<variant>/odom``          nav_msgs/msg/Odometry        each filter's estimate and its
                                                              covariance (truth rate)
``/nav/<variant>/compass_fix``   auv_twin_msgs/msg/CompassFix every compass fix of the variant
``/tf``                          tf2_msgs/msg/TFMessage       ``map`` → ``base_link`` (truth)
``/tf_static``                   tf2_msgs/msg/TFMessage       ``base_link`` → each sensor
================================ =========================== ==================================

Frames (REP 103/105): ``map`` is ENU with its origin at the launch point on the sea surface;
``base_link`` is the vehicle's body turned to ROS's x forward, y left, z up (the twin's body
frame is x right, y forward, z up: :mod:`twin.core.frames`); each sensor's frame is its MJCF
site's axes. Odometry pose covariance is in ``map`` axes (x, y, z, then rotations about them),
twist in ``base_link`` axes; the filters do not estimate angular velocity (its covariance
diagonal is −1). The run's provenance is the file's ``auv_twin.provenance`` metadata record.

World side: it sees truth and readings, as the recorder does.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.core.frames import dcm_to_quat, quat_to_dcm
from twin.record.recorder import utc_ns

if TYPE_CHECKING:
    from twin.core.messages import Reading
    from twin.scoring.observer import RunScorer
    from twin.sim.step import Simulation, StepResult

FILE = "run.mcap"

#: The twin's body axes (x right, y forward, z up) → ROS's base_link (x forward, y left, z up):
#: a vector given in base_link axes, expressed in body axes.
B_FROM_FLU = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])

#: The project's own messages (the package ``auv_twin_msgs`` exists only as these definitions).
CUSTOM_MSGS: dict[str, str] = {
    "auv_twin_msgs/msg/CompassFix": """\
# One compass method's result for one polarimeter frame (twin.onboard.compass.base.CompassFix).
std_msgs/Header header
string method            # the method's registry name, e.g. "pol", "lig_paper"
bool ok                  # a usable solution; if false, reason says why and the numbers are NaN
string reason
float64 heading_deg      # compass heading implied by the fix (NaN: none)
float64 heading_sigma_deg
geometry_msgs/Vector3 sun_body   # unit vector to the sun, body axes (x right, y forward, z up)
int32 pixels_used""",
    "auv_twin_msgs/msg/DofpLayout": """\
# The division-of-focal-plane analyser layout of /polarimeter/image_raw.
std_msgs/Header header
float64[4] analyser_deg  # super-pixel (row 0 col 0, row 0 col 1, row 1 col 0, row 1 col 1)
uint16 black_level_dn
uint16 saturation_dn""",
    "auv_twin_msgs/msg/Gravity": """\
# A marine gravimeter's reading.
std_msgs/Header header
float64 gravity_mgal""",
}


def _definitions() -> dict[str, str]:
    """Every schema's text: the standard types from rosbags' Humble store, then the project's."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in CUSTOM_MSGS.items():
        store.register(get_types_from_msg(text, name))
    names = (
        "sensor_msgs/msg/Imu", "sensor_msgs/msg/FluidPressure", "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CameraInfo", "nav_msgs/msg/Odometry", "tf2_msgs/msg/TFMessage",
        *CUSTOM_MSGS,
    )  # fmt: skip
    return {n: store.generate_msgdef(n, ros_version=2)[0] for n in names}


def _stamp(start_ns: int, t: float) -> dict[str, int]:
    ns = start_ns + round(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _header(start_ns: int, t: float, frame: str) -> dict[str, Any]:
    return {"stamp": _stamp(start_ns, t), "frame_id": frame}


def _quat_msg(c: np.ndarray) -> dict[str, float]:
    w, x, y, z = (float(v) for v in dcm_to_quat(c))
    return {"x": x, "y": y, "z": z, "w": w}


def _scalar(reading: Any, channel: str) -> float:
    """A one-number channel (shape () or (1,)) as a float."""
    return float(np.asarray(reading[channel]).reshape(-1)[0])


def _vec(v: Any) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


#: The metadata record a replay of this file reads (``twin.app.replay``): what the vehicle knew
#: at launch, as JSON strings: the scenario, the filters' initial solution (the alignment's
#: output), the camera's calibration and the depth gauge's firmware constants.
REPLAY_METADATA = "auv_twin.replay"


def _replay_block(sim: Simulation) -> dict[str, str]:
    from twin.core.calibration import calibration_to_dict

    block: dict[str, str] = {"scenario": json.dumps(sim.scenario.to_dict(), default=str)}
    if sim.navigators:
        st = next(iter(sim.navigators.values())).nav_state()
        block["nav_init"] = json.dumps(
            {
                "t": st.t, "lat_rad": st.lat_rad, "lon_rad": st.lon_rad, "h_m": st.h_m,
                "v_enu": np.asarray(st.v_enu).tolist(), "c_bn": np.asarray(st.c_bn).tolist(),
            }
        )  # fmt: skip
    cam = next((x for x in sim.suite.sensors if x.kind == "polarimeter"), None)
    if cam is not None:
        block["calibration"] = json.dumps(calibration_to_dict(cam.calibration()))  # type: ignore[attr-defined]
    depth = next((x for x in sim.suite.sensors if x.kind == "depth"), None)
    if depth is not None:
        p_atm, rho, g = depth.firmware_constants(sim.plant)  # type: ignore[attr-defined]
        block["depth"] = json.dumps({"p_atm_pa": p_atm, "rho_kg_m3": rho, "g_mps2": g})
    return block


class McapLog:
    """An observer of the stepping core that writes the run's ROS 2 messages (module docstring).

    It reads the scorer's latest truth, so it observes after the scorer. Call :meth:`close` when
    the run ends (also when it stops early: what was written stays readable).

    Args:
        path: The file to write.
        sim: The simulation.
        scorer: The run's scorer.
        start_utc: The run's start (stamps are this plus the simulation time).
        provenance: The run's provenance block, written as the file's metadata.
    """

    def __init__(
        self,
        path: Path | str,
        sim: Simulation,
        scorer: RunScorer,
        start_utc: dt.datetime,
        provenance: dict[str, Any],
    ) -> None:
        from mcap_ros2.writer import Writer

        self.path = Path(path)
        self.scorer = scorer
        self._start_ns = utc_ns(start_utc)
        self._file = open(self.path, "wb")  # closed in close()
        try:
            self._w = Writer(self._file)
            defs = _definitions()
            self._schemas = {n: self._w.register_msgdef(n, d) for n, d in defs.items()}
            # MCAP metadata through the underlying mcap writer (mcap-ros2-support exposes none).
            self._w._writer.add_metadata(
                "auv_twin.provenance", {k: json.dumps(v) for k, v in provenance.items()}
            )
            self._w._writer.add_metadata(REPLAY_METADATA, _replay_block(sim))
        except BaseException:
            self._file.close()
            raise
        self._every_truth = max(
            1, round(1.0 / (sim.scenario.recording.truth_rate_hz * sim.physics_dt))
        )
        self._k = 0
        self._last_truth_t = -math.inf
        self._counts: dict[str, int] = {}
        self._seq = 0
        self._variants = tuple(sim.navigators)
        cam = next((s for s in sim.suite.sensors if s.kind == "polarimeter"), None)
        self._calibration = cam.calibration() if cam is not None else None  # type: ignore[attr-defined]
        self._frames = {s.name: s.site or s.name for s in sim.suite.sensors}
        self._static(sim)

    # ---- writing --------------------------------------------------------------------------------
    def _write(self, topic: str, schema: str, msg: dict[str, Any], t_log: float) -> None:
        ns = self._start_ns + round(t_log * 1e9)
        # One sequence over the file: the order messages of one log time were delivered in
        # (a replay feeds them in that order).
        self._w.write_message(
            topic, self._schemas[schema], msg, log_time=ns, publish_time=ns, sequence=self._seq
        )
        self._seq += 1
        self._counts[topic] = self._counts.get(topic, 0) + 1

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per topic so far."""
        return dict(self._counts)

    def _static(self, sim: Simulation) -> None:
        plant = sim.plant
        body = plant.truth()
        c_flu_n = quat_to_dcm(body.quat_wxyz) @ B_FROM_FLU
        transforms = []
        for s in sim.suite.sensors:
            if not s.site:
                continue
            pos_n, c_site_n = plant.site_pose(s.site)
            # The site in base_link axes: r = C_flu^nᵀ (p_site − p_body), R = C_flu^nᵀ C_site^n.
            rel = c_flu_n.T @ (np.asarray(pos_n) - np.asarray(body.position_n))
            transforms.append(
                {
                    "header": _header(self._start_ns, 0.0, "base_link"),
                    "child_frame_id": s.site,
                    "transform": {
                        "translation": _vec(rel),
                        "rotation": _quat_msg(c_flu_n.T @ c_site_n),
                    },
                }
            )
        self._write("/tf_static", "tf2_msgs/msg/TFMessage", {"transforms": transforms}, 0.0)
        cal = self._calibration
        if cal is not None:
            self._write(
                "/polarimeter/dofp_layout",
                "auv_twin_msgs/msg/DofpLayout",
                {
                    "header": _header(self._start_ns, 0.0, self._frames.get("polarimeter", "")),
                    "analyser_deg": [float(a) for a in np.asarray(cal.layout_deg).reshape(-1)],
                    "black_level_dn": int(cal.black_level_dn),
                    "saturation_dn": int(cal.saturation_dn),
                },
                0.0,
            )

    def quiet_steps(self, sim: Simulation) -> int:
        """The steps before the next truth sample: :meth:`on_step` only writes their readings."""
        return self._every_truth - self._k % self._every_truth - 1

    def on_quiet_steps(self, sim: Simulation, steps: int, readings: list[Reading]) -> None:
        """Quiet steps (no frame, no truth sample): their readings, as :meth:`on_step` has them."""
        for reading in readings:
            self._reading(reading)
        self._k += steps

    def on_step(self, sim: Simulation, result: StepResult) -> None:
        for reading in result.readings:
            self._reading(reading)
        for name, event in result.events:
            self._fix(name, event)
        self._k += 1
        truth = self.scorer.last_truth
        if (
            self._k % self._every_truth != 0
            or truth is None
            or truth.t != result.t
            or truth.t == self._last_truth_t
        ):
            return
        self._last_truth_t = truth.t
        c_flu = quat_to_dcm(truth.quat_wxyz) @ B_FROM_FLU
        pose = {"position": _vec(truth.position_n), "orientation": _quat_msg(c_flu)}
        self._write(
            "/truth/odom",
            "nav_msgs/msg/Odometry",
            {
                "header": _header(self._start_ns, truth.t, "map"),
                "child_frame_id": "base_link",
                "pose": {"pose": pose, "covariance": [0.0] * 36},
                "twist": {
                    "twist": {
                        "linear": _vec(c_flu.T @ np.asarray(truth.velocity_n)),
                        "angular": _vec(B_FROM_FLU.T @ np.asarray(truth.omega_b)),
                    },
                    "covariance": [0.0] * 36,
                },
            },
            truth.t,
        )
        tf = {
            "header": _header(self._start_ns, truth.t, "map"),
            "child_frame_id": "base_link",
            "transform": {"translation": pose["position"], "rotation": pose["orientation"]},
        }
        self._write("/tf", "tf2_msgs/msg/TFMessage", {"transforms": [tf]}, truth.t)
        for name in self._variants:
            self._estimate(sim, name, truth.t)

    def _reading(self, r: Any) -> None:
        frame = self._frames.get(r.sensor, r.sensor)
        head = _header(self._start_ns, r.t, frame)
        kind = r.sensor
        if "angular_rate" in r.values and "specific_force" in r.values:
            self._write(
                f"/{kind}",
                "sensor_msgs/msg/Imu",
                {
                    "header": head,
                    "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
                    "orientation_covariance": [-1.0] + [0.0] * 8,
                    "angular_velocity": _vec(r["angular_rate"]),
                    "angular_velocity_covariance": [0.0] * 9,
                    "linear_acceleration": _vec(r["specific_force"]),
                    "linear_acceleration_covariance": [0.0] * 9,
                },
                r.t_delivered,
            )
        elif "pressure_pa" in r.values:
            self._write(
                f"/{kind}/pressure",
                "sensor_msgs/msg/FluidPressure",
                {
                    "header": head,
                    "fluid_pressure": _scalar(r, "pressure_pa"),
                    "variance": 0.0,
                },
                r.t_delivered,
            )
        elif "raw" in r.values:
            self._image(kind, head, np.asarray(r["raw"]), r.t_delivered)
        elif "gravity_mgal" in r.values:
            self._write(
                f"/{kind}",
                "auv_twin_msgs/msg/Gravity",
                {
                    "header": head,
                    "gravity_mgal": _scalar(r, "gravity_mgal"),
                },
                r.t_delivered,
            )

    def _image(self, kind: str, head: dict[str, Any], raw: np.ndarray, t_log: float) -> None:
        h, w = raw.shape
        self._write(
            f"/{kind}/image_raw",
            "sensor_msgs/msg/Image",
            {
                "header": head,
                "height": h,
                "width": w,
                "encoding": "mono16",
                "is_bigendian": 0,
                "step": 2 * w,
                "data": np.ascontiguousarray(raw, dtype="<u2").tobytes(),
            },
            t_log,
        )
        cal = self._calibration
        if cal is None:
            return
        fx = float(cal.focal_px)
        cx, cy = (float(v) for v in cal.principal_point_px)
        equidistant = cal.projection == "kannala_brandt"
        self._write(
            f"/{kind}/camera_info",
            "sensor_msgs/msg/CameraInfo",
            {
                "header": head,
                "height": int(cal.height_px),
                "width": int(cal.width_px),
                # image_pipeline's name for the Kannala–Brandt fisheye (k1…k4).
                "distortion_model": "equidistant" if equidistant else "plumb_bob",
                "d": [float(k) for k in cal.kb_coeffs] if equidistant else [0.0] * 5,
                "k": [fx, 0.0, cx, 0.0, fx, cy, 0.0, 0.0, 1.0],
                "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                "p": [fx, 0.0, cx, 0.0, 0.0, fx, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
                "binning_x": 0,
                "binning_y": 0,
                "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False},
            },
            t_log,
        )

    def _fix(self, name: str, event: Any) -> None:
        fix = event.fix
        sun = fix.sun_body if fix.sun_body is not None else (math.nan,) * 3
        self._write(
            f"/nav/{name}/compass_fix",
            "auv_twin_msgs/msg/CompassFix",
            {
                "header": _header(self._start_ns, event.t, self._frames.get("polarimeter", "")),
                "method": str(fix.method),
                "ok": bool(fix.ok),
                "reason": str(fix.reason),
                "heading_deg": math.nan if fix.heading_deg is None else float(fix.heading_deg),
                "heading_sigma_deg": (
                    math.nan
                    if fix.heading_sigma_rad is None
                    else math.degrees(fix.heading_sigma_rad)
                ),
                "sun_body": _vec(sun),
                "pixels_used": int(fix.pixels_used or 0),
            },
            event.t,
        )

    def _estimate(self, sim: Simulation, name: str, t: float) -> None:
        nav = sim.navigators[name]
        est = nav.estimate()
        east, north = nav.local_en(est)
        c_flu = np.asarray(est.c_bn) @ B_FROM_FLU
        p = np.asarray(est.covariance)
        m_n, m_e = nav.metres_per_radian
        # Position (E, N, U) in metres from (δL, δλ, δh); attitude φ about E, N, U.
        j = np.zeros((6, 15))
        j[0, 7] = m_e
        j[1, 6] = m_n
        j[2, 8] = 1.0
        j[3:6, 0:3] = np.eye(3)
        pose_cov = j @ p @ j.T
        twist_cov = np.zeros((6, 6))
        twist_cov[:3, :3] = c_flu.T @ p[3:6, 3:6] @ c_flu
        twist_cov[3, 3] = twist_cov[4, 4] = twist_cov[5, 5] = -1.0  # not estimated
        self._write(
            f"/nav/{name}/odom",
            "nav_msgs/msg/Odometry",
            {
                "header": _header(self._start_ns, t, "map"),
                "child_frame_id": "base_link",
                "pose": {
                    "pose": {
                        "position": _vec((east, north, est.h_m)),
                        "orientation": _quat_msg(c_flu),
                    },
                    "covariance": pose_cov.reshape(-1).tolist(),
                },
                "twist": {
                    "twist": {
                        "linear": _vec(c_flu.T @ np.asarray(est.v_enu)),
                        "angular": _vec((0.0, 0.0, 0.0)),
                    },
                    "covariance": twist_cov.reshape(-1).tolist(),
                },
            },
            t,
        )

    def close(self) -> None:
        """Finish the file (its summary and index); idempotent."""
        if self._file.closed:
            return
        try:
            self._w.finish()
        finally:
            self._file.close()


__all__ = ["CUSTOM_MSGS", "FILE", "REPLAY_METADATA", "McapLog"]
