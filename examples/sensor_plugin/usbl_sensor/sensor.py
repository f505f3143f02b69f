"""A USBL (ultra-short baseline) acoustic position fix, for auv-twin's ``auv_twin.sensors`` group.

A transceiver at the sea surface above the run's origin ranges the vehicle's transponder and
measures its bearing; the fix is the transponder's position in the local frame n (East, North,
Up, metres) with an error that grows with the slant range r: each axis is off by a normal draw of
σ = ``sigma_floor_m`` + ``range_fraction`` · r, independently from fix to fix (no multipath, no
sound-speed error, no outages). The fix arrives ``delay_s`` after the ping (the sound's travel and
the processing).

This is an example of the mechanism, not a sourced device: σ = 0.1 m + 1 % of the slant range,
1 Hz and 0.5 s are assumptions of the order vendors state for small USBL systems (0.1–2 % of
range); a package for a real unit would take them from its datasheet and cite it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import dm_env
import numpy as np

from sensors.base import Sensor, SensorSpec, WorldView


@dataclass(frozen=True, slots=True)
class UsblSpec(SensorSpec):
    """A USBL's datasheet: rate, latency and the position error's floor and growth with range.

    Attributes:
        sigma_floor_m: Per-axis position error at zero range (m).
        range_fraction: Per-axis position error per metre of slant range (a fraction).
    """

    rate_hz: float = 1.0
    delay_s: float = 0.5
    sigma_floor_m: float = 0.1
    range_fraction: float = 0.01

    def validate(self) -> None:
        SensorSpec.validate(self)
        if not (math.isfinite(self.sigma_floor_m) and self.sigma_floor_m >= 0.0):
            raise ValueError(f"sigma_floor_m = {self.sigma_floor_m!r}: must be a number >= 0 (m)")
        if not (math.isfinite(self.range_fraction) and 0.0 <= self.range_fraction <= 0.2):
            raise ValueError(f"range_fraction = {self.range_fraction!r}: must lie in [0, 0.2]")


class Usbl(Sensor):
    """The USBL fix of the transponder at the sensor's site (the IMU's, by default)."""

    kind: ClassVar[str] = "usbl"
    spec_type: ClassVar[type[SensorSpec]] = UsblSpec
    default_site: ClassVar[str] = "imu"
    PRESETS: ClassVar[dict[str, SensorSpec]] = {
        "generic": UsblSpec(),  # the assumptions above
        "ideal": UsblSpec(delay_s=0.0, sigma_floor_m=0.0, range_fraction=0.0),
    }

    def sample(self, world: WorldView, rng: np.random.Generator) -> dict[str, np.ndarray]:
        spec: Any = self.spec
        position, _ = world.site_pose(self.site)
        transceiver = np.array([0.0, 0.0, world.surface_z_m])
        slant = float(np.linalg.norm(position - transceiver))
        sigma = spec.sigma_floor_m + spec.range_fraction * slant
        return {
            "position_m": position + sigma * rng.standard_normal(3),
            "slant_range_m": np.asarray(slant),
        }

    def channel_specs(self) -> dict[str, dm_env.specs.Array]:
        return {
            "position_m": dm_env.specs.Array((3,), np.float64, name=f"{self.name}/position_m"),
            "slant_range_m": dm_env.specs.Array((), np.float64, name=f"{self.name}/slant_range_m"),
        }
