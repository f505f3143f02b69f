"""The scenario's mission tables.

The vehicle's start (``[initial]``), the mission (``[mission]``: legs, a lawnmower, a planned
path, station keeping) and the autopilot.

Each ``read_*`` reads one table through :class:`~scenarios.reading._Table` (every problem
reported, none raised) and returns its dataclass, or None where a problem was reported.
"""

from __future__ import annotations

from scenarios.ranges import (
    MSG_ACCEPT_TOO_BIG,
    MSG_LEG_BOTH,
    MSG_LEG_NEITHER,
)
from scenarios.reading import (
    _all_set,
    _build,
    _show,
    _Table,
)
from scenarios.schema import (
    MISSION_KINDS,
    Autopilot,
    HeadingLeg,
    Initial,
    LawnmowerMission,
    Leg,
    LegsMission,
    Mission,
    PlannedMission,
    StationKeepingMission,
    WaypointLeg,
)


def read_initial(t: _Table | None) -> Initial | None:
    if t is None:
        return None
    t.of(Initial)
    position = t.vec2("position_m")
    depth = t.number("depth_m")
    t.report.depth(t.at("depth_m"), depth)
    t.report.point(t.at("position_m"), "the start position", position)
    initial = _build(
        Initial,
        position_m=position,
        depth_m=depth,
        heading_deg=t.number("heading_deg"),
        roll_deg=t.number("roll_deg"),
        pitch_deg=t.number("pitch_deg"),
        speed_mps=t.number("speed_mps"),
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
        t.of(WaypointLeg)
        to = t.vec2("to_m")
        depth = t.number("depth_m")
        t.report.point(t.at("to_m"), "the waypoint", to)
        leg = _build(WaypointLeg, to_m=to, depth_m=depth, speed_mps=t.number("speed_mps"))
        t.finish(elsewhere=_HEADING_LEG_KEYS, context="by a waypoint leg (it has to_m)")
    else:
        t.of(HeadingLeg)
        leg = _build(
            HeadingLeg,
            heading_deg=t.number("heading_deg"),
            duration_s=t.number("duration_s"),
            depth_m=(depth := t.number("depth_m")),
            speed_mps=t.number("speed_mps"),
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


#: Each mission kind's dataclass: its fields' defaults and ranges are declared there.
_MISSION_CLASSES: dict[str, type] = {
    "legs": LegsMission,
    "lawnmower": LawnmowerMission,
    "station_keeping": StationKeepingMission,
    "planned": PlannedMission,
}


def read_mission(t: _Table | None) -> Mission | None:
    if t is None:
        return None
    kind = t.string("kind", choices=MISSION_KINDS)
    if kind is None:
        return None  # the other keys depend on the kind: checking them would only add noise
    t.of(_MISSION_CLASSES[kind])
    accept = t.number("acceptance_radius_m")
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
            "heading_deg": t.number("heading_deg"),
            "lane_length_m": t.number("lane_length_m"),
            "lane_spacing_m": t.number("lane_spacing_m"),
            "lanes": t.integer("lanes"),
        }
        depth = t.number("depth_m")
        t.report.depth(t.at("depth_m"), depth)
        speed = t.number("speed_mps")
        if _all_set(*geometry.values()):
            _lawnmower_geometry(t, LawnmowerMission(**geometry, depth_m=0.0, speed_mps=1.0), accept)
        mission = _build(
            LawnmowerMission, **geometry, depth_m=depth, speed_mps=speed, acceptance_radius_m=accept
        )
    elif kind == "planned":
        goal = t.vec2("goal_m")
        t.report.point(t.at("goal_m"), "the goal", goal)
        depth = t.number("depth_m")
        t.report.depth(t.at("depth_m"), depth)
        mission = _build(
            PlannedMission,
            goal_m=goal,
            depth_m=depth,
            speed_mps=t.number("speed_mps"),
            q_rate_m2_per_s=t.number("q_rate_m2_per_s"),
            lookahead_m=t.number("lookahead_m"),
            acceptance_radius_m=accept,
        )
    else:
        center = t.vec2("center_m")
        depth = t.number("depth_m")
        radius = t.number("radius_m")
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
            speed_mps=t.number("speed_mps"),
            acceptance_radius_m=accept,
        )
    elsewhere = {k for keys in _MISSION_KEYS.values() for k in keys}
    t.finish(elsewhere=elsewhere, context=f"by mission.kind = {_show(kind)}")
    return mission


def read_autopilot(t: _Table | None) -> Autopilot | None:
    if t is None:
        return None
    t.of(Autopilot)
    autopilot = _build(
        Autopilot,
        rate_hz=t.number("rate_hz"),
        attitude_source=t.string("attitude_source"),
        speed_control=t.string("speed_control"),
    )
    t.finish()
    return autopilot


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
