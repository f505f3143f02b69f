"""What the error-state filter reports: an update's result, a refused measurement, an estimate.

:class:`twin.onboard.eskf.Eskf` returns these; the navigator, the gravity matcher and the
navigation aids read them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from twin.core.arrays import Float64Array as FloatArray

#: The built-in measurements; a navigation aid (twin.onboard.aids) names its own kind.
MeasurementKind = Literal["gravity", "sun", "depth", "map"] | str


@dataclass(frozen=True, slots=True)
class Rejection:
    """A measurement the innovation gate refused."""

    t: float
    kind: MeasurementKind
    nis: float
    threshold: float


@dataclass(frozen=True, slots=True)
class UpdateResult:
    """What one update call did.

    Attributes:
        kind: "gravity", "sun" or "depth".
        t: Filter time (s).
        applied: True when the correction was applied.
        nis: Normalized innovation squared (NaN when not computed).
        reason: "" when applied, else why not ("gate", "not quasi-static", "no fix", ...).
    """

    kind: MeasurementKind
    t: float
    applied: bool
    nis: float = math.nan
    reason: str = ""


@dataclass(frozen=True, slots=True)
class NavEstimate:
    """The filter's estimate at one instant (copies).

    Attributes:
        t: Time (s).
        roll, pitch, yaw: Attitude (rad), :mod:`twin.core.frames` convention.
        heading_deg: Compass heading, degrees clockwise from North.
        heading_sigma_deg: 1σ of the heading, √P[φ_U, φ_U] in degrees (exact for a level
            vehicle, first order otherwise).
        c_bn: C_b^n (3×3).
        v_enu: Velocity (m/s).
        lat_rad, lon_rad, h_m: Position; h = −depth.
        gyro_bias: Gyro bias estimate (rad/s, body); accel_bias: (m/s², body).
        covariance: The 15×15 error covariance P in the state order of the module docstring.
    """

    t: float
    roll: float
    pitch: float
    yaw: float
    heading_deg: float
    heading_sigma_deg: float
    c_bn: FloatArray
    v_enu: FloatArray
    lat_rad: float
    lon_rad: float
    h_m: float
    gyro_bias: FloatArray
    accel_bias: FloatArray
    covariance: FloatArray

    @property
    def depth_m(self) -> float:
        return -self.h_m
