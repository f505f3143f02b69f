"""Depth gauge: an absolute pressure sensor (MS5837-30BA class) and its firmware's depth conversion.

True pressure at the gauge's site, hydrostatic with the world's constant density and gravity:

    P = P_atm + ρ g (z_surface − z_site)   below the surface,   P = P_atm   above it,

with ρ = ``world.water_density_kg_m3``, g = ``world.gravity_mps2``, P_atm =
``world.atmospheric_pressure_pa`` and z_site from the MJCF sensor ``{site}/position``
(``depth/position`` in ``models/auv/auv.xml``). Wave pressure and dynamic (Bernoulli) pressure of
the flow past the port are not modelled.

Measured pressure (navigation.md §2.3): P̃ = sat(quant(P + b_0 + b_GM + n)), with b_0 a turn-on
offset, b_GM a Gauss–Markov drift (temperature), n white noise, quant the output LSB and sat the
sensor's full-scale range. Depth is then converted the way the vehicle's firmware does it,
d = (P̃ − P_atm,decl) / (ρ_decl g_decl), with the *declared* constants the firmware was configured
with (Blue Robotics' MS5837 library: ``setFluidDensity(1029)``, 101300 Pa, 9.80665 m/s²). By
default they are the world's true values; set them in the spec to study a mis-configured vehicle
(a fresh-water density of 997 in the sea reads 3 % deep).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import ClassVar

import dm_env
import numpy as np

from sensors.base import Sensor, SensorSpec, WorldView
from sensors.noise import GaussMarkov
from sensors.registry import register

MBAR = 100.0
"""1 mbar in Pa."""
BAR = 1e5
"""1 bar in Pa."""

_DECLARED_FIELDS = (
    "declared_density_kg_m3",
    "declared_gravity_mps2",
    "declared_atmospheric_pressure_pa",
)


@dataclass(frozen=True, slots=True)
class DepthSpec(SensorSpec):
    """A pressure-depth gauge's datasheet, in the datasheet's units. Defaults: an ideal gauge.

    Attributes:
        rate_hz: Output rate (Hz).
        delay_s: Latency from the sampling instant to delivery (s).
        noise_mbar: White pressure noise σ per sample (mbar).
        resolution_mbar: Output LSB (mbar); 0 = no quantization.
        offset_mbar: Turn-on offset σ (mbar), constant over a run.
        bias_instability_mbar: σ of the Gauss–Markov pressure drift (mbar).
        bias_corr_time_s: Its correlation time (s).
        full_scale_bar: Upper end of the absolute-pressure range (bar); readings saturate there.
            ``inf`` = no limit.
        declared_density_kg_m3: Water density the firmware converts with; None = the world's.
        declared_gravity_mps2: Gravity the firmware converts with; None = the world's.
        declared_atmospheric_pressure_pa: Surface pressure the firmware subtracts; None = the
            world's (a vehicle that tares its gauge at the surface).
    """

    rate_hz: float = 10.0
    delay_s: float = 0.0
    noise_mbar: float = 0.0
    resolution_mbar: float = 0.0
    offset_mbar: float = 0.0
    bias_instability_mbar: float = 0.0
    bias_corr_time_s: float = 600.0
    full_scale_bar: float = math.inf
    declared_density_kg_m3: float | None = None
    declared_gravity_mps2: float | None = None
    declared_atmospheric_pressure_pa: float | None = None

    def validate(self) -> None:
        """Raise ValueError naming the field, value and allowed range if the spec is impossible."""
        SensorSpec.validate(self)

        def number(v: object) -> bool:
            return not isinstance(v, bool) and isinstance(v, int | float | np.integer | np.floating)

        for name in (
            "noise_mbar",
            "resolution_mbar",
            "offset_mbar",
            "bias_instability_mbar",
            "bias_corr_time_s",
        ):
            v = getattr(self, name)
            if not (number(v) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} = {v!r}: must be a finite number >= 0")
        v = self.full_scale_bar
        if not (number(v) and not math.isnan(v) and v > 0):
            raise ValueError(f"full_scale_bar = {v!r}: must be a number > 0 (inf for no limit)")
        for name in _DECLARED_FIELDS:
            v = getattr(self, name)
            if v is not None and not (number(v) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} = {v!r}: must be None or a finite number > 0")


DEPTH_PRESETS: MappingProxyType[str, DepthSpec] = MappingProxyType(
    {
        # TE MS5837-30BA (Blue Robotics Bar30), navigation.md §2.3.
        "ms5837_30ba": DepthSpec(
            rate_hz=10.0,
            # ASSUMPTION: one D1 + D2 conversion pair at OSR 8192 takes 2 x ~18 ms
            # (navigation.md §2.3, [U] for the exact maxima) before the reading exists.
            delay_s=0.04,
            # Datasheet: "high-resolution module 0.2 mbar" (RMS at the highest OSR), i.e. 2 mm.
            noise_mbar=0.2,
            # The output integer P of the 30BA is in units of 0.1 mbar: the Blue Robotics MS5837
            # library computes P = (D1*SENS2/2^21 - OFF2)/2^13 and returns P/10 as mbar.
            # navigation.md §2.3 quotes "0.25 mbar resolution" from the rev C2 calculation table
            # [unverified]; we use the library's 0.1 mbar, the step a vehicle's log shows.
            resolution_mbar=0.1,
            # ASSUMPTIONS: the absolute accuracy is tens of mbar (navigation.md §2.3), but a
            # vehicle tares the gauge at the surface, so the residual offset is small; the drift
            # stands for thermal effects through a dive.
            offset_mbar=1.0,
            bias_instability_mbar=0.5,
            bias_corr_time_s=600.0,
            full_scale_bar=30.0,  # 0-30 bar absolute (datasheet range)
        ),
        "ideal": DepthSpec(),
    }
)


@dataclass(frozen=True, slots=True)
class DepthErrors:
    """The gauge's true error state after its last sample, in Pa (world-side truth)."""

    offset_pa: float
    drift_pa: float
    noise_pa: float


def depth_from_pressure(pressure_pa: float, p_atm_pa: float, rho: float, g: float) -> float:
    """The firmware's depth (m, positive down) from absolute pressure: (P − P_atm) / (ρ g)."""
    return (pressure_pa - p_atm_pa) / (rho * g)


@register
class DepthGauge(Sensor):
    """A pressure depth gauge at an MJCF site: channels ``pressure_pa`` and ``depth_m``.

    Both channels are float64 arrays of shape (1,): the absolute pressure in Pa and the depth below
    the surface in metres (positive down) converted by the firmware from it (module docstring).

    Args:
        spec: A :class:`DepthSpec`.
        name: Unique name in the run (default ``"depth"``).
        site: MJCF site (default ``"depth"``); the MJCF sensor ``{site}/position`` must exist.
    """

    kind: ClassVar[str] = "depth"
    spec_type: ClassVar[type[SensorSpec]] = DepthSpec
    default_site: ClassVar[str] = "depth"
    PRESETS: ClassVar[MappingProxyType[str, DepthSpec]] = DEPTH_PRESETS
    spec: DepthSpec

    def __init__(self, spec: DepthSpec, *, name: str | None = None, site: str | None = None):
        super().__init__(spec, name=name, site=site)
        s = self.spec
        self._position_sensor = f"{self.site}/position"
        self._noise_pa = s.noise_mbar * MBAR
        self._step_pa = s.resolution_mbar * MBAR
        self._full_scale_pa = s.full_scale_bar * BAR
        self._drift = GaussMarkov(s.bias_instability_mbar * MBAR, s.bias_corr_time_s, shape=1)
        self._w = np.zeros(2)
        self._offset_pa = 0.0
        self._last_noise_pa = 0.0
        self._t_last: float | None = None

    def channel_specs(self) -> dict[str, dm_env.specs.Array]:
        """``pressure_pa`` (1,) Pa and ``depth_m`` (1,) m, float64."""
        return {
            # The sensor saturates at 0 and its full scale.
            "pressure_pa": dm_env.specs.BoundedArray(
                (1,), np.float64, 0.0, self._full_scale_pa, "pressure_pa"
            ),
            "depth_m": dm_env.specs.Array((1,), np.float64, "depth_m"),
        }

    def reset(self, world: WorldView, rng: np.random.Generator) -> None:
        """Turn on: draw the offset and the initial drift (always two normals)."""
        try:
            world.mj_sensor(self._position_sensor)
        except (KeyError, ValueError) as exc:
            raise KeyError(
                f"depth gauge {self.name!r} at site {self.site!r} needs the MJCF sensor "
                f"{self._position_sensor!r}"
            ) from exc
        self._offset_pa = self.spec.offset_mbar * MBAR * float(rng.standard_normal())
        self._drift.reset(rng, stationary=True)
        self._last_noise_pa = 0.0
        self._t_last = world.t

    def true_pressure_pa(self, world: WorldView) -> float:
        """Hydrostatic absolute pressure at the site now (Pa); P_atm above the surface."""
        z = float(world.mj_sensor(self._position_sensor)[2])
        depth = max(0.0, world.surface_z_m - z)
        return (
            world.atmospheric_pressure_pa + world.water_density_kg_m3 * world.gravity_mps2 * depth
        )

    def to_depth_m(self, pressure_pa: float, world: WorldView) -> float:
        """The firmware's conversion d = (P − P_atm) / (ρ g) with the declared constants."""
        return depth_from_pressure(pressure_pa, *self.firmware_constants(world))

    def firmware_constants(self, world: WorldView) -> tuple[float, float, float]:
        """(P_atm, ρ, g) the firmware converts with: the declared ones, else the world's."""
        s = self.spec
        rho = s.declared_density_kg_m3
        g = s.declared_gravity_mps2
        p_atm = s.declared_atmospheric_pressure_pa
        if rho is None:
            rho = world.water_density_kg_m3
        if g is None:
            g = world.gravity_mps2
        if p_atm is None:
            p_atm = world.atmospheric_pressure_pa
        return float(p_atm), float(rho), float(g)

    def sample(self, world: WorldView, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Measure now: ``pressure_pa`` and ``depth_m`` with all errors applied."""
        if self._t_last is None:
            raise RuntimeError(f"depth gauge {self.name!r}: call reset() before sample()")
        t = world.t
        dt = t - self._t_last
        self._t_last = t
        rng.standard_normal(out=self._w)
        drift = float(self._drift.advance(self._w[1:2], dt)[0])
        self._last_noise_pa = self._noise_pa * float(self._w[0])
        p = self.true_pressure_pa(world) + self._offset_pa + drift + self._last_noise_pa
        p = min(max(p, 0.0), self._full_scale_pa)  # the sensor saturates at its range
        if self._step_pa > 0.0:
            # Firmware integer division truncates (the output LSB, see the preset).
            p = self._step_pa * math.floor(p / self._step_pa)
        return {
            "pressure_pa": np.array([p]),
            "depth_m": np.array([self.to_depth_m(p, world)]),
        }

    def current_errors(self) -> DepthErrors:
        """The true error state after the last sample (before quantization and saturation)."""
        return DepthErrors(
            offset_pa=self._offset_pa,
            drift_pa=float(self._drift.value[0]),
            noise_pa=self._last_noise_pa,
        )
