"""The polarimeter sensor plugin: the whole physics chain from the vehicle's pose to a raw frame.

Per frame (``Polarimeter.sample``), from the true pose of the ``polarimeter`` site, the UTC and the
place (:class:`sensors.base.WorldView`):

1. camera rays (cached), rotated into ENU by the site attitude C_c^n; through the housing port
   (dome: unbent; flat: Snell and Fresnel twice);
2. the sun (NREL SPA, :class:`~sensors.polarimeter.optics.sun.SunTracker`);
3. below the surface: the sea surface (:mod:`~sensors.polarimeter.optics.surface`: Snell, Fresnel
   Mueller,
   optional Cox–Munk waves) maps each in-water ray to the sky direction it sees; the sky
   (:mod:`~sensors.polarimeter.optics.sky`) is evaluated there and transmitted; the water column
   (:mod:`~sensors.polarimeter.optics.water`) attenuates it and adds single- and multiple-scattered
   light.
   Above the surface (a camera in air, depth ≤ 0): the sky directly, nothing below the horizon;
4. occlusion: the rays are cast against the MuJoCo scene (``mujoco.mj_multiRay``) on a coarse grid
   (every ``occlusion_stride_px``-th pixel, nearest-neighbour upsampled); a blocked pixel keeps
   only the scattered light (no direct sky);
5. radiance (W m⁻² sr⁻¹ nm⁻¹ × the passband) → photons per pixel per second (the camera equation,
   :func:`~sensors.polarimeter.unit.mosaic.photon_rate_per_pixel`), polarization carried onto the
   sensor plane by the lens (``Camera.sensor_stokes_from_meridian``);
6. the DoFP sensor (:class:`~sensors.polarimeter.unit.mosaic.DoFPSensor`): analysers, fixed pattern,
   exposure, shot/read/dark noise, ADC → the raw uint16 mosaic.

Steps 1–5 run, by default (``PolarimeterSpec.fast``), on a coarse grid of points (every
``smooth_stride_px``-th pixel) that is bilinearly upsampled, with the exact chain at every pixel
near Snell's window edge, the sun, narrow features of the scattered light and the frame border
(``Polarimeter._render_fast``): ~15× faster, S0 within 1 % and AoP within 0.2° of the exact chain
(``docs/polarimeter.md``). ``fast=False`` renders every pixel exactly.

The reading has channels ``raw`` (uint16 mosaic) and ``exposure_us``. Truth layers (the true
sensor-plane Stokes in photons/s, the sun's pixel, Snell's window mask, the occlusion mask) are
kept in :attr:`Polarimeter.truth` — the truth channel, for the recorder and tests; onboard code
never sees them.

Limits: one wavelength stands for the passband; no lens vignetting or relative illumination; the
occlusion grid is coarse (edges of occluders are ±stride/2 pixels); waves refract the sky light
only (the sun beam below the surface assumes a flat sea, see ``water.py``).
"""

from __future__ import annotations

import dataclasses
import math
from types import MappingProxyType
from typing import Any, ClassVar

import cv2
import dm_env
import numpy as np
from numpy.typing import NDArray

from sensors.base import Sensor, SensorSpec, WorldView
from sensors.polarimeter import stokes as stokes_mod
from sensors.polarimeter import tank as tank_mod

# The configuration and truth records live in spec.py; re-exported here, where users import them.
from sensors.polarimeter.fast_path import FastPath, _Frame
from sensors.polarimeter.fast_plan import FastPlan
from sensors.polarimeter.occlusion import occlusion_mask
from sensors.polarimeter.optics import caustics as caustics_mod
from sensors.polarimeter.optics import surface as surface_mod
from sensors.polarimeter.optics import transmission as transmission_mod
from sensors.polarimeter.optics import water as water_mod
from sensors.polarimeter.optics import waves as waves_mod
from sensors.polarimeter.optics.sky import sky_radiance
from sensors.polarimeter.optics.sun import (
    NIGHT_ELEVATION_RAD,
    SunPosition,
    SunTracker,
    place_cell,
)
from sensors.polarimeter.points import PointScatterers
from sensors.polarimeter.spec import OpticsConfig, PolarimeterSpec, PolarimeterTruth
from sensors.polarimeter.unit import bench as bench_mod
from sensors.polarimeter.unit import camera as camera_mod
from sensors.polarimeter.unit import lens as lens_mod
from sensors.polarimeter.unit import mosaic as mosaic_mod
from sensors.polarimeter.unit import port as port_mod
from sensors.polarimeter.unit.calibration import calibration_from_spec
from sensors.polarimeter.unit.hardware import HardwareErrors, HardwareUnit
from sensors.registry import register
from twin.core.arrays import FloatArray
from twin.core.calibration import CameraCalibration


def _hemisphere(n: int) -> NDArray[np.float64]:
    """N near-uniform directions on the upper hemisphere (Fibonacci), for irradiance quadrature."""
    i = np.arange(n) + 0.5
    z = 1.0 - i / n
    r = np.sqrt(1.0 - z * z)
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


_HEMI = _hemisphere(2048)


@register
class Polarimeter(FastPath, PointScatterers, Sensor):
    """The upward-looking fisheye DoFP polarization camera at the ``polarimeter`` site.

    Call :meth:`configure` with the world's :class:`OpticsConfig` before the first frame (the
    world builder does; the default is a clear sky over Jerlov II water).
    """

    kind: ClassVar[str] = "polarimeter"
    spec_type: ClassVar[type[SensorSpec]] = PolarimeterSpec
    default_site: ClassVar[str] = "polarimeter"
    PRESETS: ClassVar[MappingProxyType[str, SensorSpec]] = MappingProxyType(
        {
            # LIG paper (hu2024 §4): LUCID PHX050S-P + Fujinon FE185C057HA-1, 700 µs, 10 Hz.
            "phx050s_p": PolarimeterSpec(camera="phx050s_fe185", sensor="phx050s_p"),
            # The same camera binned 4×4 (612×512): for long runs and Monte Carlo campaigns.
            "phx050s_p_bin4": PolarimeterSpec(
                camera="phx050s_fe185", sensor="phx050s_p", binning=4
            ),
            # Snell-window paper (xin2024 §4.1): PHX050S-P + FE185C046HA-1 (f = 1.4 mm), auto
            # exposure within its stated 500-2500 µs; binned 4x4 for campaigns.
            "phx050s_p_fe185c046_bin4": PolarimeterSpec(
                camera="phx050s_fe185c046", sensor="phx050s_p_xin2024", binning=4
            ),
            # ROI-A paper (fang2024 Table 2): IMX264MZR board camera, 185° lens, auto exposure,
            # PMMA shell (a flat port is not stated; a dome is assumed) [uncertain].
            "imx264mzr": PolarimeterSpec(camera="imx264_185", sensor="imx264mzr"),
            # An ideal, noise-free camera with the LIG geometry (auto exposure, 16-bit).
            "ideal": PolarimeterSpec(camera="phx050s_fe185", sensor="ideal"),
            "ideal_bin4": PolarimeterSpec(camera="phx050s_fe185", sensor="ideal", binning=4),
            # The MOI paper's hypothetical in-air pinhole imager (liang2020 §3), noise-free.
            "moi_pinhole": PolarimeterSpec(camera="moi_pinhole", sensor="ideal", occlusion=False),
        }
    )

    def __init__(self, spec: SensorSpec, *, name: str | None = None, site: str | None = None):
        super().__init__(spec, name=name, site=site)
        assert isinstance(self.spec, PolarimeterSpec)
        self.pspec: PolarimeterSpec = self.spec
        self.camera = camera_mod.Camera(self.pspec.camera_spec())
        self.optics = OpticsConfig()
        self._column: water_mod.WaterColumn | None = None
        self._tracker: SunTracker | None = None
        self._tracker_place: tuple[int, int] | None = None
        self._dofp: mosaic_mod.DoFPSensor | None = None
        self._waves: waves_mod.WaveSurface | None = None
        self._bubble_rng: np.random.Generator | None = None
        self._particle_rng: np.random.Generator | None = None
        # This frame's caustic field and the camera's (East, North), for the bubbles it lights.
        self._caustics: tuple[caustics_mod.CausticField, tuple[float, float]] | None = None
        self._last_t: float | None = None
        self.truth: PolarimeterTruth | None = None
        self._calibration: CameraCalibration | None = None
        # The unit's error budget (world side: sensors/polarimeter/unit/hardware.py) and its draw.
        # Ideal by default, so offline studies see the exact camera unless they ask otherwise;
        # scenarios configure their [hardware] budget (twin/world/assembly.py).
        self.hardware = HardwareErrors.ideal()
        self.unit: HardwareUnit | None = None
        # A tank around the camera for offline frames (configure_tank); None = open sea.
        self.tank: tank_mod.Tank | None = None
        self._plans: dict[tuple[float, int], FastPlan] = {}
        self._omega_out: tuple[float, NDArray[np.float64]] | None = None
        self._configure_derived()

    # ---- configuration -------------------------------------------------------------------------
    def configure(self, optics: OpticsConfig) -> None:
        """Set the world's optics (sky, water, surface)."""
        if not isinstance(optics, OpticsConfig):
            raise TypeError(f"configure needs an OpticsConfig, got {type(optics).__name__}")
        self.optics = optics
        self._configure_derived()

    def _configure_derived(self) -> None:
        o = self.optics
        self.n_water = o.water_index
        self._column = water_mod.WaterColumn(
            o.water(),
            self.n_water,
            o.sky,
            o.wind_speed_mps,
        )
        # Radiance → photons/s per pixel: the camera equation at the binned pixel pitch.
        pitch = self.camera.spec.pixel_pitch_um * self.camera.spec.binning
        self._photon_scale = float(
            mosaic_mod.photon_rate_per_pixel(
                self.pspec.passband_nm,
                f_number=self.pspec.f_number,
                pixel_pitch_um=pitch,
                wavelength_nm=o.wavelength_nm,
                lens_transmission=self.pspec.lens_transmission,
            )
        )
        # Sky used for irradiance quadrature: no disc (the disc is added analytically).
        self._sky_no_disc = dataclasses.replace(o.sky, sun_relative_radiance=0.0)
        sa = self.camera.pixel_solid_angle_sr.astype(np.float64)
        # ~1-pixel PSF on the sky side: in-water angles are magnified by ≈ n through the surface.
        self._psf_sigma = (0.6 * np.sqrt(np.maximum(sa, 0.0)) * self.n_water).astype(np.float32)
        self._psf_sigma_air = (0.6 * np.sqrt(np.maximum(sa, 0.0))).astype(np.float32)

    def configure_hardware(self, errors: HardwareErrors) -> None:
        """Set the unit's error budget; :meth:`reset` or :meth:`draw_unit` draws the unit."""
        if not isinstance(errors, HardwareErrors):
            raise TypeError(f"configure_hardware needs HardwareErrors, got {type(errors).__name__}")
        self.hardware = errors
        self.unit = None
        self._dofp = None  # the lens is folded into the sensor: rebuilt at the next frame/reset

    def configure_tank(self, tank: tank_mod.Tank | None) -> None:
        """Put the camera of offline frames in a tank (None: the open sea).

        In a run the MuJoCo scene's own geometry occludes instead.
        """
        if tank is not None and not isinstance(tank, tank_mod.Tank):
            raise TypeError(f"configure_tank needs a Tank or None, got {type(tank).__name__}")
        self.tank = tank

    def draw_unit(self, rng: np.random.Generator) -> HardwareUnit:
        """Draw this run's unit (calibration, boresight, clock offset) from ``rng``.

        The unit's sensor (fixed pattern) is drawn from ``rng`` too when there is none yet. With a
        benched lens, the unit's lens is then measured on the simulated bench and the table is
        added to the onboard calibration.
        """
        cal_rng, bench_rng, sensor_rng = rng.spawn(3)
        unit = self.hardware.draw(self.true_calibration(), self.camera.spec.binning, cal_rng)
        if self._dofp is None:
            # The unit's sensor (its fixed pattern) is part of the unit: from the unit's stream,
            # so that a study's frames draw the same noise whatever else the budget holds.
            self._dofp = self._new_sensor(sensor_rng)
        if self.hardware.benched:
            table = bench_mod.measure_lens(
                self._dofp, self.true_calibration(), unit.calibration, bench_rng
            )
            cal = dataclasses.replace(unit.calibration, lens_table=table)
            unit = dataclasses.replace(unit, calibration=cal)
        self.unit = unit
        return unit

    def true_calibration(self) -> CameraCalibration:
        """The exact calibration of the world's camera (truth; built once)."""
        if self._calibration is None:
            self._calibration = calibration_from_spec(self.camera.spec, self.pspec.sensor_spec())
        return self._calibration

    def calibration(self) -> CameraCalibration:
        """The onboard camera calibration: what the vehicle knows of this camera.

        The exact one when nothing is drawn per run (``HardwareErrors.drawn``); otherwise the
        drawn unit's: its calibration error and its bench-measured lens table.

        Raises:
            RuntimeError: The budget is not ideal and no unit has been drawn yet.
        """
        if not self.hardware.drawn:
            return self.true_calibration()
        if self.unit is None:
            raise RuntimeError(
                "Polarimeter.calibration: this unit's calibration error is drawn per run; call "
                "reset(), draw_unit(rng) or render_offline() first"
            )
        return self.unit.calibration

    def _new_sensor(self, rng: np.random.Generator) -> mosaic_mod.DoFPSensor:
        """The DoFP sensor with its fixed pattern from ``rng``, behind this camera's lens."""
        lens = None if self.hardware.lens.is_ideal else self._fold_lens
        return mosaic_mod.DoFPSensor(self.pspec.sensor_spec(), self.camera.shape, rng, optics=lens)

    def lens_transfer(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """(T̄, D, δ, radial angle) of the lens at every pixel (``unit.lens``)."""
        cam = self.camera
        h, w = cam.shape
        cu, cv = self.true_calibration().principal_point_px
        v, u = np.mgrid[0:h, 0:w].astype(np.float32)
        # The transfer depends on θ alone and is smooth: tabulate it on 4097 angles and
        # interpolate (a full frame's complex Fresnel algebra would take ~1 GB).
        theta = cam.theta
        grid = np.linspace(0.0, max(float(theta.max()), 1e-6), 4097)
        tabs = self.hardware.lens.transfer(grid, self.optics.wavelength_nm)
        t, d, delta = (np.interp(theta, grid, x).astype(np.float32) for x in tabs)
        return t, d, delta, np.arctan2(v - np.float32(cv), u - np.float32(cu))

    def _fold_lens(self, analysis: FloatArray) -> FloatArray:
        return lens_mod.fold_radial(analysis, *self.lens_transfer())

    @property
    def clock_offset_s(self) -> float:
        """Offset of this unit's time stamps from the IMU clock (s), read by the sensor suite."""
        return 0.0 if self.unit is None else self.unit.clock_offset_s

    def _true_attitude(self, c_cn: NDArray[np.float64]) -> NDArray[np.float64]:
        """C_c^n of the true camera from the nominal mount's (the unit's boresight)."""
        return c_cn if self.unit is None else c_cn @ self.unit.boresight

    # ---- Sensor API ----------------------------------------------------------------------------
    def channel_specs(self) -> dict[str, dm_env.specs.Array]:
        h, w = self.camera.shape
        s = self.pspec.sensor_spec()
        # Bounded where the sensor bounds them: the ADC clips at saturation, the exposure is
        # clamped to the camera's range.
        return {
            "raw": dm_env.specs.BoundedArray(
                (h, w), np.uint16, 0, s.saturation_dn, name=f"{self.name}/raw"
            ),
            "exposure_us": dm_env.specs.BoundedArray(
                (),
                np.float64,
                s.min_exposure_us,
                s.max_exposure_us,
                name=f"{self.name}/exposure_us",
            ),
        }

    def reset(self, world: WorldView, rng: np.random.Generator) -> None:
        """Draw the sensor's fixed pattern and the sea surface from this sensor's stream."""
        # The third stream (the unit's errors) is used only by a non-ideal budget, so an ideal
        # unit's fixed pattern and sea are what they were before the budget existed.
        # The fourth (bubbles) and fifth (marine snow) leave the first three as they were:
        # SeedSequence children are numbered, so spawning more does not change the others.
        seeds = rng.spawn(5)
        self._dofp = self._new_sensor(seeds[0])
        sea = self._sea()
        self._waves = None if sea.flat else waves_mod.WaveSurface(sea, seeds[1])
        self.unit = self.draw_unit(seeds[2]) if self.hardware.drawn else None
        self._bubble_rng = seeds[3]
        self._particle_rng = seeds[4]
        self._last_t = None
        self.truth = None

    def _sun_for(self, world: WorldView) -> SunPosition:
        lat = math.degrees(world.latitude_rad)
        lon = ((math.degrees(world.longitude_rad) + 180.0) % 360.0) - 180.0
        # One tracker per 1° cell (optics.sun.place_cell); within it the geometric direction is
        # turned to the camera's own place and refracted there (SunTracker's lat/lon arguments).
        cell = place_cell(lat, lon)
        if self._tracker is None or self._tracker_place != cell:
            self._tracker = SunTracker(float(cell[0]), float(cell[1]))
            self._tracker_place = cell
        return self._tracker(world.utc, lat, lon)

    def sample(self, world: WorldView, rng: np.random.Generator) -> dict[str, np.ndarray]:
        if self._dofp is None:
            self.reset(world, rng)
        assert self._dofp is not None
        pos, c_cn = world.site_pose(self.site)
        c_cn = self._true_attitude(np.asarray(c_cn, dtype=np.float64))
        depth = float(world.surface_z_m - pos[2])
        sun = self._sun_for(world)
        if self._waves is not None and self._last_t is not None:
            self._waves.step(max(world.t - self._last_t, 0.0))
        self._last_t = world.t
        raw, self.truth = self._expose(world, pos, c_cn, depth, sun, rng, world.t)
        return {"raw": raw, "exposure_us": np.asarray(self.truth.exposure_us)}

    def render_offline(
        self,
        c_cn: NDArray[np.float64],
        depth_m: float,
        sun: Any,
        rng: np.random.Generator,
        *,
        t: float = 0.0,
    ) -> tuple[NDArray[np.uint16], PolarimeterTruth]:
        """One raw frame for a camera attitude, depth and sun, without a MuJoCo world.

        For studies with known truth (compass accuracy tables, benchmarks, tests): no occlusion,
        the sensor's fixed pattern and the unit of a non-ideal hardware budget
        (:meth:`draw_unit`) drawn from ``rng`` on first use (then kept), temporal noise from
        ``rng``. A wavy sea (``OpticsConfig.wind_speed_mps`` > 0) is drawn from ``rng`` on
        first use too and evolves with ``t``: frames at increasing ``t`` see the same
        time-correlated waves a run would (the camera at the surface's origin); a ``t`` earlier
        than the last frame's does not rewind it (the frame sees the sea as it is).

        Args:
            c_cn: C_c^n, camera → ENU (3×3 rotation), of the nominal mount: a drawn unit's
                boresight turns it to the true camera's.
            depth_m: Camera depth (≤ 0: in air).
            sun: A :class:`~sensors.polarimeter.optics.sun.SunPosition` or an ENU unit vector.
            rng: Generator.
            t: Time stamp for the truth record.

        Returns:
            (raw uint16 mosaic, :class:`PolarimeterTruth`).
        """
        c = np.asarray(c_cn, dtype=np.float64)
        if c.shape != (3, 3) or not np.allclose(c @ c.T, np.eye(3), atol=1e-6):
            raise ValueError("c_cn: must be a 3x3 rotation matrix (camera -> ENU)")
        if not math.isfinite(depth_m):
            raise ValueError(f"depth_m: {depth_m!r}; allowed: a finite depth in m")
        if not math.isfinite(t):
            raise ValueError(f"t: {t!r}; allowed: a finite time in s")
        if self.tank is not None:
            self.tank.check_depth(float(depth_m))
        if self._dofp is None:
            self._dofp = self._new_sensor(rng)
        if self.unit is None and self.hardware.drawn:
            self.draw_unit(rng.spawn(1)[0])
        c = self._true_attitude(c)
        self._offline_waves(float(t), rng)
        if self._bubble_rng is None and self._bubbles() is not None:
            self._bubble_rng = rng.spawn(1)[0]  # after the others: theirs stay as they were
        if self._particle_rng is None and self._particles() is not None:
            self._particle_rng = rng.spawn(1)[0]  # likewise
        sun_enu = np.asarray(getattr(sun, "direction_enu", sun), dtype=np.float64).reshape(3)
        if not (np.all(np.isfinite(sun_enu)) and abs(np.linalg.norm(sun_enu) - 1) < 1e-6):
            raise ValueError("sun: must be a SunPosition or a unit ENU vector")
        return self._expose(None, np.zeros(3), c, float(depth_m), sun, rng, t)

    def _offline_waves(self, t: float, rng: np.random.Generator) -> None:
        """render_offline's sea: drawn on first use (a wavy sea only), stepped to ``t``."""
        if self._waves is not None and self._waves.sea != self._sea():
            self._waves = None  # reconfigured: another sea
        if self._waves is None:
            if self.optics.wind_speed_mps <= 0.0:
                return
            self._waves = waves_mod.WaveSurface(self._sea(), rng.spawn(1)[0])
            self._last_t = t
        if self._last_t is not None and t > self._last_t:
            self._waves.step(t - self._last_t)
        self._last_t = t

    def _sea(self) -> waves_mod.WindSea:
        o = self.optics
        return waves_mod.WindSea(
            wind_speed_mps=o.wind_speed_mps, wind_dir_rad=math.radians(90.0 - o.wind_toward_deg)
        )

    def _expose(
        self,
        world: WorldView | None,
        pos: NDArray[np.float64],
        c_cn: NDArray[np.float64],
        depth_m: float,
        sun: Any,
        rng: np.random.Generator,
        t: float,
    ) -> tuple[NDArray[np.uint16], PolarimeterTruth]:
        """Render, expose and read out one frame; its truth layers."""
        assert self._dofp is not None
        stokes, window, occluded, sun_look = self.render_stokes(world, pos, c_cn, depth_m, sun)
        n_bubbles = self._add_points(stokes, occluded, c_cn, depth_m, sun, "bubbles")
        n_particles = self._add_points(stokes, occluded, c_cn, depth_m, sun, "particles")
        exposure = self._dofp.exposure_for(stokes)
        raw = self._dofp.render_mosaic(stokes, exposure, rng)
        sun_px = None
        if sun_look is not None:
            # In the lens's own space: through a flat port the in-water direction bends.
            n_out = self.n_water if depth_m > 0 else 1.0
            u, v, ok = self.camera.project_outside(c_cn.T @ sun_look, n_out)
            sun_px = (float(u), float(v)) if bool(ok) else None
        sun_enu = np.asarray(getattr(sun, "direction_enu", sun), dtype=np.float64).reshape(3)
        night = bool(getattr(sun, "is_night", sun_enu[2] < math.sin(NIGHT_ELEVATION_RAD)))
        truth = PolarimeterTruth(
            t,
            stokes,
            window,
            occluded,
            sun_px,
            sun_enu,
            depth_m,
            night,
            float(exposure),
            bubbles=n_bubbles,
            particles=n_particles,
        )
        return raw, truth

    # ---- the physics chain ---------------------------------------------------------------------
    def render_stokes(
        self,
        world: WorldView | None,
        pos: NDArray[np.float64],
        c_cn: NDArray[np.float64],
        depth_m: float,
        sun: Any,
    ) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_], NDArray[np.float64] | None]:
        """Sensor-plane Stokes (photons/s per pixel) for a camera at ``pos`` with attitude C_c^n.

        Args:
            world: For occlusion (its MuJoCo model and data); None = no occlusion.
            pos: Camera position (ENU, m).
            c_cn: C_c^n, camera → ENU.
            depth_m: Camera depth below the surface (≤ 0: in air).
            sun: A :class:`~sensors.polarimeter.optics.sun.SunPosition` (or ENU vector).

        Returns:
            (stokes (H, W, 3) float32, Snell-window mask, occlusion mask, ENU look direction of
            the sun as the camera sees it (refracted under water) or None at night).
        """
        cam = self.camera
        sun_enu = np.asarray(getattr(sun, "direction_enu", sun), dtype=np.float64).reshape(3)
        o = self.optics
        in_water = depth_m > 0.0
        n_out = self.n_water if in_water else 1.0
        port = cam.outside(n_out)
        rays = port.directions  # (H, W, 3) outside the housing, camera frame
        valid = port.valid
        occluded = self._occlusion(world, pos, c_cn, rays, depth_m)
        wall_m = None
        if self.tank is not None and world is None and in_water:
            # Offline in a tank (sensors/polarimeter/tank.py): walls and floor occlude the sky.
            blocked, wall_m = self.tank.paths(rays.reshape(-1, 3) @ c_cn.T, depth_m, self.n_water)
            wall_m = wall_m.reshape(cam.shape)
            occluded = occluded | blocked.reshape(cam.shape)
        fc = self._frame_constants(sun, sun_enu, depth_m)
        plan = self._fast_plan(port) if (in_water and self._waves is None) or not in_water else None
        if plan is not None:
            st, window = self._render_fast(plan, c_cn, fc, valid, occluded)
            self._truncate_paths(st, wall_m)
            return st, window, occluded, fc.sun_look
        if not in_water:
            sky = sky_radiance(rays, sun, o.sky, rotation=c_cn, psf_sigma_rad=self._psf_sigma_air)
            st = np.array(sky.stokes, dtype=np.float32)
            up = (rays.reshape(-1, 3) @ c_cn[2].astype(rays.dtype)).reshape(cam.shape)
            window = valid & (up > 0) & ~occluded
            st *= window[..., None]
        else:
            normals = None
            if self._waves is not None:
                normals = self._waves.normals_for_rays(rays, pos[:2], depth_m, rotation=c_cn)
            trans = transmission_mod.surface_transmission(
                rays, self.n_water, rotation=c_cn, normals=normals
            )
            sky_dirs = trans.sky_directions()
            sky = sky_radiance(sky_dirs, sun, o.sky, rotation=c_cn, psf_sigma_rad=self._psf_sigma)
            window_st = trans.apply(sky.stokes)
            window = trans.sees_sky & valid & ~occluded
            if occluded.any():
                window_st = np.where(occluded[..., None], 0.0, window_st).astype(window_st.dtype)
            assert self._column is not None and fc.state is not None
            st = np.asarray(self._column.render(rays, fc.state, window_st, rotation=c_cn))
            self._caustics = None
            if self._waves is not None and o.flicker == "caustics" and fc.state.e_sun_normal > 0:
                st = self._flicker(st, rays, c_cn, pos, depth_m, sun_enu, fc.state)
        st = self._to_sensor(st, c_cn, port)
        st *= valid[..., None]
        self._finish(st)
        self._truncate_paths(st, wall_m)
        return st, window, occluded, fc.sun_look

    def _flicker(
        self,
        st: FloatArray,
        rays: FloatArray,
        c_cn: NDArray[np.float64],
        pos: NDArray[np.float64],
        depth_m: float,
        sun_enu: NDArray[np.float64],
        state: water_mod.ColumnState,
    ) -> FloatArray:
        """The single-scattered sun light scaled by each ray's caustic factor.

        :mod:`sensors.polarimeter.optics.caustics`: the factor is smooth across neighbouring rays (a
        caustic cell, ~ℓ = 0.3 m, spans degrees at the ranges that matter), so it is computed on
        every 4th pixel and resized. Keeps the frame's field for the bubbles it lights.
        """
        assert self._column is not None and self._waves is not None
        c = self._column.water.c_per_m
        cf = caustics_mod.CausticField(
            self._waves, sun_enu, self.n_water, depth_m + 4.0 / max(c, 1e-3)
        )
        self._caustics = (cf, (float(pos[0]), float(pos[1])))
        h, w = self.camera.shape
        coarse = rays[::4, ::4]
        look = coarse.reshape(-1, 3).astype(np.float64) @ c_cn.T
        f = cf.ray_factor(look, self._caustics[1], depth_m, state.sun_look, c)
        f = f.reshape(coarse.shape[:2]).astype(np.float32)
        factor = cv2.resize(f, (w, h), interpolation=cv2.INTER_LINEAR)
        ss = np.asarray(self._column.single_scattering(rays, state, rotation=c_cn))
        return st + (factor - np.float32(1.0))[..., None] * ss

    def _truncate_paths(self, st: FloatArray, wall_m: NDArray[np.float64] | None) -> None:
        """Scale the path radiance of rays that end on a tank's black wall, in place.

        A ray that ends after L m has 1 − e^(−cL) of the endless column's path radiance
        (``sensors.polarimeter.tank``).
        """
        if wall_m is None:
            return
        hit = np.isfinite(wall_m)
        if hit.any():
            assert self._column is not None
            c = self._column.water.c_per_m
            st[hit] *= (-np.expm1(-c * wall_m[hit])).astype(st.dtype)[:, None]

    def _finish(self, st: FloatArray) -> None:
        """Radiance → photons/s, in place; no NaN/inf, S0 ≥ 0."""
        st *= np.float32(self._photon_scale)
        bad = ~np.isfinite(st)  # (one pass; np.nan_to_num makes three)
        if bad.any():
            st[bad] = 0.0
        np.maximum(st[..., 0], 0.0, out=st[..., 0])

    def _frame_constants(self, sun: Any, sun_enu: NDArray[np.float64], depth_m: float) -> _Frame:
        """What one frame's pixels share: the water column's state and the sun's look direction."""
        if depth_m <= 0.0:
            return _Frame(sun, False, None, None if sun_enu[2] <= 0 else sun_enu)
        o = self.optics
        beam = surface_mod.refract_sun_beam(sun_enu, self.n_water)
        e_sun_air = o.sky.sun_disc_radiance * math.pi * o.sky.sun_radius_rad**2
        e_sky_air = self._sky_irradiance(sun)
        assert self._column is not None
        state = self._column.state(
            depth_m,
            beam.look_dir,
            beam.irradiance_factor,
            beam.dop,
            e_sun_air,
            e_sky_air,
            night=bool(getattr(sun, "is_night", sun_enu[2] < math.sin(NIGHT_ELEVATION_RAD))),
        )
        return _Frame(sun, True, state, beam.look_dir if beam.transmitted else None)

    # ---- the fast path: smooth light on a coarse grid, the exact chain where it is not smooth ----
    def _sky_irradiance(self, sun: Any) -> float:
        """Diffuse horizontal irradiance of the sky (no disc), by quadrature over the hemisphere."""
        sky = sky_radiance(_HEMI, sun, self._sky_no_disc)
        return float(np.mean(sky.stokes[..., 0] * _HEMI[:, 2]) * 2.0 * math.pi)

    def _to_sensor(
        self, st: FloatArray, c_cn: NDArray[np.float64], port: port_mod.PortRays
    ) -> FloatArray:
        """ENU-meridian Stokes of the light along −ray (outside) → sensor-plane Stokes."""
        cam = self.camera
        if port.housing == "dome":
            out = cam.sensor_stokes_from_meridian(st.astype(cam.dtype, copy=False), c_cn)
            return np.ascontiguousarray(out, dtype=np.float32)
        # Flat port: meridian (ENU) → the port's plane of incidence (camera meridional plane),
        # Fresnel twice in that basis, then the lens ray shares the plane (p-axis → p-axis).
        w = port.directions.astype(np.float64)
        d_out = -w
        ref_enu = camera_mod._meridian_reference_in_camera(w, c_cn)
        z = np.array([0.0, 0.0, 1.0])
        p_out = stokes_mod.meridian_reference(d_out, up=z)
        s = stokes_mod.rotate_reference(st.astype(np.float64), d_out, ref_enu, p_out)
        m00, m01, m22 = port_mod.interface_chain_elements(port.interfaces())
        i, q, u = s[..., 0].copy(), s[..., 1].copy(), s[..., 2].copy()
        s[..., 0] = m00 * i + m01 * q
        s[..., 1] = m01 * i + m00 * q
        s[..., 2] = m22 * u
        lens = cam.rays.astype(np.float64)
        p_in = stokes_mod.meridian_reference(-lens, up=z)
        out = cam.to_sensor_stokes(s, p_in)
        return np.ascontiguousarray(out, dtype=np.float32)

    def _occlusion(
        self,
        world: WorldView | None,
        pos: NDArray[np.float64],
        c_cn: NDArray[np.float64],
        rays: FloatArray,
        depth_m: float,
    ) -> NDArray[np.bool_]:
        """Pixels blocked from the sky (:func:`sensors.polarimeter.occlusion.occlusion_mask`)."""
        return occlusion_mask(world, self.pspec, self.camera.shape, pos, c_cn, rays, depth_m)

    def describe(self) -> dict[str, Any]:
        d = super().describe()
        d["optics"] = dataclasses.asdict(self.optics)
        d["image_shape"] = list(self.camera.shape)
        return d
