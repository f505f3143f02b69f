"""Ground truth as a navigation source: the autopilot steering on a perfect navigator.

World-side (it reads the plant); the onboard source is
:class:`twin.onboard.control.navsource.EstimateNav`.
"""

from __future__ import annotations

import math

from twin.core.frames import quat_to_dcm
from twin.onboard.control.autopilot import NavSource, NavState
from twin.world.truth import Truth


def nav_state_from_truth(truth: Truth) -> NavState:
    """The autopilot's view of the vehicle, taken from ground truth (a perfect navigator)."""
    c_bn = quat_to_dcm(truth.quat_wxyz)
    omega_n = c_bn @ truth.omega_b
    v_rel_b = c_bn.T @ (truth.velocity_n - truth.current_n)
    return NavState(
        east_m=float(truth.position_n[0]),
        north_m=float(truth.position_n[1]),
        depth_m=truth.depth_m,
        roll_rad=truth.roll_rad,
        pitch_rad=truth.pitch_rad,
        heading_rad=math.radians(truth.heading_deg),
        pitch_rate_rad_s=float(truth.omega_b[0]),
        heading_rate_rad_s=-float(omega_n[2]),  # compass heading turns opposite to ENU yaw
        speed_mps=float(v_rel_b[1]),
    )


class TruthNav:
    """A :class:`twin.onboard.control.autopilot.NavSource` that reads the plant's truth."""

    def __init__(self, plant) -> None:
        self._plant = plant

    def nav_state(self) -> NavState:
        return nav_state_from_truth(self._plant.truth())


__all__ = ["NavSource", "TruthNav", "nav_state_from_truth"]
