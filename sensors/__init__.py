"""The sensor plugin layer: physical sensors in the MJCF, noise, rate and delay in Python.

A sensor is one module that subclasses :class:`sensors.base.Sensor` and registers itself with
:func:`sensors.registry.register`. Sensors see truth (the :class:`sensors.base.WorldView`) and
produce :class:`twin.core.messages.Reading` objects; they never see estimates.
"""

from __future__ import annotations

from sensors.base import Sensor, SensorSpec, WorldView
from sensors.registry import available, create, register
from sensors.suite import SensorSuite

__all__ = ["Sensor", "SensorSpec", "SensorSuite", "WorldView", "available", "create", "register"]
