"""Replay a recorded log through the onboard stack: ``auv-twin replay LOG``.

The compass methods and filter variants of a scenario's ``[navigation]`` run on the IMU, depth and
camera messages of an MCAP file or a rosbag2 folder, exactly as they run on the twin's own
readings (``twin.onboard.navigator.Navigator``), and the estimates are scored against the log's
reference trajectory where it has one (``nav_msgs/msg/Odometry``: the twin's truth, or a
GNSS/INS solution). Writes ``metrics.json``, ``recording.rrd`` (the readings, the reference,
each filter's estimate and errors, the compass fixes: a run's entities) and
``timeseries/filters.parquet`` and ``timeseries/compass_fixes.parquet`` in the columns a run
writes.

Inputs (a twin run's ``run.mcap`` carries all of them in its ``auv_twin.replay`` metadata, so
``auv-twin replay runs/x/run.mcap`` needs nothing else):

* the scenario (its ``[navigation]``, place, start time, IMU preset): ``--scenario``, else the
  log's;
* the topics: ``--topic imu=/imu --topic depth=/depth/pressure --topic polarimeter=/cam/raw
  --topic reference=/gnss/odom`` (defaults: the twin's names, :data:`DEFAULT_TOPICS`);
* the camera's calibration (JSON, :func:`twin.core.calibration.calibration_to_dict`'s fields):
  ``--calibration``, else the log's;
* the filters' initial solution: the log's, else the reference's first message (the readings
  before it are skipped and counted in ``metrics.json``);
* the depth gauge's conversion constants: the log's, else the scenario's declared ones.

Not replayed: gravity map matching (the stored map is the world's draw, not in a log; a scenario
that fuses the gravimeter is refused with that reason).

A message's time on the vehicle's clock is its header stamp minus the scenario's start; the
order the vehicle received them is the log time (then the file's sequence, for messages of one
instant). Bad logs: a missing topic, a stamp that goes back or repeats on one topic, an image
that is not ``mono16`` or not the calibration's size are one-line errors (:class:`LogError`)
naming the topic, and so is a gap in the IMU's stream longer than the INS integrates over
(``InsConfig.max_dt_s``); a shorter gap longer than :data:`GAP_FACTOR` × the median period is
flown through (the INS propagates over it) and listed in ``metrics.json``.

``tests/test_replay.py``: a twin run exported to MCAP and replayed gives the run's estimates
bit for bit.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from scenarios.loader import parse_scenario
from scenarios.schema import Scenario
from sensors.depth import depth_from_pressure
from twin.core.calibration import CameraCalibration, calibration_from_dict
from twin.core.earth import principal_radii
from twin.core.frames import dcm_to_euler, dcm_to_quat, quat_to_dcm, yaw_to_heading_deg
from twin.core.messages import Reading
from twin.onboard.ins import NavState
from twin.onboard.navigator import Navigator, VehicleKnowledge
from twin.record.blueprint import default_blueprint
from twin.record.mcap_log import B_FROM_FLU, REPLAY_METADATA
from twin.record.observer import log_compass_event, log_nav_sample, log_truth
from twin.record.provenance import fingerprint, parquet_metadata, provenance
from twin.record.recorder import Recorder, utc_ns
from twin.record.rrd_files import compact
from twin.record.timeseries import fix_row
from twin.scoring.navigation import VariantScore
from twin.sim.build import navigator_config
from twin.world.assembly import make_sensor, optics_config
from twin.world.truth import Truth

DEFAULT_TOPICS: dict[str, str] = {
    "imu": "/imu",
    "depth": "/depth/pressure",
    "polarimeter": "/polarimeter/image_raw",
    "reference": "/truth/odom",
}
#: An IMU gap longer than this many median periods is listed in the metrics.
GAP_FACTOR = 5.0


class LogError(ValueError):
    """A log that cannot be replayed, one line naming what and where."""


@dataclasses.dataclass(frozen=True)
class _Message:
    log_ns: int
    seq: int
    topic: str
    msgtype: str
    msg: Any


def read_log(
    path: Path,
) -> tuple[list[tuple[str, str]], dict[str, dict[str, str]], Iterator[_Message]]:
    """The log's (topic, type) list, its metadata records and its messages in delivery order.

    An MCAP file is read with ``mcap``'s reader (which keeps each message's sequence) and decoded
    with rosbags' CDR decoder and the file's own schemas; a rosbag2 folder with rosbags.
    """
    if path.is_dir():
        return _read_rosbag2(path)
    if not path.is_file():
        raise LogError(f"log {path}: no such file or folder")
    return _read_mcap(path)


def _store_with(schemas: Mapping[str, str]) -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types: dict = {}
    for name, text in schemas.items():
        # A ros2msg schema: the type's fields, then each dependency after a line of '='s.
        parts = text.split("\n" + "=" * 80 + "\n")
        types.update(get_types_from_msg(parts[0], name))
        for part in parts[1:]:
            head, _, body = part.partition("\n")
            dep = head.removeprefix("MSG: ").strip()
            if "/msg/" not in dep:
                dep = dep.replace("/", "/msg/", 1)
            types.update(get_types_from_msg(body, dep))
    store.register(types)
    return store


def _read_mcap(path: Path):
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    try:
        with open(path, "rb") as f:
            reader = make_reader(f)
            summary = reader.get_summary()
            metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    except (McapError, ValueError, EOFError) as exc:
        raise LogError(f"log {path}: not a readable MCAP file ({exc})") from exc
    if summary is None:
        raise LogError(f"log {path}: an MCAP file without a summary (not finished?)")
    schemas = {s.name: s.data.decode() for s in summary.schemas.values()}
    topics = [(c.topic, summary.schemas[c.schema_id].name) for c in summary.channels.values()]
    store = _store_with(schemas)

    def messages() -> Iterator[_Message]:
        with open(path, "rb") as f:
            group: list[_Message] = []
            for schema, channel, m in make_reader(f).iter_messages(log_time_order=True):
                if group and m.log_time != group[0].log_ns:
                    yield from sorted(group, key=lambda x: x.seq)
                    group = []
                msg = store.deserialize_cdr(m.data, schema.name)
                group.append(_Message(m.log_time, m.sequence, channel.topic, schema.name, msg))
            yield from sorted(group, key=lambda x: x.seq)

    return topics, metadata, messages()


def _read_rosbag2(path: Path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:
        raise LogError(f"log {path}: not a readable rosbag2 folder ({exc})") from exc
    topics = [(c.topic, c.msgtype) for c in reader.connections]

    def messages() -> Iterator[_Message]:
        try:
            for k, (conn, t, raw) in enumerate(reader.messages()):
                yield _Message(
                    t, k, conn.topic, conn.msgtype, reader.deserialize(raw, conn.msgtype)
                )
        finally:
            reader.close()

    return topics, {}, messages()


# ---- the vehicle's knowledge from the log or the user ------------------------------------------
def _stamp_s(msg: Any, start_ns: int) -> float:
    s = msg.header.stamp
    return (s.sec * 1_000_000_000 + s.nanosec - start_ns) / 1e9


def _truth_from_odom(msg: Any, t: float, scenario: Scenario) -> Truth:
    """A reference Odometry as the scorer's truth: base_link (x forward) back to the body frame."""
    q = msg.pose.pose.orientation
    c_flu = quat_to_dcm(np.array([q.w, q.x, q.y, q.z]))
    c_bn = c_flu @ B_FROM_FLU.T
    roll, pitch, yaw = dcm_to_euler(c_bn)
    p = msg.pose.pose.position
    pos = np.array([p.x, p.y, p.z])
    v = msg.twist.twist.linear
    lat0 = math.radians(scenario.place.latitude_deg)
    r_m, r_n = principal_radii(lat0)
    return Truth(
        t=t,
        position_n=pos,
        quat_wxyz=dcm_to_quat(c_bn),
        velocity_n=c_flu @ np.array([v.x, v.y, v.z]),
        omega_b=np.zeros(3),
        roll_rad=roll,
        pitch_rad=pitch,
        yaw_rad=yaw,
        heading_deg=yaw_to_heading_deg(yaw),
        depth_m=-float(pos[2]),
        latitude_rad=lat0 + pos[1] / r_m,
        longitude_rad=math.radians(scenario.place.longitude_deg) + pos[0] / (r_n * math.cos(lat0)),
        current_n=np.zeros(3),
        speed_through_water_mps=math.nan,
        actuators=np.zeros(3),
    )


def _init_from(meta: dict[str, str], first_ref: Truth | None) -> NavState:
    if "nav_init" in meta:
        d = json.loads(meta["nav_init"])
        return NavState(
            d["t"], d["lat_rad"], d["lon_rad"], d["h_m"], np.array(d["v_enu"]), np.array(d["c_bn"])
        )
    if first_ref is None:
        raise LogError(
            "replay: no initial solution: the log has no auv_twin.replay metadata and no "
            "reference topic (--topic reference=TOPIC, a nav_msgs/msg/Odometry)"
        )
    return NavState(
        first_ref.t, first_ref.latitude_rad, first_ref.longitude_rad, -first_ref.depth_m,
        first_ref.velocity_n, quat_to_dcm(first_ref.quat_wxyz),
    )  # fmt: skip


def _depth_constants(meta: dict[str, str], scenario: Scenario) -> tuple[float, float, float]:
    if "depth" in meta:
        d = json.loads(meta["depth"])
        return d["p_atm_pa"], d["rho_kg_m3"], d["g_mps2"]
    spec = make_sensor("depth", scenario.sensors.depth, scenario.sensors.depth_overrides).spec
    vals = (
        spec.declared_atmospheric_pressure_pa,
        spec.declared_density_kg_m3,
        spec.declared_gravity_mps2,
    )
    if any(v is None for v in vals):
        raise LogError(
            "replay: the depth gauge's conversion constants are unknown (no auv_twin.replay "
            "metadata in the log): set sensors.depth_overrides declared_atmospheric_pressure_pa, "
            "declared_density_kg_m3 and declared_gravity_mps2 in the scenario"
        )
    return float(vals[0]), float(vals[1]), float(vals[2])  # type: ignore[arg-type]


# ---- the replay -------------------------------------------------------------------------------
def replay(
    log: Path | str,
    out_dir: Path | str,
    *,
    scenario: Scenario | None = None,
    topics: Mapping[str, str] | None = None,
    calibration: CameraCalibration | None = None,
) -> dict[str, Any]:
    """Run the scenario's filter variants on the log's readings; write and return the metrics.

    Raises:
        LogError: A log that cannot be replayed (module docstring).
        ScenarioError: An invalid scenario in the log's metadata.
    """
    path = Path(log)
    out = Path(out_dir)
    top = {**DEFAULT_TOPICS, **(topics or {})}
    unknown = sorted(set(top) - set(DEFAULT_TOPICS))
    if unknown:
        raise LogError(
            f"replay --topic: unknown role(s) {unknown}; allowed: {sorted(DEFAULT_TOPICS)}"
        )
    available, metadata, _ = read_log(path)
    meta = metadata.get(REPLAY_METADATA, {})
    if scenario is None:
        if "scenario" not in meta:
            raise LogError(f"log {path}: no scenario in it (not a twin log): give --scenario")
        scenario = parse_scenario(json.loads(meta["scenario"]), source=f"{path} (its scenario)")
    variants = scenario.navigation.variants
    if not variants:
        raise LogError("replay: the scenario's [navigation] has no variants to run")
    g = scenario.gravity
    if g.map != "none" and g.matching and scenario.sensors.gravimeter is not None:
        # The stored map is the world's draw, not in the log: matching would silently be off.
        raise LogError(
            "replay: the scenario fuses the gravimeter against a stored map, which a log does "
            "not carry; set [gravity] matching = false to replay without it"
        )
    types = dict(available)
    compass = any(v != "ins" for v in variants)
    needed = ["imu", "depth"] + (["polarimeter"] if compass else [])
    for role in needed:
        if top[role] not in types:
            raise LogError(
                f"log {path}: topic {top[role]!r} ({role}) is not in it; its topics: "
                f"{sorted(types)} (map another with --topic {role}=TOPIC)"
            )
    if calibration is None and "calibration" in meta:
        calibration = calibration_from_dict(json.loads(meta["calibration"]))
    if compass and calibration is None:
        raise LogError(
            f"log {path}: the compass variants need the camera's calibration: give --calibration"
        )
    depth_k = _depth_constants(meta, scenario)
    start_ns = utc_ns(scenario.start_utc)
    cfg = navigator_config(
        scenario, make_sensor("imu", scenario.sensors.imu, scenario.sensors.imu_overrides).spec
    )
    knowledge = VehicleKnowledge(
        start_utc=scenario.start_utc,
        latitude_deg=scenario.place.latitude_deg,
        longitude_deg=scenario.place.longitude_deg,
        water_index=optics_config(scenario).water_index,
        calibration=calibration,
    )
    out.mkdir(parents=True, exist_ok=True)
    rec = Recorder(
        out / "recording.rrd",
        recording_id=f"replay-{path.stem}",
        start_utc=scenario.start_utc,
        compact=False,
        blueprint=default_blueprint(variants),
    )
    block = provenance(fingerprint=fingerprint(scenario.to_dict()), seed=None)
    rec.log_properties("provenance", block)
    setup = _Setup(
        path, out, scenario, variants, top, types, meta, compass, needed, calibration,
        depth_k, start_ns, cfg, knowledge, metadata.get("auv_twin.provenance", {}), block,
    )  # fmt: skip
    try:
        metrics = _replay_into(rec, setup)
    finally:
        rec.close()
    compact(out / "recording.rrd")
    return metrics


@dataclasses.dataclass(frozen=True)
class _Setup:
    """What :func:`replay` resolved before reading the messages."""

    path: Path
    out: Path
    scenario: Scenario
    variants: tuple[str, ...]
    top: dict[str, str]
    types: dict[str, str]
    meta: dict[str, str]
    compass: bool
    needed: list[str]
    calibration: CameraCalibration | None
    depth_k: tuple[float, float, float]
    start_ns: int
    cfg: Any
    knowledge: VehicleKnowledge
    log_provenance: dict[str, str]
    provenance: dict[str, Any]


def _replay_into(rec: Recorder, setup: _Setup) -> dict[str, Any]:
    """:func:`replay`'s loop over the log, logging into ``rec``; returns the metrics."""
    path, out, scenario, variants = setup.path, setup.out, setup.scenario, setup.variants
    top, types, meta, compass = setup.top, setup.types, setup.meta, setup.compass
    calibration, depth_k, start_ns = setup.calibration, setup.depth_k, setup.start_ns
    cfg, knowledge, needed = setup.cfg, setup.knowledge, setup.needed
    _, _, messages = read_log(path)
    has_ref = top["reference"] in types
    navs: dict[str, Navigator] | None = None
    scores = {v: VariantScore(v) for v in variants}
    filter_rows: list[dict[str, Any]] = []
    fix_rows: list[dict[str, Any]] = []
    last_stamp: dict[str, float] = {}
    imu_t: list[float] = []
    counts: dict[str, int] = {}
    skipped: dict[str, int] = {}
    max_gap = cfg.eskf.ins.max_dt_s
    role_of = {top[r]: r for r in ("imu", "depth", "polarimeter", "reference")}
    params = scenario.navigation.method_params
    init = _init_from(meta, None) if "nav_init" in meta else None
    if init is not None:
        navs = {v: Navigator(v, knowledge, init, cfg, method_params=params(v)) for v in variants}
    for m in messages:
        role = role_of.get(m.topic)
        if role is None or (role == "polarimeter" and not compass):
            continue
        t = _stamp_s(m.msg, start_ns)
        prev = last_stamp.get(m.topic)
        if prev is not None and t <= prev:
            what = "repeats" if t == prev else "goes back"
            raise LogError(
                f"log {path}: topic {m.topic!r}: the stamp {what} at message {counts[m.topic] + 1} "
                f"(t = {t:.6f} s after {prev:.6f} s)"
            )
        last_stamp[m.topic] = t
        counts[m.topic] = counts.get(m.topic, 0) + 1
        if role == "reference":
            truth = _truth_from_odom(m.msg, t, scenario)
            if navs is None:
                init_t = _init_from(meta, truth)
                navs = {
                    v: Navigator(v, knowledge, init_t, cfg, method_params=params(v))
                    for v in variants
                }
            log_truth(rec, truth)
            for v, nav in navs.items():
                sample = scores[v].add(nav, truth)
                log_nav_sample(rec, v, t, sample)
                filter_rows.append(
                    {"t": t, "variant": v, **{k: float(x) for k, x in sample.items()}}
                )
            continue
        if navs is None:
            # No initial solution yet (a log without the twin's metadata starts its filters at
            # the reference's first message): the readings before it are skipped, and counted.
            skipped[m.topic] = skipped.get(m.topic, 0) + 1
            continue
        t_log = (m.log_ns - start_ns) / 1e9
        reading = _reading(role, m, t, t_log, depth_k, calibration, path)
        if role == "imu":
            if imu_t and t - imu_t[-1] > max_gap:
                raise LogError(
                    f"log {path}: topic {m.topic!r}: a gap of {t - imu_t[-1]:.3f} s after "
                    f"t = {imu_t[-1]:.3f} s, longer than the INS integrates over "
                    f"({max_gap:g} s, InsConfig.max_dt_s)"
                )
            imu_t.append(t)
        rec.log_reading(reading)
        for v, nav in navs.items():
            event = nav.on_reading(reading)
            if event is not None:
                fix_rows.append(fix_row(v, event))
                log_compass_event(rec, v, event)
    if navs is None:
        raise LogError(f"log {path}: no messages on the mapped topics")
    gaps = _gaps(imu_t)
    block = setup.provenance
    metrics: dict[str, Any] = {
        "log": str(path),
        "topics": {r: top[r] for r in needed + (["reference"] if has_ref else [])},
        "messages": counts,
        "skipped_before_initial_solution": skipped,
        "provenance": block,
        # The run that wrote the log, where the log says (a twin run's run.mcap).
        "log_provenance": {k: json.loads(v) for k, v in setup.log_provenance.items()},
        "scored": has_ref,
        "imu_gaps": gaps,
        # As a run's metrics.json: navigation.variants.<name>.
        "navigation": {
            "variants": {v: scores[v].summary(navs[v]) for v in variants} if has_ref else {}
        },
    }
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, default=str) + "\n")
    folder = out / "timeseries"
    folder.mkdir(exist_ok=True)
    for name, rows in (("filters", filter_rows), ("compass_fixes", fix_rows)):
        table = pa.Table.from_pylist(rows) if rows else pa.table({"t": pa.array([], pa.float64())})
        pq.write_table(
            table.replace_schema_metadata(parquet_metadata(block)), folder / f"{name}.parquet"
        )
    return metrics


def _require(m: _Message, msgtype: str, path: Path) -> None:
    if m.msgtype != msgtype:
        raise LogError(f"log {path}: topic {m.topic!r} is {m.msgtype}; allowed: {msgtype}")


def _reading(
    role: str,
    m: _Message,
    t: float,
    t_log: float,
    depth_constants: tuple[float, float, float],
    cal: CameraCalibration | None,
    path: Path,
) -> Reading:
    """A message as the reading the twin's sensor delivers (the sensor's channel names)."""
    msg = m.msg
    if role == "imu":
        _require(m, "sensor_msgs/msg/Imu", path)
        w, a = msg.angular_velocity, msg.linear_acceleration
        values = {
            "angular_rate": np.array([w.x, w.y, w.z]),
            "specific_force": np.array([a.x, a.y, a.z]),
        }
        return Reading("imu", t, t_log, values)
    if role == "depth":
        _require(m, "sensor_msgs/msg/FluidPressure", path)
        p = float(msg.fluid_pressure)
        depth = depth_from_pressure(p, *depth_constants)
        return Reading(
            "depth", t, t_log, {"pressure_pa": np.array([p]), "depth_m": np.array([depth])}
        )
    _require(m, "sensor_msgs/msg/Image", path)
    if msg.encoding not in ("mono16", "16UC1"):
        raise LogError(
            f"log {path}: topic {m.topic!r}: encoding {msg.encoding!r}; allowed: mono16 (the raw "
            "DoFP mosaic)"
        )
    assert cal is not None
    if (msg.width, msg.height) != (cal.width_px, cal.height_px):
        raise LogError(
            f"log {path}: topic {m.topic!r}: a {msg.width}×{msg.height} image; the calibration "
            f"is for {cal.width_px}×{cal.height_px}"
        )
    dtype = ">u2" if msg.is_bigendian else "<u2"
    raw = np.frombuffer(bytes(msg.data), dtype=dtype).reshape(msg.height, msg.width)
    return Reading("polarimeter", t, t_log, {"raw": raw.astype(np.uint16)})


def _gaps(t: list[float]) -> list[dict[str, float]]:
    if len(t) < 3:
        return []
    d = np.diff(np.asarray(t))
    med = float(np.median(d))
    return [
        {"after_s": float(t[i]), "length_s": float(d[i])}
        for i in np.flatnonzero(d > GAP_FACTOR * med)
    ]


__all__ = ["DEFAULT_TOPICS", "LogError", "read_log", "replay"]
