"""The USBL fix as a filter update, for auv-twin's ``auv_twin.nav_aids`` entry point.

Onboard side: the vehicle's computer turns each fix into a horizontal position update of its
filter (:meth:`twin.onboard.eskf.Eskf.update_vector`: innovation = predicted − measured East and
North, H from the launch point's metres per radian, R from the accuracy the vehicle is *told* the
unit has, σ = ``sigma_floor_m`` + ``range_fraction`` · slant range). The fix is of the instant of
the ping, and arrives later: the prediction is moved back along the estimated velocity by the
reading's age. The vertical is left to the depth gauge.

The declared accuracy is the vehicle's belief, set in the scenario (``[navigation.aids.<sensor>]``);
the sensor's true error is the sensor's own spec (``[sensors.extra.<sensor>]``). Telling the
vehicle the wrong figure is a study, not a bug.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from twin.core.messages import Reading
from twin.onboard.aids import AidContext, NavAid, finite, horizontal_position_rows
from twin.onboard.eskf import UpdateResult


class UsblPositionAid(NavAid):
    """Fuse a USBL fix's East and North into the filter.

    Args:
        sigma_floor_m: Declared per-axis error at zero range (m), ≥ 0.
        range_fraction: Declared per-axis error per metre of slant range, ≥ 0.
    """

    name: ClassVar[str] = "usbl_position"
    channels: ClassVar[tuple[str, ...]] = ("position_m", "slant_range_m")

    def __init__(self, sigma_floor_m: float = 0.1, range_fraction: float = 0.01):
        self.sigma_floor_m = finite("sigma_floor_m", sigma_floor_m, 0.0, open_lo=False)
        self.range_fraction = finite("range_fraction", range_fraction, 0.0, open_lo=False)
        if self.sigma_floor_m == 0.0 and self.range_fraction == 0.0:
            raise ValueError(
                "sigma_floor_m and range_fraction: both 0; allowed: a declared error > 0"
            )

    def update(self, nav: AidContext, reading: Reading) -> UpdateResult | None:
        fix = np.asarray(reading["position_m"], dtype=np.float64).reshape(3)
        slant = float(np.asarray(reading["slant_range_m"]))
        if not (np.all(np.isfinite(fix)) and np.isfinite(slant)):
            return None  # a dropped fix (NaN) is not fused
        predicted, h = horizontal_position_rows(nav)
        # The fix is of the ping's instant: move the prediction back by the reading's age.
        age = nav.filter.t - reading.t
        predicted = predicted - np.asarray(nav.estimate().v_enu, dtype=np.float64)[:2] * age
        sigma = self.sigma_floor_m + self.range_fraction * slant
        return nav.filter.update_vector(
            "usbl", predicted - fix[:2], h, np.diag([sigma * sigma, sigma * sigma])
        )
