"""The polarimeter's configuration and truth records: the world's optics, the camera's spec.

Split from :mod:`sensors.polarimeter.render` (which re-exports them): the data a scenario or a
study sets, validated here, apart from the chain that renders with them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sensors.base import SensorSpec
from sensors.polarimeter.optics import bubbles as bubbles_mod
from sensors.polarimeter.optics import caustics as caustics_mod
from sensors.polarimeter.optics import particles as particles_mod
from sensors.polarimeter.optics import scattering as scattering_mod
from sensors.polarimeter.optics import surface as surface_mod
from sensors.polarimeter.optics import water as water_mod
from sensors.polarimeter.optics import waves as waves_mod
from sensors.polarimeter.optics.sky import SkySpec
from sensors.polarimeter.unit import fisheye as fisheye_mod
from sensors.polarimeter.unit import mosaic as mosaic_mod
from twin.core.arrays import FloatArray
from twin.core.extensions import WATER_BODIES
from twin.core.options import INLINE_WATER


@dataclass(frozen=True, slots=True)
class OpticsConfig:
    """The world's optics the polarimeter looks through (scenario tables [optics] and [water]).

    Attributes:
        sky: Sky radiance and polarization model.
        jerlov_type: The water body: a Jerlov type (``water.JERLOV_TYPES``) or a plug-in's
            (``twin.core.extensions.WATER_BODIES``); ``"inline"`` with ``water_body``.
        water_body: The water's own IOPs (a scenario's ``[water.iops]``), with ``jerlov_type``
            ``"inline"``; None for a named water body.
        turbidity: Multiplier on the type's particle scattering (1 = the type itself).
        particle_dop_max: The particles' peak linear polarization P (scattering.py, sourced).
        depolarization_ratio: The water molecules' depolarization ratio δ (scattering.py).
        salinity_psu: Salinity, for the refractive index (Quan & Fry).
        temperature_c: Water temperature, for the refractive index.
        wavelength_nm: The one wavelength of the optics.
        wind_speed_mps: Wind at 12.5 m for Cox–Munk slopes; 0 = a flat sea.
        wind_toward_deg: Compass direction the wind blows toward.
        bubbles: ``"hall_novarini"``: the breaking waves' bubbles near the surface, drawn per
            frame as bright unpolarized points (:mod:`sensors.polarimeter.optics.bubbles`; none on a
            flat sea or in a tank); ``"ideal"``: none. Ideal by default here, so offline studies
            see only what they ask for; a scenario's ``[optics]`` defaults to the real one.
        flicker: ``"caustics"``: the waves focus the sun's beam into a moving net that the
            water's sun-lit path radiance (and the bubbles) carry
            (:mod:`sensors.polarimeter.optics.caustics`; a flat sea has none); ``"ideal"``: the beam
            stays uniform under the waves. Ideal by default here, as ``bubbles``.
        particles: ``"marine_snow"``: suspended aggregates through the water column, drawn per
            frame as bright unpolarized points (:mod:`sensors.polarimeter.optics.particles`; none in
            a
            tank); ``"ideal"``: none. Ideal by default here, as ``bubbles``.
    """

    sky: SkySpec = field(default_factory=SkySpec)
    jerlov_type: str = "II"
    turbidity: float = 1.0
    particle_dop_max: float = scattering_mod.PARTICLE_DOP_MAX
    depolarization_ratio: float = scattering_mod.WATER_DEPOLARIZATION_RATIO
    salinity_psu: float = 35.0
    temperature_c: float = 15.0
    wavelength_nm: float = 500.0
    wind_speed_mps: float = 0.0
    wind_toward_deg: float = 0.0
    bubbles: str = "ideal"
    flicker: str = "ideal"
    particles: str = "ideal"
    water_body: water_mod.WaterBody | None = None

    def __post_init__(self) -> None:
        if (self.jerlov_type == INLINE_WATER) != (self.water_body is not None):
            raise ValueError(
                f"OpticsConfig.water_body: {self.water_body!r} with jerlov_type "
                f"{self.jerlov_type!r}; allowed: a WaterBody exactly when jerlov_type is "
                f"{INLINE_WATER!r}"
            )
        if self.water_body is None and self.jerlov_type not in WATER_BODIES.names():
            raise ValueError(
                f"OpticsConfig.jerlov_type: {self.jerlov_type!r}; allowed: {WATER_BODIES.names()}"
            )
        if not (math.isfinite(self.wind_toward_deg)):
            raise ValueError(
                f"OpticsConfig.wind_toward_deg: {self.wind_toward_deg!r}; allowed: finite"
            )
        if self.bubbles not in bubbles_mod.BUBBLE_MODELS:
            raise ValueError(
                f"OpticsConfig.bubbles: {self.bubbles!r}; allowed: {bubbles_mod.BUBBLE_MODELS}"
            )
        if self.particles not in particles_mod.PARTICLE_MODELS:
            raise ValueError(
                f"OpticsConfig.particles: {self.particles!r}; "
                f"allowed: {particles_mod.PARTICLE_MODELS}"
            )
        if self.flicker not in caustics_mod.FLICKER_MODELS:
            raise ValueError(
                f"OpticsConfig.flicker: {self.flicker!r}; allowed: {caustics_mod.FLICKER_MODELS}"
            )
        # The stage constructors validate the rest (turbidity, index ranges, wind speed).
        self.water()
        surface_mod.water_index(self.salinity_psu, self.temperature_c, self.wavelength_nm)
        waves_mod.cox_munk_variances(self.wind_speed_mps)

    def water(self) -> water_mod.WaterOptics:
        """The water's optical properties (type, turbidity, P and δ)."""
        try:
            return water_mod.jerlov_water(
                self.water_body if self.water_body is not None else self.jerlov_type,
                self.turbidity,
                particle_dop_max=self.particle_dop_max,
                depolarization_ratio=self.depolarization_ratio,
            )
        except ValueError as e:
            raise ValueError(f"OpticsConfig: {e}") from None

    @property
    def water_index(self) -> float:
        return float(
            surface_mod.water_index(self.salinity_psu, self.temperature_c, self.wavelength_nm)
        )


@dataclass(frozen=True, slots=True)
class PolarimeterSpec(SensorSpec):
    """A polarization camera: lens + housing, DoFP sensor, and how the twin renders it.

    Attributes:
        rate_hz: Frame rate (Hz). The seeds' cameras ran at 10 Hz.
        delay_s: Readout + transfer latency (s).
        camera: Lens/geometry preset (``unit.fisheye.PRESETS``).
        sensor: DoFP sensor preset (``mosaic.PRESETS``).
        binning: On-sensor same-orientation binning 1, 2 or 4 (2448×2048 → 612×512 at 4).
        housing: ``"dome"`` or ``"flat"`` port.
        f_number: Working f-number of the lens (FE185C057HA-1: F1.4–F16; F2.8 by default
            [uncertain: the seeds do not state the aperture]).
        passband_nm: Effective spectral width the one-wavelength radiance stands for (nm):
            mono IMX250MZR with no filter, weighted by water's transmission, ~100 nm [uncertain].
        lens_transmission: Lens (and dome) throughput in (0, 1].
        exposure_us: Fixed exposure (µs); None = the sensor preset's.
        auto_exposure: Override the sensor preset's auto exposure; None = the preset's.
        occlusion: Cast rays against the MuJoCo scene (vehicle fins, a ship's hull, a pier).
        occlusion_stride_px: Cast every n-th pixel (in both axes) and upsample.
        occlusion_geomgroups: MJCF geom groups that occlude (visual groups 0–2 by default; the
            sensor-site group 5 and any collision-only group are excluded).
        psf: See the solar disc through a ~1-pixel Gaussian PSF (keeps its energy on the grid).
        fast: Render the smooth parts of the frame on a coarse grid and upsample (bilinear), with
            the exact chain kept at every pixel near Snell's window edge (the horizon in air), the
            sun and the frame border (see ``Polarimeter._render_fast``; ≈ 10× faster, errors in
            ``docs/polarimeter.md``). False = the exact chain at every pixel. Waves, a flat port
            and the orthographic lens mapping always use the exact chain.
        smooth_stride_px: The coarse grid's spacing in frame pixels (a divisor of both frame
            sizes); None = 8 full-resolution pixels, at least 2 frame pixels (8 at binning 1,
            4 at binning 2, 2 at binning 4).
    """

    rate_hz: float = 10.0
    delay_s: float = 0.0
    camera: str = "phx050s_fe185"
    sensor: str = "phx050s_p"
    binning: int = 1
    housing: Literal["dome", "flat"] = "dome"
    f_number: float = 2.8
    passband_nm: float = 100.0
    lens_transmission: float = 0.9
    exposure_us: float | None = None
    auto_exposure: bool | None = None
    occlusion: bool = True
    occlusion_stride_px: int = 8
    occlusion_geomgroups: tuple[int, ...] = (0, 1, 2)
    psf: bool = True
    fast: bool = True
    smooth_stride_px: int | None = None

    def validate(self) -> None:
        """Raise ValueError naming the field, the value and what is allowed."""
        SensorSpec.validate(self)
        if self.camera not in fisheye_mod.PRESETS:
            raise ValueError(f"camera = {self.camera!r}: allowed: {sorted(fisheye_mod.PRESETS)}")
        if self.sensor not in mosaic_mod.PRESETS:
            raise ValueError(f"sensor = {self.sensor!r}: allowed: {sorted(mosaic_mod.PRESETS)}")
        if self.binning not in (1, 2, 4):
            raise ValueError(f"binning = {self.binning!r}: allowed: 1, 2, 4")
        if self.housing not in ("dome", "flat"):
            raise ValueError(f"housing = {self.housing!r}: allowed: 'dome', 'flat'")
        for name, lo, hi in (
            ("f_number", 0.5, 64.0),
            ("passband_nm", 1.0, 1000.0),
            ("lens_transmission", 1e-6, 1.0),
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"{name} = {v!r}: allowed: [{lo:g}, {hi:g}]")
        if self.exposure_us is not None and not (
            math.isfinite(self.exposure_us) and 0 < self.exposure_us <= 1e7
        ):
            raise ValueError(f"exposure_us = {self.exposure_us!r}: allowed: (0, 1e7] or None")
        if not (isinstance(self.occlusion_stride_px, int) and 1 <= self.occlusion_stride_px <= 64):
            raise ValueError(
                f"occlusion_stride_px = {self.occlusion_stride_px!r}: allowed: integers 1..64"
            )
        if self.smooth_stride_px is not None and not (
            isinstance(self.smooth_stride_px, int) and 2 <= self.smooth_stride_px <= 64
        ):
            raise ValueError(
                f"smooth_stride_px = {self.smooth_stride_px!r}: allowed: None or integers 2..64"
            )
        if any(not (0 <= g <= 5) for g in self.occlusion_geomgroups):
            raise ValueError(
                f"occlusion_geomgroups = {self.occlusion_geomgroups!r}: allowed: groups 0..5"
            )
        self.camera_spec()  # binning vs sensor size, housing

    def camera_spec(self) -> fisheye_mod.FisheyeSpec:
        return fisheye_mod.preset(self.camera, binning=self.binning, housing=self.housing)

    def sensor_spec(self) -> mosaic_mod.PolarizationSensorSpec:
        """The DoFP spec of one (binned) pixel.

        Binning b sums the charge of b² same-orientation pixels and reads it out rescaled to the
        same ADC range (a camera's "average" binning mode): full well, conversion gain and dark
        current scale by b², read noise and DSNU (independent per pixel) by b. Shot noise follows
        from the summed signal, so SNR grows by b as it should. A binned pixel is hot when one of
        its b² is (probability 1 − (1 − f)^(b²); a hot pixel's own dark current is what it adds),
        and its row noise sums b rows' offsets, each b times: σ·b^1.5.
        """
        s = mosaic_mod.preset(self.sensor)
        changes: dict[str, Any] = {}
        b = self.binning
        if b > 1:
            changes.update(
                full_well_e=s.full_well_e * b * b,
                conversion_gain_e_per_dn=s.conversion_gain_e_per_dn * b * b,
                dark_current_e_per_s=s.dark_current_e_per_s * b * b,
                read_noise_e=s.read_noise_e * b,
                dsnu_e=s.dsnu_e * b,
                hot_pixel_fraction=1.0 - (1.0 - s.hot_pixel_fraction) ** (b * b),
                row_noise_e=s.row_noise_e * b**1.5,
            )
        if self.exposure_us is not None:
            changes["exposure_us"] = float(self.exposure_us)
        if self.auto_exposure is not None:
            changes["auto_exposure"] = bool(self.auto_exposure)
        return dataclasses.replace(s, **changes) if changes else s


@dataclass(frozen=True, slots=True)
class PolarimeterTruth:
    """Truth layers of the last frame (truth channel only).

    Attributes:
        t: Sim time of the frame.
        stokes: (H, W, 3) true sensor-plane Stokes, photons per pixel per second (float32).
        snell_window: (H, W) pixels whose ray reaches the sky through the surface.
        occluded: (H, W) pixels whose sky is blocked by the scene.
        sun_pixel: (u, v) of the (refracted) sun in the image, or None when not in view / night.
        sun_enu: (3,) true ENU direction to the sun in air.
        depth_m: Camera depth below the surface (negative: in air).
        night: The sun was below the night threshold.
        exposure_us: Exposure used.
        bubbles: How many bubbles were drawn into the frame
            (:mod:`sensors.polarimeter.optics.bubbles`).
        particles: How many marine-snow aggregates were
            (:mod:`sensors.polarimeter.optics.particles`).
    """

    t: float
    stokes: FloatArray
    snell_window: NDArray[np.bool_]
    occluded: NDArray[np.bool_]
    sun_pixel: tuple[float, float] | None
    sun_enu: NDArray[np.float64]
    depth_m: float
    night: bool
    exposure_us: float
    bubbles: int = 0
    particles: int = 0


__all__ = ["OpticsConfig", "PolarimeterSpec", "PolarimeterTruth"]
