"""Actuator commands and the command-side limits (travel and slew rate).

The actuator *state* (true fin angle, true propeller speed) lives in MuJoCo as actuator activation
(``filterexact`` first-order dynamics, ``actrange`` travel; see models/auv/auv.xml). Here the
command is clipped to the travel and slewed at the servo's rate limit before MuJoCo sees it.
"""

from __future__ import annotations

import math

from twin.core.messages import ActuatorCommand
from twin.world.vehicle import VehicleParams

ACTUATOR_NAMES = ("rudder", "stern_planes", "propeller")
__all__ = ["ACTUATOR_NAMES", "ActuatorCommand", "CommandLimiter"]


class CommandLimiter:
    """Clip commands to the actuators' travel and slew them at the rate limits."""

    def __init__(self, params: VehicleParams):
        self._max = (params.fin_max_rad, params.fin_max_rad, params.prop_max_rpm / 60.0)
        self._min = (-params.fin_max_rad, -params.fin_max_rad, 0.0)
        # The propeller has no separate slew limit: its motor lag (T_n) is in MuJoCo.
        self._rate = (params.fin_rate_max_rad_s, params.fin_rate_max_rad_s, math.inf)
        self._last: tuple[float, float, float] | None = None

    def reset(self, initial: tuple[float, float, float]) -> None:
        self._last = tuple(  # type: ignore[assignment]
            min(hi, max(lo, float(x)))
            for x, lo, hi in zip(initial, self._min, self._max, strict=True)
        )

    def __call__(self, command: ActuatorCommand, dt: float) -> tuple[float, float, float]:
        """The limited command (rudder, stern, propeller) for one step of length dt."""
        raw = (command.rudder_rad, command.stern_rad, command.propeller_rps)
        if not (math.isfinite(raw[0]) and math.isfinite(raw[1]) and math.isfinite(raw[2])):
            raise ValueError(f"actuator command has a non-finite value: {command}")
        lo, hi, rate = self._min, self._max, self._rate
        last = self._last
        out = [0.0, 0.0, 0.0]
        for i in range(3):  # unrolled by hand would be faster still; this runs once per step
            x = raw[i]
            x = hi[i] if x > hi[i] else (lo[i] if x < lo[i] else x)
            if last is not None:
                step = rate[i] * dt
                d = x - last[i]
                x = last[i] + (step if d > step else (-step if d < -step else d))
            out[i] = x
        self._last = (out[0], out[1], out[2])
        return self._last
