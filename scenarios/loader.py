"""TOML sea-trial files to validated :class:`~scenarios.schema.Scenario` objects.

The whole file is checked before anything runs, and every problem is collected, so a user fixes a
file in one pass: :class:`ScenarioError` carries one line per problem, each naming the field by its
dotted path (``mission.legs[2].speed_mps``), the offending value and what is allowed.

Checks, in order: TOML syntax; each field's presence, type (no strings for numbers, no booleans for
numbers, no NaN or infinity), range or choices; unknown keys (in every table); then cross-field
rules (tank limits, seabed clearance, profile order, lawnmower geometry). A cross-field rule is
checked only on fields that passed their own checks, so one mistake gives one error.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import tomllib
from collections.abc import Mapping
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from scenarios.reading import (
    _MISSING,
    MSG_BAD_NAME,
    MSG_NOT_A_CHOICE,
    MSG_NOT_FINITE,
    MSG_WRONG_TYPE,
    Range,
    ScenarioError,
    _all_set,
    _build,
    _choices,
    _Default,
    _Report,
    _show,
    _Table,
    _type_name,
)
from scenarios.schema import (
    ATTITUDE_SOURCES,
    BUBBLE_MODELS,
    CALIBRATION_MODELS,
    CURRENT_KINDS,
    FLICKER_MODELS,
    GRAVITY_MAPS,
    HARDWARE_SIGMAS,
    JERLOV_TYPES,
    LENS_MODELS,
    MISSION_KINDS,
    MOUNTING_MODELS,
    NAV_ALIGNMENTS,
    NAV_TUNINGS,
    PARTICLE_MODELS,
    SCENES,
    SKY_POLARIZATION_MODELS,
    SPEED_CONTROLS,
    SUN_MEASUREMENTS,
    TANK_FLOOR_DEPTH_M,
    TANK_LENGTH_M,
    TANK_MAX_DEPTH_M,
    TANK_WIDTH_M,
    Autopilot,
    Current,
    Gravity,
    Hardware,
    HeadingLeg,
    Initial,
    LawnmowerMission,
    Leg,
    LegsMission,
    Mission,
    Navigation,
    Optics,
    OverrideValue,
    Place,
    PlannedMission,
    ProfilePoint,
    Recording,
    Scenario,
    Sensors,
    StationKeepingMission,
    Water,
    WaypointLeg,
    nav_variants,
)
from twin.core.extensions import INS_ONLY, SCENARIO_CHECKS
from twin.core.options import PARTICLE_DOP_MAX, WATER_DEPOLARIZATION_RATIO

# ---- error text --------------------------------------------------------------------------------

MSG_NAIVE_TIME = (
    "{value} has no UTC offset; write a timezone-aware time such as 2021-09-03T02:00:00Z "
    "or 2021-09-03T10:00:00+08:00"
)
MSG_LEG_BOTH = (
    "has both to_m and heading_deg; a leg is EITHER a waypoint leg (to_m, depth_m, speed_mps) "
    "OR a heading leg (heading_deg, duration_s, depth_m, speed_mps)"
)
MSG_LEG_NEITHER = (
    "has neither to_m nor heading_deg; a leg is EITHER a waypoint leg (to_m, depth_m, speed_mps) "
    "OR a heading leg (heading_deg, duration_s, depth_m, speed_mps)"
)
MSG_TANK_DEPTH = (
    "{value:g} is too deep for the tank scene (floor at {floor:g} m); allowed: {allowed}"
)
MSG_TANK_OUTSIDE = (
    "{what} lies outside the tank; the {length:g} m x {width:g} m tank spans "
    "East {east}, North {north}"
)
MSG_TANK_SEABED = (
    "not allowed in the tank scene, whose floor is part of the scene at {floor:g} m; remove it"
)
MSG_BELOW_SEABED = "{value:g} is not above the seabed (water.seabed_depth_m = {seabed:g})"
MSG_ACCEPT_TOO_BIG = (
    "{value} is not smaller than the shortest lawnmower leg ({shortest:g} m); "
    "waypoints would be skipped"
)
MSG_PROFILE_ORDER = (
    "{value:g} is not deeper than the previous point's {prev:g}; depths must increase"
)

# Pattern of line and column at the end of tomllib's messages (Python 3.11 has no attributes).
_TOML_POSITION = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")
_NAME = re.compile(r"[a-z0-9_]+")


# ---- ranges ------------------------------------------------------------------------------------


NON_NEGATIVE = Range(0.0)
#: A root seed: an int64 (a Parquet column holds it; numpy's SeedSequence takes any int).
SEED_MAX = 2**63 - 1
SEED = Range(0, SEED_MAX)
POSITIVE = Range(0.0, lo_open=True)
# The poles are excluded: the INS mechanises in local-level ENU, whose East axis and longitude rate
# (v_E / (R cos φ)) are undefined at ±90° (twin/onboard/ins.py); a grid-frame INS would be needed.
LATITUDE_DEG = Range(-90.0, 90.0, lo_open=True, hi_open=True)
# The sun model (pvlib's SPA) and the recorder's timeline take nanosecond timestamps (numpy/pandas
# datetime64[ns]): 1677-09-21 to 2262-04-11. A run must start and end inside whole years of that.
START_UTC_MIN = datetime(1678, 1, 1, tzinfo=UTC)
START_UTC_END = datetime(2262, 1, 1, tzinfo=UTC)
MSG_START_RANGE = (
    "{value} is out of range; allowed 1678-01-01 to 2261-12-31 UTC (the sun model's "
    "nanosecond timestamps); the whole run must fit"
)
LONGITUDE_DEG = Range(-180.0, 180.0)
COMPASS_DEG = Range(0.0, 360.0, hi_open=True)
ROLL_DEG = Range(-180.0, 180.0)
PITCH_DEG = Range(-90.0, 90.0)
DURATION_S = Range(0.0, 86400.0, lo_open=True)
DENSITY_KG_M3 = Range(990.0, 1050.0)
TEMPERATURE_C = Range(-2.0, 40.0)
SALINITY_PSU = Range(0.0, 42.0)
UNIT_INTERVAL = Range(0.0, 1.0)
DEPOLARIZATION_RATIO = Range(0.0, 0.5, hi_open=True)
CURRENT_SPEED_MPS = Range(0.0, 3.0)
GUST_SIGMA_MPS = Range(0.0, 1.0)
VEHICLE_SPEED_MPS = Range(0.0, 3.0)  # the initial speed: may be 0 (starting at rest)
COMMANDED_SPEED_MPS = Range(0.0, 2.5, lo_open=True)  # REMUS-100's top speed is about 2.5 m/s
RATE_HZ = Range(0.0, 1000.0, lo_open=True)
CAMERA_RATE_HZ = Range(0.0, 30.0, lo_open=True)
CAMERA_WIDTH = Range(16, 1920)
CAMERA_HEIGHT = Range(16, 1080)
LANES = Range(1)
CIE_SKY_TYPE = Range(1, 15)
UNIT_INTERVAL = Range(0.0, 1.0)
BERRY_DELTA_DEG = Range(0.0, 60.0)
ZENITH_RADIANCE = Range(0.0, 10.0, lo_open=True)
TURBIDITY = Range(0.0, 50.0, lo_open=True)
WIND_SPEED_MPS = Range(0.0, 30.0)
#: The Beaufort scale's wind speeds (m/s at 10 m), force 0–11: the middle of each force's range
#: in WMO's table (WMO-No. 8, Guide to Instruments and Methods of Observation, Annex 5.A:
#: 0–0.2, 0.3–1.5, 1.6–3.3, 3.4–5.4, 5.5–7.9, 8.0–10.7, 10.8–13.8, 13.9–17.1, 17.2–20.7,
#: 20.8–24.4, 24.5–28.4, 28.5–32.6 m/s). Force 11's middle (30.55) is clipped to the surface
#: model's 30 m/s; force 12 (≥ 32.7 m/s) is beyond it. The 2 % difference between WMO's 10 m
#: and Cox & Munk's 12.5 m (a neutral log profile over the sea) is well inside a force's range.
BEAUFORT_MPS: tuple[float, ...] = (
    0.1, 0.9, 2.45, 4.4, 6.7, 9.35, 12.3, 15.5, 18.95, 22.6, 26.45, 30.0,
)  # fmt: skip
BEAUFORT_FORCE = Range(0.0, 11.0)
WAVELENGTH_NM = Range(400.0, 700.0)
# [hardware] σ bounds: far beyond any real unit, short of values that break the geometry (a
# focal length off by 20 %, a camera turned by 10°).
HARDWARE_RANGES: dict[str, Range] = {
    "focal_sigma_rel": Range(0.0, 0.2),
    "principal_point_sigma_px": Range(0.0, 200.0),
    "polarizer_sigma_deg": Range(0.0, 10.0),
    "focal_tolerance_rel": Range(0.0, 0.2),
    "decentre_sigma_um": Range(0.0, 1000.0),
    "boresight_sigma_deg": Range(0.0, 10.0),
    "clock_offset_sigma_ms": Range(0.0, 1000.0),
}
#: [hardware]'s on/off keys, with the position an ideal model gives them.
HARDWARE_SWITCHES: dict[str, bool] = {"lens_compensation": False, "distortion_correction": True}
GATE_PROBABILITY = Range(0.5, 1.0)
MAP_SIZE_KM = Range(1.0, 1000.0)
MAP_SPACING_M = Range(10.0, 20_000.0)
MAP_CORRELATION_KM = Range(0.01, 1000.0)
MAP_RANGE_MGAL = Range(0.0, 10_000.0, lo_open=True)
MAP_POSITION_KM = Range(0.0, 1000.0)
MAP_ERROR_MGAL = Range(0.0, 100.0)
TANK_DEPTH_M = Range(0.0, TANK_MAX_DEPTH_M)
TANK_EAST_M = Range(-TANK_LENGTH_M / 2, TANK_LENGTH_M / 2, lo_open=True, hi_open=True)
TANK_NORTH_M = Range(-TANK_WIDTH_M / 2, TANK_WIDTH_M / 2, lo_open=True, hi_open=True)


# ---- sections ----------------------------------------------------------------------------------


def _start_utc(top: _Table) -> datetime | None:
    key, expected = "start_utc", "a timezone-aware datetime (TOML datetime or ISO-8601 string)"
    raw = top._raw(key, _MISSING, expected)
    if raw is _MISSING:
        return None
    errs, path = top.report, top.at(key)
    value = raw
    if isinstance(raw, str):
        try:
            value = datetime.fromisoformat(raw)
        except ValueError:
            errs.add(path, f"{_show(raw)} is not an ISO-8601 datetime; expected {expected}")
            return None
    if not isinstance(value, datetime):
        errs.add(
            path,
            MSG_WRONG_TYPE.format(value=_show(raw), type_name=_type_name(raw), expected=expected),
        )
        return None
    if value.tzinfo is None or value.utcoffset() is None:
        errs.add(path, MSG_NAIVE_TIME.format(value=_show(raw)))
        return None
    try:
        utc = value.astimezone(UTC)
    except OverflowError:  # an offset that moves year 1 or 9999 out of datetime's range
        utc = None
    if utc is None or not (START_UTC_MIN <= utc < START_UTC_END):
        errs.add(path, MSG_START_RANGE.format(value=_show(raw)))
        return None
    return utc


def _place(t: _Table | None) -> Place | None:
    if t is None:
        return None
    place = _build(
        Place,
        latitude_deg=t.number("latitude_deg", LATITUDE_DEG),
        longitude_deg=t.number("longitude_deg", LONGITUDE_DEG),
    )
    t.finish()
    return place


def _water(t: _Table | None) -> Water | None:
    if t is None:
        return None
    density = t.number("density_kg_m3", DENSITY_KG_M3, default=1025.0)
    temperature = t.number("temperature_c", TEMPERATURE_C, default=15.0)
    salinity = t.number("salinity_psu", SALINITY_PSU, default=35.0)
    jerlov = t.string("jerlov_type", choices=JERLOV_TYPES, default="II")
    seabed_given = "seabed_depth_m" in t.data
    seabed = t.number("seabed_depth_m", POSITIVE, default=None)
    peak_p = t.number("particle_peak_polarization", UNIT_INTERVAL, default=PARTICLE_DOP_MAX)
    delta = t.number(
        "depolarization_ratio", DEPOLARIZATION_RATIO, default=WATER_DEPOLARIZATION_RATIO
    )
    t.report.seabed_m = seabed
    t.finish()
    values = (density, temperature, salinity, jerlov, peak_p, delta)
    if not _all_set(*values) or (seabed_given and seabed is None):
        return None
    return Water(density, temperature, salinity, jerlov, seabed, peak_p, delta)


_CURRENT_KEYS = {
    "none": ("kind",),
    "constant": ("kind", "speed_mps", "toward_deg"),
    "profile": ("kind", "profile"),
    "gauss_markov": ("kind", "speed_mps", "toward_deg", "sigma_mps", "tau_s"),
}


def _current(t: _Table | None) -> Current | None:
    if t is None:
        return None
    kind = t.string("kind", choices=CURRENT_KINDS, default="none")
    if kind is None:
        return None  # the other keys depend on the kind: checking them would only add noise
    elsewhere = {k for keys in _CURRENT_KEYS.values() for k in keys}
    current: Current | None = Current()
    if kind == "constant":
        current = _build(
            Current,
            kind=kind,
            speed_mps=t.number("speed_mps", CURRENT_SPEED_MPS),
            toward_deg=t.number("toward_deg", COMPASS_DEG),
        )
    elif kind == "gauss_markov":
        current = _build(
            Current,
            kind=kind,
            speed_mps=t.number("speed_mps", CURRENT_SPEED_MPS, default=0.0),
            toward_deg=t.number("toward_deg", COMPASS_DEG, default=0.0),
            sigma_mps=t.number("sigma_mps", GUST_SIGMA_MPS),
            tau_s=t.number("tau_s", POSITIVE),
        )
    elif kind == "profile":
        current = _build(Current, kind=kind, profile=_profile(t))
    t.finish(elsewhere=elsewhere, context=f"by current.kind = {_show(kind)}")
    return current


def _profile(t: _Table) -> tuple[ProfilePoint, ...] | None:
    tables = t.tables(
        "profile",
        min_len=2,
        expected="an array of >= 2 {depth_m, speed_mps, toward_deg} tables, depths increasing",
    )
    if tables is None:
        return None
    points: list[ProfilePoint | None] = []
    prev: float | None = None
    for p in tables:
        if p is None:
            points.append(None)
            continue
        depth = p.number("depth_m", NON_NEGATIVE)
        if depth is not None and prev is not None and depth <= prev:
            t.report.add(p.at("depth_m"), MSG_PROFILE_ORDER.format(value=depth, prev=prev))
            depth = None
        prev = depth if depth is not None else prev
        points.append(
            _build(
                ProfilePoint,
                depth_m=depth,
                speed_mps=p.number("speed_mps", CURRENT_SPEED_MPS),
                toward_deg=p.number("toward_deg", COMPASS_DEG),
            )
        )
        p.finish()
    return tuple(p for p in points if p is not None) if _all_set(*points) else None


def _initial(t: _Table | None) -> Initial | None:
    if t is None:
        return None
    position = t.vec2("position_m", default=(0.0, 0.0))
    depth = t.number("depth_m", NON_NEGATIVE, default=0.0)
    t.report.depth(t.at("depth_m"), depth)
    t.report.point(t.at("position_m"), "the start position", position)
    initial = _build(
        Initial,
        position_m=position,
        depth_m=depth,
        heading_deg=t.number("heading_deg", COMPASS_DEG, default=0.0),
        roll_deg=t.number("roll_deg", ROLL_DEG, default=0.0),
        pitch_deg=t.number("pitch_deg", PITCH_DEG, default=0.0),
        speed_mps=t.number("speed_mps", VEHICLE_SPEED_MPS, default=0.0),
    )
    t.finish()
    return initial


_WAYPOINT_LEG_KEYS = ("to_m", "depth_m", "speed_mps")
_HEADING_LEG_KEYS = ("heading_deg", "duration_s", "depth_m", "speed_mps")


def _leg(t: _Table) -> Leg | None:
    has_to, has_heading = "to_m" in t.data, "heading_deg" in t.data
    if has_to and has_heading:
        t.report.add(t.path, MSG_LEG_BOTH)
        return None
    if not (has_to or has_heading):
        t.report.add(t.path, MSG_LEG_NEITHER)
        return None
    leg: Leg | None
    if has_to:
        to = t.vec2("to_m")
        depth = t.number("depth_m", NON_NEGATIVE)
        t.report.point(t.at("to_m"), "the waypoint", to)
        leg = _build(
            WaypointLeg,
            to_m=to,
            depth_m=depth,
            speed_mps=t.number("speed_mps", COMMANDED_SPEED_MPS),
        )
        t.finish(elsewhere=_HEADING_LEG_KEYS, context="by a waypoint leg (it has to_m)")
    else:
        leg = _build(
            HeadingLeg,
            heading_deg=t.number("heading_deg", COMPASS_DEG),
            duration_s=t.number("duration_s", DURATION_S),
            depth_m=(depth := t.number("depth_m", NON_NEGATIVE)),
            speed_mps=t.number("speed_mps", COMMANDED_SPEED_MPS),
        )
        t.finish(elsewhere=_WAYPOINT_LEG_KEYS, context="by a heading leg (it has heading_deg)")
    t.report.depth(t.at("depth_m"), depth)
    return leg


_MISSION_KEYS = {
    "legs": ("kind", "acceptance_radius_m", "legs"),
    "lawnmower": (
        "kind",
        "acceptance_radius_m",
        "origin_m",
        "heading_deg",
        "lane_length_m",
        "lane_spacing_m",
        "lanes",
        "depth_m",
        "speed_mps",
    ),
    "station_keeping": (
        "kind",
        "acceptance_radius_m",
        "center_m",
        "depth_m",
        "radius_m",
        "speed_mps",
    ),
    "planned": (
        "kind",
        "acceptance_radius_m",
        "goal_m",
        "depth_m",
        "speed_mps",
        "q_rate_m2_per_s",
        "lookahead_m",
    ),
}


def _mission(t: _Table | None) -> Mission | None:
    if t is None:
        return None
    kind = t.string("kind", choices=MISSION_KINDS)
    if kind is None:
        return None  # the other keys depend on the kind: checking them would only add noise
    accept = t.number("acceptance_radius_m", POSITIVE, default=5.0)
    mission: Mission | None = None
    if kind == "legs":
        tables = t.tables(
            "legs", min_len=1, expected="an array of >= 1 leg tables ([[mission.legs]])"
        )
        legs = None if tables is None else [_leg(x) if x is not None else None for x in tables]
        if legs is not None and _all_set(*legs):
            mission = _build(LegsMission, legs=tuple(legs), acceptance_radius_m=accept)
    elif kind == "lawnmower":
        geometry = {
            "origin_m": t.vec2("origin_m"),
            "heading_deg": t.number("heading_deg", COMPASS_DEG),
            "lane_length_m": t.number("lane_length_m", POSITIVE),
            "lane_spacing_m": t.number("lane_spacing_m", POSITIVE),
            "lanes": t.integer("lanes", LANES),
        }
        depth = t.number("depth_m", NON_NEGATIVE)
        t.report.depth(t.at("depth_m"), depth)
        speed = t.number("speed_mps", COMMANDED_SPEED_MPS)
        if _all_set(*geometry.values()):
            _lawnmower_geometry(t, LawnmowerMission(**geometry, depth_m=0.0, speed_mps=1.0), accept)
        mission = _build(
            LawnmowerMission, **geometry, depth_m=depth, speed_mps=speed, acceptance_radius_m=accept
        )
    elif kind == "planned":
        goal = t.vec2("goal_m")
        t.report.point(t.at("goal_m"), "the goal", goal)
        depth = t.number("depth_m", NON_NEGATIVE)
        t.report.depth(t.at("depth_m"), depth)
        mission = _build(
            PlannedMission,
            goal_m=goal,
            depth_m=depth,
            speed_mps=t.number("speed_mps", COMMANDED_SPEED_MPS),
            q_rate_m2_per_s=t.number("q_rate_m2_per_s", POSITIVE, default=100.0),
            lookahead_m=t.number("lookahead_m", NON_NEGATIVE, default=0.0),
            acceptance_radius_m=accept,
        )
    else:
        center = t.vec2("center_m")
        depth = t.number("depth_m", NON_NEGATIVE)
        radius = t.number("radius_m", POSITIVE)
        t.report.depth(t.at("depth_m"), depth)
        if center is not None and radius is not None:
            (e, n), r = center, radius
            for p in ((e - r, n), (e + r, n), (e, n - r), (e, n + r)):
                t.report.point(t.at("radius_m"), "the loiter circle", p)
        mission = _build(
            StationKeepingMission,
            center_m=center,
            depth_m=depth,
            radius_m=radius,
            speed_mps=t.number("speed_mps", COMMANDED_SPEED_MPS),
            acceptance_radius_m=accept,
        )
    elsewhere = {k for keys in _MISSION_KEYS.values() for k in keys}
    t.finish(elsewhere=elsewhere, context=f"by mission.kind = {_show(kind)}")
    return mission


def _overrides(t: _Table | None) -> tuple[tuple[str, OverrideValue], ...] | None:
    if t is None:
        return None
    expected = "a number or an array of numbers"
    out: list[tuple[str, OverrideValue]] = []
    ok = True
    for key, raw in t.data.items():
        t.known.append(key)
        path = t.at(key)
        if not key.isidentifier():
            t.report.add(path, "is not a spec field name (a Python identifier)")
            ok = False
            continue
        if isinstance(raw, list):
            if not raw:
                t.report.add(path, f"is an empty array; expected {expected}")
                ok = False
                continue
            items = [_override_number(t.report, f"{path}[{i}]", v) for i, v in enumerate(raw)]
            if _all_set(*items):
                out.append((key, tuple(items)))
            else:
                ok = False
        else:
            value = _override_number(t.report, path, raw, expected=expected)
            if value is None:
                ok = False
            else:
                out.append((key, value))
    return tuple(sorted(out)) if ok else None


def _override_number(
    errs: _Report, path: str, value: Any, expected: str = "a number"
) -> int | float | None:
    # Ints stay ints: a spec field may be an integer (bits, a sample count).
    if isinstance(value, bool) or not isinstance(value, int | float):
        errs.add(
            path,
            MSG_WRONG_TYPE.format(
                value=_show(value), type_name=_type_name(value), expected=expected
            ),
        )
        return None
    if isinstance(value, float) and not math.isfinite(value):
        errs.add(path, MSG_NOT_FINITE.format(value=_show(value), expected=expected))
        return None
    return value


def _sensors(t: _Table | None) -> Sensors | None:
    if t is None:
        return None
    sensors = _build(
        Sensors,
        imu=t.string("imu", non_empty=True, default="lig2024"),
        depth=t.string("depth", non_empty=True, default="ms5837_30ba"),
        imu_overrides=_overrides(t.table("imu_overrides")),
        depth_overrides=_overrides(t.table("depth_overrides")),
        # "" stands for "no polarimeter" here: _build treats None as a failed check.
        polarimeter=t.string("polarimeter", non_empty=True, default=""),
        polarimeter_overrides=_overrides(t.table("polarimeter_overrides")),
        gravimeter=t.string("gravimeter", non_empty=True, default=""),
        gravimeter_overrides=_overrides(t.table("gravimeter_overrides")),
    )
    t.finish()
    if sensors is not None and sensors.polarimeter == "":
        sensors = dataclasses.replace(sensors, polarimeter=None)
    if sensors is not None and sensors.gravimeter == "":
        sensors = dataclasses.replace(sensors, gravimeter=None)
    return sensors


_NO_LAUNCH: Any = object()  # launch_km absent: the map's centre


def _gravity(t: _Table | None) -> Gravity | None:
    if t is None:
        return None
    gravity = _build(
        Gravity,
        map=t.string("map", choices=GRAVITY_MAPS, default="none"),
        file=t.string("file", default=""),
        variable=t.string("variable", default=""),
        size_km=t.pair("size_km", MAP_SIZE_KM, default=(40.0, 40.0)),
        spacing_m=t.number("spacing_m", MAP_SPACING_M, default=500.0),
        map_seed=t.integer("map_seed", NON_NEGATIVE, default=0),
        correlation_km=t.number("correlation_km", MAP_CORRELATION_KM, default=5.0),
        range_mgal=t.number("range_mgal", MAP_RANGE_MGAL, default=78.0),
        stored_spacing_m=t.number("stored_spacing_m", MAP_SPACING_M, default=1000.0),
        map_error_mgal=t.number("map_error_mgal", MAP_ERROR_MGAL, default=1.7),
        matching=t.boolean("matching", default=True),
    )
    launch = t.pair("launch_km", MAP_POSITION_KM, default=_NO_LAUNCH)
    t.finish()
    if gravity is None or launch is None:
        return None
    if launch is not _NO_LAUNCH:
        gravity = dataclasses.replace(gravity, launch_km=launch)
    if gravity.map == "file" and not gravity.file:
        t.report.add(t.at("file"), 'missing; required with map = "file": a NetCDF/GeoTIFF path')
    # The stored map's spacing against the field's: twin.world.gravity_area.check_gravity (it
    # knows every map's node spacing and extent, a file's included).
    return gravity


def _optics(t: _Table | None) -> Optics | None:
    if t is None:
        return None
    optics = _build(
        Optics,
        cie_sky_type=t.integer("cie_sky_type", CIE_SKY_TYPE, default=12),
        sky_polarization=t.string(
            "sky_polarization", choices=SKY_POLARIZATION_MODELS, default="rayleigh"
        ),
        dop_max=t.number("dop_max", UNIT_INTERVAL, default=0.75),
        berry_delta_deg=t.number("berry_delta_deg", BERRY_DELTA_DEG, default=30.0),
        zenith_radiance_w_m2_sr_nm=t.number(
            "zenith_radiance_w_m2_sr_nm", ZENITH_RADIANCE, default=0.05
        ),
        turbidity=t.number("turbidity", TURBIDITY, default=1.0),
        wind_speed_mps=_wind(t),
        wind_toward_deg=t.number("wind_toward_deg", COMPASS_DEG, default=0.0),
        wavelength_nm=t.number("wavelength_nm", WAVELENGTH_NM, default=500.0),
        bubbles=t.string("bubbles", choices=BUBBLE_MODELS, default="hall_novarini"),
        flicker=t.string("flicker", choices=FLICKER_MODELS, default="caustics"),
        particles=t.string("particles", choices=PARTICLE_MODELS, default="marine_snow"),
    )
    t.finish()
    return optics


def _wind(t: _Table) -> float | None:
    """optics.wind_speed_mps, or the speed of optics.wind_beaufort (one of them, not both)."""
    if "wind_beaufort" in t.data and "wind_speed_mps" in t.data:
        t.known += ["wind_beaufort", "wind_speed_mps"]
        t.report.add(
            t.at("wind_beaufort"),
            "given together with wind_speed_mps; expected one of them: a Beaufort force "
            "(integer 0–11) or a speed in m/s",
        )
        return None
    if "wind_beaufort" in t.data:
        force = t.integer("wind_beaufort", BEAUFORT_FORCE)
        return None if force is None else BEAUFORT_MPS[int(force)]
    return t.number("wind_speed_mps", WIND_SPEED_MPS, default=0.0)


def _autopilot(t: _Table | None) -> Autopilot | None:
    if t is None:
        return None
    autopilot = _build(
        Autopilot,
        rate_hz=t.number("rate_hz", RATE_HZ, default=10.0),
        attitude_source=t.string("attitude_source", choices=ATTITUDE_SOURCES, default="truth"),
        speed_control=t.string("speed_control", choices=SPEED_CONTROLS, default="feedback"),
    )
    t.finish()
    return autopilot


def _navigation(t: _Table | None) -> Navigation | None:
    if t is None:
        return None
    choices = nav_variants()
    raw = t._raw("variants", [], "a list of variant names")
    variants: tuple[str, ...] | None = ()
    if not isinstance(raw, _Default):
        path = t.at("variants")
        if not isinstance(raw, list):
            t.report.add(
                path,
                MSG_WRONG_TYPE.format(
                    value=_show(raw), type_name=_type_name(raw), expected="a list of names"
                ),
            )
            variants = None
        else:
            names: list[str] = []
            for i, v in enumerate(raw):
                if not isinstance(v, str) or v not in choices:
                    t.report.add(
                        f"{path}[{i}]",
                        MSG_NOT_A_CHOICE.format(value=_show(v), choices=_choices(choices)),
                    )
                    variants = None
                elif v in names:
                    t.report.add(f"{path}[{i}]", f"{_show(v)} is listed twice")
                    variants = None
                else:
                    names.append(v)
            if variants is not None:
                variants = tuple(names)
    steer_on = t.string("steer_on", choices=choices, default="")
    if variants is not None and steer_on and steer_on not in variants:
        t.report.add(
            t.at("steer_on"),
            f"{_show(steer_on)} is not one of the variants run ({list(variants)})",
        )
        steer_on = None
    nav = _build(
        Navigation,
        variants=variants,
        steer_on=steer_on,
        compass_rate_hz=t.number("compass_rate_hz", CAMERA_RATE_HZ, default=1.0),
        gravity_aiding=t.boolean("gravity_aiding", default=True),
        depth_aiding=t.boolean("depth_aiding", default=True),
        initial_error=t.boolean("initial_error", default=True),
        gate_probability=t.number("gate_probability", GATE_PROBABILITY, default=0.999),
        sun_measurement=t.string("sun_measurement", choices=SUN_MEASUREMENTS, default="azimuth"),
        tuning=t.string("tuning", choices=NAV_TUNINGS, default="imu"),
        alignment=t.string("alignment", choices=NAV_ALIGNMENTS, default="paper"),
        methods=_method_params(t.table("methods"), variants),
    )
    t.finish()
    if nav is not None and nav.steer_on == "":
        nav = dataclasses.replace(nav, steer_on=None)
    return nav


def _method_params(
    t: _Table | None, variants: tuple[str, ...] | None
) -> tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] | None:
    """``[navigation.methods.<name>]``: each compass method's config fields, for a method run.

    The fields and their values are checked by building the method as a run does
    (``twin.sim.build.check_navigation``); here, the tables' shapes and names.
    """
    if t is None:
        return None
    out = []
    ok = True
    for name, params in t.data.items():
        t.known.append(name)
        path = t.at(name)
        if not isinstance(params, Mapping):
            expected = "a table of the method's parameters"
            t.report.add(
                path,
                MSG_WRONG_TYPE.format(
                    value=_show(params), type_name=_type_name(params), expected=expected
                ),
            )
            ok = False
        elif name == INS_ONLY:
            t.report.add(path, f"{_show(name)} has no compass method to configure")
            ok = False
        elif variants is not None and name not in variants:
            run = [v for v in variants if v != INS_ONLY]
            t.report.add(
                path,
                f"configures {_show(name)}, which is not a compass method run here; "
                f"allowed: the compass variants in navigation.variants ({run})",
            )
            ok = False
        else:
            out.append((name, tuple(params.items())))
    return tuple(out) if ok else None


def _recording(t: _Table | None) -> Recording | None:
    if t is None:
        return None
    recording = _build(
        Recording,
        truth_rate_hz=t.number("truth_rate_hz", RATE_HZ, default=10.0),
        camera=t.boolean("camera", default=True),
        camera_rate_hz=t.number("camera_rate_hz", CAMERA_RATE_HZ, default=1.0),
        camera_width=t.integer("camera_width", CAMERA_WIDTH, default=320),
        camera_height=t.integer("camera_height", CAMERA_HEIGHT, default=240),
        polarimeter_log_rate_hz=t.number("polarimeter_log_rate_hz", CAMERA_RATE_HZ, default=1.0),
    )
    t.finish()
    return recording


def _hardware(t: _Table | None) -> Hardware | None:
    if t is None:
        return None
    defaults = Hardware()
    values: dict[str, Any] = {}
    choices = {
        "calibration": CALIBRATION_MODELS,
        "mounting": MOUNTING_MODELS,
        "lens": LENS_MODELS,
    }
    for model, sigmas in HARDWARE_SIGMAS.items():
        kind = t.string(model, choices=choices[model], default=getattr(defaults, model))
        values[model] = kind
        for key in sigmas:
            if kind == "ideal" and key in t.data:
                t.known.append(key)
                t.report.add(
                    t.at(key),
                    f"is set while hardware.{model} = 'ideal'; an ideal model has no error "
                    f"(use {model} = {_show(choices[model][0])} for it)",
                )
                values[key] = None
                continue
            if key in HARDWARE_SWITCHES:
                values[key] = t.boolean(key, default=True)
            else:
                values[key] = t.number(key, HARDWARE_RANGES[key], default=getattr(defaults, key))
    hardware = _build(Hardware, **values)
    t.finish()
    if hardware is not None:
        # An ideal model's σ are 0 and its switches take their ideal position (an ideal lens
        # needs no compensation; an exact calibration is a corrected one): nothing is drawn for
        # it downstream.
        for model, sigmas in HARDWARE_SIGMAS.items():
            if getattr(hardware, model) == "ideal":
                off = {k: HARDWARE_SWITCHES.get(k, 0.0) for k in sigmas}
                hardware = dataclasses.replace(hardware, **off)
    return hardware


# ---- cross-field rules -------------------------------------------------------------------------


def _lawnmower_geometry(t: _Table, pattern: LawnmowerMission, accept: float | None) -> None:
    # The pattern is a rectangle: its four corners bound every waypoint.
    wps = pattern.waypoints_m()
    for p in sorted(set(wps[:2] + wps[-2:])):
        t.report.point(t.path, "the lawnmower pattern's corner", p)
    # The autopilot takes the next waypoint once within the acceptance radius; a radius as large
    # as a lane or a crossover would skip waypoints and fly a different pattern.
    shortest = pattern.lane_length_m
    if pattern.lanes > 1:
        shortest = min(shortest, pattern.lane_spacing_m)
    if accept is not None and accept >= shortest:
        t.report.add(
            t.at("acceptance_radius_m"),
            MSG_ACCEPT_TOO_BIG.format(value=_show(accept), shortest=shortest),
        )


def _cross_checks(report: _Report, scene: str | None) -> None:
    """Rules between fields: the tank's walls and floor, the seabed."""
    if scene == "tank":
        if report.seabed_m is not None:
            report.add("water.seabed_depth_m", MSG_TANK_SEABED.format(floor=TANK_FLOOR_DEPTH_M))
        for d in report.depths:
            if d.depth_m not in TANK_DEPTH_M:
                report.add(
                    d.path,
                    MSG_TANK_DEPTH.format(
                        value=d.depth_m, floor=TANK_FLOOR_DEPTH_M, allowed=TANK_DEPTH_M
                    ),
                )
        reported: set[str] = set()
        for p in report.points:
            if p.path in reported:
                continue  # one message per field (a circle has four extreme points)
            if p.en_m[0] not in TANK_EAST_M or p.en_m[1] not in TANK_NORTH_M:
                report.add(
                    p.path,
                    MSG_TANK_OUTSIDE.format(
                        what=f"{p.what} (E {p.en_m[0]:g}, N {p.en_m[1]:g})",
                        length=TANK_LENGTH_M,
                        width=TANK_WIDTH_M,
                        east=TANK_EAST_M,
                        north=TANK_NORTH_M,
                    ),
                )
                reported.add(p.path)
    elif report.seabed_m is not None:
        for d in report.depths:
            if d.depth_m >= report.seabed_m:
                report.add(d.path, MSG_BELOW_SEABED.format(value=d.depth_m, seabed=report.seabed_m))


def _navigation_checks(
    report: _Report,
    nav: Navigation | None,
    sensors: Sensors | None,
    autopilot: Autopilot | None,
) -> None:
    """Compass variants need a camera; steering on the estimate needs a filter."""
    if nav is None:
        return
    compass = [v for v in nav.variants if v != "ins"]
    if compass and sensors is not None and sensors.polarimeter is None:
        report.add(
            "navigation.variants",
            f"compass variants {compass} need a camera; set sensors.polarimeter "
            '(e.g. "phx050s_p_bin4") or keep only "ins"',
        )
    if nav.alignment == "gyrocompass" and nav.tuning == "paper":
        report.add(
            "navigation.alignment",
            '"gyrocompass" needs the IMU\'s datasheet, which navigation.tuning = "paper" ignores; '
            'set tuning = "imu" or "datasheet", or alignment = "paper"',
        )
    if autopilot is not None and autopilot.attitude_source == "estimate" and not nav.variants:
        report.add(
            "autopilot.attitude_source",
            '"estimate" needs an onboard filter; list navigation.variants (e.g. ["ins", "lig"])',
        )


# ---- entry points ------------------------------------------------------------------------------


def _time_span_checks(report: _Report, start: datetime | None, duration: float | None) -> None:
    """The run must end inside the sun model's time range, not only start in it."""
    if start is None or duration is None:
        return
    if start + timedelta(seconds=duration) >= START_UTC_END:
        report.add(
            "duration_s",
            f"{_show(duration)} makes the run end after 2261-12-31 UTC (start_utc "
            f"{start.isoformat()}); allowed: a run that ends by then (the sun model's "
            "nanosecond timestamps)",
        )


def _callable_check(name: str, obj: object) -> None:
    if not callable(obj):
        raise TypeError(f"scenario check {name!r} is {type(obj).__name__}; expected a function")


def _buildable_checks(scenario: Scenario, source: str) -> None:
    """Build every sensor exactly as a run does; report what that would raise.

    Runs after the table checks (it needs a complete scenario), so ``validate`` rejects whatever
    ``run`` would reject deep inside (unknown presets, bad ``*_overrides`` fields, a binning that
    leaves no image, a compass rate above the camera's frame rate).
    """
    # The checks by name (twin.core.extensions.SCENARIO_CHECKS): heavy (mujoco, the optics),
    # imported on first use, and above this layer.
    problems: list[str] = []
    for name in SCENARIO_CHECKS.names():
        problems += SCENARIO_CHECKS.load(name, _callable_check)(scenario)
    if problems:
        raise ScenarioError(problems, source)


def parse_scenario(data: Mapping[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a mapping (a parsed TOML document, or :meth:`Scenario.to_dict` output).

    Args:
        data: The scenario's top-level table.
        source: Name shown in error messages (the file path, usually).

    Returns:
        The scenario, every optional field filled with its default.

    Raises:
        ScenarioError: Listing every problem found.
    """
    report = _Report()
    if not isinstance(data, Mapping):
        raise ScenarioError([f"the scenario is {_type_name(data)}; expected a table"], source)
    top = _Table(report, "", data)
    name = top.string("name", expected="a string of lowercase letters, digits and '_'")
    if name is not None and not _NAME.fullmatch(name):
        report.add("name", MSG_BAD_NAME.format(value=_show(name)))
        name = None
    description = top.string("description", default="")
    seed = top.integer("seed", SEED, default=0)
    duration = top.number("duration_s", DURATION_S)
    start = _start_utc(top)
    scene = top.string("scene", choices=SCENES, default="open_sea")
    place = _place(
        top.table(
            "place", required=True, expected="a [place] table with latitude_deg, longitude_deg"
        )
    )
    water = _water(top.table("water"))
    current = _current(top.table("current"))
    initial = _initial(top.table("initial"))
    mission = _mission(
        top.table(
            "mission",
            required=True,
            expected="a [mission] table with kind = " + " | ".join(_show(k) for k in MISSION_KINDS),
        )
    )
    sensors = _sensors(top.table("sensors"))
    optics = _optics(top.table("optics"))
    autopilot = _autopilot(top.table("autopilot"))
    recording = _recording(top.table("recording"))
    navigation = _navigation(top.table("navigation"))
    hardware = _hardware(top.table("hardware"))
    gravity = _gravity(top.table("gravity"))
    top.finish()
    _cross_checks(report, scene)
    _navigation_checks(report, navigation, sensors, autopilot)
    _time_span_checks(report, start, duration)
    if report.lines:
        raise ScenarioError(report.lines, source)
    scenario = _build(
        Scenario,
        name=name,
        duration_s=duration,
        start_utc=start,
        place=place,
        mission=mission,
        description=description,
        seed=seed,
        scene=scene,
        water=water,
        current=current,
        initial=initial,
        sensors=sensors,
        optics=optics,
        autopilot=autopilot,
        recording=recording,
        navigation=navigation,
        hardware=hardware,
        gravity=gravity,
    )
    # Every None above was reported; reaching here without a scenario is a bug in this module.
    assert scenario is not None, "unreported validation failure"
    _buildable_checks(scenario, source)
    return scenario


def load_scenario(path: str | os.PathLike[str]) -> Scenario:
    """Read and validate a scenario file.

    Raises:
        ScenarioError: The file cannot be read, is not TOML (the message gives line and column),
            or is not a valid scenario (every problem listed).
    """
    p = Path(path)
    source = str(p)
    try:
        text = p.read_bytes().decode("utf-8")
    except OSError as exc:
        raise ScenarioError([f"cannot read the file: {exc.strerror or exc}"], source) from None
    except UnicodeDecodeError as exc:
        raise ScenarioError([f"not UTF-8 text (bad byte at offset {exc.start})"], source) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = _TOML_POSITION.search(msg)
        where = f"line {m.group(1)}, column {m.group(2)}: " if m else ""
        detail = _TOML_POSITION.sub("", msg)
        raise ScenarioError([f"{where}TOML syntax error: {detail}"], source) from None
    return parse_scenario(data, source)
