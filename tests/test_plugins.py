"""Plug-ins: a compass method and a water body from installed packages, named in a scenario.

``examples/compass_plugin`` is installed by the README's test command (``pip install -e
examples/compass_plugin``): its only link to the project is the entry point in its own
pyproject.toml. These tests use it as a user would: validate a scenario that names it and sets
its parameter, fly a short trial, and run a campaign that compares it with LIG, read back with
pandas.
"""

from __future__ import annotations

import json
import shutil
import sys
from importlib import metadata
from pathlib import Path

import pandas as pd
import pytest

import scenarios
from scenarios.schema import nav_variants
from sensors.polarimeter.optics.water import WaterBody, jerlov_water
from sensors.polarimeter.spec import OpticsConfig
from twin.app.cli import main
from twin.campaign.results import load_campaign_results
from twin.core.extensions import COMPASS_METHODS, STUDY_TRIALS, WATER_BODIES, ExtensionPoint
from twin.core.options import JERLOV_TYPES
from twin.onboard.compass import CompassMethod, available, create

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "compass_plugin"


def test_the_example_plugin_is_installed_and_found_through_its_entry_point() -> None:
    eps = {ep.name: ep for ep in metadata.entry_points(group=COMPASS_METHODS.group)}
    assert eps["sun_spot"].value == "sun_spot_compass.method:SunSpotCompass"
    assert eps["sun_spot"].dist is not None
    assert eps["sun_spot"].dist.name == "auv-twin-sun-spot-compass"
    assert "sun_spot" in nav_variants() and "sun_spot" in available()
    method = create("sun_spot", top_fraction=0.01)
    assert method.name == "sun_spot" and method.config.top_fraction == 0.01
    with pytest.raises(ValueError, match=r"top_fraction: 2.*allowed: \(0, 0.1\]"):
        create("sun_spot", top_fraction=2)


def test_every_registered_method_is_a_compass_method_named_as_its_entry() -> None:
    # The registry is the one declaration (name → class); the class's name must agree with it.
    for name, cls in available().items():
        assert issubclass(cls, CompassMethod), name
        assert cls.name == name
    assert set(COMPASS_METHODS.builtins) < set(nav_variants())
    assert nav_variants()[0] == "ins"
    assert {"moi_noise", "lig_tank"} <= set(STUDY_TRIALS.names())


def test_a_scenario_names_the_plugin_and_sets_its_parameters(capsys, tmp_path: Path) -> None:
    trial = EXAMPLE / "sun_spot_trial.toml"
    assert main(["validate", str(trial)]) == 0
    s = scenarios.load(trial)
    assert s.navigation.variants == ("ins", "sun_spot", "lig")
    assert s.navigation.method_params("sun_spot") == {"top_fraction": 0.002, "min_contrast": 3.0}
    assert scenarios.parse_scenario(s.to_dict()) == s  # the parameters survive the round trip
    text = trial.read_text()
    bad = tmp_path / "bad.toml"
    # The tables' shapes and names first (every problem at once) ...
    extra = "\n[navigation.methods.pol]\nmin_pixels = 10\n\n[navigation.methods.ins]\n"
    bad.write_text(text + extra)
    capsys.readouterr()
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "navigation.methods.pol" in err and "not a compass method run here" in err
    assert "navigation.methods.ins" in err and "no compass method to configure" in err
    # ... then the parameters, by building the method as a run does (validate = run).
    bad.write_text(text.replace("top_fraction = 0.002", "top_fraction = 0.5\nblur_px = 3"))
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "navigation.methods.sun_spot" in err and "blur_px" in err and "top_fraction" in err
    assert main(["run", str(bad), "--out", str(tmp_path / "x")]) == 2
    assert "navigation.methods.sun_spot" in capsys.readouterr().err


def test_a_short_trial_flies_the_plugin_beside_lig(tmp_path: Path) -> None:
    src = (EXAMPLE / "sun_spot_trial.toml").read_text()
    src = src.replace("duration_s = 60.0", "duration_s = 12.0")
    trial = tmp_path / "trial.toml"
    trial.write_text(src)
    assert main(["run", str(trial), "--out", str(tmp_path / "run"), "--quiet"]) == 0
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    variants = metrics["navigation"]["variants"]
    assert variants["sun_spot"]["compass"]["fixes"] >= 10  # one frame a second, the sun in view
    assert variants["lig"]["compass"]["fixes"] >= 10
    assert 0.0 <= variants["sun_spot"]["heading_rmse_deg"] < 10.0


def test_a_campaign_compares_the_plugin_with_lig(tmp_path: Path) -> None:
    # The example's own spec, shortened: its base path is relative to the spec, so copy both.
    folder = tmp_path / "spec"
    shutil.copytree(EXAMPLE, folder, ignore=shutil.ignore_patterns("*.egg-info", "__pycache__"))
    spec = folder / "compare.toml"
    spec.write_text(
        spec.read_text()
        .replace("seeds = 3", "seeds = 2")
        .replace("values = [5.0, 15.0]", "values = [5.0]")
        .replace("[set]", "[set]\nduration_s = 8.0")
    )
    out = tmp_path / "out"
    assert main(["campaign", "run", str(spec), "--out", str(out), "--quiet"]) == 0
    rows = load_campaign_results(out)
    assert len(rows) == 2 and set(rows["status"]) == {"ok"}
    table = pd.read_parquet(out / "results.parquet")
    for v in ("sun_spot", "lig", "pol", "ins"):
        col = f"metric.navigation.variants.{v}.heading_rmse_deg"
        assert col in table.columns and table[col].notna().all(), col


def test_a_plugin_may_not_take_a_built_in_name(tmp_path: Path, monkeypatch) -> None:
    # A real distribution on the path (its dist-info), found by importlib.metadata as pip's are.
    info = tmp_path / "rogue_pkg-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: rogue-pkg\nVersion: 1.0\n")
    eps = "[auv_twin.test_point]\nlig = rogue:Lig\nnew = rogue:New\n"
    (info / "entry_points.txt").write_text(eps)
    monkeypatch.syspath_prepend(str(tmp_path))
    point = ExtensionPoint("compass method", "auv_twin.test_point", {"lig": "x:Lig"})
    with pytest.raises(ValueError, match=r"'lig' from rogue-pkg \(rogue:Lig\) takes a built-in"):
        point.names()
    ok = ExtensionPoint("thing", "auv_twin.test_point", {"other": "x:Y"})
    assert ok.names() == ("other", "lig", "new")
    with pytest.raises(ValueError, match=r"thing 'new' \(rogue:New\) does not import"):
        ok.load("new")
    with pytest.raises(ValueError, match=r"thing: 'nope' is unknown; allowed: \['other'"):
        ok.load("nope")
    assert "rogue" not in sys.modules


def test_a_clashing_plugin_is_a_one_line_error_with_exit_2(tmp_path: Path, monkeypatch, capsys):
    # A user's fix (rename the plug-in), as a bad scenario's: not an "internal error".
    info = tmp_path / "rogue_pkg-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: rogue-pkg\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[auv_twin.compass_methods]\nlig = rogue:Lig\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(COMPASS_METHODS, "_plugins", None)  # read the installed ones afresh
    assert main(["validate", "default"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "internal error" not in err
    assert "'lig' from rogue-pkg (rogue:Lig) takes a built-in name" in err


# ---- a water body from another package (examples/water_plugin) -------------------------------

HARBOUR = ROOT / "examples" / "water_plugin"


def test_the_example_water_body_is_found_and_a_scenario_names_it(tmp_path: Path, capsys) -> None:
    eps = {ep.name: ep for ep in metadata.entry_points(group=WATER_BODIES.group)}
    assert eps["turbid_harbour"].value == "harbour_water.bodies:TURBID_HARBOUR"
    assert eps["turbid_harbour"].dist is not None
    assert eps["turbid_harbour"].dist.name == "auv-twin-harbour-water"
    assert WATER_BODIES.names()[: len(JERLOV_TYPES)] == JERLOV_TYPES
    assert "turbid_harbour" in WATER_BODIES.names()
    # Its properties reach the optics as the package declares them (3C, particles doubled: the
    # same arithmetic as the twin's own turbidity = 2 on 3C, written apart).
    w, ref = jerlov_water("turbid_harbour"), jerlov_water("3C", turbidity=2.0)
    assert (w.a_per_m, w.b_per_m, w.kd_per_m) == pytest.approx(
        (ref.a_per_m, ref.b_per_m, ref.kd_per_m), rel=1e-12
    )
    assert w.name == "turbid_harbour"
    assert OpticsConfig(jerlov_type="turbid_harbour").water() == w
    trial = HARBOUR / "harbour_trial.toml"
    assert main(["validate", str(trial)]) == 0
    s = scenarios.load(trial)
    assert s.water.jerlov_type == "turbid_harbour"
    assert scenarios.parse_scenario(s.to_dict()) == s
    # A name nobody declared: the allowed list has the plug-in's too.
    bad = tmp_path / "bad.toml"
    bad.write_text(trial.read_text().replace('"turbid_harbour"', '"murky"'))
    capsys.readouterr()
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "water.jerlov_type" in err and '"murky"' in err and '"turbid_harbour"' in err


def test_a_water_body_entry_that_is_not_one_is_a_one_line_error() -> None:
    WATER_BODIES.add("not_water", object())
    try:
        with pytest.raises(ValueError, match=r"'not_water' is object; expected a .*WaterBody"):
            OpticsConfig(jerlov_type="not_water")
    finally:
        WATER_BODIES.remove("not_water")
    with pytest.raises(
        ValueError, match=r"WaterBody.a_per_m: -1.0; allowed: a number in \(0, 100\]"
    ):
        WaterBody(0.1, -1.0, 0.2, "a citation")
    with pytest.raises(ValueError, match=r"WaterBody.iop_source: ''"):
        WaterBody(0.1, 0.05, 0.2, "")
