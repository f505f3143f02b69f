"""A run as ROS 2 messages in MCAP (twin.record.mcap_log), read back by an independent reader.

The file is written with mcap-ros2-support's CDR encoder and read here with rosbags' own reader
and CDR decoder, and checked against what the run wrote by another path (its Parquet time series)
or against the readings themselves.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

import scenarios
from twin.record.mcap_log import B_FROM_FLU, McapLog
from twin.scoring.observer import RunScorer
from twin.sim.build import build_simulation

EXPECTED_TYPES = {
    "/imu": "sensor_msgs/msg/Imu",
    "/depth/pressure": "sensor_msgs/msg/FluidPressure",
    "/polarimeter/image_raw": "sensor_msgs/msg/Image",
    "/polarimeter/camera_info": "sensor_msgs/msg/CameraInfo",
    "/polarimeter/dofp_layout": "auv_twin_msgs/msg/DofpLayout",
    "/truth/odom": "nav_msgs/msg/Odometry",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
}


def _read(path: Path) -> dict[str, list[tuple[int, object]]]:
    """topic → [(log time ns, decoded message)], and the connections' types, via rosbags."""
    out: dict[str, list[tuple[int, object]]] = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as r:
        types = {c.topic: c.msgtype for c in r.connections}
        for conn, t, raw in r.messages():
            out.setdefault(conn.topic, []).append((t, r.deserialize(raw, conn.msgtype)))
    out["__types__"] = list(types.items())  # type: ignore[assignment]
    return out


def _ns(start: dt.datetime, t: float) -> int:
    epoch = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
    return (start - epoch) // dt.timedelta(microseconds=1) * 1000 + round(t * 1e9)


def _stamp_ns(msg: object) -> int:
    s = msg.header.stamp  # type: ignore[attr-defined]
    return s.sec * 1_000_000_000 + s.nanosec


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory) -> Path:
    """`auv-twin run default --mcap --timeseries`, 8 s."""
    tmp = tmp_path_factory.mktemp("mcap")
    text = (
        scenarios.shipped()["default"].read_text().replace("duration_s = 300.0", "duration_s = 8.0")
    )
    f = tmp / "short.toml"
    f.write_text(text)
    out = tmp / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "twin.app.cli", "run", str(f), "--out", str(out), "--quiet",
         "--no-camera", "--mcap", "--timeseries"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "mcap:" in proc.stdout
    return out


def test_the_topics_types_and_counts_are_the_runs(cli_run: Path) -> None:
    msgs = _read(cli_run / "run.mcap")
    types = dict(msgs.pop("__types__"))  # type: ignore[arg-type]
    for topic, typ in EXPECTED_TYPES.items():
        assert types[topic] == typ
    sc = scenarios.load(str(cli_run.parent / "short.toml"))
    for v in sc.navigation.variants:
        assert types[f"/nav/{v}/odom"] == "nav_msgs/msg/Odometry"
    ts = cli_run / "timeseries"
    assert len(msgs["/imu"]) == len(pd.read_parquet(ts / "readings_imu.parquet"))
    assert len(msgs["/depth/pressure"]) == len(pd.read_parquet(ts / "readings_depth.parquet"))
    truth = pd.read_parquet(ts / "truth.parquet")
    assert len(msgs["/truth/odom"]) == len(msgs["/tf"]) == len(truth)
    fixes = pd.read_parquet(ts / "compass_fixes.parquet")
    for v in sc.navigation.variants:
        assert len(msgs[f"/nav/{v}/odom"]) == len(truth)
        n_fix = int((fixes["variant"] == v).sum())
        assert len(msgs.get(f"/nav/{v}/compass_fix", [])) == n_fix
    n_frames = len(msgs["/polarimeter/image_raw"])
    assert n_frames == len(msgs["/polarimeter/camera_info"]) >= 8  # 1 Hz over 8 s
    metrics = json.loads((cli_run / "metrics.json").read_text())
    assert metrics["mcap"]["messages"]["/imu"] == len(msgs["/imu"])


def test_the_values_and_stamps_are_the_runs(cli_run: Path) -> None:
    msgs = _read(cli_run / "run.mcap")
    sc = scenarios.load(str(cli_run.parent / "short.toml"))
    ts = cli_run / "timeseries"
    imu = pd.read_parquet(ts / "readings_imu.parquet")
    for (t_log, m), (_, row) in zip(msgs["/imu"], imu.iterrows(), strict=True):
        assert _stamp_ns(m) == _ns(sc.start_utc, row["t"])
        assert t_log == _ns(sc.start_utc, row["t_delivered"])
        got = (m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z)
        want = tuple(row[f"angular_rate[{i}]"] for i in range(3))
        assert got == want
        assert m.linear_acceleration.z == row["specific_force[2]"]
        assert m.orientation_covariance[0] == -1.0
    depth = pd.read_parquet(ts / "readings_depth.parquet")
    got = [m.fluid_pressure for _, m in msgs["/depth/pressure"]]
    np.testing.assert_array_equal(got, depth["pressure_pa"].to_numpy())
    truth = pd.read_parquet(ts / "truth.parquet")
    for (_, m), (_, row) in zip(msgs["/truth/odom"], truth.iterrows(), strict=True):
        p = m.pose.pose.position
        assert (p.x, p.y, p.z) == (row["east_m"], row["north_m"], row["up_m"])
        assert _stamp_ns(m) == _ns(sc.start_utc, row["t"])
        assert _heading_deg(m.pose.pose.orientation) == pytest.approx(row["heading_deg"], abs=1e-9)
        v = _dcm(m.pose.pose.orientation) @ _vec(m.twist.twist.linear)  # base_link → map
        assert v == pytest.approx(
            [row["v_east_mps"], row["v_north_mps"], row["v_up_mps"]], abs=1e-9
        )
    filters = pd.read_parquet(ts / "filters.parquet")
    for variant in sc.navigation.variants:
        rows = filters[filters["variant"] == variant]
        odom = msgs[f"/nav/{variant}/odom"]
        assert len(odom) == len(rows)
        for (_, m), (_, row) in zip(odom, rows.iterrows(), strict=True):
            assert _heading_deg(m.pose.pose.orientation) == pytest.approx(
                row["heading_deg"], abs=1e-6
            )
            cov = np.asarray(m.pose.covariance).reshape(6, 6)
            # The heading σ of the sample is √P[φ_U, φ_U]: the pose's rotation-about-z variance.
            assert math.degrees(math.sqrt(cov[5, 5])) == pytest.approx(
                row["heading_sigma_deg"], rel=1e-9
            )
            assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > -1e-12)
    fixes = pd.read_parquet(ts / "compass_fixes.parquet")
    for variant in sc.navigation.variants:
        rows = fixes[fixes["variant"] == variant]
        for (_, m), (_, row) in zip(
            msgs.get(f"/nav/{variant}/compass_fix", []), rows.iterrows(), strict=True
        ):
            assert m.ok == row["ok"]
            if row["ok"] and row["heading_deg"] is not None and not pd.isna(row["heading_deg"]):
                assert m.heading_deg == pytest.approx(row["heading_deg"], abs=1e-12)
            else:
                assert math.isnan(m.heading_deg) or not m.ok
    info = msgs["/polarimeter/camera_info"][0][1]
    img = msgs["/polarimeter/image_raw"][0][1]
    assert (img.width, img.height, img.encoding, img.step) == (
        info.width,
        info.height,
        "mono16",
        2 * info.width,
    )
    assert info.distortion_model == "equidistant" and len(info.d) == 4
    layout = msgs["/polarimeter/dofp_layout"][0][1]
    # The vehicle's calibrated layout: the nominal 0/45/90/135° within the unit's drawn error.
    assert np.sort(np.asarray(layout.analyser_deg) % 180.0) == pytest.approx(
        [0.0, 45.0, 90.0, 135.0], abs=1.0
    )


def test_the_image_is_the_frame_the_vehicle_received(tmp_path: Path) -> None:
    """The mosaic's bytes against the raw frame of the same reading, and /tf_static's sites."""
    sc = dataclasses.replace(scenarios.load("default"), duration_s=2.5)
    world = build_simulation(sc)
    scorer = RunScorer(world)
    log = McapLog(tmp_path / "run.mcap", world, scorer, sc.start_utc, {"test": True})
    frames: list[np.ndarray] = []

    class Keep:
        def on_step(self, sim, result) -> None:
            frames.extend(np.array(r["raw"]) for r in result.readings if "raw" in r.values)

    world.observers[:] = [scorer, log, Keep()]
    world.fly(sc.duration_s)
    log.close()
    msgs = _read(tmp_path / "run.mcap")
    images = [m for _, m in msgs["/polarimeter/image_raw"]]
    assert len(images) == len(frames) >= 2
    for m, raw in zip(images, frames, strict=True):
        got = np.frombuffer(bytes(m.data), dtype="<u2").reshape(m.height, m.width)
        np.testing.assert_array_equal(got, raw)
    # /tf_static: every sensor site under base_link, at the site's place in the body.
    ((_, tf_static),) = msgs["/tf_static"]
    children = {t.child_frame_id: t for t in tf_static.transforms}
    assert {s.site for s in world.suite.sensors if s.site} == set(children)
    body = world.plant.truth()
    c_flu = _quat_dcm_wxyz(body.quat_wxyz) @ B_FROM_FLU
    for name, t in children.items():
        pos, _ = world.plant.site_pose(name)
        rel = c_flu.T @ (np.asarray(pos) - body.position_n)
        tr = t.transform.translation
        assert (tr.x, tr.y, tr.z) == pytest.approx(tuple(rel), abs=1e-9)


# ---- helpers --------------------------------------------------------------------------------
def _vec(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z])


def _dcm(q) -> np.ndarray:
    return _quat_dcm_wxyz(np.array([q.w, q.x, q.y, q.z]))


def _quat_dcm_wxyz(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _heading_deg(q) -> float:
    """Compass heading of base_link's x (forward) axis in map (ENU)."""
    fwd = _dcm(q)[:, 0]
    return math.degrees(math.atan2(fwd[0], fwd[1])) % 360.0
