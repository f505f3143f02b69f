"""Navigation sources the autopilot can steer on: ground truth, or an onboard filter's estimate."""

from __future__ import annotations

import math

from twin.autopilot import NavSource, NavState
from twin.frames import quat_to_dcm
from twin.onboard.navigator import Navigator
from twin.truth import Truth


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
    """A :class:`twin.autopilot.NavSource` that reads the plant's truth."""

    def __init__(self, plant) -> None:
        self._plant = plant

    def nav_state(self) -> NavState:
        return nav_state_from_truth(self._plant.truth())


class EstimateNav:
    """A :class:`NavSource` that reads one onboard filter variant (the loop closed for real).

    Rates come from the INS's last bias-compensated gyro sample; the speed is the estimated
    velocity along the body's forward axis (over ground: the vehicle has no water-speed sensor).
    """

    def __init__(self, navigator: Navigator) -> None:
        self.navigator = navigator

    def nav_state(self) -> NavState:
        nav = self.navigator
        ins = nav.filter.ins
        est = nav.estimate()
        east, north = nav.local_en(est)
        omega_n = est.c_bn @ ins.omega_ib_b
        return NavState(
            east_m=east,
            north_m=north,
            depth_m=est.depth_m,
            roll_rad=est.roll,
            pitch_rad=est.pitch,
            heading_rad=math.radians(est.heading_deg),
            pitch_rate_rad_s=float(ins.omega_ib_b[0]),
            heading_rate_rad_s=-float(omega_n[2]),
            speed_mps=float((est.c_bn.T @ est.v_enu)[1]),
        )


__all__ = ["EstimateNav", "NavSource", "TruthNav", "nav_state_from_truth"]
