"""A sensor from another package (``examples/sensor_plugin``, a USBL), mounted by a scenario.

The same package adds the onboard side, a navigation aid that fuses the fixes
(``auv_twin.nav_aids``); a scenario ties them with ``[navigation.aids.<sensor>]``.

The package's only link to the project is its entry point (``auv_twin.sensors``); the README's
test command installs it. A scenario mounts it with ``[sensors.extra.<name>] kind = "usbl"``
and sets its spec's fields; ``validate`` builds and starts it as a run does; a run samples it on
its own random stream (appended after the built-in sensors', which do not move), records it and
writes its readings' time series.
"""

from __future__ import annotations

import copy
import dataclasses
import json
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from rrd_helpers import entities

import scenarios
import sensors
from scenarios import ScenarioError, parse_scenario
from sensors.registry import sensor_class
from twin.app.cli import main
from twin.app.run import run_scenario
from twin.core.extensions import NAV_AIDS, SENSORS, ExtensionError
from twin.core.messages import Reading
from twin.onboard.aids import create_aid

ROOT = Path(__file__).resolve().parents[1]
TRIAL = ROOT / "examples" / "sensor_plugin" / "usbl_trial.toml"


def test_the_example_sensor_is_found_through_its_entry_point() -> None:
    eps = {ep.name: ep for ep in metadata.entry_points(group=SENSORS.group)}
    assert eps["usbl"].value == "usbl_sensor.sensor:Usbl"
    assert eps["usbl"].dist is not None and eps["usbl"].dist.name == "auv-twin-usbl-sensor"
    assert set(SENSORS.builtins) == {"imu", "depth", "gravimeter", "polarimeter"}
    kinds = sensors.available()
    assert "usbl" in kinds and kinds["usbl"].kind == "usbl"
    for kind, cls in kinds.items():  # one declaration: the entry's name is the class's kind
        assert cls.kind == kind
    usbl = sensors.create("usbl", "generic", name="fix", range_fraction=0.05)
    assert usbl.name == "fix" and usbl.site == "imu" and usbl.spec.range_fraction == 0.05
    with pytest.raises(ValueError, match=r"range_fraction = 0.5: must lie in \[0, 0.2\]"):
        sensors.create("usbl", "generic", range_fraction=0.5)


def test_a_sensor_entry_must_be_a_sensor_of_its_own_kind() -> None:
    class NotASensor:
        kind = "thing"

    SENSORS.add("thing", NotASensor)
    SENSORS.add("imu_copy", sensor_class("imu"))
    try:
        with pytest.raises(ExtensionError, match=r"expected a subclass of sensors\.base\.Sensor"):
            sensor_class("thing")
        with pytest.raises(ExtensionError, match="whose kind is 'imu'; the entry's name must be"):
            sensor_class("imu_copy")
    finally:
        SENSORS.remove("thing")
        SENSORS.remove("imu_copy")
    with pytest.raises(KeyError, match="unknown sensor kind 'sonar'; known: depth, gravimeter"):
        sensor_class("sonar")


def test_the_example_trial_validates_and_bad_extras_are_one_line_errors(tmp_path: Path, capsys):
    assert main(["validate", str(TRIAL)]) == 0
    s = scenarios.load(TRIAL)
    (e,) = s.sensors.extra
    assert (e.name, e.kind, e.preset, e.site, e.overrides) == (
        "usbl", "usbl", "generic", None, (("range_fraction", 0.02),))  # fmt: skip
    assert parse_scenario(s.to_dict()) == s
    doc = s.to_dict()
    del doc["navigation"]["aids"]  # (aids: below)
    doc["sensors"]["extra"] = {
        "imu": {"kind": "usbl"},  # a slot's name
        "fix": {"kind": "sonar"},  # no such kind
        "fix2": {"kind": "usbl", "preset": "deluxe"},  # no such preset
        "fix3": {"kind": "usbl", "site": "mast"},  # no such site
        "fix4": {"kind": "usbl", "range_fraction": 0.9},  # an impossible field
        "fix5": {"kind": "depth", "site": "imu"},  # a site without what the kind reads there
    }
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, "bad")
    lines = str(err.value).splitlines()[1:]
    assert len(lines) == 2  # the schema's problems first; the build's when these are fixed
    assert any(x.startswith("  sensors.extra.imu: is a built-in sensor's name") for x in lines)
    assert any(x.startswith('  sensors.extra.fix.kind: "sonar" is not one of') and '"usbl"' in x
               for x in lines)  # fmt: skip
    del doc["sensors"]["extra"]["imu"], doc["sensors"]["extra"]["fix"]
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, "bad")
    msg = str(err.value)
    assert "sensors.extra.fix2: unknown usbl preset 'deluxe'; known: generic, ideal" in msg
    assert "sensors.extra.fix3: site 'mast' is not on the vehicle; allowed: ['depth'" in msg
    assert "sensors.extra.fix4: range_fraction = 0.9: must lie in [0, 0.2]" in msg
    assert "sensors.extra.fix5: depth gauge 'fix5' at site 'imu' needs the MJCF sensor" in msg
    bad = tmp_path / "bad.toml"
    bad.write_text(TRIAL.read_text().replace("range_fraction = 0.02", "range_fraction = 0.9"))
    capsys.readouterr()
    assert main(["validate", str(bad)]) == 2
    out = capsys.readouterr().err
    assert "sensors.extra.usbl: range_fraction = 0.9" in out and "Traceback" not in out


def test_a_run_samples_records_and_writes_the_plugin_sensor(tmp_path: Path) -> None:
    s = dataclasses.replace(scenarios.load(TRIAL), duration_s=20.0)
    m = run_scenario(s, tmp_path / "run", seed=4, timeseries=True)
    assert m["sensor_readings"]["usbl"] == 20  # 1 Hz, delivered 0.5 s after each ping
    assert [x["name"] for x in m["sensors"]][-1] == "usbl"
    fixes = pd.read_parquet(tmp_path / "run" / "timeseries" / "readings_usbl.parquet")
    truth = pd.read_parquet(tmp_path / "run" / "timeseries" / "truth.parquet")
    assert len(fixes) == 20 and (fixes["t_delivered"] - fixes["t"]).round(9).eq(0.5).all()
    # Each fix is the vehicle's position within a few of its σ (0.1 m + 2 % of ~10 m of range).
    at = truth.set_index("t").reindex(fixes["t"], method="nearest")
    depth_err = fixes["position_m[2]"].to_numpy() - (-at["depth_m"].to_numpy())
    assert np.all(np.abs(depth_err) < 5 * (0.1 + 0.02 * fixes["slant_range_m"].to_numpy()) + 0.3)
    assert fixes["slant_range_m"].between(9.0, 60.0).all()
    rows = entities(tmp_path / "run" / "recording.rrd")
    assert rows.get("/sensors/usbl/position_m", 0) > 0


def test_an_extra_sensor_leaves_the_built_in_streams_alone(tmp_path: Path) -> None:
    # Appended after the built-in sensors, it takes a new random stream: the IMU's and the depth
    # gauge's noise, hence the filters, are bit for bit those of the run without it.
    base = dataclasses.replace(scenarios.load(TRIAL), duration_s=6.0)
    doc = copy.deepcopy(base.to_dict())
    del doc["sensors"]["extra"], doc["navigation"]["aids"]
    alone = parse_scenario(doc, "alone")
    doc = copy.deepcopy(base.to_dict())
    del doc["navigation"]["aids"]
    base = parse_scenario(doc, "sampled, not fused")
    nav = {}
    for name, sc in (("with", base), ("without", alone)):
        m = run_scenario(sc, tmp_path / name, seed=9, record=False)
        nav[name] = json.dumps(m["navigation"]["variants"], sort_keys=True)
    assert nav["with"] == nav["without"]


# ---- the onboard side: the fixes fused by a navigation aid ------------------------------------


def test_the_example_aid_is_found_and_checks_its_parameters() -> None:
    eps = {ep.name: ep for ep in metadata.entry_points(group=NAV_AIDS.group)}
    assert eps["usbl_position"].value == "usbl_sensor.aid:UsblPositionAid"
    aid = create_aid("usbl_position", range_fraction=0.05)
    assert aid.name == "usbl_position" and aid.range_fraction == 0.05
    with pytest.raises(ValueError, match=r"sigma_floor_m: -1; allowed: a finite number >= 0"):
        create_aid("usbl_position", sigma_floor_m=-1)
    bad = r"colour: not a parameter of aid 'usbl_position'; allowed: \['sigma_floor_m', 'range_"
    with pytest.raises(ValueError, match=bad):
        create_aid("usbl_position", colour=1)
    with pytest.raises(ExtensionError, match=r"navigation aid: 'sonar' is unknown; allowed: \["):
        create_aid("sonar")
    # A dropped fix (NaN) is skipped before the filter is touched.
    nan = Reading("usbl", 1.0, 1.5, {"position_m": np.array([np.nan, 0.0, -10.0]),
                                     "slant_range_m": np.asarray(10.0)})  # fmt: skip
    assert aid.update(None, nan) is None  # type: ignore[arg-type]


def test_aids_are_checked_like_the_rest_of_the_scenario(tmp_path: Path, capsys) -> None:
    s = scenarios.load(TRIAL)
    assert s.navigation.aids == (
        ("usbl", "usbl_position", (("sigma_floor_m", 0.1), ("range_fraction", 0.02))),)  # fmt: skip
    assert parse_scenario(s.to_dict()) == s
    doc = s.to_dict()
    doc["navigation"]["aids"] = {"usbl": {"aid": "sonar_position"}}  # no such aid
    with pytest.raises(ScenarioError, match=r'navigation\.aids\.usbl\.aid: "sonar_position"'):
        parse_scenario(doc, "bad")
    # A built-in sensor, which the filter fuses itself.
    doc["navigation"]["aids"] = {"depth": {"aid": "usbl_position"}}
    with pytest.raises(ScenarioError, match=r'navigation\.aids\.depth: "depth" is not one'):
        parse_scenario(doc, "bad")
    doc["navigation"]["aids"] = {"usbl": {"aid": "usbl_position", "range_fraction": -0.1}}
    with pytest.raises(ScenarioError, match=r"navigation.aids.usbl: range_fraction: -0.1; allowed"):
        parse_scenario(doc, "bad parameter")
    bad = tmp_path / "bad.toml"
    bad.write_text(TRIAL.read_text().replace('aid = "usbl_position"', 'aid = "usbl"'))
    capsys.readouterr()
    assert main(["validate", str(bad)]) == 2
    out = capsys.readouterr().err
    assert 'navigation.aids.usbl.aid: "usbl" is not one of' in out and "Traceback" not in out


def test_the_fused_fixes_hold_the_position_the_free_ins_loses(tmp_path: Path) -> None:
    # The same seed with and without the aid: the free INS (MEMS IMU, no DVL) drifts tens of
    # metres in a minute; with a fix a second (σ ~ 0.3 m) the filter stays within metres.
    aided = scenarios.load(TRIAL)
    doc = aided.to_dict()
    del doc["navigation"]["aids"]
    free = parse_scenario(doc, "free")
    out = {}
    for name, sc in (("aided", aided), ("free", free)):
        m = run_scenario(sc, tmp_path / name, seed=2, record=False)
        out[name] = m["navigation"]["variants"]["ins"]
    assert out["aided"]["updates_applied"]["usbl"] == m["sensor_readings"]["usbl"] == 60
    assert "usbl" not in out["free"]["updates_applied"]
    assert out["free"]["position_drift_max_m"] > 10.0
    assert out["aided"]["position_drift_max_m"] < 3.0
    assert out["aided"]["heading_rmse_deg"] < 2.0  # the update does not spoil the attitude


def test_the_filter_s_vector_update_refuses_what_it_cannot_use() -> None:
    from twin.onboard.eskf import Eskf
    from twin.onboard.ins import NavState

    f = Eskf(None, NavState(0.0, 0.6, 2.1, -10.0, np.zeros(3), np.eye(3)))
    h = np.zeros((2, 15))
    h[0, 6], h[1, 7] = 6.4e6, 5.0e6
    r = np.diag([0.25, 0.25])
    assert f.update_vector("fix", np.array([0.3, -0.2]), h, r).applied
    assert f.counts["fix"] == 1
    with pytest.raises(ValueError, match=r"z \(2,\), H \(3, 15\)"):
        f.update_vector("fix", np.zeros(2), np.zeros((3, 15)), r)
    with pytest.raises(ValueError, match="non-finite"):
        f.update_vector("fix", np.array([np.nan, 0.0]), h, r)
    with pytest.raises(ValueError, match="symmetric positive definite"):
        f.update_vector("fix", np.zeros(2), h, np.diag([0.25, -1.0]))


def test_an_aid_tied_to_a_sensor_without_its_channels_is_refused_by_validate(tmp_path: Path):
    # The USBL aid reads position_m and slant_range_m; a depth gauge gives neither. run would
    # fail at the first reading, so validate refuses it (exit 2, one line naming the field).
    text = TRIAL.read_text().replace('kind = "usbl"\npreset = "generic"', 'kind = "depth"')
    text = text.replace("range_fraction = 0.02   # a worse unit", "# range_fraction: a worse unit")
    bad = tmp_path / "depth_as_usbl.toml"
    bad.write_text(text)
    with pytest.raises(ScenarioError) as err:
        scenarios.load(bad)
    (line,) = [e for e in err.value.errors if e.startswith("navigation.aids.usbl")]
    assert "aid 'usbl_position' reads ['position_m', 'slant_range_m']" in line
    assert "sensor 'usbl' (kind 'depth') does not give" in line
