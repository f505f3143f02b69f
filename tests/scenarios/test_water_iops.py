"""A scenario's own water: ``[water.iops]`` gives a, b and K_d with their source.

The inline path must be the named path's: the same IOPs as Jerlov II, given inline, give the
same frames and the same run, bit for bit (both look up the light-field table by the IOPs, not
by the name).
"""

from __future__ import annotations

import copy
import dataclasses
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import scenarios
from scenarios import ScenarioError, parse_scenario
from scenarios.schema import WaterIops
from sensors.polarimeter.optics.water import JERLOV_500NM, WaterBody, jerlov_water
from sensors.polarimeter.render import OpticsConfig
from twin.app.cli import main
from twin.app.run import run_scenario
from twin.core.extensions import WATER_BODIES, ExtensionError
from twin.core.frames import euler_to_dcm

II = JERLOV_500NM["II"]
II_IOPS = {"a_per_m": II.a_per_m, "b_per_m": II.b_per_m, "kd_per_m": II.kd_per_m,
           "source": "Williamson & Hollins 2022 (Jerlov II's, as a test)"}  # fmt: skip


def _inline(doc: dict[str, Any], iops: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(doc)
    out["water"].pop("jerlov_type", None)
    out["water"]["iops"] = dict(iops)
    return out


def test_inline_iops_load_name_the_water_inline_and_round_trip() -> None:
    base = scenarios.load("default")
    s = parse_scenario(_inline(base.to_dict(), II_IOPS), "inline")
    assert s.water.jerlov_type == "inline"
    assert s.water.iops == WaterIops(II.a_per_m, II.b_per_m, II.kd_per_m, II_IOPS["source"])
    d = s.to_dict()
    assert "jerlov_type" not in d["water"] and d["water"]["iops"]["b_per_m"] == II.b_per_m
    assert parse_scenario(d, "again") == s
    assert "iops" not in base.to_dict()["water"]  # a named water writes its name only


def test_bad_iops_are_one_line_errors_naming_each_field() -> None:
    doc = scenarios.load("default").to_dict()
    bad = _inline(doc, {"a_per_m": 0.0, "b_per_m": -1.0, "kd_per_m": 0.07, "colour": "green"})
    with pytest.raises(ScenarioError) as e:
        parse_scenario(bad, "bad")
    msg = str(e.value)
    assert "water.iops.a_per_m: 0.0 is out of range; allowed: (0, 100]" in msg
    assert "water.iops.b_per_m: -1.0 is out of range; allowed: [0, 100]" in msg
    assert "water.iops.source: missing" in msg
    assert "water.iops.colour: unknown key" in msg
    # Diffuse light cannot fade slower than it is absorbed.
    low = _inline(doc, dict(II_IOPS, kd_per_m=0.01))
    with pytest.raises(ScenarioError, match=r"water.iops.kd_per_m: 0.01 is below a_per_m"):
        parse_scenario(low, "low")
    # One name for the water: a type or its own IOPs, not both.
    both = _inline(doc, II_IOPS)
    both["water"]["jerlov_type"] = "3C"
    with pytest.raises(ScenarioError, match=r'water.jerlov_type: "3C" and \[water.iops\] both'):
        parse_scenario(both, "both")
    with pytest.raises(ScenarioError, match=r"water.iops: .*expected a table"):
        parse_scenario(_inline(doc, {}) | {"water": doc["water"] | {"iops": 3}}, "shape")


def test_validate_refuses_bad_iops_with_exit_2(tmp_path: Path, capsys) -> None:
    text = re.sub(r'(?m)^jerlov_type = "II".*\n', "", scenarios.shipped()["default"].read_text())
    path = tmp_path / "iops.toml"
    good = '[water.iops]\na_per_m = 0.0529\nb_per_m = 0.185\nkd_per_m = 0.07\nsource = "WH22"\n'
    path.write_text(text + good)
    assert main(["validate", str(path)]) == 0
    path.write_text(text + good.replace("0.07", "0.02"))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "water.iops.kd_per_m: 0.02 is below a_per_m = 0.0529" in err
    assert "Traceback" not in err


def test_the_optics_take_a_water_body_only_as_inline() -> None:
    body = WaterBody(II.kd_per_m, II.a_per_m, II.b_per_m, "test")
    w = OpticsConfig(jerlov_type="inline", water_body=body).water()
    assert dataclasses.replace(w, name="II") == jerlov_water("II")
    with pytest.raises(ValueError, match=r"OpticsConfig\.water_body: None with jerlov_type"):
        OpticsConfig(jerlov_type="inline")
    with pytest.raises(ValueError, match="allowed: a WaterBody exactly when"):
        OpticsConfig(jerlov_type="II", water_body=body)
    with pytest.raises(ValueError, match=r"WaterBody.kd_per_m: 0.01 is below a_per_m"):
        WaterBody(0.01, 0.05, 0.1, "test")
    WATER_BODIES.add("inline", body)
    try:
        with pytest.raises(ExtensionError, match="reserved for a scenario's own"):
            jerlov_water("inline")
    finally:
        WATER_BODIES.remove("inline")


def test_jerlov_ii_given_inline_renders_and_runs_as_the_named_type(tmp_path: Path) -> None:
    import sensors

    sun = np.array([0.3, -0.5, 0.8124])
    sun /= np.linalg.norm(sun)
    frames = []
    for cfg in (
        OpticsConfig(jerlov_type="II"),
        OpticsConfig(jerlov_type="inline", water_body=WaterBody(
            II.kd_per_m, II.a_per_m, II.b_per_m, "test")),
    ):  # fmt: skip
        cam = sensors.create("polarimeter", "phx050s_p_bin4")
        cam.configure(cfg)
        raw, _ = cam.render_offline(euler_to_dcm(0.05, -0.03, 1.0), 5.0, sun,
                                    np.random.default_rng(7))  # fmt: skip
        frames.append(raw)
    assert np.array_equal(frames[0], frames[1])
    # A whole run, camera and compass included.
    base = dataclasses.replace(scenarios.load("default"), duration_s=4.0)
    inline = parse_scenario(_inline(base.to_dict(), II_IOPS), "inline")
    out = {}
    for name, sc in (("named", base), ("inline", inline)):
        m = run_scenario(sc, tmp_path / name, seed=3, record=False)
        nav = m["navigation"]["variants"]
        assert nav["pol"]["compass"]["fixes"] >= 3
        out[name] = json.dumps(nav, sort_keys=True)
    assert out["named"] == out["inline"]
