"""What crosses the world/onboard boundary: sensor readings in, actuator commands out.

This module is shared by both sides. It imports nothing from the world (no MuJoCo, no truth), so the
onboard package may depend on it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, slots=True)
class Reading:
    """One sample of one sensor, as the vehicle computer receives it.

    Attributes:
        sensor: The sensor's name (unique in a run, e.g. ``"imu"``).
        t: The reading's time stamp (s): the sampling instant on the sensor's own clock, which
            is the sim clock except for a sensor with a clock offset (a drawn polarimeter unit,
            ``sensors.polarimeter.unit.hardware``); the truth a reading carries keeps the true
            instant.
        t_delivered: Sim time in seconds at which the vehicle computer receives it
            (the true sampling instant plus the sensor's delay).
        values: Channel name to value (numpy arrays; scalars are 0-d or shape (1,)).
    """

    sensor: str
    t: float
    t_delivered: float
    values: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __getitem__(self, channel: str) -> np.ndarray:
        return self.values[channel]


@dataclass(frozen=True, slots=True)
class ActuatorCommand:
    """Raw actuator commands.

    Attributes:
        rudder_rad: Rudder angle; positive turns the vehicle to starboard (heading increases).
        stern_rad: Stern-plane angle; positive pitches the nose up.
        propeller_rps: Propeller speed in revolutions per second (>= 0).
    """

    rudder_rad: float = 0.0
    stern_rad: float = 0.0
    propeller_rps: float = 0.0
