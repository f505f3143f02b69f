"""Marine gravimeter: the magnitude of specific force on a levelled platform, in mGal.

World side. A marine gravimeter (a spring or force-feedback sensor on a gyro-stabilised platform,
e.g. the DGS AT1M) measures the vertical specific force, not the anomaly. Over each output
interval T = 1/rate it reads the mean of

    g̃ = γ(φ, d) + Δg(E, N) − E(v) + a_up + b_0 + ḃ·t + n,

* γ(φ, d): WGS84 normal gravity at the latitude, continued down through the water with the
  Poincaré–Prey gradient (:func:`twin.core.earth.normal_gravity_in_water_mgal`: the anomaly is
  defined against that formula, so the vehicle reduces its readings with the same one);
* Δg(E, N): the world's anomaly field at the sensor (:meth:`Gravimeter.configure_field`); off
  the field's map the reading is NaN (the truth is unknown there: a documented gap, not a number
  made up), and the vehicle skips non-finite readings;
* E(v) = 2Ω v_E cos φ + (v_E² + v_N²)/R: the Eötvös effect of moving over the rotating Earth
  (Harlan 1968, Geophysics 33(3)), with the interval's mean velocity — 14.6 mGal per m/s of
  eastward speed at the equator, so the vehicle must correct it with its own velocity estimate;
* a_up: the interval's mean vertical acceleration (the change of the vertical velocity over the
  interval): a diving or climbing AUV's depth changes read as gravity;
* b_0: the offset left after the meter is tied to a known station before the dive; ḃ: a linear
  drift (spring ageing); n: white noise per output.

Velocities are the site's true ones (MJCF ``{site}/linvel``, the IMU's own): the interval's mean
is that of its two ends, its vertical acceleration their difference over the interval (zero for
the first sample, which has no previous one).

Presets (``GRAVIMETER_PRESETS``):

* ``"at1m"``: Dynamic Gravity Systems AT1M. 1 Hz output, delivered 5 s late (the meter's 5 s
  anti-aliasing filter and its 5 s time shift: the NOAA/UNOLS sensor notes for AT1M-33); linear
  drift "in the order of 2 mGal a month" for a new sensor (Austin Exploration's AT1M page) →
  σ = 0.067 mGal/day; white noise 0.5 mGal per output [uncertain: navigation.md's 0.5–1 mGal for
  marine gravimeters after filtering]; offset after a station tie 0.1 mGal [uncertain: the tie's
  repeatability, not stated by DGS].
* ``"ideal"``: no errors (the physics — Eötvös, vertical acceleration — is still there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import ClassVar

import dm_env
import numpy as np

from sensors.base import Sensor, SensorSpec, WorldView
from sensors.registry import register
from twin.core import earth
from twin.core.gravity_map import GravityGrid

SECONDS_PER_DAY = 86400.0


@dataclass(frozen=True, slots=True)
class GravimeterSpec(SensorSpec):
    """A marine gravimeter's datasheet. Defaults: an ideal meter at 1 Hz.

    Attributes:
        rate_hz: Output rate (Hz); each output is the mean over its interval.
        delay_s: Latency from the interval's end to delivery (s).
        noise_mgal: White noise σ per output (mGal).
        offset_mgal: σ of the offset left after the pre-dive station tie (mGal).
        drift_mgal_per_day: σ of the linear drift rate (mGal/day).
    """

    rate_hz: float = 1.0
    delay_s: float = 0.0
    noise_mgal: float = 0.0
    offset_mgal: float = 0.0
    drift_mgal_per_day: float = 0.0

    def validate(self) -> None:
        """Raise ValueError naming the field, value and allowed range if the spec is impossible."""
        SensorSpec.validate(self)
        for name in ("noise_mgal", "offset_mgal", "drift_mgal_per_day"):
            v = getattr(self, name)
            ok = isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            if not (ok and 0 <= v <= 1000):
                raise ValueError(f"{name} = {v!r}: must be a number in [0, 1000]")


GRAVIMETER_PRESETS: MappingProxyType[str, GravimeterSpec] = MappingProxyType(
    {
        "at1m": GravimeterSpec(
            rate_hz=1.0,
            delay_s=5.0,
            noise_mgal=0.5,
            offset_mgal=0.1,
            drift_mgal_per_day=2.0 / 30.0,
        ),
        "ideal": GravimeterSpec(),
    }
)


@dataclass(frozen=True, slots=True)
class GravimeterTruth:
    """What the last reading was made of (mGal; world-side truth, for scoring and tests)."""

    anomaly_mgal: float
    normal_mgal: float
    eotvos_mgal: float
    vertical_accel_mgal: float
    error_mgal: float


@register
class Gravimeter(Sensor):
    """A gravimeter at an MJCF site: channel ``gravity_mgal`` (1,), float64.

    The world's anomaly field is given with :meth:`configure_field` before the run; without one
    the meter reads normal gravity and the kinematic effects only (anomaly 0).

    Args:
        spec: A :class:`GravimeterSpec`.
        name: Unique name in the run (default ``"gravimeter"``).
        site: MJCF site (default ``"imu"``: the meter sits with the inertial unit, at the centre of
            the vehicle).
    """

    kind: ClassVar[str] = "gravimeter"
    spec_type: ClassVar[type[SensorSpec]] = GravimeterSpec
    default_site: ClassVar[str] = "imu"
    PRESETS: ClassVar[MappingProxyType[str, GravimeterSpec]] = GRAVIMETER_PRESETS
    spec: GravimeterSpec

    def __init__(self, spec: GravimeterSpec, *, name: str | None = None, site: str | None = None):
        super().__init__(spec, name=name, site=site)
        self.field: GravityGrid | None = None
        self.field_origin_m: tuple[float, float] = (0.0, 0.0)
        self._offset = 0.0
        self._drift_per_s = 0.0
        self._linvel_sensor = f"{self.site}/linvel"
        self._last: tuple[float, np.ndarray] | None = None  # (t, ENU velocity) of the last sample
        self._t0 = 0.0
        self.truth: GravimeterTruth | None = None

    def configure_field(
        self, field: GravityGrid | None, origin_m: tuple[float, float] = (0.0, 0.0)
    ) -> None:
        """The world's anomaly field; ``origin_m`` is where the world's ENU origin lies on it."""
        if field is not None and not isinstance(field, GravityGrid):
            raise TypeError(f"configure_field needs a GravityGrid, got {type(field).__name__}")
        e, n = (float(x) for x in origin_m)
        if not (math.isfinite(e) and math.isfinite(n)):
            raise ValueError(f"gravimeter field origin: {origin_m!r}; allowed: finite metres")
        self.field = field
        self.field_origin_m = (e, n)

    def channel_specs(self) -> dict[str, dm_env.specs.Array]:
        """``gravity_mgal`` (1,): the interval's mean vertical specific force, mGal."""
        return {"gravity_mgal": dm_env.specs.Array((1,), np.float64, "gravity_mgal")}

    def reset(self, world: WorldView, rng: np.random.Generator) -> None:
        """Turn on: the tie's residual offset and this dive's drift rate (always two normals)."""
        try:
            world.mj_sensor(self._linvel_sensor)
        except (KeyError, ValueError) as exc:
            raise KeyError(
                f"gravimeter {self.name!r} at site {self.site!r} needs the MJCF sensor "
                f"{self._linvel_sensor!r}"
            ) from exc
        z = rng.standard_normal(2)
        self._offset = self.spec.offset_mgal * float(z[0])
        self._drift_per_s = self.spec.drift_mgal_per_day * float(z[1]) / SECONDS_PER_DAY
        self._t0 = world.t
        self._last = None
        self.truth = None

    def anomaly_at(self, east_m: float, north_m: float) -> float:
        """The world field at a world ENU position (mGal); NaN off the map, 0 without a field."""
        if self.field is None:
            return 0.0
        e = east_m + self.field_origin_m[0]
        n = north_m + self.field_origin_m[1]
        if not bool(self.field.contains(e, n)):
            return math.nan
        return float(self.field.value(e, n))

    def sample(self, world: WorldView, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Measure now: the interval's mean since the last sample, all errors applied."""
        t = world.t
        pos, _ = world.site_pose(self.site)
        v = np.array(world.mj_sensor(self._linvel_sensor), dtype=np.float64)  # ENU, world frame
        v_mean, a_up = v, 0.0
        if self._last is not None and t > self._last[0]:
            dt = t - self._last[0]
            v_mean = 0.5 * (v + self._last[1])
            a_up = (v[2] - self._last[1][2]) / dt
        self._last = (t, v)
        lat = world.latitude_rad
        depth = max(world.surface_z_m - float(pos[2]), 0.0)
        normal = earth.normal_gravity_in_water_mgal(lat, depth)
        anomaly = self.anomaly_at(float(pos[0]), float(pos[1]))
        eotvos = earth.eotvos_mgal(float(v_mean[0]), float(v_mean[1]), lat)
        error = (
            self._offset
            + self._drift_per_s * (t - self._t0)
            + self.spec.noise_mgal * float(rng.standard_normal())
        )
        accel = a_up / earth.MGAL_MPS2
        self.truth = GravimeterTruth(anomaly, normal, eotvos, accel, error)
        return {"gravity_mgal": np.array([normal + anomaly - eotvos + accel + error])}


__all__ = [
    "GRAVIMETER_PRESETS",
    "Gravimeter",
    "GravimeterSpec",
    "GravimeterTruth",
]
