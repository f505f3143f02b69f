"""The onboard navigation source: the autopilot steering on a filter variant's estimate."""

from __future__ import annotations

import math

from twin.onboard.control.autopilot import NavSource, NavState
from twin.onboard.navigator import Navigator

__all__ = ["EstimateNav", "NavSource"]


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
