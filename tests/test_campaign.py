"""Campaigns (groundwork of issue 10): specs, the local pool, Parquet rows, resume, isolation."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from twin.app.cli import main
from twin.campaign.report import write_report
from twin.campaign.results import load_campaign_results
from twin.campaign.runner import _job, execute_run, run_campaign
from twin.campaign.spec import CampaignError, RunSpec, load_campaign, parse_campaign, set_path
from twin.campaign.stats import fmt_ci

SMALL = """
name = "small"
base = "tank"
seeds = 2
metrics = ["depth_error_rms_m", "distance_travelled_m", "final.*", "sim_time_s"]
[set]
duration_s = 2.0
[[sweep]]
path = ["initial.depth_m", "mission.legs[*].depth_m"]
values = [1.0, 2.0]
"""


@pytest.fixture()
def small_spec(tmp_path: Path) -> Path:
    p = tmp_path / "small.toml"
    p.write_text(SMALL)
    return p


def test_a_spec_resolves_to_hashed_runs_with_every_scenario_checked(small_spec: Path) -> None:
    spec = load_campaign(small_spec)
    assert len(spec.runs) == 4  # 2 depths x 2 seeds
    assert len({r.run_id for r in spec.runs}) == 4
    # The identity is the resolved scenario and seed: the same spec gives the same ids.
    assert [r.run_id for r in load_campaign(small_spec).runs] == [r.run_id for r in spec.runs]
    r = spec.runs[2]
    assert dict(r.params) == {"initial.depth_m": 2.0} and r.seed == 0
    assert r.scenario["initial"]["depth_m"] == 2.0
    assert all(leg["depth_m"] == 2.0 for leg in r.scenario["mission"]["legs"])
    assert r.scenario["duration_s"] == 2.0


def test_ranges_random_draws_and_zip(tmp_path: Path) -> None:
    data = {
        "name": "axes",
        "base": "tank",
        "combine": "zip",
        "seeds": [3],
        "random_seed": 7,
        "sweep": [
            {"path": "optics.wind_speed_mps", "range": {"start": 0.0, "stop": 6.0, "step": 2.0}},
            {
                "path": "water.temperature_c",
                "random": {"distribution": "uniform", "low": 5.0, "high": 25.0, "count": 3},
            },
        ],
    }
    a, b = parse_campaign(data), parse_campaign(data)
    assert [dict(r.params)["optics.wind_speed_mps"] for r in a.runs] == [0.0, 2.0, 4.0]
    temps = [dict(r.params)["water.temperature_c"] for r in a.runs]
    assert temps == [dict(r.params)["water.temperature_c"] for r in b.runs]  # seeded draws
    assert all(5.0 <= t <= 25.0 for t in temps) and len(set(temps)) == 3


@pytest.mark.parametrize(
    ("edit", "text"),
    [
        ({"colour": "red"}, "colour: unknown key"),
        ({"seeds": 0}, "seeds: 0"),
        ({"combine": "mix"}, 'combine: "mix"'),
        ({"base": "nowhere"}, 'base: "nowhere"'),
        ({"sweep": [{"path": "water.jerlov_type", "values": ["II", "XX"]}]}, "water.jerlov_type"),
        ({"sweep": [{"path": "a..b", "values": [1]}]}, "not a dotted path"),
        ({"sweep": [{"path": "x", "range": {"start": 2, "stop": 1}}]}, "stop > start"),
        ({"sweep": [{"path": "x", "random": {"distribution": "cauchy", "count": 2}}]}, "cauchy"),
        ({"set": {"nothing": {"here": 1}}}, "no field 'nothing'"),
    ],
)
def test_bad_specs_name_the_field(edit: dict, text: str) -> None:
    data = {"name": "bad", "base": "tank", **edit}
    with pytest.raises(CampaignError) as info:
        parse_campaign(data)
    assert text in str(info.value)


def test_an_invalid_swept_value_names_the_run() -> None:
    data = {"name": "bad", "base": "tank", "sweep": [{"path": "duration_s", "values": [1.0, -5]}]}
    with pytest.raises(CampaignError, match=r"run with duration_s = -5: duration_s"):
        parse_campaign(data)


def test_set_path_reaches_tables_arrays_and_every_item() -> None:
    d = {"a": {"b": [{"c": 1}, {"c": 2}]}}
    set_path(d, "a.b[*].c", 9)
    set_path(d, "a.b[0].e", 3)
    assert d == {"a": {"b": [{"c": 9, "e": 3}, {"c": 9}]}}
    with pytest.raises(KeyError, match="out of range"):
        set_path(d, "a.b[5].c", 1)


def test_same_numbers_whatever_the_worker_count_and_rows_read_back(
    small_spec: Path, tmp_path: Path
) -> None:
    spec = load_campaign(small_spec)
    one, two = tmp_path / "one", tmp_path / "two"
    assert run_campaign(spec, one, workers=1) == {"ok": 4}
    assert run_campaign(spec, two, workers=2) == {"ok": 4}
    a = pd.read_parquet(one / "results.parquet")
    b = load_campaign_results(two)
    assert list(a["run_id"]) == [r.run_id for r in spec.runs] == list(b["run_id"])
    metrics = [c for c in a.columns if c.startswith("metric.")]
    assert "metric.final.depth_m" in metrics and "param.initial.depth_m" in a.columns
    for c in metrics:
        if c != "metric.wall_time_s":
            np.testing.assert_array_equal(a[c].to_numpy(), b[c].to_numpy(), err_msg=c)
    # The swept depth really changed the run.
    d = a.groupby("param.initial.depth_m")["metric.final.depth_m"].mean()
    assert d[1.0] == pytest.approx(1.0, abs=0.3) and d[2.0] == pytest.approx(2.0, abs=0.3)
    # A re-run skips what is on disk.
    assert run_campaign(spec, one, workers=1, on_message=lambda m: None) == {}


def test_a_failing_run_and_a_slow_run_are_recorded_and_the_campaign_goes_on(
    small_spec: Path, tmp_path: Path
) -> None:
    spec = load_campaign(small_spec)
    job = _job(spec)
    broken = RunSpec(99, (), 0, {**spec.runs[0].scenario, "duration_s": "long"})
    row = execute_run(broken, job)
    assert row["status"] == "error" and "duration_s" in row["error"]
    # 1 ms: no run finishes that fast, on any machine (50 ms did, once runs got quick enough).
    slow = execute_run(spec.runs[0], {**job, "wall_time_limit_s": 0.001})
    assert slow["status"] == "timeout" and "wall-time limit" in slow["error"]
    ok = execute_run(spec.runs[0], job)
    assert ok["status"] == "ok"


def test_sigkill_loses_only_runs_in_flight_and_the_same_command_resumes(tmp_path: Path) -> None:
    spec_path = tmp_path / "k.toml"
    # 100 runs: a dozen 2 s tank trials wrote their rows within 0.15 s on two workers (measured
    # 2026-12-07), close to the poll below; a hundred cannot, and the kill lands with most to run.
    spec_path.write_text(SMALL.replace("seeds = 2", "seeds = 50"))
    out = tmp_path / "k"
    cmd = [sys.executable, "-m", "twin.app.cli", "campaign", "run", str(spec_path)]
    cmd += ["--out", str(out), "--quiet"]
    env = {**os.environ, "MUJOCO_GL": "disable"}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(list((out / "runs").glob("*.parquet"))) < 3:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    rows = load_campaign_results(out)  # readable after SIGKILL
    assert 3 <= len(rows) < 100 and set(rows["status"]) == {"ok"}
    assert main(["campaign", "run", str(spec_path), "--out", str(out), "--quiet"]) == 0
    final = load_campaign_results(out)
    assert len(final) == 100 and final["run_id"].is_unique
    assert set(rows["run_id"]) <= set(final["run_id"])


def test_resuming_with_an_added_axis_reuses_runs_and_labels_them_with_it(tmp_path: Path) -> None:
    """A new axis whose values include the base's own reuses the runs already made; their rows
    then carry the new axis and the new order, so grouping by it finds them."""
    first = parse_campaign(
        {
            "name": "grow",
            "base": "tank",
            "seeds": 1,
            "set": {"duration_s": 2.0},
            "sweep": [{"path": "initial.depth_m", "values": [1.0]}],
        }
    )
    out = tmp_path / "grow"
    assert run_campaign(first, out, workers=1) == {"ok": 1}
    grown = parse_campaign(
        {
            "name": "grow",
            "base": "tank",
            "seeds": 1,
            "set": {"duration_s": 2.0},
            "sweep": [
                {"path": "water.temperature_c", "values": [10.0, 25.0]},  # 25: the tank's own
                {"path": "initial.depth_m", "values": [1.0]},
            ],
        }
    )
    messages: list[str] = []
    assert run_campaign(grown, out, workers=1, on_message=messages.append) == {"ok": 1}
    assert any("resuming: 1 of 2" in m for m in messages)
    rows = load_campaign_results(out)
    assert len(rows) == 2 and rows["param.water.temperature_c"].notna().all()
    reused = rows[rows["param.water.temperature_c"] == 25.0]
    expected = next(r for r in grown.runs if dict(r.params)["water.temperature_c"] == 25.0)
    assert list(reused["run_id"]) == [expected.run_id]
    assert list(reused["index"]) == [expected.index]


def test_ctrl_c_stops_the_pool_cleanly_and_says_how_to_resume(tmp_path: Path) -> None:
    spec_path = tmp_path / "i.toml"
    # 100 runs of 4 s (a dozen take ~0.2 s on 2 workers): the Ctrl-C lands with most to run.
    spec_path.write_text(SMALL.replace("seeds = 2", "seeds = 50").replace("2.0\n[[", "4.0\n[["))
    out = tmp_path / "i"
    cmd = [sys.executable, "-m", "twin.app.cli", "campaign", "run", str(spec_path)]
    cmd += ["--out", str(out), "--quiet", "--workers", "2"]
    env = {**os.environ, "MUJOCO_GL": "disable"}
    # Its own process group, signalled as a whole: what a terminal's Ctrl-C does.
    proc = subprocess.Popen(
        cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline and not list((out / "runs").glob("*.parquet")):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    text = err.decode()
    assert proc.returncode == 130, text
    assert "Traceback" not in text
    assert "run the same command again to resume" in text
    rows = load_campaign_results(out)
    assert 1 <= len(rows) < 100 and set(rows["status"]) == {"ok"}
    assert main(["campaign", "run", str(spec_path), "--out", str(out), "--quiet"]) == 0
    assert len(load_campaign_results(out)) == 100


def test_cli_validate_reports_in_one_place(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\nbase = "tank"\nseeds = -1\n')
    assert main(["campaign", "validate", str(bad)]) == 2  # the exit code of run
    err = capsys.readouterr().err
    assert "seeds: -1" in err and "Traceback" not in err
    assert main(["campaign", "run", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()


# ---- Ray: a real local instance, and a real head node on 127.0.0.1 ----------------------------
def test_ray_gives_the_local_pools_numbers(small_spec: Path, tmp_path: Path) -> None:
    spec = load_campaign(small_spec)
    assert run_campaign(spec, tmp_path / "pool", workers=1) == {"ok": 4}
    assert run_campaign(spec, tmp_path / "ray", workers=2, use_ray=True) == {"ok": 4}
    a, b = load_campaign_results(tmp_path / "pool"), load_campaign_results(tmp_path / "ray")
    assert list(a["run_id"]) == list(b["run_id"])
    for c in (c for c in a.columns if c.startswith("metric.") and c != "metric.wall_time_s"):
        np.testing.assert_array_equal(a[c].to_numpy(), b[c].to_numpy(), err_msg=c)


def test_a_campaign_runs_on_a_ray_head_node_at_its_address(
    small_spec: Path, tmp_path: Path, monkeypatch
) -> None:
    import sysconfig

    # A loopback-only cluster for the test: Ray's token authentication is switched off for it.
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    ray_cli = str(Path(sysconfig.get_path("scripts")) / "ray")
    port = _start_ray_head(ray_cli)
    try:
        spec = load_campaign(small_spec)
        counts = run_campaign(spec, tmp_path / "c", use_ray=True, ray_address=f"127.0.0.1:{port}")
        assert counts == {"ok": 4}
        assert len(load_campaign_results(tmp_path / "c")) == 4
    finally:
        subprocess.run([ray_cli, "stop", "--force"], capture_output=True, timeout=120)


def _free_ports(n: int) -> list[int]:
    """``n`` distinct loopback ports that are free now (all bound at once, then released)."""
    import socket

    socks = [socket.socket() for _ in range(n)]
    try:
        for s in socks:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def _start_ray_head(ray_cli: str, tries: int = 3) -> int:
    """Start a Ray head node on 127.0.0.1 and return its GCS port.

    Every port of the head's own services is given explicitly. A GCS port drawn from the
    ephemeral range once landed on 52365, the default port of the dashboard agent, and the head
    could not start (CI, stop 23). The Ray client server's port is left alone (naming it starts
    that server, which needs ``ray[client]``); workers take 10002–19999, below the ephemeral
    range. A port can still be taken between drawing and binding, so a failed start is retried
    with fresh ports; the last failure's own output is in the message.
    """
    names = (
        "--port",
        "--dashboard-agent-listen-port",
        "--dashboard-agent-grpc-port",
        "--runtime-env-agent-port",
        "--metrics-export-port",
        "--node-manager-port",
        "--object-manager-port",
    )
    err = ""
    for _ in range(tries):
        ports = _free_ports(len(names))
        start = [ray_cli, "start", "--head", "--node-ip-address", "127.0.0.1"]
        for name, port in zip(names, ports, strict=True):
            start += [name, str(port)]
        start += ["--num-cpus", "2", "--include-dashboard", "false", "--disable-usage-stats"]
        done = subprocess.run(start, capture_output=True, text=True, timeout=120)
        if done.returncode == 0:
            return ports[0]
        err = (done.stdout + done.stderr)[-2000:]
        subprocess.run([ray_cli, "stop", "--force"], capture_output=True, timeout=120)
    raise AssertionError(f"ray start --head failed {tries} times; last output:\n{err}")


# ---- the report ---------------------------------------------------------------------------------
def test_the_report_computes_from_the_rows_and_draws_real_figures(tmp_path: Path) -> None:
    import matplotlib.image as mpimg

    spec = parse_campaign(
        {
            "name": "rep",
            "base": "default",
            "seeds": 3,
            "metrics": ["navigation.variants.*.heading_rmse_deg"],
            "set": {"duration_s": 2.0},
            "sweep": [
                {"path": ["initial.depth_m", "mission.legs[*].depth_m"], "values": [5.0, 12.0]}
            ],
        }
    )
    out = tmp_path / "rep"
    assert run_campaign(spec, out) == {"ok": 6}
    import twin  # the one-call API

    pd.testing.assert_frame_equal(twin.load_campaign_results(out), load_campaign_results(out))
    md = write_report(out)
    text = md.read_text()
    folder = out / "report" / "heading_rmse_deg"
    assert md == folder / "report.md"
    groups = pd.read_csv(folder / "groups.csv")
    rows = load_campaign_results(out)
    # The table is the rows' statistics: the mean per (depth, variant) is pandas' own.
    for _, g in groups.iterrows():
        sel = rows[rows["param.initial.depth_m"] == g["param.initial.depth_m"]]
        col = f"metric.navigation.variants.{g['variant']}.heading_rmse_deg"
        assert g["mean"] == pytest.approx(sel[col].mean())
        assert g["mean_lo"] <= g["mean"] <= g["mean_hi"] and g["n"] == 3
        assert fmt_ci(g["mean"], g["mean_lo"], g["mean_hi"]) in text
    paired = pd.read_csv(folder / "paired.csv")
    assert set(zip(paired["a"], paired["b"], strict=True)) == {
        ("ins", "lig"),
        ("ins", "pol"),
        ("lig", "pol"),
    }
    for name in (
        "heading_rmse_deg_vs_initial_depth_m",
        "heading_rmse_deg_cdf",
        "heading_rmse_deg_box",
    ):
        png = folder / f"{name}.png"
        assert f"({png.name})" in text
        img = mpimg.imread(png)
        assert img.shape[0] > 200 and img.std() > 0.05  # drawn, not blank


def test_report_errors_are_one_line(tmp_path: Path, capsys) -> None:
    assert main(["campaign", "report", str(tmp_path / "none")]) == 2
    assert "no such campaign folder" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["campaign", "report", str(tmp_path / "empty")]) == 2
    assert "no finished run" in capsys.readouterr().err


def test_the_shipped_campaigns_validate() -> None:
    folder = Path(__file__).resolve().parents[1] / "scenarios" / "campaigns"
    specs = {p.stem: load_campaign(p) for p in sorted(folder.glob("*.toml"))}
    assert set(specs) >= {"quick", "depth_water"}
    assert len(specs["quick"].runs) == 10
    dw = specs["depth_water"]
    assert len(dw.runs) == 4 * 4 * 20 and len(dw.seeds) >= 20
    waters = {dict(r.params)["water.jerlov_type"] for r in dw.runs}
    assert waters == {"I", "II", "1C", "3C"}
    tod = specs["time_of_day"]
    starts = sorted({r.scenario["start_utc"] for r in tod.runs})
    assert starts[0] == "2021-09-02T23:00:00Z" and starts[-1] == "2021-09-03T07:00:00Z"
    assert len(starts) == 9 and len(tod.seeds) == 10
    # The window methods' studies: one trial, three specs (water, tilt, sea state).
    assert {specs[n].trial for n in ("snell_water", "snell_attitude", "snell_waves")} == {
        "snell_attitude"
    }
    assert len(specs["snell_water"].runs) == 4 * 3 * 2 * 2 * 20
    assert len(specs["snell_attitude"].runs) == 2 * 19 * 2 * 3
    assert len(specs["snell_waves"].runs) == 4 * 2 * 19 * 3
    moi = specs["moi_noise"]  # the paper's full study: 2000 trials per elevation and case
    assert moi.trial == "moi_noise" and len(moi.seeds) == 2000 and len(moi.runs) == 6 * 3 * 2000
    # The two experiments that were benchmark scripts: LIG vs POL under water, the sea trials.
    cu = specs["compass_underwater"]
    assert cu.trial == "apparent_sun" and len(cu.runs) == 4 * 6 * 50
    st = specs["sea_trials"]
    assert len(st.runs) == 2 * 2 * 2 * 5
    setups = {
        (r.scenario["navigation"]["sun_measurement"], r.scenario["navigation"]["gate_probability"])
        for r in st.runs
    }
    assert setups == {(m, g) for m in ("vector", "azimuth") for g in (1.0, 0.999)}
    depths = {(r.scenario["initial"]["depth_m"], r.scenario["mission"]["legs"][2]["depth_m"])
              for r in st.runs}  # fmt: skip
    assert depths == {(10.0, 10.0), (15.0, 15.0)}


def test_the_worst_runs_are_flown_again_with_their_recording(tmp_path: Path) -> None:
    import json

    from rerun.chunk import RrdReader

    spec_path = tmp_path / "keep.toml"
    spec_path.write_text(
        SMALL.replace("seeds = 2", 'seeds = 2\nkeep_recordings = 1\nworst_by = "final.east_m"')
    )
    spec = load_campaign(spec_path)
    out = tmp_path / "keep"
    run_campaign(spec, out, on_message=lambda m: None)
    kept = list((out / "recordings").glob("*/recording.rrd"))
    assert len(kept) == 1
    RrdReader(kept[0]).store()  # a complete, readable recording
    run_id = kept[0].parent.name
    row = load_campaign_results(out).set_index("run_id").loc[run_id]
    m = json.loads((kept[0].parent / "metrics.json").read_text())
    # Same scenario and seed: the recorded run is the campaign's run.
    assert m["final"]["depth_m"] == row["metric.final.depth_m"]
    assert row["metric.final.east_m"] == load_campaign_results(out)["metric.final.east_m"].max()


def test_per_run_time_series_are_kept_keyed_by_run_id(tmp_path: Path) -> None:
    from twin.campaign.results import load_timeseries

    spec = parse_campaign(
        {
            "name": "ts",
            "base": "default",
            "seeds": [4],
            "metrics": ["navigation.variants.*.heading_rmse_deg"],
            "set": {"duration_s": 3.0},
            "timeseries": {"keep": ["heading_error_deg"], "rate_hz": 1.0},
        }
    )
    out = tmp_path / "ts"
    assert run_campaign(spec, out) == {"ok": 1}
    ts = load_timeseries(out)
    assert set(ts["run_id"]) == {spec.runs[0].run_id}
    assert {"t", "ins.heading_error_deg", "pol.heading_error_deg", "lig.heading_error_deg"} <= set(
        ts.columns
    )
    np.testing.assert_allclose(ts["t"], [0.1, 1.1, 2.1], atol=1e-9)  # 1 Hz from the 10 Hz truth
    rmse = float(np.sqrt(np.mean(np.square(ts["lig.heading_error_deg"]))))
    row = load_campaign_results(out).iloc[0]
    # The kept samples are the scored ones: their RMSE is of the run's RMSE's size.
    assert rmse == pytest.approx(row["metric.navigation.variants.lig.heading_rmse_deg"], rel=0.5)


def test_a_worker_that_dies_costs_one_retry_and_the_campaign_completes(tmp_path: Path) -> None:
    # A real worker death: SIGKILL one of the pool's processes while runs are in flight.
    import threading

    import psutil

    spec_path = tmp_path / "d.toml"
    # 600 s trials (~1 s each): the campaign must still be running when a worker is killed, on a
    # fast machine (a dozen 30 s trials wrote their rows within 0.37 s on two workers, measured).
    spec_path.write_text(SMALL.replace("seeds = 2", "seeds = 4").replace("2.0\n[[", "600.0\n[["))
    spec = load_campaign(spec_path)
    out = tmp_path / "d"
    result: dict = {}
    said: list[str] = []
    t = threading.Thread(
        target=lambda: result.update(run_campaign(spec, out, workers=2, on_message=said.append))
    )
    t.start()
    me = psutil.Process()
    victim = None
    deadline = time.monotonic() + 60
    while victim is None and time.monotonic() < deadline:
        # Wait until the workers are busy with runs (the first rows are being written).
        workers = [p for p in me.children() if "multiprocessing" in " ".join(p.cmdline())]
        busy = [p for p in workers if p.cpu_percent(interval=0.05) > 20]
        if len(workers) >= 2 and busy and (out / "runs").is_dir():
            victim = busy[0]
        time.sleep(0.1)
    assert victim is not None
    victim.kill()
    t.join(timeout=240)
    assert not t.is_alive()
    rows = load_campaign_results(out)
    assert len(rows) == 8 and rows["run_id"].is_unique
    # Every run, the ones in flight at the death included, finished on its retry.
    assert set(rows["status"]) == {"ok"} and result == {"ok": 8}
    assert any("worker process died" in m for m in said), said


def test_a_run_that_kills_its_worker_twice_is_failed_and_its_neighbours_are_not(
    tmp_path: Path,
) -> None:
    # A real segfault in the worker (tests/campaign_trials.py), in flight beside healthy runs:
    # the pool cannot say whose run killed it, so every run in flight is retried alone; the
    # culprit dies again and is "failed", the bystanders finish.
    spec = parse_campaign(
        {
            "name": "crashy",
            "trial": "campaign_trials:crash_or_echo",
            "seeds": 3,
            "sweep": [{"path": "crash", "values": [False, True]}],
        }
    )
    said: list[str] = []
    counts = run_campaign(spec, tmp_path / "c", workers=2, on_message=said.append)
    assert counts == {"ok": 3, "failed": 3}
    rows = load_campaign_results(tmp_path / "c").sort_values("index")
    crashed = rows[rows["param.crash"]]
    assert set(crashed["status"]) == {"failed"}
    assert all("died twice" in e for e in crashed["error"])
    healthy = rows[~rows["param.crash"]]
    assert set(healthy["status"]) == {"ok"}
    assert sorted(healthy["metric.value"]) == [0.0, 1.0, 2.0]
    assert any("worker process died" in m for m in said), said


def test_the_moi_noise_study_runs_as_a_campaign_of_paired_trials(tmp_path: Path) -> None:
    import matplotlib.image as mpimg

    spec = parse_campaign(
        {
            "name": "moi_small",
            "trial": "moi_noise",
            "seeds": 2,
            "set": {"methods": ["moi", "patz"]},
            "sweep": [
                {"path": "elevation_deg", "values": [10.0, 30.0]},
                {"path": "case", "values": ["ideal", "gaussian"]},
            ],
        }
    )
    assert len(spec.runs) == 8 and spec.base is None
    assert run_campaign(spec, tmp_path / "m", workers=1) == {"ok": 8}
    rows = load_campaign_results(tmp_path / "m")
    # Paired: one seed is one solar azimuth in every case and at every elevation.
    az = rows.groupby("seed")["metric.sun_azimuth_deg"].nunique()
    assert (az == 1).all()
    key = ["param.elevation_deg", "seed"]
    ideal = rows[rows["param.case"] == "ideal"].set_index(key).sort_index()
    noisy = rows[rows["param.case"] == "gaussian"].set_index(key).sort_index()
    # Without noise MOI and PATZ find the axis to < 1e-3° (the paper's Fig. 8); 1 % noise costs
    # PATZ far more than MOI (Fig. 9): a result of the methods, asserted per trial.
    moi, patz = "metric.methods.moi.error_deg", "metric.methods.patz.error_deg"
    assert (ideal[moi] < 1e-3).all() and (ideal[patz] < 1e-3).all()
    assert (noisy[patz] > 10 * ideal[patz]).all()
    assert (noisy[moi] < noisy[patz]).all()
    report = write_report(tmp_path / "m")
    text = report.read_text()
    assert "# Campaign report: moi_small, azimuth error" in text and "| moi |" in text
    # Two swept parameters: small multiples (error vs elevation, one panel per case).
    png = report.parent / "error_deg_vs_elevation_deg_by_case.png"
    assert f"({png.name})" in text
    img = mpimg.imread(png)
    assert img.shape[1] > 500 and img.std() > 0.05


def test_a_study_spec_names_its_bad_parameters() -> None:
    with pytest.raises(CampaignError) as err:
        parse_campaign(
            {
                "name": "bad",
                "trial": "moi_noise",
                "base": "tank",
                "set": {"colour": 1},
                "sweep": [{"path": "elevation_deg", "values": [95.0]}],
            }
        )
    assert 'base: "tank"; allowed: none for a study trial' in str(err.value)
    with pytest.raises(CampaignError, match="colour: not a parameter of trial 'moi_noise'"):
        parse_campaign({"name": "bad", "trial": "moi_noise", "set": {"colour": 1}})
    with pytest.raises(CampaignError, match=r"elevation_deg: 95\.0; allowed"):
        parse_campaign(
            {
                "name": "bad",
                "trial": "moi_noise",
                "sweep": [{"path": "elevation_deg", "values": [95.0]}],
            }
        )
    with pytest.raises(CampaignError, match="trial: 'nosuch'"):
        parse_campaign({"name": "bad", "trial": "nosuch"})
