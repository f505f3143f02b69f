"""twin.record.recorder: real .rrd files in tmp_path, read back with rerun.chunk.RrdReader."""

from __future__ import annotations

import datetime as dt
import math
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
import rerun.blueprint as rrb
from rerun.chunk import ChunkStore, LazyStore, RrdReader

from twin.core.frames import euler_to_quat
from twin.core.messages import Reading
from twin.record.blueprint import default_blueprint
from twin.record.recorder import FLUSH_EVERY_S, MAX_SERIES_WIDTH, Recorder
from twin.record.rrd_files import salvage

START = dt.datetime(2024, 6, 21, 10, 30, 15, 250000, tzinfo=dt.UTC)
START_NS = (START - dt.datetime(1970, 1, 1, tzinfo=dt.UTC)) // dt.timedelta(microseconds=1) * 1000
REPO = Path(__file__).resolve().parents[1]

# The scripted run: 12.34 s at 100 Hz (truth, IMU), 10 Hz (depth, control), 1 Hz (image, text).
DT = 0.01
N_STEPS = 1235
WAYPOINTS = np.array([[0.0, 0.0, -5.0], [40.0, 30.0, -5.0], [80.0, 0.0, -10.0]])
HALF_SIZES = (0.095, 0.8, 0.095)


def _truth(k: int) -> dict[str, np.ndarray | float]:
    t = k * DT
    yaw = 0.3 + 0.02 * t
    return {
        "position_n": np.array([1.2 * t, 0.5 * t, -5.0 - 0.01 * t]),
        "quat_wxyz": euler_to_quat(0.01, -0.02, yaw),
        "velocity_n": np.array([1.2, 0.5, -0.01]),
        "rpy_deg": np.degrees([0.01, -0.02, yaw]),
        "heading_deg": (-math.degrees(yaw)) % 360.0,
        "depth_m": 5.0 + 0.01 * t,
    }


def _accel(k: int) -> np.ndarray:
    return np.array([0.01 * k, -0.02 * k, 9.81 + 1e-3 * k])


def _scripted_run(rec: Recorder, n_steps: int = N_STEPS, fail_at: int | None = None) -> None:
    """Log a deterministic run; raise RuntimeError at step ``fail_at`` like a crashing sim."""
    rec.log_static_scene(
        waypoints_n=WAYPOINTS, vehicle_half_sizes=HALF_SIZES, surface_z=0.0, seabed_z=-40.0
    )
    for k in range(n_steps):
        if k == fail_at:
            raise RuntimeError("simulated crash")
        t = k * DT
        rec.log_truth(t, **_truth(k))  # type: ignore[arg-type]
        rec.log_reading(
            Reading("imu", t, t, {"accel": _accel(k), "gyro": np.array([1e-3, 0.0, -2e-3 * k])})
        )
        if k % 10 == 0:
            rec.log_reading(
                Reading(
                    "depth",
                    t,
                    t + 0.05,
                    {"depth_m": np.array(5.0 + 1e-3 * k), "raw_frame": np.zeros((8, 8))},
                )
            )
            rec.log_scalars("/control/rudder_rad", t, 0.05 * math.sin(t))
            rec.log_scalars("/control/fins_rad", t, np.array([0.1, -0.1]), names=["port", "stbd"])
        if k % 100 == 0:
            image = np.full((24, 32, 3), k % 256, dtype=np.uint8)
            rec.log_image("/camera/chase", t, image)
            rec.log_text(t, f"step {k}", level="WARN" if k == 500 else "INFO")


def _record(path: Path, **kwargs: object) -> Path:
    with Recorder(path, recording_id="test-run", start_utc=START, **kwargs) as rec:  # type: ignore[arg-type]
        _scripted_run(rec)
    return path


def _summary_rows(summary: str) -> dict[str, int]:
    """Entity -> total temporal rows, from store.summary()."""
    rows: dict[str, int] = {}
    for line in summary.splitlines():
        entity, rest = line.split(" rows=", 1)
        n, static = rest.split(" ", 2)[:2]
        if static == "static=False":
            rows[entity] = rows.get(entity, 0) + int(n)
    return rows


def _table(store: LazyStore | ChunkStore, entity: str) -> pa.Table:
    """All temporal rows of one entity, sorted by sim_time."""
    batches = [
        c.to_record_batch()
        for c in store.stream().filter(content=entity, is_static=False).to_chunks()
        if c.entity_path == entity
    ]
    assert batches, f"no temporal chunks for {entity}"
    table = pa.Table.from_batches(batches, schema=batches[0].schema)
    return table.sort_by("sim_time")


def _ns(table: pa.Table, column: str = "sim_time") -> np.ndarray:
    return table.column(column).cast(pa.int64()).to_numpy()


def _values(table: pa.Table, column: str = "Scalars:scalars") -> np.ndarray:
    return np.array(table.column(column).to_pylist(), dtype=np.float64)


@pytest.fixture(scope="module")
def run_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _record(tmp_path_factory.mktemp("rec") / "run.rrd", flush_every_s=5.0)


@pytest.fixture(scope="module")
def store(run_file: Path) -> LazyStore:
    return RrdReader(run_file).store()


# --------------------------------------------------------------------------- contents


def test_recording_identity(run_file: Path) -> None:
    [entry] = RrdReader(run_file).recordings()
    assert (entry.application_id, entry.recording_id) == ("auv_twin", "test-run")


def test_expected_entities(store: LazyStore) -> None:
    entities = {line.split(" rows=")[0] for line in store.summary().splitlines()}
    assert entities == {
        "/world",
        "/world/auv",
        "/world/auv/hull",
        "/world/auv/nose",
        "/world/path",
        "/world/mission/waypoints",
        "/world/mission/route",
        "/world/surface",
        "/world/seabed",
        "/truth/rpy_deg",
        "/truth/heading_deg",
        "/truth/depth_m",
        "/truth/speed_mps",
        "/truth/velocity_n",
        "/sensors/imu/accel",
        "/sensors/imu/gyro",
        "/sensors/depth/depth_m",
        "/control/rudder_rad",
        "/control/fins_rad",
        "/camera/chase",
        "/log",
    }
    # No wall-clock timeline anywhere: only sim_time and utc.
    timelines = {line.split("timelines=")[1].split("]")[0] for line in store.summary().splitlines()}
    assert timelines <= {"[", "['sim_time', 'utc'"}


def test_rows_per_entity_equal_what_was_logged(store: LazyStore) -> None:
    rows = _summary_rows(store.summary())
    n_10hz = len(range(0, N_STEPS, 10))
    n_1hz = len(range(0, N_STEPS, 100))
    expected = {
        "/world/auv": N_STEPS,
        "/truth/rpy_deg": N_STEPS,
        "/truth/heading_deg": N_STEPS,
        "/truth/depth_m": N_STEPS,
        "/truth/speed_mps": N_STEPS,
        "/truth/velocity_n": N_STEPS,
        "/sensors/imu/accel": N_STEPS,
        "/sensors/imu/gyro": N_STEPS,
        "/sensors/depth/depth_m": n_10hz,
        "/control/rudder_rad": n_10hz,
        "/control/fins_rad": n_10hz,
        "/camera/chase": n_1hz,
        "/log": n_1hz,
    }
    assert {e: rows[e] for e in expected} == expected


def test_columns_are_chunked_by_flush_and_compacted_on_close(store: LazyStore) -> None:
    # flush_every_s = 5 s of sim time at 100 Hz: written as ceil(12.35 / 5) = 3 chunks while
    # the run flies (a killed run keeps them), then compacted into one when the file is closed.
    assert math.ceil(N_STEPS * DT / 5.0) == 3
    lines = [ln for ln in store.summary().splitlines() if ln.startswith("/sensors/imu/accel rows=")]
    temporal = [ln for ln in lines if "static=False" in ln]
    assert len(temporal) == 1


def test_sim_time_and_utc_round_trip(store: LazyStore) -> None:
    table = _table(store, "/sensors/imu/accel")
    assert table.schema.field("sim_time").type == pa.duration("ns")
    assert table.schema.field("utc").type == pa.timestamp("ns")
    expected_ns = np.array([round(k * DT * 1e9) for k in range(N_STEPS)], dtype=np.int64)
    np.testing.assert_array_equal(_ns(table), expected_ns)
    np.testing.assert_array_equal(_ns(table, "utc"), START_NS + expected_ns)


def test_vector_series_round_trips(store: LazyStore) -> None:
    table = _table(store, "/sensors/imu/accel")
    np.testing.assert_array_equal(_values(table), np.array([_accel(k) for k in range(N_STEPS)]))
    fins = _values(_table(store, "/control/fins_rad"))
    np.testing.assert_array_equal(fins, np.tile([0.1, -0.1], (len(fins), 1)))


def test_scalar_reading_stamped_at_sampling_time(store: LazyStore) -> None:
    table = _table(store, "/sensors/depth/depth_m")
    ks = np.arange(0, N_STEPS, 10)
    np.testing.assert_array_equal(_ns(table), np.rint(ks * DT * 1e9).astype(np.int64))
    np.testing.assert_array_equal(_values(table)[:, 0], 5.0 + 1e-3 * ks)


def test_series_names_are_static(store: LazyStore) -> None:
    def names(entity: str) -> list[str]:
        [chunk] = [
            c
            for c in store.stream().filter(content=entity, is_static=True).to_chunks()
            if c.entity_path == entity
        ]
        return chunk.to_record_batch().column("SeriesLines:names").to_pylist()[0]

    assert names("/sensors/imu/accel") == ["x", "y", "z"]
    assert names("/sensors/depth/depth_m") == ["depth_m"]
    assert names("/control/fins_rad") == ["port", "stbd"]
    assert names("/truth/rpy_deg") == ["roll", "pitch", "yaw"]


def test_transform_round_trips_quaternion_in_xyzw(store: LazyStore) -> None:
    table = _table(store, "/world/auv")
    k = 321
    row = table.slice(k, 1)
    assert _ns(row)[0] == round(k * DT * 1e9)
    q_wxyz = _truth(k)["quat_wxyz"]
    [q_xyzw] = row.column("Transform3D:quaternion").to_pylist()[0]
    np.testing.assert_allclose(q_xyzw, [*q_wxyz[1:], q_wxyz[0]], atol=1e-7)  # float32 storage
    [p] = row.column("Transform3D:translation").to_pylist()[0]
    np.testing.assert_allclose(p, _truth(k)["position_n"], rtol=1e-6)


def test_known_quaternion_order(tmp_path: Path) -> None:
    # 90 deg about z: wxyz (c, 0, 0, s) must be stored as xyzw (0, 0, s, c).
    c = s = math.sqrt(0.5)
    with Recorder(tmp_path / "q.rrd", recording_id="q", start_utc=START) as rec:
        rec.log_truth(
            0.0,
            position_n=np.array([1.0, 2.0, -3.0]),
            quat_wxyz=np.array([c, 0.0, 0.0, s]),
            velocity_n=np.zeros(3),
            rpy_deg=np.array([0.0, 0.0, 90.0]),
            heading_deg=270.0,
            depth_m=3.0,
        )
    table = _table(RrdReader(tmp_path / "q.rrd").store(), "/world/auv")
    [q] = table.column("Transform3D:quaternion").to_pylist()[0]
    np.testing.assert_allclose(q, [0.0, 0.0, s, c], atol=1e-7)


def test_truth_series_values(store: LazyStore) -> None:
    k = np.arange(N_STEPS)
    np.testing.assert_allclose(
        _values(_table(store, "/truth/depth_m"))[:, 0], 5.0 + 0.01 * k * DT, rtol=1e-12
    )
    np.testing.assert_allclose(
        _values(_table(store, "/truth/speed_mps"))[:, 0], math.hypot(1.2, 0.5, 0.01)
    )
    heading = _values(_table(store, "/truth/heading_deg"))[:, 0]
    np.testing.assert_allclose(heading, [_truth(i)["heading_deg"] for i in k])


def test_path_is_connected_segments_ending_at_last_sample(store: LazyStore) -> None:
    table = _table(store, "/world/path")
    segments = np.array([row[0] for row in table.column("LineStrips3D:strips").to_pylist()])
    assert segments.shape[1:] == (2, 3)
    # One segment per 0.5 s period after the first, plus the closing one to the last sample.
    assert len(segments) == math.floor((N_STEPS - 1) * DT / 0.5) + 1
    np.testing.assert_allclose(
        segments[1:, 0], segments[:-1, 1]
    )  # each starts where the last ended
    np.testing.assert_allclose(segments[0, 0], _truth(0)["position_n"], atol=1e-6)
    np.testing.assert_allclose(segments[-1, 1], _truth(N_STEPS - 1)["position_n"], rtol=1e-6)
    assert _ns(table)[-1] == round((N_STEPS - 1) * DT * 1e9)


def test_text_log_levels(store: LazyStore) -> None:
    table = _table(store, "/log")
    levels = [v[0] for v in table.column("TextLog:level").to_pylist()]
    texts = [v[0] for v in table.column("TextLog:text").to_pylist()]
    assert texts[5] == "step 500" and levels[5] == "WARN"
    assert levels.count("INFO") == len(levels) - 1


def test_images_are_jpeg_by_default(store: LazyStore) -> None:
    table = _table(store, "/camera/chase")
    assert {v[0] for v in table.column("EncodedImage:media_type").to_pylist()} == {"image/jpeg"}


def test_jpeg_images_read_back_in_their_own_colours(tmp_path: Path) -> None:
    """RGB in, the same RGB out (within JPEG's error): no channel order swapped on the way."""
    import cv2

    img = np.zeros((32, 48, 3), np.uint8)
    img[:, :16] = (255, 0, 0)  # red, green, blue bands
    img[:, 16:32] = (0, 255, 0)
    img[:, 32:] = (0, 0, 255)
    with Recorder(tmp_path / "rgb.rrd", recording_id="c", start_utc=START) as rec:
        rec.log_image("/camera/chase", 0.0, img)
        rec.log_image("/camera/grey", 0.0, img[..., 1])
    store = RrdReader(tmp_path / "rgb.rrd").store()
    for entity, want in (("/camera/chase", img), ("/camera/grey", img[..., 1])):
        blob = _table(store, entity).column("EncodedImage:blob").to_pylist()[0][0]
        got = cv2.imdecode(np.frombuffer(bytes(blob), np.uint8), cv2.IMREAD_UNCHANGED)
        if got.ndim == 3:
            got = cv2.cvtColor(got, cv2.COLOR_BGR2RGB)
        assert got.shape == want.shape
        assert np.abs(got.astype(int) - want.astype(int)).mean() < 8


def test_buffered_images_and_points_read_back_one_row_per_call_in_time_order(
    tmp_path: Path,
) -> None:
    """Images and image-space points wait for the flush: every call is still its own row, at its
    own time, with its own points (a marker cleared by an empty call), labels and colours."""
    import cv2

    imgs = [np.full((8, 12), 40 * k, np.uint8) for k in range(4)]
    with Recorder(tmp_path / "b.rrd", recording_id="b", start_utc=START, flush_every_s=1.5) as rec:
        for k, img in enumerate(imgs):
            rec.log_image("/cam", 0.5 * k, img)
            pts = np.zeros((0, 2)) if k == 2 else np.array([[k + 0.25, 2.0 * k]])
            rec.log_points2d("/cam/sun", 0.5 * k, pts, color=(10 * k, 2, 3), label="true sun")
        rec.log_points2d("/cam/two", 0.5, np.array([[1.0, 2.0], [3.0, 4.0]]))
    store = RrdReader(tmp_path / "b.rrd").store()
    table = _table(store, "/cam")
    assert list(_ns(table)) == [round(0.5e9 * k) for k in range(4)]
    for row, want in zip(table.column("EncodedImage:blob").to_pylist(), imgs, strict=True):
        got = cv2.imdecode(np.frombuffer(bytes(row[0]), np.uint8), cv2.IMREAD_UNCHANGED)
        assert abs(float(got.mean()) - float(want.mean())) < 2
    sun = _table(store, "/cam/sun")
    assert list(_ns(sun)) == [round(0.5e9 * k) for k in range(4)]
    positions = sun.column("Points2D:positions").to_pylist()
    assert [len(p) for p in positions] == [1, 1, 0, 1]
    assert positions[3] == [[3.25, 6.0]]
    assert sun.column("Points2D:labels").to_pylist()[1] == ["true sun"]
    assert sun.column("Points2D:radii").to_pylist()[0] == [4.0]
    colours = sun.column("Points2D:colors").to_pylist()
    assert colours[1] == [(10 << 24) | (2 << 16) | (3 << 8) | 255]
    two = _table(store, "/cam/two")
    assert two.column("Points2D:positions").to_pylist() == [[[1.0, 2.0], [3.0, 4.0]]]
    assert "Points2D:labels" not in two.column_names or two.column(
        "Points2D:labels"
    ).to_pylist() == [None]


def test_raw_images_when_jpeg_disabled(tmp_path: Path) -> None:
    with Recorder(tmp_path / "raw.rrd", recording_id="r", start_utc=START, jpeg_quality=None) as r:
        r.log_image("/camera/chase", 0.0, np.zeros((4, 6), dtype=np.uint8))
    summary = RrdReader(tmp_path / "raw.rrd").store().summary()
    assert "Image:buffer" in summary and "EncodedImage" not in summary


@pytest.mark.parametrize(
    "image",
    [np.zeros((4, 6, 4), np.uint8), np.zeros((4, 6), np.float32), np.zeros(6, np.uint8)],
    ids=["rgba", "float", "1d"],
)
def test_log_image_rejects_unsupported(tmp_path: Path, image: np.ndarray) -> None:
    with Recorder(tmp_path / "bad.rrd", recording_id="b", start_utc=START) as rec:
        with pytest.raises(ValueError, match="expected uint8"):
            rec.log_image("/camera/chase", 0.0, image)


# --------------------------------------------------------------------------- blueprint


def _views(path: Path) -> set[tuple[str, str, str]]:
    reader = RrdReader(path)
    [bp] = reader.blueprints()
    views = set()
    for chunk in reader.stream(store=bp).to_chunks():
        rb = chunk.to_record_batch()
        if "ViewBlueprint:class_identifier" in rb.schema.names:
            views.add(
                (
                    rb.column("ViewBlueprint:class_identifier").to_pylist()[0][0],
                    rb.column("ViewBlueprint:display_name").to_pylist()[0][0],
                    rb.column("ViewBlueprint:space_origin").to_pylist()[0][0],
                )
            )
    return views


def test_default_blueprint_is_stored(run_file: Path) -> None:
    assert isinstance(default_blueprint(), rrb.Blueprint)
    views = _views(run_file)
    assert ("3D", "World (ENU)", "/world") in views
    assert ("2D", "Chase camera", "/camera/chase") in views
    assert {(cls, origin) for cls, _, origin in views} >= {
        ("TimeSeries", "/truth/rpy_deg"),
        ("TimeSeries", "/sensors/imu"),
        ("TimeSeries", "/control"),
        ("TextLog", "/log"),
    }


def test_custom_blueprint_is_stored(tmp_path: Path) -> None:
    bp = rrb.Blueprint(rrb.Spatial3DView(origin="/world", name="Only the world"))
    with Recorder(tmp_path / "bp.rrd", recording_id="bp", start_utc=START, blueprint=bp):
        pass
    assert _views(tmp_path / "bp.rrd") == {("3D", "Only the world", "/world")}


# --------------------------------------------------------------------------- lifecycle


def test_close_is_idempotent(tmp_path: Path) -> None:
    rec = Recorder(tmp_path / "c.rrd", recording_id="c", start_utc=START)
    rec.log_scalars("/control/x", 0.0, 1.0)
    rec.close()
    rec.close()
    assert rec.closed
    with rec:  # leaving the context manager closes again: still fine
        pass
    assert _summary_rows(RrdReader(tmp_path / "c.rrd").store().summary()) == {"/control/x": 1}


def test_logging_after_close_is_an_error(tmp_path: Path) -> None:
    rec = Recorder(tmp_path / "c.rrd", recording_id="c", start_utc=START)
    rec.close()
    rec.log_scalars("/control/x", 0.0, 1.0)
    with pytest.raises(RuntimeError, match="after close"):
        rec.flush()


def test_exception_mid_run_leaves_readable_file(tmp_path: Path) -> None:
    path = tmp_path / "crash.rrd"
    rec = Recorder(path, recording_id="crash", start_utc=START)
    with pytest.raises(RuntimeError, match="simulated crash"):
        try:
            _scripted_run(rec, fail_at=777)
        finally:
            rec.close()
    rows = _summary_rows(RrdReader(path).store().summary())  # footer written: store() works
    assert rows["/world/auv"] == 777
    assert rows["/sensors/imu/accel"] == 777
    assert rows["/sensors/depth/depth_m"] == len(range(0, 777, 10))
    assert rows["/log"] == len(range(0, 777, 100))


def test_same_inputs_give_same_summary(tmp_path: Path, store: LazyStore) -> None:
    again = RrdReader(_record(tmp_path / "again.rrd", flush_every_s=5.0)).store()
    assert again.summary() == store.summary()
    np.testing.assert_array_equal(
        _values(_table(again, "/truth/rpy_deg")), _values(_table(store, "/truth/rpy_deg"))
    )


def test_auto_flush_writes_while_running(tmp_path: Path) -> None:
    path = tmp_path / "live.rrd"
    with Recorder(path, recording_id="live", start_utc=START, flush_every_s=1.0) as rec:
        # 2.49 s: flushes at t = 1.00 (0..1.00 s buffered) and t = 2.01 (1.01..2.01 s buffered).
        for k in range(250):
            rec.log_reading(Reading("imu", k * DT, k * DT, {"accel": _accel(k)}))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "RRD file has no footer" while it is being written
            live = RrdReader(path).stream().collect()
        assert _summary_rows(live.summary())["/sensors/imu/accel"] == 202
    assert _summary_rows(RrdReader(path).store().summary())["/sensors/imu/accel"] == 250


def test_a_file_alone_is_written_every_flush_every_s_of_sim_time(tmp_path: Path) -> None:
    # The default for a file alone (no live viewer): FLUSH_EVERY_S of sim time buffered.
    path = tmp_path / "default.rrd"
    n = round(FLUSH_EVERY_S / DT)
    with Recorder(path, recording_id="default", start_utc=START) as rec:
        assert rec.flush_every_s == FLUSH_EVERY_S
        for k in range(n):  # 0 .. FLUSH_EVERY_S - DT: nothing written yet
            rec.log_reading(Reading("imu", k * DT, k * DT, {"accel": _accel(k)}))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "RRD file has no footer" while it is being written
            assert "/sensors/imu/accel" not in _summary_rows(
                RrdReader(path).stream().collect().summary()
            )
            rec.log_reading(Reading("imu", n * DT, n * DT, {"accel": _accel(n)}))
            live = RrdReader(path).stream().collect()
        assert _summary_rows(live.summary())["/sensors/imu/accel"] == n + 1


_KILLED_RUN = """
import datetime as dt, os, signal
import numpy as np
from twin.core.messages import Reading
from twin.record.recorder import Recorder

rec = Recorder({path!r}, recording_id="killed",
               start_utc=dt.datetime(2024, 6, 21, tzinfo=dt.UTC), flush_every_s=1.0)
for k in range(250):  # auto-flushes at t = 1.00 s and 2.01 s; 2.02..2.49 s stay buffered
    t = k * 0.01
    rec.log_reading(Reading("imu", t, t, {{"accel": np.array([k, 0.0, 9.81])}}))
os.kill(os.getpid(), signal.SIGKILL)
"""


@pytest.fixture(scope="module")
def killed_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("killed") / "killed.rrd"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
    }
    proc = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(_KILLED_RUN.format(path=str(path)))],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == -9, proc.stderr
    return path


@pytest.mark.filterwarnings("ignore:RRD file has no footer")
def test_killed_process_flushed_data_is_recoverable(killed_file: Path) -> None:
    with pytest.raises(RuntimeError, match="without footer"):
        RrdReader(killed_file).store()
    live = RrdReader(killed_file).stream().collect()
    table = _table(live, "/sensors/imu/accel")
    np.testing.assert_array_equal(_values(table)[:, 0], np.arange(202))


@pytest.mark.filterwarnings("ignore:RRD file has no footer")
def test_salvage_gives_a_footered_file(killed_file: Path, tmp_path: Path) -> None:
    fixed = salvage(killed_file, tmp_path / "fixed.rrd")
    [entry] = RrdReader(fixed).recordings()
    assert entry.recording_id == "killed"
    assert _summary_rows(RrdReader(fixed).store().summary())["/sensors/imu/accel"] == 202


@pytest.mark.filterwarnings("ignore:RRD file has no footer")
def test_salvage_drops_a_torn_last_message(killed_file: Path, tmp_path: Path) -> None:
    torn = tmp_path / "torn.rrd"
    torn.write_bytes(killed_file.read_bytes()[:-10])  # killed in the middle of a write
    with pytest.raises(RuntimeError, match="exceeds file size"):
        RrdReader(torn).stream().collect()
    rows = _summary_rows(RrdReader(salvage(torn, tmp_path / "fixed.rrd")).store().summary())
    # The first flush (t <= 1.0 s, 101 rows) is whole; the torn chunk may be lost.
    assert 101 <= rows["/sensors/imu/accel"] <= 202


# --------------------------------------------------------------------------- validation


def test_wide_channels_are_skipped(tmp_path: Path) -> None:
    with Recorder(tmp_path / "w.rrd", recording_id="w", start_utc=START) as rec:
        frame = np.zeros(MAX_SERIES_WIDTH + 1)
        rec.log_reading(Reading("pol", 0.0, 0.0, {"frame": frame, "aop": np.array([1.0, 2.0])}))
        assert rec.skipped_channels == {"/sensors/pol/frame"}
    rows = _summary_rows(RrdReader(tmp_path / "w.rrd").store().summary())
    assert rows == {"/sensors/pol/aop": 1}


def test_channel_shape_change_raises(tmp_path: Path) -> None:
    with Recorder(tmp_path / "s.rrd", recording_id="s", start_utc=START) as rec:
        rec.log_reading(Reading("imu", 0.0, 0.0, {"accel": np.zeros(3)}))
        with pytest.raises(ValueError, match=r"/sensors/imu/accel: shape \(2,\)"):
            rec.log_reading(Reading("imu", 0.01, 0.01, {"accel": np.zeros(2)}))


def test_python_numbers_in_readings_are_accepted(tmp_path: Path) -> None:
    with Recorder(tmp_path / "p.rrd", recording_id="p", start_utc=START) as rec:
        for k in range(3):
            rec.log_reading(Reading("depth", k * 0.1, k * 0.1, {"depth_m": 2.0 + k}))  # type: ignore[dict-item]
    table = _table(RrdReader(tmp_path / "p.rrd").store(), "/sensors/depth/depth_m")
    np.testing.assert_array_equal(_values(table)[:, 0], [2.0, 3.0, 4.0])


def test_log_scalars_validates_width_and_names(tmp_path: Path) -> None:
    with Recorder(tmp_path / "v.rrd", recording_id="v", start_utc=START) as rec:
        with pytest.raises(ValueError, match="2 names for 3 values"):
            rec.log_scalars("/control/a", 0.0, np.zeros(3), names=["a", "b"])
        rec.log_scalars("/control/b", 0.0, np.zeros(3))
        with pytest.raises(ValueError, match="width must not change"):
            rec.log_scalars("/control/b", 0.1, np.zeros(4))


def test_bad_truth_vector_raises_at_flush(tmp_path: Path) -> None:
    rec = Recorder(tmp_path / "t.rrd", recording_id="t", start_utc=START)
    truth = {**_truth(0), "position_n": np.zeros(2)}
    rec.log_truth(0.0, **truth)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="position_n"):
        rec.close()
    assert rec.closed
    RrdReader(tmp_path / "t.rrd").store()  # still finalized


def test_truth_accepts_sequences(tmp_path: Path) -> None:
    with Recorder(tmp_path / "seq.rrd", recording_id="seq", start_utc=START) as rec:
        rec.log_truth(
            0.0,
            position_n=[1.0, 2.0, -3.0],  # type: ignore[arg-type]
            quat_wxyz=(1.0, 0.0, 0.0, 0.0),  # type: ignore[arg-type]
            velocity_n=[0.0, 0.0, 0.0],  # type: ignore[arg-type]
            rpy_deg=[0.0, 0.0, 0.0],  # type: ignore[arg-type]
            heading_deg=0.0,
            depth_m=3.0,
        )
    table = _table(RrdReader(tmp_path / "seq.rrd").store(), "/world/auv")
    assert table.column("Transform3D:translation").to_pylist()[0] == [[1.0, 2.0, -3.0]]


def test_naive_start_utc_is_rejected(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="timezone-aware"):
        Recorder(tmp_path / "n.rrd", recording_id="n", start_utc=dt.datetime(2024, 6, 21))


def test_tank_scene(tmp_path: Path) -> None:
    with Recorder(tmp_path / "tank.rrd", recording_id="tank", start_utc=START) as rec:
        rec.log_static_scene(
            waypoints_n=None,
            vehicle_half_sizes=HALF_SIZES,
            seabed_z=-4.0,
            tank_half_sizes=(6, 3, 2),
        )
    store = RrdReader(tmp_path / "tank.rrd").store()
    [chunk] = store.stream().filter(content="/world/tank").to_chunks()
    rb = chunk.to_record_batch()
    assert rb.column("Boxes3D:centers").to_pylist()[0] == [[0.0, 0.0, -2.0]]
    assert rb.column("Boxes3D:half_sizes").to_pylist()[0] == [[6.0, 3.0, 2.0]]


def test_the_run_blueprint_has_a_tab_per_filter_variant(tmp_path: Path) -> None:
    with Recorder(tmp_path / "v.rrd", recording_id="v", start_utc=START, variants=("ins", "lig")):
        pass
    views = {(cls, origin) for cls, _, origin in _views(tmp_path / "v.rrd")}
    for v in ("ins", "lig"):
        for series in ("heading_error_deg", "attitude_error_deg", "position_error_m"):
            assert ("TimeSeries", f"/nav/{v}/{series}") in views
        assert ("TimeSeries", f"/nav/{v}/nees_attitude") in views
    # Compass fixes are scored per fix for a compass variant only.
    assert ("TimeSeries", "/nav/lig/compass_fix_error_deg") in views
    assert ("TimeSeries", "/nav/ins/compass_fix_error_deg") not in views
