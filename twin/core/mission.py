"""The mission plan: what the vehicle is told to fly (waypoint and heading legs, surveys, loiter).

Shared contract: the scenario file declares it (:mod:`scenarios.schema` re-exports these classes)
and the vehicle computer's guidance (:mod:`twin.onboard.control.guidance`) flies it. Plain data, no
world state: positions are (East, North) metres from the launch point, headings compass degrees.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, Literal, TypeAlias

from twin.core.fields import COMPASS_DEG, DURATION_S, NON_NEGATIVE, POSITIVE, Range, declared

Vec2: TypeAlias = tuple[float, float]
#: A commanded speed through the water: REMUS-100's top speed is about 2.5 m/s.
COMMANDED_SPEED_MPS = Range(0.0, 2.5, lo_open=True)
#: A lawnmower's number of lanes.
LANES = Range(1)
MissionKind: TypeAlias = Literal["legs", "lawnmower", "station_keeping", "planned"]
MISSION_KINDS: tuple[str, ...] = ("legs", "lawnmower", "station_keeping", "planned")


@dataclass(frozen=True, slots=True)
class WaypointLeg:
    """Go to ``to_m`` = (East, North) at ``depth_m`` and ``speed_mps``.

    The leg ends when the vehicle is horizontally within the mission's ``acceptance_radius_m`` of
    the point.
    """

    to_m: Vec2
    depth_m: float = declared(allowed=NON_NEGATIVE)
    speed_mps: float = declared(allowed=COMMANDED_SPEED_MPS)


@dataclass(frozen=True, slots=True)
class HeadingLeg:
    """Hold compass ``heading_deg`` at ``depth_m`` and ``speed_mps`` for ``duration_s``."""

    heading_deg: float = declared(allowed=COMPASS_DEG)
    duration_s: float = declared(allowed=DURATION_S)
    depth_m: float = declared(allowed=NON_NEGATIVE)
    speed_mps: float = declared(allowed=COMMANDED_SPEED_MPS)


Leg: TypeAlias = WaypointLeg | HeadingLeg


@dataclass(frozen=True, slots=True)
class LegsMission:
    """A sequence of waypoint and heading legs, flown in order."""

    kind: ClassVar[Literal["legs"]] = "legs"
    legs: tuple[Leg, ...]
    acceptance_radius_m: float = declared(5.0, POSITIVE)

    def expand(self) -> tuple[Leg, ...]:
        """The legs to fly (already explicit for this kind)."""
        return self.legs


@dataclass(frozen=True, slots=True)
class LawnmowerMission:
    """A boustrophedon survey of ``lanes`` parallel lanes.

    Geometry: the first lane starts at ``origin_m`` and runs ``lane_length_m`` along compass
    ``heading_deg``. Each next lane lies ``lane_spacing_m`` to the *right* of the previous one (as
    seen looking along the first lane's direction, i.e. toward ``heading_deg + 90``) and runs the
    opposite way, so the vehicle turns right, then left, then right... and the pattern covers the
    rectangle to the right of the first lane.
    """

    kind: ClassVar[Literal["lawnmower"]] = "lawnmower"
    origin_m: Vec2
    heading_deg: float = declared(allowed=COMPASS_DEG)
    lane_length_m: float = declared(allowed=POSITIVE)
    lane_spacing_m: float = declared(allowed=POSITIVE)
    lanes: int = declared(allowed=LANES)
    depth_m: float = declared(allowed=NON_NEGATIVE)
    speed_mps: float = declared(allowed=COMMANDED_SPEED_MPS)
    acceptance_radius_m: float = declared(5.0, POSITIVE)

    def waypoints_m(self) -> tuple[Vec2, ...]:
        """Lane endpoints in flying order: start and end of lane 0, of lane 1, ... (2 per lane)."""
        h = math.radians(self.heading_deg)
        along = (math.sin(h), math.cos(h))  # (E, N) unit vector of the first lane
        right = (math.cos(h), -math.sin(h))  # its right-hand normal: heading + 90 deg
        e0, n0 = self.origin_m
        out: list[Vec2] = []
        for i in range(self.lanes):
            off = i * self.lane_spacing_m
            a = (e0 + off * right[0], n0 + off * right[1])
            b = (a[0] + self.lane_length_m * along[0], a[1] + self.lane_length_m * along[1])
            out.extend([a, b] if i % 2 == 0 else [b, a])
        return tuple(out)

    def expand(self) -> tuple[WaypointLeg, ...]:
        """The survey as waypoint legs: 2 per lane (to the lane's start, then to its end).

        The first leg goes to ``origin_m`` from wherever the vehicle starts; between lanes the leg
        to the next lane's start is the ``lane_spacing_m`` crossover.
        """
        return tuple(
            WaypointLeg(to_m=p, depth_m=self.depth_m, speed_mps=self.speed_mps)
            for p in self.waypoints_m()
        )


@dataclass(frozen=True, slots=True)
class StationKeepingMission:
    """Loiter on a circle of ``radius_m`` around ``center_m`` at ``depth_m`` and ``speed_mps``.

    A torpedo AUV needs way on to steer, so it cannot hover; it circles instead. The direction of
    the circle is the autopilot's choice.
    """

    kind: ClassVar[Literal["station_keeping"]] = "station_keeping"
    center_m: Vec2
    depth_m: float = declared(allowed=NON_NEGATIVE)
    radius_m: float = declared(allowed=POSITIVE)
    speed_mps: float = declared(allowed=COMMANDED_SPEED_MPS)
    acceptance_radius_m: float = declared(5.0, POSITIVE)


@dataclass(frozen=True, slots=True)
class PlannedMission:
    """Go to ``goal_m`` along the route the vehicle plans at launch on its stored gravity map.

    The route is wang2023's PCRB-A* (``twin.onboard.gravity.planner``): the path whose bound on
    the position error, summed over its nodes, is least, with the INS's position variance growing
    at ``q_rate_m2_per_s`` per axis (default 100 m²/s: Table 1's Q_t read as km²/s, not the
    printed m²/s that the paper's own study implies, ``pcrb.Q_T_READINGS``; a navigation-grade INS
    drifts about that fast, the HG9900 flown here somewhat faster). The vehicle then flies
    the route's nodes as waypoint legs (:meth:`legs_along`).

    ``lookahead_m`` is the line-of-sight guidance's look-ahead on those legs; 0 (the default)
    takes the stored map's node spacing. A vehicle that knows its position to hundreds of metres
    sees its estimate jump by as much at each map update; with the few-metre look-ahead of a
    survey leg it turns square to the leg after every jump and zig-zags (the shipped route,
    seed 0, with 8 m: 3 of 5 legs in 16 000 s, 23.9 km flown for 15.7 km planned).
    """

    kind: ClassVar[Literal["planned"]] = "planned"
    goal_m: Vec2
    depth_m: float = declared(allowed=NON_NEGATIVE)
    speed_mps: float = declared(allowed=COMMANDED_SPEED_MPS)
    q_rate_m2_per_s: float = declared(100.0, POSITIVE)
    acceptance_radius_m: float = declared(5.0, POSITIVE)
    lookahead_m: float = declared(0.0, NON_NEGATIVE)

    def legs_along(self, route_en_m: Sequence[Vec2]) -> LegsMission:
        """The route (ENU from the launch point, start first) as waypoint legs to the goal.

        Nodes where the route runs straight on are dropped (the autopilot flies a straight line
        between the others); the last leg ends on ``goal_m`` itself, not on its map node.
        """
        pts = [tuple(map(float, p)) for p in route_en_m]
        keep: list[Vec2] = []
        for k in range(1, len(pts) - 1):
            a, b, c = pts[k - 1], pts[k], pts[k + 1]
            cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
            if abs(cross) > 1e-6 * max(1.0, math.dist(a, b) * math.dist(b, c)):
                keep.append((b[0], b[1]))
        keep.append((float(self.goal_m[0]), float(self.goal_m[1])))
        legs = tuple(
            WaypointLeg(to_m=p, depth_m=self.depth_m, speed_mps=self.speed_mps) for p in keep
        )
        return LegsMission(legs=legs, acceptance_radius_m=self.acceptance_radius_m)


Mission: TypeAlias = LegsMission | LawnmowerMission | StationKeepingMission | PlannedMission
