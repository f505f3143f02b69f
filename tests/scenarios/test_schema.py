"""Scenario files: the shipped trials load, bad files give errors that name the field."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import pickle
import tomllib
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pytest

import scenarios
from scenarios import Scenario, ScenarioError, load, load_scenario, parse_scenario, schema, shipped
from scenarios.schema import (
    Current,
    HeadingLeg,
    LawnmowerMission,
    LegsMission,
    ProfilePoint,
    StationKeepingMission,
    WaypointLeg,
)

DATA = Path(__file__).parent / "data"

# A small valid open-sea scenario; each bad case below changes one thing in a copy of it.
OPEN_SEA = """
name = "base"
duration_s = 300.0
start_utc = 2021-09-03T02:00:00Z
[place]
latitude_deg = 37.54
longitude_deg = 122.06
[water]
seabed_depth_m = 50.0
[initial]
depth_m = 10.0
[mission]
kind = "legs"
[[mission.legs]]
to_m = [0.0, 100.0]
depth_m = 10.0
speed_mps = 1.5
[[mission.legs]]
heading_deg = 90.0
duration_s = 60.0
depth_m = 12.0
speed_mps = 1.0
"""

TANK = """
name = "base_tank"
duration_s = 60.0
start_utc = 2021-07-31T04:00:00Z
scene = "tank"
[place]
latitude_deg = 36.175
longitude_deg = 120.482
[initial]
position_m = [-4.0, 0.0]
depth_m = 2.0
[mission]
kind = "legs"
acceptance_radius_m = 1.0
[[mission.legs]]
to_m = [4.0, 0.0]
depth_m = 2.0
speed_mps = 0.5
"""

LAWNMOWER = {
    "kind": "lawnmower",
    "origin_m": [0.0, 0.0],
    "heading_deg": 0.0,
    "lane_length_m": 300.0,
    "lane_spacing_m": 50.0,
    "lanes": 4,
    "depth_m": 10.0,
    "speed_mps": 1.5,
}


def _base(text: str = OPEN_SEA) -> dict[str, Any]:
    return tomllib.loads(text)


def _errors(data: dict[str, Any]) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, source="case")
    return info.value.errors


# ---- shipped scenarios -------------------------------------------------------------------------


def test_shipped_lists_the_required_trials() -> None:
    names = list(shipped())
    assert names == sorted(names)
    assert {"default", "station_keeping_10m", "lawnmower_10m", "tank"} <= set(names)
    for path in shipped().values():
        assert path.parent == scenarios.SCENARIOS_DIR
        assert path.suffix == ".toml"


@pytest.mark.parametrize("name", sorted(shipped()))
def test_every_shipped_scenario_loads(name: str) -> None:
    path = shipped()[name]
    s = load(name)
    assert isinstance(s, Scenario)
    assert s.name == name == path.stem
    assert s.description
    assert s.start_utc.tzinfo is UTC
    # Each file opens with a comment header saying what it reproduces.
    assert path.read_text().splitlines()[0].startswith("# ")
    assert "Reproduces" in path.read_text()
    assert load(path) == s == load(str(path)) == load_scenario(path)


def test_default_is_the_readme_sea_trial() -> None:
    s = load("default")
    assert (s.place.latitude_deg, s.place.longitude_deg) == (37.54, 122.06)
    assert datetime(2021, 9, 3, 2, tzinfo=UTC) <= s.start_utc <= datetime(2021, 9, 3, 3, tzinfo=UTC)
    assert s.duration_s == 300.0
    assert s.scene == "open_sea"
    assert (s.sensors.imu, s.sensors.depth) == ("lig2024", "ms5837_30ba")
    assert isinstance(s.mission, LegsMission)
    assert len(s.mission.legs) >= 2
    assert all(isinstance(leg, WaypointLeg) for leg in s.mission.legs)
    assert {leg.depth_m for leg in s.mission.legs} == {10.0}


def test_station_keeping_trial() -> None:
    s = load("station_keeping_10m")
    assert isinstance(s.mission, StationKeepingMission)
    assert s.mission.depth_m == 10.0
    assert s.duration_s == 600.0
    assert s.water.seabed_depth_m == 60.0
    assert s.current.kind == "constant"
    assert 0.0 < s.current.speed_mps <= 0.2


def test_lawnmower_trial_finishes_within_its_duration() -> None:
    s = load("lawnmower_10m")
    m = s.mission
    assert isinstance(m, LawnmowerMission)
    assert m.depth_m == 10.0
    assert m.lanes == 4
    path_m = m.lanes * m.lane_length_m + (m.lanes - 1) * m.lane_spacing_m
    nominal_s = path_m / m.speed_mps
    assert 12 * 60 <= nominal_s <= 18 * 60  # about a quarter of an hour of survey
    assert nominal_s < s.duration_s <= 1.3 * nominal_s


def test_tank_trial() -> None:
    s = load("tank")
    assert s.scene == "tank"
    assert s.duration_s <= 120.0  # a quick CI trial
    assert isinstance(s.mission, LegsMission)
    assert all(leg.depth_m == 2.0 for leg in s.mission.legs)


def test_load_unknown_name_lists_the_shipped_ones() -> None:
    with pytest.raises(ScenarioError, match="default") as info:
        load("no_such_trial")
    assert info.value.source == "no_such_trial"


def test_load_missing_file() -> None:
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(DATA / "does_not_exist.toml")


# ---- values, defaults and types ----------------------------------------------------------------


def test_defaults_fill_every_optional_field() -> None:
    data = _base()
    del data["water"], data["initial"]
    s = parse_scenario(data)
    assert s.seed == 0
    assert s.description == ""
    assert s.scene == "open_sea"
    assert (s.water.density_kg_m3, s.water.temperature_c, s.water.salinity_psu) == (1025, 15, 35)
    assert s.water.jerlov_type == "II"
    assert s.water.seabed_depth_m is None
    assert s.current == Current()
    assert s.initial.position_m == (0.0, 0.0)
    assert s.initial.depth_m == 0.0
    assert s.mission.acceptance_radius_m == 5.0
    assert (s.sensors.imu, s.sensors.depth) == ("lig2024", "ms5837_30ba")
    assert (s.autopilot.rate_hz, s.autopilot.attitude_source) == (10.0, "truth")
    r = s.recording
    assert (r.truth_rate_hz, r.camera, r.camera_rate_hz) == (10.0, True, 1.0)
    assert (r.camera_width, r.camera_height) == (320, 240)


def test_all_features_file() -> None:
    s = load_scenario(DATA / "all_features.toml")
    # "2021-09-03T10:00:00+08:00" as a string, normalised to UTC.
    assert s.start_utc == datetime(2021, 9, 3, 2, tzinfo=UTC)
    assert s.start_utc.tzinfo is UTC
    assert s.current.kind == "profile"
    assert s.current.profile[1] == ProfilePoint(20.0, 0.2, 0.0)
    assert isinstance(s.mission, LegsMission)
    assert isinstance(s.mission.legs[1], HeadingLeg)
    assert s.initial.position_m == (10.0, -20.0)
    assert isinstance(s.initial.position_m, tuple)
    assert isinstance(s.initial.depth_m, float)  # TOML integers become floats in float fields
    assert dict(s.sensors.imu_overrides) == {
        "gyro_turn_on_bias": 1.0e-4,
        "accel_noise_density": (1.0e-3, 2, 3.5e-3),
        "rate_hz": 50,
    }
    assert isinstance(dict(s.sensors.imu_overrides)["rate_hz"], int)
    assert s.autopilot.attitude_source == "estimate"
    assert s.recording.camera is False
    assert s.navigation.variants == ("ins", "pol", "lig")
    assert s.navigation.steering_variant == "lig"
    assert (s.navigation.compass_rate_hz, s.navigation.depth_aiding) == (2.0, False)
    assert s.navigation.tuning == "paper"


@pytest.mark.parametrize(
    ("nav", "extra", "path", "needle"),
    [
        ({"variants": ["ins", "nope"]}, {}, "navigation.variants[1]", '"nope" is not one of'),
        ({"variants": ["lig", "lig"]}, {}, "navigation.variants[1]", "listed twice"),
        ({"variants": "lig"}, {}, "navigation.variants", "expected a list"),
        ({"variants": ["ins"], "steer_on": "lig"}, {}, "navigation.steer_on", "not one of the"),
        ({"variants": ["ins"], "compass_rate_hz": 0}, {}, "navigation.compass_rate_hz", "range"),
        ({"variants": ["ins", "lig"]}, {"no_camera": True}, "navigation.variants", "need a camera"),
        ({"variants": []}, {"estimate": True}, "autopilot.attitude_source", "needs an onboard"),
        ({"varients": ["ins"]}, {}, "navigation.varients", "unknown key"),
        ({"variants": ["ins"], "tuning": "guess"}, {}, "navigation.tuning", "not one of"),
        (
            {"variants": ["ins"], "gate_probability": 0.2},
            {},
            "navigation.gate_probability",
            "range",
        ),
    ],
)
def test_navigation_errors_name_the_field(nav, extra, path, needle) -> None:
    data = load_scenario(DATA / "all_features.toml").to_dict()
    data["navigation"] = nav
    if extra.get("no_camera"):
        data["sensors"].pop("polarimeter")
        data["sensors"].pop("polarimeter_overrides")
    if not extra.get("estimate"):
        data["autopilot"]["attitude_source"] = "truth"
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data)
    hits = [e for e in info.value.errors if e.startswith(path)]
    assert hits and needle in hits[0], info.value.errors


def test_navigation_defaults_to_no_filter_and_round_trips() -> None:
    s = parse_scenario(_base(OPEN_SEA))
    assert s.navigation.variants == () and s.navigation.steering_variant is None
    f = load_scenario(DATA / "all_features.toml")
    assert parse_scenario(f.to_dict()) == f


def test_offset_datetime_is_normalised_to_utc() -> None:
    data = _base(OPEN_SEA.replace("2021-09-03T02:00:00Z", "2021-09-03T10:30:00+08:00"))
    s = parse_scenario(data)
    assert s.start_utc == datetime(2021, 9, 3, 2, 30, tzinfo=UTC)
    assert s.start_utc.utcoffset().total_seconds() == 0  # type: ignore[union-attr]
    assert s.utc_at(60.0) == datetime(2021, 9, 3, 2, 31, tzinfo=UTC)
    assert s.end_utc == datetime(2021, 9, 3, 2, 35, tzinfo=UTC)


def test_dataclasses_are_frozen_with_slots() -> None:
    s = load("default")
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.seed = 3  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.place.latitude_deg = 0.0  # type: ignore[misc]
    for obj in (s, s.place, s.water, s.current, s.initial, s.mission, s.sensors, s.recording):
        assert not hasattr(obj, "__dict__")
    hash(s)  # hashable: usable as a cache key


def test_replace_seed() -> None:
    s = load("default")
    t = s.replace_seed(42)
    assert t.seed == 42
    assert dataclasses.replace(t, seed=s.seed) == s
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError):
            s.replace_seed(bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", sorted(shipped()))
def test_to_dict_round_trip_through_json(name: str) -> None:
    s = load(name)
    d = s.to_dict()
    again = parse_scenario(json.loads(json.dumps(d)))
    assert again == s


def test_to_dict_round_trip_all_kinds() -> None:
    base = _base()
    variants: list[dict[str, Any]] = [_base(TANK)]
    s = load_scenario(DATA / "all_features.toml")
    variants.append(s.to_dict())
    gm = copy.deepcopy(base)
    gm["current"] = {"kind": "gauss_markov", "speed_mps": 0.2, "toward_deg": 45.0}
    gm["current"] |= {"sigma_mps": 0.05, "tau_s": 60.0}
    variants.append(gm)
    lawn = copy.deepcopy(base)
    lawn["mission"] = dict(LAWNMOWER)
    variants.append(lawn)
    loiter = copy.deepcopy(base)
    loiter["mission"] = {
        "kind": "station_keeping",
        "center_m": [5.0, 5.0],
        "depth_m": 10.0,
        "radius_m": 20.0,
        "speed_mps": 1.0,
    }
    variants.append(loiter)
    for data in variants:
        s = parse_scenario(data)
        text = json.dumps(s.to_dict())
        assert parse_scenario(json.loads(text)) == s


def test_scenario_error_pickles() -> None:
    err = ScenarioError(["a: one", "b: two"], source="x.toml")
    back = pickle.loads(pickle.dumps(err))
    assert back.errors == err.errors
    assert back.source == "x.toml"
    assert str(back) == str(err)
    assert isinstance(back, ValueError)


# ---- bad inputs: one mistake, one error, naming the field --------------------------------------

Mutation = Callable[[dict[str, Any]], None]


def _set(path: str, value: Any) -> Mutation:
    """Mutation that sets a dotted path (with [i] indices) in the data."""

    def apply(data: dict[str, Any]) -> None:
        node: Any = data
        parts = path.replace("]", "").replace("[", ".").split(".")
        for part in parts[:-1]:
            node = node[int(part)] if part.isdigit() else node.setdefault(part, {})
        last = parts[-1]
        if last.isdigit():
            node[int(last)] = value
        else:
            node[last] = value

    return apply


def _del(path: str) -> Mutation:
    def apply(data: dict[str, Any]) -> None:
        node: Any = data
        parts = path.replace("]", "").replace("[", ".").split(".")
        for part in parts[:-1]:
            node = node[int(part)] if part.isdigit() else node[part]
        del node[parts[-1]]

    return apply


def _all(*mutations: Mutation) -> Mutation:
    def apply(data: dict[str, Any]) -> None:
        for m in mutations:
            m(data)

    return apply


NAIVE = datetime(2021, 9, 3, 2)
PROFILE_BAD = [
    {"depth_m": 0.0, "speed_mps": 0.3, "toward_deg": 90.0},
    {"depth_m": 20.0, "speed_mps": 0.2, "toward_deg": 80.0},
    {"depth_m": 20.0, "speed_mps": 0.1, "toward_deg": 70.0},
]

# (id, base, mutation, field path the error must start with, text the message must contain)
BAD_CASES: list[tuple[str, str, Mutation, str, str]] = [
    ("latitude 95", OPEN_SEA, _set("place.latitude_deg", 95.0), "place.latitude_deg", "(-90, 90)"),
    ("longitude NaN", OPEN_SEA, _set("place.longitude_deg", math.nan), "place.longitude_deg",
     "not a finite number"),
    ("depth inf", OPEN_SEA, _set("initial.depth_m", math.inf), "initial.depth_m", "finite"),
    ("unknown top key", OPEN_SEA, _set("colour", "red"), "colour", "allowed keys"),
    ("unknown nested key", OPEN_SEA, _set("water.turbidity", 3.0), "water.turbidity",
     "seabed_depth_m"),
    ("unknown leg key", OPEN_SEA, _set("mission.legs[0].depth", 3.0), "mission.legs[0].depth",
     "unknown key"),
    ("naive datetime", OPEN_SEA, _set("start_utc", NAIVE), "start_utc", "UTC offset"),
    ("naive ISO string", OPEN_SEA, _set("start_utc", "2021-09-03T02:00:00"), "start_utc",
     "UTC offset"),
    ("not a datetime", OPEN_SEA, _set("start_utc", "tomorrow"), "start_utc", "ISO-8601"),
    ("date only", OPEN_SEA, _set("start_utc", NAIVE.date()), "start_utc", "a date"),
    ("string for number", OPEN_SEA, _set("duration_s", "600"), "duration_s", "a string"),
    ("bool for number", OPEN_SEA, _set("initial.speed_mps", True), "initial.speed_mps",
     "a boolean"),
    ("bool for int", OPEN_SEA, _set("seed", True), "seed", "a boolean"),
    ("float for int", OPEN_SEA, _set("seed", 1.0), "seed", "an integer"),
    ("negative seed", OPEN_SEA, _set("seed", -1), "seed", "[0, 9223372036854775807]"),
    ("seed past int64", OPEN_SEA, _set("seed", 2**63), "seed", "[0, 9223372036854775807]"),
    ("zero duration", OPEN_SEA, _set("duration_s", 0.0), "duration_s", "(0, 86400]"),
    ("negative speed", OPEN_SEA, _set("mission.legs[1].speed_mps", -1.0),
     "mission.legs[1].speed_mps", "(0, 2.5]"),
    ("too fast", OPEN_SEA, _set("mission.legs[0].speed_mps", 3.0), "mission.legs[0].speed_mps",
     "(0, 2.5]"),
    ("heading 360", OPEN_SEA, _set("initial.heading_deg", 360.0), "initial.heading_deg",
     "[0, 360)"),
    ("pitch 91", OPEN_SEA, _set("initial.pitch_deg", 91.0), "initial.pitch_deg", "[-90, 90]"),
    ("bad name", OPEN_SEA, _set("name", "Sea Trial"), "name", "[a-z0-9_]+"),
    ("bad scene", OPEN_SEA, _set("scene", "lake"), "scene", '"open_sea", "tank"'),
    ("bad jerlov", OPEN_SEA, _set("water.jerlov_type", "IV"), "water.jerlov_type", '"9C"'),
    ("density", OPEN_SEA, _set("water.density_kg_m3", 1100.0), "water.density_kg_m3",
     "[990, 1050]"),
    ("unknown mission kind", OPEN_SEA, _set("mission.kind", "zigzag"), "mission.kind",
     '"legs", "lawnmower", "station_keeping"'),
    ("leg with both", OPEN_SEA, _set("mission.legs[0].heading_deg", 10.0), "mission.legs[0]",
     "both to_m and heading_deg"),
    ("leg with neither", OPEN_SEA, _del("mission.legs[0].to_m"), "mission.legs[0]",
     "neither to_m nor heading_deg"),
    ("heading-leg key on a waypoint leg", OPEN_SEA, _set("mission.legs[0].duration_s", 5.0),
     "mission.legs[0].duration_s", "waypoint leg"),
    ("no legs", OPEN_SEA, _set("mission.legs", []), "mission.legs", ">= 1"),
    ("missing place", OPEN_SEA, _del("place"), "place", "missing"),
    ("missing name", OPEN_SEA, _del("name"), "name", "missing"),
    ("missing start", OPEN_SEA, _del("start_utc"), "start_utc", "missing"),
    ("missing leg depth", OPEN_SEA, _del("mission.legs[0].depth_m"), "mission.legs[0].depth_m",
     "missing"),
    ("missing mission kind", OPEN_SEA, _del("mission.kind"), "mission.kind", "missing"),
    ("section not a table", OPEN_SEA, _set("place", 5), "place", "a [place] table"),
    ("position length", OPEN_SEA, _set("initial.position_m", [1.0]), "initial.position_m",
     "1 element"),
    ("position element", OPEN_SEA, _set("initial.position_m", [1.0, "x"]),
     "initial.position_m[1]", "a string"),
    ("camera not bool", OPEN_SEA, _set("recording.camera", 1), "recording.camera",
     "true or false"),
    ("camera width float", OPEN_SEA, _set("recording.camera_width", 320.0),
     "recording.camera_width", "an integer"),
    ("camera too wide", OPEN_SEA, _set("recording.camera_width", 4000), "recording.camera_width",
     "[16, 1920]"),
    ("attitude source", OPEN_SEA, _set("autopilot.attitude_source", "gps"),
     "autopilot.attitude_source", '"truth", "estimate"'),
    ("empty imu preset", OPEN_SEA, _set("sensors.imu", ""), "sensors.imu", "non-empty"),
    ("override string", OPEN_SEA, _set("sensors.imu_overrides", {"gyro_bias_dph": "big"}),
     "sensors.imu_overrides.gyro_bias_dph", "a number or an array of numbers"),
    ("override list element", OPEN_SEA, _set("sensors.depth_overrides", {"noise": [1.0, None]}),
     "sensors.depth_overrides.noise[1]", "a number"),
    ("seabed above a leg", OPEN_SEA, _set("water.seabed_depth_m", 11.0),
     "mission.legs[1].depth_m", "seabed"),
    ("current key for another kind", OPEN_SEA, _set("current", {"kind": "none", "speed_mps": 1.0}),
     "current.speed_mps", 'not used by current.kind = "none"'),
    ("unknown current kind", OPEN_SEA, _set("current", {"kind": "tidal"}), "current.kind",
     '"gauss_markov"'),
    ("constant current without direction", OPEN_SEA,
     _set("current", {"kind": "constant", "speed_mps": 0.2}), "current.toward_deg", "missing"),
    ("current too fast", OPEN_SEA,
     _set("current", {"kind": "constant", "speed_mps": 4.0, "toward_deg": 0.0}),
     "current.speed_mps", "[0, 3]"),
    ("gauss-markov without tau", OPEN_SEA,
     _set("current", {"kind": "gauss_markov", "sigma_mps": 0.05}), "current.tau_s", "missing"),
    ("profile depths not increasing", OPEN_SEA,
     _set("current", {"kind": "profile", "profile": PROFILE_BAD}), "current.profile[2].depth_m",
     "increase"),
    ("profile of one point", OPEN_SEA,
     _set("current", {"kind": "profile", "profile": PROFILE_BAD[:1]}), "current.profile", ">= 2"),
    ("lawnmower lanes float", OPEN_SEA, _set("mission", {**LAWNMOWER, "lanes": 4.0}),
     "mission.lanes", "an integer"),
    ("lawnmower zero lanes", OPEN_SEA, _set("mission", {**LAWNMOWER, "lanes": 0}),
     "mission.lanes", ">= 1"),
    ("lawnmower acceptance too big", OPEN_SEA,
     _set("mission", {**LAWNMOWER, "acceptance_radius_m": 60.0}), "mission.acceptance_radius_m",
     "skipped"),
    ("lawnmower key in a legs mission", OPEN_SEA, _set("mission.lanes", 3),
     "mission.lanes", 'not used by mission.kind = "legs"'),
    ("station keeping zero radius", OPEN_SEA,
     _set("mission", {"kind": "station_keeping", "center_m": [0, 0], "depth_m": 10.0,
                      "radius_m": 0.0, "speed_mps": 1.0}), "mission.radius_m", "> 0"),
    ("tank depth 10", TANK, _set("initial.depth_m", 10.0), "initial.depth_m", "[0, 3.5]"),
    ("tank leg depth", TANK, _set("mission.legs[0].depth_m", 3.8), "mission.legs[0].depth_m",
     "tank"),
    ("tank waypoint outside", TANK, _set("mission.legs[0].to_m", [7.0, 0.0]),
     "mission.legs[0].to_m", "outside the tank"),
    ("tank start outside", TANK, _set("initial.position_m", [0.0, -3.0]), "initial.position_m",
     "outside the tank"),
    ("tank seabed", TANK, _set("water.seabed_depth_m", 4.0), "water.seabed_depth_m", "tank"),
    ("tank lawnmower outside", TANK,
     _set("mission", {**LAWNMOWER, "acceptance_radius_m": 1.0, "depth_m": 2.0}), "mission",
     "outside the tank"),
    ("tank loiter outside", TANK,
     _set("mission", {"kind": "station_keeping", "center_m": [0, 0], "depth_m": 2.0,
                      "radius_m": 4.0, "speed_mps": 0.5}), "mission.radius_m",
     "outside the tank"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("base", "mutate", "path", "text"),
    [case[1:] for case in BAD_CASES],
    ids=[case[0] for case in BAD_CASES],
)
def test_bad_input_names_the_field(base: str, mutate: Mutation, path: str, text: str) -> None:
    data = _base(base)
    mutate(data)
    errors = _errors(data)
    assert len(errors) == 1, errors  # one mistake, one error: no follow-on noise
    assert errors[0].startswith(f"{path}: "), errors[0]
    assert text in errors[0], errors[0]


def test_error_shows_the_offending_value_and_the_allowed_range() -> None:
    data = _base()
    data["mission"]["legs"][1]["speed_mps"] = -1.25
    (err,) = _errors(data)
    assert err == "mission.legs[1].speed_mps: -1.25 is out of range; allowed: (0, 2.5]"


def test_unknown_key_lists_the_allowed_keys() -> None:
    data = _base()
    data["place"]["altitude_m"] = 3.0
    (err,) = _errors(data)
    assert "latitude_deg, longitude_deg" in err


def test_valid_tank_base_and_open_sea_base_load() -> None:
    # The bad cases are single changes to these; they must be valid themselves.
    parse_scenario(_base(OPEN_SEA))
    parse_scenario(_base(TANK))


def test_tank_allows_depth_limit_and_points_inside() -> None:
    data = _base(TANK)
    data["mission"]["legs"][0]["depth_m"] = 3.5
    data["mission"]["legs"][0]["to_m"] = [5.9, -2.9]
    parse_scenario(data)


def test_duration_need_not_cover_the_mission() -> None:
    data = _base()
    data["duration_s"] = 1.0  # the run cuts the mission short; that is allowed
    parse_scenario(data)


def test_several_errors_in_one_file_are_all_reported() -> None:
    path = DATA / "many_errors.toml"
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    err = info.value
    fields = sorted(e.split(": ", 1)[0] for e in err.errors)
    assert fields == sorted(
        [
            "duration_s",
            "speling",
            "place.latitude_deg",
            "water.jerlov_type",
            "mission.legs[0].depth_m",  # below the seabed
            "initial.depth_m",
            "mission.legs[1].speed_mps",
            "recording.camera",
        ]
    )
    text = str(err)
    assert text.startswith(str(path))
    assert len(text.splitlines()) == 1 + len(err.errors)  # a header, then one line per problem
    assert err.source == str(path)


def test_toml_syntax_error_gives_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text('name = "broken"\nduration_s = 300.0\nstart_utc = = 3\n')
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert str(path) in str(info.value)
    (err,) = info.value.errors
    assert err.startswith("line 3, column ")
    assert "TOML syntax error" in err


def test_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "latin1.toml"
    path.write_bytes('name = "caf\u00e9"\n'.encode("latin-1"))
    with pytest.raises(ScenarioError, match="UTF-8"):
        load_scenario(path)


# ---- geometry and helpers ----------------------------------------------------------------------


def _lawnmower(**kw: Any) -> LawnmowerMission:
    args = {k: v for k, v in LAWNMOWER.items() if k != "kind"}
    args["origin_m"] = tuple(args["origin_m"])
    args.update(kw)
    return LawnmowerMission(**args)


def test_lawnmower_north_lanes_step_east() -> None:
    m = _lawnmower()
    assert m.waypoints_m() == (
        (0.0, 0.0),
        (0.0, 300.0),
        (50.0, 300.0),
        (50.0, 0.0),
        (100.0, 0.0),
        (100.0, 300.0),
        (150.0, 300.0),
        (150.0, 0.0),
    )
    legs = m.expand()
    assert len(legs) == 2 * m.lanes
    assert all(isinstance(leg, WaypointLeg) for leg in legs)
    assert {(leg.depth_m, leg.speed_mps) for leg in legs} == {(10.0, 1.5)}
    assert [leg.to_m for leg in legs] == list(m.waypoints_m())


def test_lawnmower_east_lanes_step_south() -> None:
    m = _lawnmower(heading_deg=90.0, origin_m=(10.0, 20.0), lanes=2)
    pts = m.waypoints_m()
    expected = [(10.0, 20.0), (310.0, 20.0), (310.0, -30.0), (10.0, -30.0)]
    assert len(pts) == len(expected)
    for got, want in zip(pts, expected, strict=True):
        assert got == pytest.approx(want, abs=1e-9)


@pytest.mark.parametrize("heading_deg", [0.0, 33.0, 135.0, 271.5])
def test_lawnmower_geometry_any_heading(heading_deg: float) -> None:
    m = _lawnmower(heading_deg=heading_deg, lanes=5, origin_m=(-7.0, 4.0))
    pts = m.waypoints_m()
    h = math.radians(heading_deg)
    along = (math.sin(h), math.cos(h))
    assert pts[0] == pytest.approx(m.origin_m)
    for i in range(m.lanes):
        a, b = pts[2 * i], pts[2 * i + 1]
        run = (b[0] - a[0], b[1] - a[1])
        assert math.hypot(*run) == pytest.approx(m.lane_length_m)
        # Lanes alternate direction: even lanes along the heading, odd ones against it.
        sign = 1.0 if i % 2 == 0 else -1.0
        assert run[0] * along[0] + run[1] * along[1] == pytest.approx(sign * m.lane_length_m)
        if i:
            prev_end = pts[2 * i - 1]
            step = (a[0] - prev_end[0], a[1] - prev_end[1])
            assert math.hypot(*step) == pytest.approx(m.lane_spacing_m)
            # To the right of the first lane's direction: the ENU cross product along x step < 0.
            assert along[0] * step[1] - along[1] * step[0] == pytest.approx(-m.lane_spacing_m)


def test_single_lane() -> None:
    m = _lawnmower(lanes=1)
    assert m.waypoints_m() == ((0.0, 0.0), (0.0, 300.0))


def test_legs_mission_expands_to_itself() -> None:
    s = parse_scenario(_base())
    assert isinstance(s.mission, LegsMission)
    assert s.mission.expand() == s.mission.legs


def test_current_mean_velocity() -> None:
    assert Current().mean_velocity_en(5.0) == (0.0, 0.0)
    east = Current(kind="constant", speed_mps=0.2, toward_deg=90.0).mean_velocity_en(30.0)
    assert east == pytest.approx((0.2, 0.0), abs=1e-12)
    profile = Current(
        kind="profile",
        profile=(ProfilePoint(0.0, 0.2, 90.0), ProfilePoint(10.0, 0.4, 0.0)),
    )
    assert profile.mean_velocity_en(-1.0) == pytest.approx((0.2, 0.0), abs=1e-12)
    assert profile.mean_velocity_en(5.0) == pytest.approx((0.1, 0.2), abs=1e-12)
    assert profile.mean_velocity_en(50.0) == pytest.approx((0.0, 0.4), abs=1e-12)
    # Across North: components interpolate, no 360-degree jump.
    wrap = Current(
        kind="profile",
        profile=(ProfilePoint(0.0, 1.0, 350.0), ProfilePoint(10.0, 1.0, 10.0)),
    )
    e, n = wrap.mean_velocity_en(5.0)
    assert e == pytest.approx(0.0, abs=1e-12)
    assert n == pytest.approx(math.cos(math.radians(10.0)))


def test_optics_and_polarimeter_settings_validate_and_round_trip() -> None:
    d = load("default").to_dict()
    d["sensors"]["polarimeter"] = "phx050s_p"
    d["sensors"]["polarimeter_overrides"] = {"rate_hz": 2}
    d["optics"].update(cie_sky_type=3, sky_polarization="berry", turbidity=4.0, wind_speed_mps=5.0)
    s = parse_scenario(d)
    assert s.sensors.polarimeter == "phx050s_p"
    assert s.optics.sky_polarization == "berry" and s.optics.turbidity == 4.0
    assert parse_scenario(s.to_dict()) == s
    # Without a polarimeter the key is absent (TOML has no null) and reads back as None.
    assert "polarimeter" not in load("lawnmower_10m").to_dict()["sensors"]
    assert load("lawnmower_10m").sensors.polarimeter is None


@pytest.mark.parametrize(
    ("key", "value", "field"),
    [
        ("cie_sky_type", 0, "optics.cie_sky_type"),
        ("sky_polarization", "mie", "optics.sky_polarization"),
        ("dop_max", 1.5, "optics.dop_max"),
        ("turbidity", -1.0, "optics.turbidity"),
        ("wind_speed_mps", 40.0, "optics.wind_speed_mps"),
        ("wind_beaufort", 12, "optics.wind_beaufort"),
        ("wind_beaufort", 5.5, "optics.wind_beaufort"),
        ("wavelength_nm", 1000.0, "optics.wavelength_nm"),
        ("haze", 1.0, "optics.haze"),
        ("bubbles", "foam", "optics.bubbles"),
        ("flicker", 1, "optics.flicker"),
    ],
)
def test_bad_optics_name_the_field(key: str, value: object, field: str) -> None:
    d = load("default").to_dict()
    d["optics"][key] = value
    with pytest.raises(ScenarioError) as info:
        parse_scenario(d)
    assert field in str(info.value)


def test_bubbles_and_flicker_default_to_the_real_sea_and_reach_the_camera() -> None:
    from sensors.polarimeter.optics.bubbles import BUBBLE_MODELS
    from sensors.polarimeter.optics.caustics import FLICKER_MODELS
    from twin.world.assembly import optics_config

    assert schema.BUBBLE_MODELS == BUBBLE_MODELS and schema.FLICKER_MODELS == FLICKER_MODELS
    d = load("default").to_dict()
    d["optics"].update(wind_speed_mps=8.0)
    d["optics"].pop("bubbles", None), d["optics"].pop("flicker", None)
    s = parse_scenario(d)
    assert (s.optics.bubbles, s.optics.flicker) == ("hall_novarini", "caustics")
    cfg = optics_config(s)
    assert (cfg.bubbles, cfg.flicker) == ("hall_novarini", "caustics")
    d["optics"].update(bubbles="ideal", flicker="ideal")
    cfg = optics_config(parse_scenario(d))
    assert (cfg.bubbles, cfg.flicker) == ("ideal", "ideal")
    # The tank scene has no breaking waves, whatever its wind: no bubbles, but the caustics.
    tank = _base(TANK)
    tank["optics"] = {"wind_speed_mps": 2.0}
    cfg = optics_config(parse_scenario(tank))
    assert (cfg.bubbles, cfg.flicker) == ("ideal", "caustics")


def test_the_wind_may_be_a_beaufort_force_but_not_both() -> None:
    d = load("default").to_dict()
    d["optics"].pop("wind_speed_mps", None)
    d["optics"]["wind_beaufort"] = 5
    s = parse_scenario(d)
    assert s.optics.wind_speed_mps == pytest.approx(9.35)  # WMO force 5: 8.0–10.7 m/s
    assert parse_scenario(s.to_dict()) == s  # written back as the speed
    d["optics"]["wind_speed_mps"] = 3.0
    with pytest.raises(ScenarioError, match=r"wind_beaufort.*wind_speed_mps"):
        parse_scenario(d)


def test_each_value_list_the_schema_copies_equals_its_owners() -> None:
    # The lists the schema imports are one declaration; the two it copies (their owners are heavy
    # imports for a schema) are tied here, so that a new water type or sky model cannot drift.
    from sensors.polarimeter.optics import sky, water
    from twin.world.current import Current

    assert schema.JERLOV_TYPES == water.JERLOV_TYPES == tuple(water.JERLOV_500NM)
    assert set(schema.JerlovType.__args__) == set(schema.JERLOV_TYPES)
    assert schema.SKY_POLARIZATION_MODELS == sky.POLARIZATIONS == sky.Polarization.__args__
    assert Current.KINDS == schema.CURRENT_KINDS == schema.CurrentKind.__args__
