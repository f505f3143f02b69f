"""The sensor interface: a spec, a mount site, a rate, a delay, and ``sample(world, rng)``."""

from __future__ import annotations

import abc
import datetime as dt
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import dm_env
import mujoco
import numpy as np


class WorldView(Protocol):
    """What a sensor may look at: the true state of the world at the current instant.

    Implemented by :class:`twin.world.plant.Plant`. Everything here is truth; sensors turn it into
    readings.
    """

    @property
    def t(self) -> float:
        """Sim time in seconds."""

    @property
    def utc(self) -> dt.datetime:
        """UTC instant of the current sim time (timezone-aware)."""

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled MuJoCo model."""

    @property
    def data(self) -> mujoco.MjData:
        """The MuJoCo data, after the current step (acceleration-stage sensors are valid)."""

    @property
    def latitude_rad(self) -> float:
        """Geodetic latitude of the vehicle (radians)."""

    @property
    def longitude_rad(self) -> float:
        """Longitude of the vehicle (radians)."""

    @property
    def gravity_mps2(self) -> float:
        """Magnitude of local normal gravity (m/s^2); MuJoCo's opt.gravity is set to it."""

    @property
    def water_density_kg_m3(self) -> float:
        """Sea-water density (kg/m^3)."""

    @property
    def atmospheric_pressure_pa(self) -> float:
        """Air pressure at the sea surface (Pa)."""

    @property
    def surface_z_m(self) -> float:
        """World z of the sea surface (m); depth = surface_z_m - z."""

    def mj_sensor(self, name: str) -> np.ndarray:
        """The value of the named MJCF sensor (a view into ``data.sensordata``; copy to keep)."""

    def site_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(position in n, C_s^n rotation matrix) of the named site."""


@dataclass(frozen=True, slots=True)
class SensorSpec:
    """Base class of every sensor's spec: what a datasheet says about it.

    Subclasses add their own fields (frozen dataclasses too); ``rate_hz`` and ``delay_s`` are
    common to all.
    """

    rate_hz: float = 100.0
    delay_s: float = 0.0

    def validate(self) -> None:
        """Raise ValueError naming the field, value and allowed range if the spec is impossible."""
        if not (np.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ValueError(f"rate_hz = {self.rate_hz!r}: must be a finite number > 0")
        if not (np.isfinite(self.delay_s) and self.delay_s >= 0):
            raise ValueError(f"delay_s = {self.delay_s!r}: must be a finite number >= 0")


class Sensor(abc.ABC):
    """A sensor plugin.

    Subclasses set ``kind`` (the registry key), ``spec_type`` and ``PRESETS``, and implement
    :meth:`sample` and :meth:`channel_specs`. Stateful error processes (biases) are (re)drawn in
    :meth:`reset` from the Generator the suite gives each sensor, never from a global RNG.

    Args:
        spec: The sensor's spec.
        name: Unique name in a run (defaults to ``kind``); readings carry it, Rerun logs under it.
        site: The MJCF site the sensor is mounted at (defaults to ``default_site``).
    """

    kind: ClassVar[str] = ""
    spec_type: ClassVar[type[SensorSpec]] = SensorSpec
    default_site: ClassVar[str] = ""
    PRESETS: ClassVar[Mapping[str, SensorSpec]] = {}

    def __init__(self, spec: SensorSpec, *, name: str | None = None, site: str | None = None):
        if not isinstance(spec, self.spec_type):
            raise TypeError(
                f"{type(self).__name__} needs a {self.spec_type.__name__}, "
                f"got {type(spec).__name__}"
            )
        spec.validate()
        self.spec = spec
        self.name = name or self.kind
        self.site = site or self.default_site

    @property
    def rate_hz(self) -> float:
        return self.spec.rate_hz

    @property
    def delay_s(self) -> float:
        return self.spec.delay_s

    def reset(self, world: WorldView, rng: np.random.Generator) -> None:  # noqa: B027
        """Start an episode: draw turn-on errors. Default: nothing to draw."""

    @abc.abstractmethod
    def sample(self, world: WorldView, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Measure the world now: channel name to value, shapes as in :meth:`channel_specs`."""

    @abc.abstractmethod
    def channel_specs(self) -> dict[str, dm_env.specs.Array]:
        """Shape and dtype of each channel :meth:`sample` returns."""

    def describe(self) -> dict[str, Any]:
        """A JSON-able summary for metrics files and logs."""
        from dataclasses import asdict

        return {"kind": self.kind, "name": self.name, "site": self.site, "spec": asdict(self.spec)}
