"""Autopilot: speed, depth and heading hold, steering on a navigation source.

The autopilot takes its attitude, depth and speed from a :class:`NavSource`: truth
(``twin.sim.navsources.TruthNav``) or an onboard filter's estimate (``EstimateNav``, scenario
setting ``autopilot.attitude_source = "estimate"``): the autopilot code does not change, only
the source.

Sign conventions (twin.core.messages.ActuatorCommand): positive rudder turns to starboard
(heading increases);
positive stern planes pitch the nose up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from twin.core.frames import wrap_pi
from twin.core.messages import ActuatorCommand


@dataclass(frozen=True, slots=True)
class NavState:
    """What the autopilot and guidance need to know, from whichever source.

    Attributes:
        east_m: Position East of the origin (m).
        north_m: Position North of the origin (m).
        depth_m: Depth below the surface (m).
        roll_rad: Roll.
        pitch_rad: Pitch (nose up positive).
        heading_rad: Compass heading (clockwise from North), radians.
        pitch_rate_rad_s: Body rate about the body x axis (nose-up positive).
        heading_rate_rad_s: Rate of change of the compass heading.
        speed_mps: Forward speed through the water.
    """

    east_m: float
    north_m: float
    depth_m: float
    roll_rad: float
    pitch_rad: float
    heading_rad: float
    pitch_rate_rad_s: float
    heading_rate_rad_s: float
    speed_mps: float


class NavSource(Protocol):
    """Anything that can tell the autopilot where the vehicle is and how it is oriented."""

    def nav_state(self) -> NavState:
        """The current navigation state."""


@dataclass(frozen=True, slots=True)
class Setpoint:
    """What the autopilot holds: forward speed, depth and compass heading."""

    speed_mps: float
    depth_m: float
    heading_rad: float


@dataclass(frozen=True, slots=True)
class AutopilotGains:
    """PID gains, tuned on the REMUS-100 plant (tests/test_autopilot.py checks the responses).

    Heading: rudder = kp·e + ki·∫e − kd·ψ̇. Depth: an outer loop turns depth error into a pitch
    command (≤ max_pitch), an inner loop turns pitch error into stern-plane angle. Speed:
    propeller feed-forward from the plant's steady-speed map plus an integral on speed error.
    """

    heading_kp: float = 1.2
    heading_ki: float = 0.02
    heading_kd: float = 1.5
    depth_kp: float = 0.12  # rad of pitch per m
    depth_ki: float = 0.004
    depth_integral_band_m: float = 1.0
    max_pitch_rad: float = math.radians(20.0)
    pitch_kp: float = 2.0
    pitch_ki: float = 0.1
    pitch_kd: float = 1.5
    speed_ki: float = 0.5  # rev/s per (m/s · s)
    integrator_limit: float = 0.3


@dataclass(frozen=True, slots=True)
class PropellerMap:
    """The vehicle's declared speed–propeller curve: steady forward speed (m/s) to rev/s.

    Declared knowledge (the vehicle's datasheet or acceptance-trial table), not the plant's
    hydrodynamics: the autopilot's feed-forward interpolates it linearly and clamps at the ends.
    """

    speeds_mps: tuple[float, ...]
    rps: tuple[float, ...]

    def __post_init__(self) -> None:
        s = np.asarray(self.speeds_mps, float)
        r = np.asarray(self.rps, float)
        if s.ndim != 1 or s.shape != r.shape or len(s) < 2:
            raise ValueError("PropellerMap: speeds_mps and rps must be equal-length, >= 2 points")
        if not (np.all(np.isfinite(s)) and np.all(np.isfinite(r)) and np.all(np.diff(s) > 0)):
            raise ValueError("PropellerMap: speeds must be finite and increasing, rps finite")

    def __call__(self, speed_mps: float) -> float:
        return float(np.interp(speed_mps, self.speeds_mps, self.rps))


class Autopilot:
    """Speed, depth and heading hold.

    Args:
        rps_for_speed: Steady-state propeller speed (rev/s) for a forward speed (m/s): the
            feed-forward map (a :class:`PropellerMap`, or any callable).
        gains: Controller gains.
        max_rps: Propeller limit (rev/s).
        max_fin_rad: Fin travel, for anti-windup.
        speed_feedback: Integrate the navigation source's speed error (False: the propeller map
            alone, open-loop revolutions).
    """

    def __init__(
        self,
        rps_for_speed,
        gains: AutopilotGains | None = None,
        *,
        max_rps: float = 1525.0 / 60.0,
        max_fin_rad: float = math.radians(15.0),
        speed_feedback: bool = True,
    ):
        self._ff = rps_for_speed
        self.speed_feedback = speed_feedback
        self.gains = gains or AutopilotGains()
        self._max_rps = max_rps
        self._max_fin = max_fin_rad
        self._ff_cache: tuple[float, float] = (math.nan, 0.0)
        self.reset()

    def reset(self) -> None:
        self._i_heading = 0.0
        self._i_depth = 0.0
        self._i_pitch = 0.0
        self._i_speed = 0.0

    def _feedforward(self, speed: float) -> float:
        if self._ff_cache[0] != speed:
            self._ff_cache = (speed, self._ff(speed) if speed > 0 else 0.0)
        return self._ff_cache[1]

    def update(self, nav: NavState, sp: Setpoint, dt: float) -> ActuatorCommand:
        """One control update over an interval dt (s)."""
        g = self.gains
        lim = g.integrator_limit

        e_psi = wrap_pi(sp.heading_rad - nav.heading_rad)
        rudder = (
            g.heading_kp * e_psi
            + g.heading_ki * self._i_heading
            - g.heading_kd * (nav.heading_rate_rad_s)
        )
        if abs(rudder) < self._max_fin:  # conditional integration: no wind-up in saturation
            self._i_heading = max(
                -lim / g.heading_ki, min(lim / g.heading_ki, self._i_heading + e_psi * dt)
            )
        rudder = max(-self._max_fin, min(self._max_fin, rudder))

        # Deeper than wanted => e_z < 0 => pitch up.
        e_z = sp.depth_m - nav.depth_m
        # Integrate only near the setpoint: during a dive the error is large for long and the
        # integral would overshoot the depth (it is there for trim offsets, not for transients).
        if abs(e_z) < g.depth_integral_band_m:
            self._i_depth = max(-lim / g.depth_ki, min(lim / g.depth_ki, self._i_depth + e_z * dt))
        pitch_cmd = -(g.depth_kp * e_z + g.depth_ki * self._i_depth)
        pitch_cmd = max(-g.max_pitch_rad, min(g.max_pitch_rad, pitch_cmd))
        e_theta = pitch_cmd - nav.pitch_rad
        stern = (
            g.pitch_kp * e_theta + g.pitch_ki * self._i_pitch - g.pitch_kd * nav.pitch_rate_rad_s
        )
        if abs(stern) < self._max_fin:
            self._i_pitch = max(
                -lim / g.pitch_ki, min(lim / g.pitch_ki, self._i_pitch + e_theta * dt)
            )
        stern = max(-self._max_fin, min(self._max_fin, stern))

        e_u = sp.speed_mps - nav.speed_mps
        rps = self._feedforward(sp.speed_mps) + g.speed_ki * self._i_speed
        if self.speed_feedback and 0.0 < rps < self._max_rps:
            self._i_speed = max(-10.0, min(10.0, self._i_speed + e_u * dt))
        rps = max(0.0, min(self._max_rps, rps))
        return ActuatorCommand(rudder_rad=rudder, stern_rad=stern, propeller_rps=rps)
