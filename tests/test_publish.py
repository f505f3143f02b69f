"""Issue 26 parts 2-5: provenance in every output, a report fit for a paper, no silent traps,
data a paper can archive. Real files: Parquet read back with pandas and pyarrow, the recording
with Rerun's reader, the HTML page in headless Chromium."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from rerun.chunk import RrdReader

import scenarios
from twin.app.cli import main
from twin.app.run import run_scenario
from twin.campaign.labels import describe, markdown_table
from twin.campaign.report import write_report
from twin.campaign.runner import run_campaign
from twin.campaign.spec import parse_campaign
from twin.record.provenance import PACKAGES, read_parquet_provenance

ROOT = Path(__file__).resolve().parents[1]


def _git_head() -> str | None:
    if not (ROOT / ".git").exists() or shutil.which("git") is None:
        return None
    return subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True, check=True
    ).stdout.strip()


def _rrd_provenance(rrd: Path) -> dict[str, str]:
    store = RrdReader(rrd).store()
    chunks = store.stream().filter(content="/__properties/provenance", is_static=True).to_chunks()
    out: dict[str, str] = {}
    for c in chunks:
        rb = c.to_record_batch()
        for name in rb.schema.names:
            v = rb.column(name).to_pylist()[0]
            if isinstance(v, list) and v and isinstance(v[0], str):
                out[name] = v[0]
    return out


# ---- part 2: provenance ------------------------------------------------------------------------
def test_a_tree_is_dirty_for_code_not_for_benchmark_results(tmp_path: Path, monkeypatch) -> None:
    """A benchmark's fresh table does not mark the next one's run as made from changed code."""
    from twin.record import provenance as pv

    git = ["git", "-C", str(tmp_path), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run([*git, "init", "-q"], check=True)
    (tmp_path / "code.py").write_text("x = 1\n")
    subprocess.run([*git, "add", "."], check=True)
    subprocess.run([*git, "commit", "-q", "-m", "c"], check=True)
    monkeypatch.setattr(pv, "_REPO", tmp_path)

    def dirty() -> bool:
        pv.code_version.cache_clear()
        return pv.code_version()["dirty"]

    assert dirty() is False
    (tmp_path / "benchmarks" / "results").mkdir(parents=True)
    (tmp_path / "benchmarks" / "results" / "table.md").write_text("| a |\n")
    (tmp_path / "benchmarks" / "results" / "table.json").write_text("{}\n")
    (tmp_path / "validation" / "results" / "campaigns").mkdir(parents=True)
    (tmp_path / "validation" / "results" / "campaigns" / "groups.csv").write_text("a\n1\n")
    (tmp_path / "NOTES.md").write_text("prose\n")
    assert dirty() is False
    (tmp_path / "code.py").write_text("x = 2\n")
    assert dirty() is True
    pv.code_version.cache_clear()


def test_every_output_of_a_run_says_where_it_came_from(tmp_path: Path, capsys) -> None:
    base = dataclasses.replace(scenarios.load("tank"), duration_s=2.0)
    changed = dataclasses.replace(base, duration_s=3.0)  # one input changed
    fps = {}
    for name, sc, seed in (("a", base, 0), ("b", base, 7), ("c", changed, 0)):
        out = tmp_path / name
        m = run_scenario(sc, out, seed=seed, camera=False, timeseries=True)
        prov = json.loads((out / "metrics.json").read_text())["provenance"]
        assert prov == m["provenance"]
        assert set(prov["packages"]) == set(PACKAGES)
        assert prov["seed"] == seed and prov["light_model"] >= 1
        assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", prov["created_utc"])
        assert prov["python"] and prov["os"] and prov["cpu"]
        head = _git_head()
        if head is not None:  # a checkout: the commit, and whether the tree was dirty
            assert prov["commit"] == head and isinstance(prov["dirty"], bool)
        # The recording's properties and every time-series file carry the same block.
        rrd = _rrd_provenance(out / "recording.rrd")
        assert rrd["fingerprint"] == prov["fingerprint"] and rrd["seed"] == str(seed)
        assert rrd["packages.mujoco"] == prov["packages"]["mujoco"]
        for f in (out / "timeseries").glob("*.parquet"):
            assert read_parquet_provenance(f)["fingerprint"] == prov["fingerprint"], f
        fps[name] = prov["fingerprint"]
    assert fps["a"] == fps["b"] != fps["c"]  # the seed is not an input's content; duration is
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    line = capsys.readouterr().out
    assert line.startswith("auv-twin ") and (head is None or head in line)


def test_every_output_of_a_campaign_says_where_it_came_from(tmp_path: Path) -> None:
    def spec(duration: float):
        return parse_campaign(
            {
                "name": "p",
                "base": "tank",
                "seeds": 2,
                "metrics": ["sim_time_s"],
                "set": {"duration_s": duration},
            }
        )

    seen = set()
    for duration in (1.0, 1.5):
        out = tmp_path / f"d{duration}"
        run_campaign(spec(duration), out, on_message=lambda _m: None)
        rec = json.loads((out / "campaign.json").read_text())
        fp = rec["fingerprint"]
        assert rec["provenance"]["fingerprint"] == fp and rec["parts"]["set"] == {
            "duration_s": duration
        }
        for f in (out / "runs").glob("*.parquet"):
            block = read_parquet_provenance(f)
            assert block["fingerprint"] == fp and block["seed"] in (0, 1)
        assert read_parquet_provenance(out / "results.parquet")["fingerprint"] == fp
        rows = pd.read_parquet(out / "results.parquet")
        assert set(rows["spec_fingerprint"]) == {fp}
        md = write_report(out, "sim_time_s").read_text()
        assert f"fingerprint `{fp}`" in md and "`duration_s` = " + str(duration) in md
        head = _git_head()
        if head is not None:
            assert f"commit {head[:12]}" in md
        seen.add(fp)
    assert len(seen) == 2


# ---- part 3: the report ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    """Two water types x two sun measurements x 3 seeds of 5 s of the default trial."""
    spec = parse_campaign(
        {
            "name": "paper",
            "base": "default",
            "seeds": 3,
            "metrics": ["navigation.variants.*"],
            "set": {"duration_s": 5.0},
            "sweep": [
                {"path": "water.jerlov_type", "values": ["II", "I"]},
                {"path": "navigation.sun_measurement", "values": ["azimuth", "vector"]},
            ],
        }
    )
    out = tmp_path_factory.mktemp("paper") / "c"
    assert run_campaign(spec, out, workers=2, on_message=lambda _m: None) == {"ok": 12}
    return out


def test_the_report_is_labelled_with_units_n_and_its_interval_methods(campaign: Path) -> None:
    md = write_report(campaign)
    assert md == campaign / "report" / "heading_rmse_deg" / "report.md"
    text = md.read_text()
    q = describe("heading_rmse_deg")
    assert q.definition in text and "heading RMSE (°)" in text
    assert "| Jerlov water type | sun measurement | variant | n |" in text
    # n = 3: no silent [min, max]: the small-sample methods are named, and the report warns.
    groups = pd.read_csv(md.parent / "groups.csv")
    assert (groups["n"] == 3).all()
    assert set(groups["ci_method"]) == {
        "mean: Student t; rmse: none (n < 10); median: none (n < 6); p95: none (n < 10)"
    }
    assert groups["rmse_lo"].isna().all() and groups["p95_lo"].isna().all()
    assert "12 of 12 groups have fewer than 10 runs" in text
    # The vector arm is the trap: its compass variants fused none; the report says so.
    assert re.search(r"\*\*(pol|lig): too few fixes fused in [1-9]\d* of 12 runs\*\*", text)
    # Categories are drawn as categories; every figure has PNG >= 200 dpi and an SVG.
    figs = sorted(md.parent.glob("*.png"))
    names = {p.stem for p in figs}
    assert "heading_rmse_deg_vs_water_jerlov_type" in names
    for png in figs:
        import matplotlib.image as mpimg

        img = mpimg.imread(png)
        assert img.shape[1] >= 6.4 * 200 - 1 and img.std() > 0.05, png
        svg = png.with_suffix(".svg")
        assert ET.parse(svg).getroot().tag.endswith("svg")
        assert f"({png.name})" in text and f"({svg.name})" in text
    assert "Pooled over sun measurement" in text  # a figure that pools says so
    # Numbers to three significant digits, consistently: no 4-digit mantissas like 0.4413.
    table = text.split("## Per group", 1)[1].split("## Paired", 1)[0]
    for number in re.findall(r"(?<![\w.])\d+\.\d+", table):
        digits = number.replace(".", "").lstrip("0")
        assert len(digits) <= 3, number


def test_each_metric_reports_into_its_own_folder_and_a_rerun_leaves_no_stale_figure(
    campaign: Path,
) -> None:
    a = write_report(campaign, "heading_rmse_deg").parent
    b = write_report(campaign, "roll_rmse_deg").parent
    assert a != b and a.is_dir() and b.is_dir()
    assert not list(b.glob("heading_rmse_deg*")) and list(b.glob("roll_rmse_deg_*.png"))
    before = {p.name: p.read_bytes() for p in a.glob("*.[ps][nv]g")}
    stale = a / "heading_rmse_deg_vs_old_axis.png"
    stale.write_bytes(b"")
    write_report(campaign, "heading_rmse_deg")
    assert not stale.exists()
    # The same rows give the same figure files, byte for byte (no dates, fixed SVG ids).
    assert {p.name: p.read_bytes() for p in a.glob("*.[ps][nv]g")} == before


def _chrome():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    assert binary and driver, "Debian's chromium and chromium-driver (installed by .ci/run)"
    opts = webdriver.ChromeOptions()
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"):
        opts.add_argument(a)
    opts.binary_location = binary
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver), options=opts)


def test_the_html_report_opens_in_a_real_browser(campaign: Path, tmp_path: Path) -> None:
    md = write_report(campaign)
    page = md.with_suffix(".html")
    # Self-contained: the page alone, copied elsewhere, still shows every figure.
    alone = tmp_path / "report.html"
    alone.write_bytes(page.read_bytes())
    d = _chrome()
    try:
        d.set_window_size(1200, 900)
        d.get(alone.as_uri())
        assert "Campaign report" in d.title
        imgs = d.execute_script(
            "return Array.from(document.images).map(i => "
            "[i.complete, i.naturalWidth, i.naturalHeight, i.getBoundingClientRect().width])"
        )
        n_figs = len(list(md.parent.glob("*.png")))
        assert len(imgs) == n_figs >= 4
        assert all(ok and w > 0 and h > 0 and shown > 0 for ok, w, h, shown in imgs), imgs
        errors = [e for e in d.get_log("browser") if e["level"] in ("SEVERE", "ERROR")]
        assert not errors, errors
        shot = tmp_path / "shot.png"
        d.save_screenshot(str(shot))
    finally:
        d.quit()
    import matplotlib.image as mpimg

    img = mpimg.imread(shot)
    assert img.std() > 0.05  # text and figures, not a blank page


def test_the_docs_reference_is_the_label_table() -> None:
    # Generated: `python -m twin.campaign.labels` prints it; the docs hold it verbatim.
    assert markdown_table() in (ROOT / "docs" / "campaigns.md").read_text()


# ---- part 4: no silent traps -------------------------------------------------------------------
def test_a_variant_that_fuses_no_fix_is_a_loud_warning(tmp_path: Path, capsys) -> None:
    text = scenarios.shipped()["default"].read_text()
    text = text.replace('sun_measurement = "azimuth"', 'sun_measurement = "vector"')
    text = re.sub(r"(?m)^duration_s = .*$", "duration_s = 8.0", text)
    path = tmp_path / "vec.toml"
    path.write_text(text)
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet", "--no-camera"]) == 0
    out = capsys.readouterr().out
    m = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert m["warnings"] and all("NIS gate" in w and "'vector'" in w for w in m["warnings"])
    for w in m["warnings"]:
        assert f"WARNING: {w}" in out
    for v in ("pol", "lig"):
        assert m["navigation"]["variants"][v]["compass"]["fused_fraction"] < 0.1


def test_the_schema_default_is_the_measurement_that_fuses() -> None:
    from scenarios.schema import Navigation

    assert Navigation().sun_measurement == "azimuth"
    assert scenarios.load("closed_loop_10m").navigation.sun_measurement == "azimuth"
    # The paper's set-up is explicit where it is reproduced.
    sea = scenarios.load("sea_trial_10m").navigation
    assert (sea.sun_measurement, sea.gate_probability) == ("vector", 1.0)


def test_a_progress_bar_into_a_file_redraws_every_few_seconds(tmp_path: Path) -> None:
    sc = tmp_path / "p.toml"
    sc.write_text(
        re.sub(
            r"(?m)^duration_s = .*$", "duration_s = 20.0", scenarios.shipped()["tank"].read_text()
        )
    )
    proc = subprocess.run(
        [sys.executable, "-m", "twin.app.cli", "run", str(sc), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "MUJOCO_GL": "disable"},
    )
    assert proc.returncode == 0, proc.stderr
    draws = proc.stderr.count("sea trial:")
    # A 20 s trial takes a few seconds: the first and the last draw, at most one between
    # (every 0.1 s, as on a terminal, was dozens).
    assert 1 <= draws <= 4, proc.stderr


# ---- part 5: data a paper can archive ----------------------------------------------------------
def test_a_run_writes_its_time_series_as_parquet_and_a_compact_recording(tmp_path: Path) -> None:
    sc = dataclasses.replace(scenarios.load("default"), duration_s=6.0)
    m = run_scenario(sc, tmp_path, camera=False, timeseries=True)
    ts = tmp_path / "timeseries"
    truth = pd.read_parquet(ts / "truth.parquet")
    assert (
        len(truth) == round(6.0 * sc.recording.truth_rate_hz) and truth["t"].is_monotonic_increasing
    )
    assert str(truth["utc"].dt.tz) == "UTC"
    assert truth["utc"].iloc[0] == pd.Timestamp(sc.start_utc) + pd.Timedelta(
        truth["t"].iloc[0], "s"
    )
    imu = pd.read_parquet(ts / "readings_imu.parquet")
    assert len(imu) == m["sensor_readings"]["imu"]
    assert {"specific_force[0]", "angular_rate[2]", "t_delivered"} <= set(imu.columns)
    pol = pq.read_table(ts / "readings_polarimeter.parquet")
    assert "raw" in json.loads(pol.schema.metadata[b"auv_twin.notes"])["channels_left_out"]
    filters = pd.read_parquet(ts / "filters.parquet")
    assert set(filters["variant"]) == {"ins", "pol", "lig"}
    last = filters[filters["variant"] == "lig"]["heading_err_deg"].to_numpy()
    rmse = float(np.sqrt(np.mean(last**2)))
    assert rmse == pytest.approx(m["navigation"]["variants"]["lig"]["heading_rmse_deg"], abs=1e-3)
    fixes = pd.read_parquet(ts / "compass_fixes.parquet")
    comp = m["navigation"]["variants"]["pol"]["compass"]
    assert (fixes["variant"] == "pol").sum() == comp["frames"]
    # The recording is compacted on close: rerun's own check finds no excess chunks.
    stats = subprocess.run(
        [sys.executable, "-m", "rerun_cli", "rrd", "stats", str(tmp_path / "recording.rrd")],
        capture_output=True,
        text=True,
    )
    ratio = re.search(r"effective:\s+[\d\s]+chunks \(([\d.]+)×\)", stats.stdout + stats.stderr)
    assert ratio and float(ratio.group(1)) <= 1.5, stats.stdout[-800:]


def test_render_writes_float_images_colour_bars_and_the_sun(tmp_path: Path, capsys) -> None:
    import cv2

    args = ["render", "default", "--at", "1", "--s0-max", "3000"]
    assert main([*args, "--out", str(tmp_path / "n"), "--float", "npz"]) == 0
    assert main([*args, "--out", str(tmp_path / "t"), "--float", "tiff"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"sun: elevation 5\d\.\d\d deg, azimuth 1\d\d\.\d\d deg", out)
    z = np.load(tmp_path / "n" / "default_t1.npz")
    s0 = cv2.imread(str(tmp_path / "t" / "default_t1_s0.tiff"), cv2.IMREAD_UNCHANGED)
    assert s0.dtype == np.float32 and s0.shape == z["s0"].shape
    np.testing.assert_array_equal(s0, z["s0"])  # the same seeded frame, losslessly
    assert float(np.nanmax(z["dop"])) <= 1.0 and z["aop"].dtype == np.float32
    side = json.loads((tmp_path / "t" / "default_t1.json").read_text())
    assert side["provenance"]["seed"] == 0 and side["provenance"]["fingerprint"]
    in_npz = json.loads(str(z["provenance"]))
    assert (in_npz["fingerprint"], in_npz["seed"]) == (side["provenance"]["fingerprint"], 0)
    assert "default_t1_s0.tiff" in side["files"]
    panel = tmp_path / "n" / "default_t1_panel.png"
    assert panel.is_file() and (tmp_path / "n" / "default_t1_panel.svg").is_file()
    # A fixed scale: the 8-bit intensity saturates at the same DN in both renders.
    a = cv2.imread(str(tmp_path / "n" / "default_t1_intensity.png"), cv2.IMREAD_UNCHANGED)
    b = cv2.imread(str(tmp_path / "t" / "default_t1_intensity.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(a, b)


def test_render_says_when_the_sun_is_down_and_refuses_a_preset_it_would_ignore(
    tmp_path: Path, capsys
) -> None:
    night = tmp_path / "night.toml"
    night.write_text(
        re.sub(
            r"(?m)^start_utc = .*$",
            "start_utc = 2021-09-03T14:00:00Z",
            scenarios.shipped()["default"].read_text(),
        )
    )
    assert main(["render", str(night), "--out", str(tmp_path / "o")]) == 0
    assert "the sun is below the horizon" in capsys.readouterr().out
    assert main(["render", "default", "--preset", "no_such_camera"]) == 2
    assert "allowed one of" in capsys.readouterr().err
    assert main(["render", "default", "--preset", "phx050s_p"]) == 2
    assert "has its own polarimeter" in capsys.readouterr().err


def test_a_campaign_progress_bar_into_a_file_redraws_every_few_seconds(tmp_path: Path) -> None:
    import time

    spec = tmp_path / "s.toml"
    spec.write_text('name = "s"\ntrial = "campaign_trials:crash_or_echo"\nseeds = 60\n')
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "twin.app.cli", "campaign", "run", str(spec), "--out",
         str(tmp_path / "o")],
        capture_output=True, text=True, timeout=300,
        env={**os.environ, "PYTHONPATH": str(ROOT / "tests")},
    )  # fmt: skip
    wall = time.perf_counter() - t0
    assert proc.returncode == 0, proc.stderr
    draws = proc.stderr.count("campaign:")
    # 60 runs: one redraw a run was 60 lines; at most one every 5 s, plus the first and last.
    assert 1 <= draws <= wall / 5 + 3, (draws, wall)
