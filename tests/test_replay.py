"""`auv-twin replay`: the onboard stack on a recorded log (twin.app.replay).

A twin run exported to MCAP and replayed gives the run's estimates; a rosbag2 folder without the
twin's metadata replays with the user's scenario and calibration; bad logs are one-line errors.
"""

from __future__ import annotations

import dataclasses
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer as RawWriter
from rrd_helpers import entities

import scenarios
from twin.app.replay import LogError, read_log, replay

SHORT = 8.0


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """`auv-twin run default --mcap --timeseries`, 8 s, and the scenario file beside it."""
    tmp = tmp_path_factory.mktemp("replay")
    text = scenarios.shipped()["default"].read_text()
    text = text.replace("duration_s = 300.0", f"duration_s = {SHORT}")
    (tmp / "short.toml").write_text(text)
    out = tmp / "run"
    _cli("run", str(tmp / "short.toml"), "--out", str(out), "--quiet", "--no-camera", "--mcap",
         "--timeseries")  # fmt: skip
    return out


def m_rep_variants(out: Path) -> list[str]:
    return list(json.loads((out / "metrics.json").read_text())["navigation"]["variants"])


def _cli(*args: str, ok: bool = True) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [sys.executable, "-m", "twin.app.cli", *args], capture_output=True, text=True, timeout=600
    )
    if ok:
        assert proc.returncode == 0, proc.stderr
    return proc


def test_a_twin_run_replayed_gives_the_runs_estimates(run_dir: Path, tmp_path: Path) -> None:
    """Round trip: the same estimates to the ROS stamps' nanosecond rounding of the run's times.

    Measured (2026-12-05, 8 s, INS + POL/INS + LIG/INS): positions bit-identical, headings within
    7e-11°, compass fixes within 1.4e-10°: a header stamp is whole nanoseconds, the simulation's
    clock a float sum of its steps (1.3e-13 s apart after 8 s), so the INS integrates over time
    steps that differ in the 13th digit.
    """
    out = tmp_path / "replayed"
    proc = _cli("replay", str(run_dir / "run.mcap"), "--out", str(out))
    assert "heading RMSE" in proc.stdout
    run = pd.read_parquet(run_dir / "timeseries" / "filters.parquet")
    rep = pd.read_parquet(out / "timeseries" / "filters.parquet")
    assert len(rep) == len(run) > 0
    assert list(rep["variant"]) == list(run["variant"])
    assert np.abs(rep["t"].to_numpy() - run["t"].to_numpy()).max() < 1e-9
    assert np.abs(rep["heading_deg"].to_numpy() - run["heading_deg"].to_numpy()).max() < 1e-8
    assert np.abs(rep["east_m"].to_numpy() - run["east_m"].to_numpy()).max() < 1e-6
    assert np.abs(rep["north_m"].to_numpy() - run["north_m"].to_numpy()).max() < 1e-6
    rel = np.abs(rep["heading_sigma_deg"] / run["heading_sigma_deg"] - 1.0).max()
    assert rel < 1e-9
    fr = pd.read_parquet(run_dir / "timeseries" / "compass_fixes.parquet")
    fp = pd.read_parquet(out / "timeseries" / "compass_fixes.parquet")
    assert len(fp) == len(fr) > 0 and list(fp["ok"]) == list(fr["ok"])
    h = fr["heading_deg"].astype(float).to_numpy()
    g = fp["heading_deg"].astype(float).to_numpy()
    assert np.array_equal(np.isnan(h), np.isnan(g))
    assert np.nanmax(np.abs(h - g)) < 1e-8
    # The recording: the reference as the run's truth, each variant's samples and fixes.
    ents = entities(out / "recording.rrd")
    assert ents["/world/auv"] > 0
    for v in m_rep_variants(out):
        assert any(e.startswith(f"/nav/{v}/") for e in ents), v
    m_run = json.loads((run_dir / "metrics.json").read_text())
    m_rep = json.loads((out / "metrics.json").read_text())
    for v, nav in m_rep["navigation"]["variants"].items():
        assert nav["heading_rmse_deg"] == pytest.approx(
            m_run["navigation"]["variants"][v]["heading_rmse_deg"], abs=1e-6
        )


def test_a_rosbag2_log_replays_with_the_users_scenario_and_calibration(
    run_dir: Path, tmp_path: Path
) -> None:
    """No twin metadata: the scenario, the calibration and the depth constants come from the user,
    the initial solution from the reference's first message."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / "bag"
    keep = {"/imu", "/depth/pressure", "/polarimeter/image_raw", "/truth/odom"}
    _, meta, messages = read_log(run_dir / "run.mcap")
    with Writer(bag, version=8) as w:
        conns: dict[str, object] = {}
        for m in messages:
            if m.topic not in keep:
                continue
            if m.topic not in conns:
                conns[m.topic] = w.add_connection(m.topic, m.msgtype, typestore=store)
            w.write(conns[m.topic], m.log_ns, store.serialize_cdr(m.msg, m.msgtype))
    cal = tmp_path / "calibration.json"
    cal.write_text(meta["auv_twin.replay"]["calibration"])
    depth = json.loads(meta["auv_twin.replay"]["depth"])
    scenario = tmp_path / "vehicle.toml"
    scenario.write_text(
        (run_dir.parent / "short.toml").read_text()
        + "\n[sensors.depth_overrides]\n"
        + f"declared_density_kg_m3 = {depth['rho_kg_m3']!r}\n"
        + f"declared_gravity_mps2 = {depth['g_mps2']!r}\n"
        + f"declared_atmospheric_pressure_pa = {depth['p_atm_pa']!r}\n"
    )
    # Without the calibration the compass variants cannot run: a one-line error.
    bad = _cli(
        "replay", str(bag), "--scenario", str(scenario), "--out", str(tmp_path / "x"), ok=False
    )
    assert bad.returncode == 2 and "--calibration" in bad.stderr
    out = tmp_path / "replayed"
    _cli("replay", str(bag), "--scenario", str(scenario), "--calibration", str(cal),
         "--out", str(out))  # fmt: skip
    m = json.loads((out / "metrics.json").read_text())
    assert m["scored"] is True
    # The readings before the reference's first message (0.1 s) wait for an initial solution.
    assert m["messages"]["/imu"] == int(SHORT * 100)
    assert m["skipped_before_initial_solution"]["/imu"] == 10  # 0.01 … 0.10 s
    for nav in m["navigation"]["variants"].values():
        # Started at the reference (no alignment error): headings within a few degrees.
        assert nav["samples"] == int(SHORT * 10) and nav["heading_rmse_deg"] < 5.0
        assert nav["position_drift_final_m"] < 50.0


def _rewrite(src: Path, dst: Path, edit) -> None:
    """Copy an MCAP file record by record (raw CDR), letting ``edit`` drop, reorder or alter."""
    with open(src, "rb") as f:
        reader = make_reader(f)
        metadata = list(reader.iter_metadata())
        records = [(s, c, m) for s, c, m in reader.iter_messages(log_time_order=True)]
    with open(dst, "wb") as f:
        w = RawWriter(f)
        w.start(profile="ros2")
        schemas: dict[int, int] = {}
        chans: dict[int, int] = {}
        for md in metadata:
            w.add_metadata(md.name, dict(md.metadata))
        for s, c, m in edit(records):
            if s.id not in schemas:
                schemas[s.id] = w.register_schema(s.name, s.encoding, s.data)
            if c.id not in chans:
                chans[c.id] = w.register_channel(c.topic, c.message_encoding, schemas[s.id])
            w.add_message(chans[c.id], m.log_time, m.data, m.publish_time, m.sequence)
        w.finish()


def _imu_indices(records) -> list[int]:
    return [i for i, (_, c, _) in enumerate(records) if c.topic == "/imu"]


def _drop_depth(r):
    return [x for x in r if x[1].topic != "/depth/pressure"]


def _duplicate_imu(r):
    i = _imu_indices(r)
    return [*r[: i[5]], r[i[4]], *r[i[5] :]]


def _imu_back(r):
    i = _imu_indices(r)
    return _swap(r, i[5], i[6])


def _wrong_encoding(r):
    return [_encoding(x) for x in r]


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (_drop_depth, "'/depth/pressure' \\(depth\\) is not in it"),
        (_duplicate_imu, "'/imu': the stamp repeats"),
        (_imu_back, "'/imu': the stamp goes back"),
        (_wrong_encoding, "encoding 'rgba16'"),
    ],
    ids=["missing topic", "duplicate stamp", "stamp goes back", "wrong encoding"],
)
def test_bad_logs_are_one_line_errors(run_dir: Path, tmp_path: Path, edit, needle: str) -> None:
    bad = tmp_path / "bad.mcap"
    _rewrite(run_dir / "run.mcap", bad, edit)
    with pytest.raises(LogError, match=needle) as err:
        replay(bad, tmp_path / "out")
    assert "\n" not in str(err.value)


def _swap(records, i: int, j: int):
    r = list(records)
    (si, ci, mi), (sj, cj, mj) = r[i], r[j]
    # Keep the log times in place (the file stays in delivery order); swap the payloads.
    r[i] = (si, ci, dataclasses.replace(mi, data=mj.data))
    r[j] = (sj, cj, dataclasses.replace(mj, data=mi.data))
    return r


def _encoding(rec):
    s, c, m = rec
    if c.topic != "/polarimeter/image_raw":
        return rec
    data = m.data.replace(b"mono16", b"rgba16", 1)
    return (s, c, dataclasses.replace(m, data=data))


def test_a_file_that_is_not_a_log_is_a_clear_error(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    with pytest.raises(LogError, match="not a readable MCAP file"):
        replay(junk, tmp_path / "out")
    proc = _cli("replay", str(tmp_path / "missing.mcap"), "--out", str(tmp_path / "o"), ok=False)
    assert proc.returncode == 2 and "no such file" in proc.stderr


def _drop_imu(first: int, last: int):
    def edit(r):
        gone = set(_imu_indices(r)[first:last])
        return [x for k, x in enumerate(r) if k not in gone]

    return edit


def test_an_imu_gap_is_flown_through_and_listed(run_dir: Path, tmp_path: Path) -> None:
    gap = tmp_path / "gap.mcap"
    _rewrite(run_dir / "run.mcap", gap, _drop_imu(300, 350))
    m = replay(gap, tmp_path / "out")
    assert len(m["imu_gaps"]) == 1
    assert m["imu_gaps"][0]["length_s"] == pytest.approx(0.51, abs=1e-6)
    assert m["navigation"]["variants"]["ins"]["samples"] == int(SHORT * 10)
    # Longer than the INS integrates over (1 s): a one-line error naming the gap.
    _rewrite(run_dir / "run.mcap", gap, _drop_imu(300, 401))
    with pytest.raises(LogError, match=re.escape("a gap of 1.020 s after t = 3.000 s")):
        replay(gap, tmp_path / "out2")


def test_a_scenario_that_fuses_the_gravimeter_is_refused(run_dir: Path, tmp_path: Path) -> None:
    """The stored map is the world's draw and no log carries it: refused, not silently off."""
    with pytest.raises(LogError, match="fuses the gravimeter against a stored map"):
        replay(run_dir / "run.mcap", tmp_path / "out", scenario=scenarios.load("gravity_aided"))
