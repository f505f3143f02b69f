"""Guidance: a mission to autopilot setpoints (line of sight, heading legs, loitering)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from twin.core.mission import (
    HeadingLeg,
    LawnmowerMission,
    LegsMission,
    Mission,
    StationKeepingMission,
    WaypointLeg,
)
from twin.onboard.control.autopilot import NavState, Setpoint


@dataclass(frozen=True, slots=True)
class GuidanceStatus:
    """Where the mission stands.

    Attributes:
        leg: Index of the active leg (equals the number of legs once complete).
        legs: Number of legs (0 for station keeping, which never completes).
        complete: The last leg is done.
        cross_track_m: Signed distance from the active path (positive: right of it); for station
            keeping, the distance outside the loiter circle.
    """

    leg: int
    legs: int
    complete: bool
    cross_track_m: float


def _bearing(de: float, dn: float) -> float:
    """Compass bearing (rad, clockwise from North) of a displacement (East, North)."""
    return math.atan2(de, dn)


class Guidance:
    """Line-of-sight guidance over a list of legs, or a loiter circle.

    Args:
        mission: A validated scenario mission.
        start_en: The vehicle's start position (East, North), the first path's origin.
        lookahead_m: LOS look-ahead distance Δ (a few vehicle lengths).
        turn_radius_m: The vehicle's turning radius. Between two waypoint legs the guidance
            switches at the wheel-over point, R·tan(Δχ/2) before the waypoint (Δχ: the change of
            course), so the turn ends on the next leg instead of overshooting it; a REMUS cannot
            turn inside the acceptance circle. 0 disables it.
    """

    def __init__(
        self,
        mission: Mission,
        start_en: tuple[float, float],
        lookahead_m: float = 8.0,
        turn_radius_m: float = 0.0,
    ):
        self.mission = mission
        self._lookahead = lookahead_m
        self._turn_radius = turn_radius_m
        self._acceptance = mission.acceptance_radius_m
        if isinstance(mission, LegsMission):
            self._legs: tuple[WaypointLeg | HeadingLeg, ...] = tuple(mission.legs)
        elif isinstance(mission, LawnmowerMission):
            self._legs = tuple(mission.expand())
        elif isinstance(mission, StationKeepingMission):
            self._legs = ()
        else:  # pragma: no cover - the schema admits no other kinds
            raise TypeError(f"unsupported mission {type(mission).__name__}")
        self._leg = 0
        self._leg_start_t = 0.0
        self._from = start_en
        self._last_sp: Setpoint | None = None

    @property
    def legs(self) -> tuple[WaypointLeg | HeadingLeg, ...]:
        """The mission's legs in flying order (empty for station keeping)."""
        return self._legs

    @property
    def legs_completed(self) -> int:
        return self._leg

    @property
    def waypoints_en(self) -> list[tuple[float, float]]:
        """Waypoints of the waypoint legs (for plotting)."""
        return [leg.to_m for leg in self._legs if isinstance(leg, WaypointLeg)]

    def update(self, nav: NavState, t: float) -> tuple[Setpoint, GuidanceStatus]:
        """The setpoint for now and the mission status."""
        m = self.mission
        if isinstance(m, StationKeepingMission):
            return self._loiter(nav, m)
        # Advance past legs that are done (possibly several in one update).
        while self._leg < len(self._legs):
            leg = self._legs[self._leg]
            if isinstance(leg, HeadingLeg):
                if t - self._leg_start_t < leg.duration_s:
                    break
                self._next_leg((nav.east_m, nav.north_m), t)
                continue
            de, dn = leg.to_m[0] - nav.east_m, leg.to_m[1] - nav.north_m
            # Reached when inside the acceptance circle or past the end of the segment.
            pe, pn = leg.to_m[0] - self._from[0], leg.to_m[1] - self._from[1]
            seg = math.hypot(pe, pn)
            to_go = (de * pe + dn * pn) / seg if seg > 1e-9 else 0.0  # along-track distance left
            if math.hypot(de, dn) > self._acceptance and to_go > self._wheel_over(leg, pe, pn):
                break
            self._next_leg(leg.to_m, t)
        n = len(self._legs)
        if self._leg >= n:
            last = self._legs[-1]
            sp = Setpoint(0.0, last.depth_m, self._last_sp.heading_rad if self._last_sp else 0.0)
            return sp, GuidanceStatus(n, n, True, 0.0)
        leg = self._legs[self._leg]
        if isinstance(leg, HeadingLeg):
            sp = Setpoint(leg.speed_mps, leg.depth_m, math.radians(leg.heading_deg))
            self._last_sp = sp
            return sp, GuidanceStatus(self._leg, n, False, 0.0)
        # LOS on the segment from the previous waypoint to this one (Fossen 2021 §12.4).
        pe, pn = leg.to_m[0] - self._from[0], leg.to_m[1] - self._from[1]
        path = _bearing(pe, pn)
        se, sn = nav.east_m - self._from[0], nav.north_m - self._from[1]
        # Cross-track error, positive to the right of the path direction.
        e = se * math.cos(path) - sn * math.sin(path)
        heading = path - math.atan2(e, self._lookahead)
        sp = Setpoint(leg.speed_mps, leg.depth_m, heading)
        self._last_sp = sp
        return sp, GuidanceStatus(self._leg, n, False, e)

    def _wheel_over(self, leg: WaypointLeg, pe: float, pn: float) -> float:
        """Along-track distance before ``leg``'s waypoint at which to start the next turn."""
        nxt = self._legs[self._leg + 1] if self._leg + 1 < len(self._legs) else None
        if self._turn_radius <= 0 or not isinstance(nxt, WaypointLeg):
            return 0.0
        qe, qn = nxt.to_m[0] - leg.to_m[0], nxt.to_m[1] - leg.to_m[1]
        if math.hypot(qe, qn) < 1e-9:
            return 0.0
        turn = abs(math.remainder(_bearing(qe, qn) - _bearing(pe, pn), 2 * math.pi))
        # Beyond ~120 deg the tangent explodes; cap at the shorter of the two legs' halves.
        limit = 0.5 * min(math.hypot(pe, pn), math.hypot(qe, qn))
        return min(self._turn_radius * math.tan(min(turn, math.radians(120.0)) / 2), limit)

    def _next_leg(self, new_from: tuple[float, float], t: float) -> None:
        self._from = new_from
        self._leg += 1
        self._leg_start_t = t

    def _loiter(self, nav: NavState, m: StationKeepingMission) -> tuple[Setpoint, GuidanceStatus]:
        """Clockwise orbit: tangent course plus a LOS correction on the radial error."""
        de, dn = nav.east_m - m.center_m[0], nav.north_m - m.center_m[1]
        dist = math.hypot(de, dn)
        beta = _bearing(de, dn)  # bearing from the centre to the vehicle
        e = dist - m.radius_m  # positive outside; clockwise orbit: inward is to the right
        heading = beta + math.pi / 2 + math.atan2(e, self._lookahead)
        sp = Setpoint(m.speed_mps, m.depth_m, heading)
        return sp, GuidanceStatus(0, 0, False, e)
