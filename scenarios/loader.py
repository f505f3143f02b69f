"""TOML sea-trial files to validated :class:`~scenarios.schema.Scenario` objects.

The whole file is checked before anything runs, and every problem is collected, so a user fixes a
file in one pass: :class:`ScenarioError` carries one line per problem, each naming the field by its
dotted path (``mission.legs[2].speed_mps``), the offending value and what is allowed.

Checks, in order: TOML syntax; each field's presence, type (no strings for numbers, no booleans for
numbers, no NaN or infinity), range or choices; unknown keys (in every table); then cross-field
rules (tank limits, seabed clearance, profile order, lawnmower geometry). A cross-field rule is
checked only on fields that passed their own checks, so one mistake gives one error.

The tables are read by concept: :mod:`scenarios.environment` (time, place, water, current, optics,
gravity map), :mod:`scenarios.mission` (start, mission, autopilot), :mod:`scenarios.equipment`
(sensors, hardware, navigation, recording), with the ranges and messages in
:mod:`scenarios.ranges`; this module holds the rules between tables and the entry points.
"""

from __future__ import annotations

import os
import re
import tomllib
from collections.abc import Mapping
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

from scenarios.environment import (
    read_current,
    read_gravity,
    read_optics,
    read_place,
    read_start_utc,
    read_water,
)
from scenarios.equipment import read_hardware, read_navigation, read_recording, read_sensors
from scenarios.mission import read_autopilot, read_initial, read_mission
from scenarios.ranges import (
    MSG_BELOW_SEABED,
    MSG_TANK_DEPTH,
    MSG_TANK_OUTSIDE,
    MSG_TANK_SEABED,
    START_UTC_END,
    TANK_DEPTH_M,
    TANK_EAST_M,
    TANK_NORTH_M,
)
from scenarios.reading import (
    MSG_BAD_NAME,
    ScenarioError,
    _build,
    _Report,
    _show,
    _Table,
    _type_name,
)
from scenarios.schema import (
    MISSION_KINDS,
    TANK_FLOOR_DEPTH_M,
    TANK_LENGTH_M,
    TANK_WIDTH_M,
    Autopilot,
    Navigation,
    Scenario,
    Sensors,
)
from twin.core.extensions import SCENARIO_CHECKS

# Pattern of line and column at the end of tomllib's messages (Python 3.11 has no attributes).
_TOML_POSITION = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")
_NAME = re.compile(r"[a-z0-9_]+")


# ---- cross-field rules -------------------------------------------------------------------------


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
    """Compass variants need a camera; an aid, its sensor; steering on the estimate, a filter."""
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
    extra = {e.name for e in sensors.extra} if sensors is not None else None
    for sensor, _, _ in nav.aids:
        if extra is not None and sensor not in extra:
            report.add(
                f"navigation.aids.{sensor}",
                f"{_show(sensor)} is not one of the scenario's extra sensors; allowed: "
                f"the names in [sensors.extra] ({sorted(extra)})",
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
    top = _Table(report, "", data, Scenario)
    name = top.string("name", expected="a string of lowercase letters, digits and '_'")
    if name is not None and not _NAME.fullmatch(name):
        report.add("name", MSG_BAD_NAME.format(value=_show(name)))
        name = None
    description = top.string("description")
    seed = top.integer("seed")
    duration = top.number("duration_s")
    start = read_start_utc(top)
    scene = top.string("scene")
    place = read_place(
        top.table(
            "place", required=True, expected="a [place] table with latitude_deg, longitude_deg"
        )
    )
    water = read_water(top.table("water"))
    current = read_current(top.table("current"))
    initial = read_initial(top.table("initial"))
    mission = read_mission(
        top.table(
            "mission",
            required=True,
            expected="a [mission] table with kind = " + " | ".join(_show(k) for k in MISSION_KINDS),
        )
    )
    sensors = read_sensors(top.table("sensors"))
    optics = read_optics(top.table("optics"))
    autopilot = read_autopilot(top.table("autopilot"))
    recording = read_recording(top.table("recording"))
    navigation = read_navigation(top.table("navigation"))
    hardware = read_hardware(top.table("hardware"))
    gravity = read_gravity(top.table("gravity"))
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
