"""Issue 26 parts 1 and 6: a campaign folder holds one experiment, and survives its users."""

from __future__ import annotations

import datetime as dt
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from twin.app.cli import main
from twin.campaign.folder import FolderError, locked
from twin.campaign.report import write_report
from twin.campaign.results import consolidate, load_campaign_results
from twin.campaign.runner import run_campaign
from twin.campaign.spec import CampaignError, parse_campaign

TESTS = Path(__file__).resolve().parent
FLIGHT = """
name = "mix"
base = "default"
seeds = 2
metrics = ["navigation.variants.*.heading_rmse_deg"]
[set]
duration_s = {duration}
[[sweep]]
path = "water.temperature_c"
values = [10.0, 20.0]
"""


def _cli(*args: str) -> list[str]:
    """The command line a user types, as a subprocess (the study trials importable)."""
    return [sys.executable, "-m", "twin.app.cli", *args]


_ENV = {**os.environ, "PYTHONPATH": str(TESTS)}


def _echo(seeds: int = 3, **extra) -> dict:
    return {"name": "echo", "trial": "campaign_trials:crash_or_echo", "seeds": seeds, **extra}


def _quiet(_m: str) -> None:
    pass


def test_a_second_experiment_into_the_same_folder_is_refused_before_any_run(
    tmp_path: Path, capsys
) -> None:
    """The issue's case: the same spec with duration_s changed, run into the same --out."""
    first, second = tmp_path / "a.toml", tmp_path / "b.toml"
    first.write_text(FLIGHT.format(duration=2.0))
    second.write_text(FLIGHT.format(duration=3.0))
    out = tmp_path / "out"
    assert main(["campaign", "run", str(first), "--out", str(out), "--quiet"]) == 0
    rows_before = sorted((out / "runs").iterdir())
    capsys.readouterr()
    assert main(["campaign", "run", str(second), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "holds another experiment" in err and "Traceback" not in err
    assert 'set ({"duration_s": 2.0} -> {"duration_s": 3.0})' in err  # names what differs
    assert "--out out_2" in err  # and suggests a new folder
    assert sorted((out / "runs").iterdir()) == rows_before  # no run was made
    # The report still holds the first experiment alone: 4 runs, n = 2 per group.
    df = load_campaign_results(out)
    assert len(df) == 4 and df.attrs["ignored"] == 0
    md = write_report(out).read_text()
    assert "Rows of this experiment on disk: 4 (ok 4)" in md


def test_growing_the_same_experiment_resumes_and_other_rows_are_ignored(tmp_path: Path) -> None:
    out = tmp_path / "g"
    first = parse_campaign(_echo(2, set={"offset": 0.0}))
    assert run_campaign(first, out, on_message=_quiet) == {"ok": 2}
    said: list[str] = []
    # More seeds, and more values on an axis: the existing runs' ids are unchanged.
    grown = parse_campaign(_echo(3, sweep=[{"path": "offset", "values": [0.0, 1.0]}]))
    assert run_campaign(grown, out, on_message=said.append) == {"ok": 4}
    assert any("resuming: 2 of 6" in m for m in said), said
    rec = load_campaign_results(out).attrs["record"]
    assert rec["runs"] == 6 and len(rec["history"]) == 2
    # Shrinking drops runs of the folder's experiment: another experiment.
    with pytest.raises(FolderError, match="4 of its 6 runs are not runs of this spec"):
        run_campaign(
            parse_campaign(_echo(2, sweep=[{"path": "offset", "values": [0.0]}])),
            out,
            on_message=_quiet,
        )
    # A row file that is not the experiment's (copied in by hand) is ignored and counted.
    foreign = tmp_path / "f"
    run_campaign(parse_campaign(_echo(1, set={"offset": 5.0})), foreign, on_message=_quiet)
    (f,) = (foreign / "runs").glob("*.parquet")
    (out / "runs" / f.name).write_bytes(f.read_bytes())
    notes: list[str] = []
    df = load_campaign_results(out, say=notes.append)
    assert len(df) == 6 and df.attrs["ignored"] == 1
    assert any("ignored 1 row file" in n for n in notes)
    assert "1 row files of other experiments ignored" in write_report(out, "value").read_text()


def test_a_corrupt_row_file_is_named_set_aside_and_run_again(tmp_path: Path) -> None:
    spec = parse_campaign(_echo(4))
    out = tmp_path / "c"
    run_campaign(spec, out, on_message=_quiet)
    victim = sorted((out / "runs").glob("*.parquet"))[1]
    victim.write_bytes(victim.read_bytes()[:40])  # truncated: no footer
    notes: list[str] = []
    df = load_campaign_results(out, say=notes.append)
    assert len(df) == 3 and df.attrs["corrupt"] == [victim.name]
    assert any(victim.name in n and "set aside" in n for n in notes), notes
    assert (out / "corrupt" / victim.name).exists() and not victim.exists()
    consolidate(out)  # no longer fails
    said: list[str] = []
    assert run_campaign(spec, out, on_message=said.append) == {"ok": 1}  # that run, again
    assert len(load_campaign_results(out)) == 4


def test_a_folder_with_only_results_parquet_is_reported(tmp_path: Path) -> None:
    out = tmp_path / "r"
    run_campaign(parse_campaign(_echo(3)), out, on_message=_quiet)
    import shutil

    shutil.rmtree(out / "runs")
    df = load_campaign_results(out)
    assert len(df) == 3
    # A run's own metric (no filter variants): one series, named "run".
    assert "| run | 3 |" in write_report(out, metric="value").read_text()


def test_one_worker_is_as_isolated_as_two(tmp_path: Path) -> None:
    spec = parse_campaign(_echo(1, sweep=[{"path": "crash", "values": [True, False]}]))
    counts = run_campaign(spec, tmp_path / "s", workers=1, on_message=_quiet)
    assert counts == {"ok": 1, "failed": 1}  # the segfault, then the next run, each recorded


def test_two_campaigns_into_one_folder_the_second_stops_at_once(tmp_path: Path, capsys) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text('name = "s"\ntrial = "campaign_trials:crash_or_echo"\nseeds = 2\n')
    out = tmp_path / "busy"
    out.mkdir()
    with locked(out):  # a campaign holds the folder (this process; the lock is per open file)
        code = subprocess.run(
            _cli("campaign", "run", str(spec), "--out", str(out), "--quiet"),
            capture_output=True, text=True, env=_ENV, timeout=120,
        )  # fmt: skip
    assert code.returncode == 2, code.stderr
    assert f"in use by another campaign (pid {os.getpid()})" in code.stderr
    assert not (out / "runs").exists()


def test_workers_die_with_their_campaign(tmp_path: Path) -> None:
    import psutil

    spec = tmp_path / "z.toml"
    spec.write_text(
        'name = "z"\ntrial = "campaign_trials:sleep_then_echo"\nseeds = 8\n[set]\nsleep_s = 30.0\n'
    )
    proc = subprocess.Popen(
        _cli("campaign", "run", str(spec), "--out", str(tmp_path / "z"), "--workers", "2"),
        env=_ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    parent = psutil.Process(proc.pid)
    deadline = time.monotonic() + 60
    workers: list = []
    while time.monotonic() < deadline and len(workers) < 2:
        workers = [
            p for p in parent.children(recursive=True) if "multiprocessing" in " ".join(p.cmdline())
        ]
        time.sleep(0.2)
    assert len(workers) >= 2
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    _gone, alive = psutil.wait_procs(workers, timeout=10)
    assert not alive, [p.pid for p in alive]


def test_mixed_datetime_and_string_start_times_consolidate(tmp_path: Path) -> None:
    spec = parse_campaign(
        {
            "name": "when",
            "base": "tank",
            "set": {"duration_s": 1.0},
            "metrics": ["sim_time_s"],
            "sweep": [
                {
                    "path": "start_utc",
                    "values": [dt.datetime(2021, 9, 3, 1, tzinfo=dt.UTC), "2021-09-03T03:00:00Z"],
                }
            ],
        }
    )
    out = tmp_path / "w"
    assert run_campaign(spec, out, on_message=_quiet) == {"ok": 2}
    df = pd.read_parquet(out / "results.parquet")
    assert list(df["param.start_utc"]) == ["2021-09-03T01:00:00Z", "2021-09-03T03:00:00Z"]


@pytest.mark.parametrize(
    ("data", "text"),
    [
        (_echo(seeds=[2**63]), "integers in [0, 9223372036854775807]"),
        (
            {"name": "s", "base": "tank", "sweep": [{"path": "seed", "values": [1, 2, 3]}]},
            'sweep[0].path: "seed"',
        ),
        ({"name": "s", "base": "tank", "set": {"seed": 4}}, "set.seed"),
        (
            {
                "name": "s",
                "base": "tank",
                "sweep": [{"path": "water.temperature_c", "values": [10.0, 20.0, 10.0]}],
            },
            "10.0 given more than once",
        ),
        (
            {
                "name": "s",
                "base": "tank",
                "sweep": [{"path": "water.temperature_c", "values": [25.0, 25]}],
            },
            "given more than once",
        ),
    ],
    ids=["seed-2**63", "sweep-seed", "set-seed", "duplicate-values", "equal-values"],
)
def test_specs_that_would_silently_misfly_are_refused(data: dict, text: str) -> None:
    with pytest.raises(CampaignError, match=None) as exc:
        parse_campaign(data)
    assert text in str(exc.value)


def test_two_sweep_values_that_make_one_scenario_are_refused() -> None:
    # Zipped axes may repeat a value, but not a whole pair: that pair would fly twice.
    zipped = {
        "name": "s",
        "base": "tank",
        "combine": "zip",
        "sweep": [
            {"path": "water.temperature_c", "values": [10.0, 20.0, 10.0]},
            {"path": "water.salinity_psu", "values": [30.0, 30.0, 30.0]},
        ],
    }
    with pytest.raises(CampaignError, match=r"runs 0 \(.*\) and 2 \(.*\), seed 0, resolve"):
        parse_campaign(zipped)
    zipped["sweep"][1]["values"] = [30.0, 30.0, 35.0]
    assert len(parse_campaign(zipped).runs) == 3


def test_ray_missing_is_a_one_line_error(tmp_path: Path, capsys, monkeypatch) -> None:
    spec = tmp_path / "r.toml"
    spec.write_text('name = "r"\ntrial = "campaign_trials:crash_or_echo"\nseeds = 1\n')
    monkeypatch.setitem(sys.modules, "ray", None)  # as if not installed: import raises
    assert main(["campaign", "run", str(spec), "--out", str(tmp_path / "o"), "--ray"]) == 2
    err = capsys.readouterr().err
    assert "pip install 'auv-twin[ray]'" in err and "internal error" not in err


def test_a_metric_pattern_that_matches_nothing_is_said(tmp_path: Path) -> None:
    said: list[str] = []
    spec = parse_campaign(_echo(1, metrics=["value", "no_such_metric*"]))
    run_campaign(spec, tmp_path / "p", on_message=said.append)
    assert any("'no_such_metric*' matched no metric" in m for m in said), said
    assert sum("matched no metric" in m for m in said) == 1  # 'value' matched


@pytest.mark.parametrize(
    ("gravity", "text"),
    [
        (
            'map = "seafloor"\nsize_km = [1.0, 1.0]\nspacing_m = 600.0\nstored_spacing_m = 600.0',
            "gravity.spacing_m: 600 leaves fewer than 3 nodes",
        ),
        (
            'map = "seafloor"\nsize_km = [40.0, 40.0]\nspacing_m = 100.0',
            "gravity.spacing_m: 100 on a 40 × 40 km seafloor",
        ),
    ],
    ids=["too-coarse", "too-fine"],
)
def test_a_seafloor_map_that_cannot_be_built_is_a_field_error(
    tmp_path: Path, capsys, gravity: str, text: str
) -> None:
    import scenarios

    path = tmp_path / "g.toml"
    path.write_text(scenarios.shipped()["tank"].read_text() + f"\n[gravity]\n{gravity}\n")
    t0 = time.perf_counter()
    assert main(["validate", str(path)]) == 2
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert time.perf_counter() - t0 < 30  # refused, not built for minutes
    err = capsys.readouterr().err
    assert err.count(text) == 2 and "internal error" not in err
