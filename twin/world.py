"""Builds the world of a scenario: plant, current, sensors, guidance and autopilot.

Shared by the run loop (:mod:`twin.run`) and the dm_env environment (:mod:`twin.env`), so both
simulate exactly the same thing for the same scenario and seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import sensors
from scenarios.schema import Scenario
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.sky import SkySpec
from sensors.suite import SensorSuite
from twin.autopilot import Autopilot
from twin.current import Current, CurrentProfilePoint
from twin.earth import principal_radii
from twin.frames import heading_deg_to_yaw, quat_to_dcm
from twin.guidance import Guidance
from twin.messages import Reading
from twin.navsources import EstimateNav, NavSource, TruthNav
from twin.onboard.eskf import EskfConfig, ImuGrade
from twin.onboard.ins import InsConfig, rotvec_to_dcm
from twin.onboard.ins import NavState as InsNavState
from twin.onboard.navigator import CompassEvent, Navigator, NavigatorConfig, VehicleKnowledge
from twin.plant import Plant, PlantConfig

# Order of the root seed's children. Append new consumers at the end: existing streams then stay
# the same when a new stochastic component is added.
SEED_SENSORS, SEED_CURRENT, SEED_NAV = 0, 1, 2
_N_SEED_CHILDREN = 3


@dataclass
class World:
    """Everything a run steps, built from one scenario and one seed."""

    scenario: Scenario
    seed: int
    plant: Plant
    suite: SensorSuite
    guidance: Guidance
    autopilot: Autopilot
    nav: NavSource
    navigators: dict[str, Navigator] = field(default_factory=dict)

    def deliver(self, readings: list[Reading]) -> list[tuple[str, CompassEvent]]:
        """Hand sensor readings (in delivery order) to every onboard filter variant.

        Returns the frames the variants' compass methods processed, as (variant, event).
        """
        events = []
        for name, nav in self.navigators.items():
            for r in readings:
                event = nav.on_reading(r)
                if event is not None:
                    events.append((name, event))
        return events

    @property
    def physics_dt(self) -> float:
        return float(self.plant.model.opt.timestep)

    def fly(self, until_s: float) -> None:
        """Fly the mission (guidance, autopilot, physics, sensors) up to sim time ``until_s``.

        Nothing is recorded: this is for getting somewhere (``auv-twin render``), not for
        recording (``twin.run``). The sensors are sampled only when onboard filters run (their
        estimates need the readings; the autopilot may steer on one).
        """
        sc = self.scenario
        dt = self.physics_dt
        every = max(1, round(1.0 / (sc.autopilot.rate_hz * dt)))
        cmd = None
        k = 0
        while self.plant.t < until_s - 0.5 * dt:
            if cmd is None or k % every == 0:
                nav = self.nav.nav_state()
                sp, _ = self.guidance.update(nav, self.plant.t)
                cmd = self.autopilot.update(nav, sp, every * dt)
            self.plant.step(cmd)
            if self.navigators:
                self.deliver(self.suite.poll(self.plant))
            k += 1


def _current(scenario: Scenario, rng: np.random.Generator) -> Current:
    c = scenario.current
    return Current(
        c.kind,
        speed_mps=c.speed_mps,
        toward_deg=c.toward_deg,
        profile=tuple(CurrentProfilePoint(p.depth_m, p.speed_mps, p.toward_deg) for p in c.profile),
        sigma_mps=c.sigma_mps,
        tau_s=c.tau_s,
        rng=rng,
    )


def _sensor(kind: str, preset: str, overrides: tuple[tuple[str, object], ...]) -> sensors.Sensor:
    """Create a scenario's sensor; any error names the scenario field."""
    try:
        return sensors.create(
            kind, preset, **{k: (tuple(v) if isinstance(v, list) else v) for k, v in overrides}
        )
    except (KeyError, ValueError, TypeError) as exc:
        raise ValueError(f"sensors.{kind}: {exc}") from exc


def optics_config(scenario: Scenario) -> OpticsConfig:
    """The polarimeter's OpticsConfig from the scenario's [optics] and [water] tables."""
    o, w = scenario.optics, scenario.water
    sky = SkySpec(
        cie_type=o.cie_sky_type,
        polarization=o.sky_polarization,
        dop_max=o.dop_max,
        berry_delta_rad=math.radians(o.berry_delta_deg),
        zenith_radiance=o.zenith_radiance_w_m2_sr_nm,
        wavelength_nm=o.wavelength_nm,
    )
    return OpticsConfig(
        sky=sky,
        jerlov_type=w.jerlov_type,
        turbidity=o.turbidity,
        salinity_psu=w.salinity_psu,
        temperature_c=w.temperature_c,
        wavelength_nm=o.wavelength_nm,
        wind_speed_mps=o.wind_speed_mps,
        wind_toward_deg=o.wind_toward_deg,
    )


def polarimeter_sensor(scenario: Scenario, preset: str | None = None) -> sensors.Sensor:
    """The scenario's polarimeter (or one from ``preset``), configured with its optics."""
    s = scenario.sensors
    name = preset or s.polarimeter
    if name is None:
        raise ValueError("sensors.polarimeter: the scenario has no polarimeter")
    cam = _sensor("polarimeter", name, s.polarimeter_overrides if preset is None else ())
    cam.configure(optics_config(scenario))
    return cam


def build_world(scenario: Scenario, seed: int | None = None) -> World:
    """Build and reset the world of ``scenario`` (seed defaults to the scenario's)."""
    seed = scenario.seed if seed is None else seed
    children = np.random.SeedSequence(seed).spawn(_N_SEED_CHILDREN)
    current = _current(scenario, np.random.default_rng(children[SEED_CURRENT]))
    plant = Plant(
        PlantConfig(
            scene=scenario.scene,
            latitude_deg=scenario.place.latitude_deg,
            longitude_deg=scenario.place.longitude_deg,
            start_utc=scenario.start_utc,
            water_density_kg_m3=scenario.water.density_kg_m3,
            seabed_depth_m=scenario.water.seabed_depth_m,
        ),
        current,
    )
    ini = scenario.initial
    plant.reset(
        position_n=(ini.position_m[0], ini.position_m[1], plant.surface_z_m - ini.depth_m),
        rpy_rad=(
            math.radians(ini.roll_deg),
            math.radians(ini.pitch_deg),
            heading_deg_to_yaw(ini.heading_deg),
        ),
        forward_speed_mps=ini.speed_mps,
    )
    s = scenario.sensors
    # Sensor order fixes each one's random stream (SensorSuite): append, never insert.
    suite_sensors = [
        _sensor("imu", s.imu, s.imu_overrides),
        _sensor("depth", s.depth, s.depth_overrides),
    ]
    if s.polarimeter is not None:
        suite_sensors.append(polarimeter_sensor(scenario))
    suite = SensorSuite(suite_sensors, seed=children[SEED_SENSORS])
    suite.reset(plant)
    navigators = _navigators(scenario, plant, suite, children[SEED_NAV])
    # Wheel-over radius: about 3/4 of the 26 m full-rudder turning radius of the REMUS model, so
    # the autopilot keeps some rudder in reserve through the turn.
    guidance = Guidance(
        scenario.mission, (ini.position_m[0], ini.position_m[1]), turn_radius_m=20.0
    )
    autopilot = Autopilot(
        plant.hydro.rps_for_speed,
        max_rps=plant.params.prop_max_rpm / 60.0,
        max_fin_rad=plant.params.fin_max_rad,
    )
    nav: NavSource = TruthNav(plant)
    if scenario.autopilot.attitude_source == "estimate":
        steer = scenario.navigation.steering_variant
        assert steer is not None  # the loader refuses "estimate" without variants
        nav = EstimateNav(navigators[steer])
    return World(scenario, seed, plant, suite, guidance, autopilot, nav, navigators)


def _imu_grade(spec: Any) -> ImuGrade:
    """The vehicle's declared IMU grade: its datasheet (the spec), SI, worst axis."""

    def worst(v: Any) -> float:
        return float(np.max(np.abs(np.asarray(v, dtype=np.float64))))

    return ImuGrade(
        gyro_noise_density=worst(spec.gyro_noise_density),
        gyro_bias_instability=spec.gyro_bias_instability,
        gyro_bias_corr_time_s=spec.gyro_bias_corr_time_s,
        gyro_turn_on_bias=spec.gyro_turn_on_bias,
        gyro_scale_factor=spec.gyro_scale_factor,
        gyro_misalignment=spec.gyro_misalignment,
        accel_noise_density=worst(spec.accel_noise_density),
        accel_bias_instability=spec.accel_bias_instability,
        accel_bias_corr_time_s=spec.accel_bias_corr_time_s,
        accel_turn_on_bias=spec.accel_turn_on_bias,
        accel_scale_factor=spec.accel_scale_factor,
        accel_misalignment=spec.accel_misalignment,
    )


def _navigators(
    scenario: Scenario, plant: Plant, suite: SensorSuite, seed: np.random.SeedSequence
) -> dict[str, Navigator]:
    """The onboard filter variants, started from one shared (perturbed) launch alignment.

    Every variant starts from the same initial solution — truth perturbed by one draw from the
    filter's P0 when ``navigation.initial_error`` — so that their comparison is paired.
    """
    nav = scenario.navigation
    if not nav.variants:
        return {}
    imu = suite["imu"].spec
    # The world's gravity does not change with depth (sensors/imu.py): the vehicle's INS is
    # given the same model, so that the twin has no gravity-model error of its own.
    ins = InsConfig(free_air_gravity=False)
    eskf = (
        EskfConfig(gate_probability=nav.gate_probability, ins=ins)
        if nav.tuning == "paper"
        else EskfConfig.for_imu(_imu_grade(imu), gate_probability=nav.gate_probability, ins=ins)
    )
    cfg = NavigatorConfig(
        compass_rate_hz=nav.compass_rate_hz,
        gravity_aiding=nav.gravity_aiding,
        depth_aiding=nav.depth_aiding,
        sun_azimuth_only=nav.sun_measurement == "azimuth",
        eskf=eskf,
    )
    tr = plant.truth()
    c_init = quat_to_dcm(tr.quat_wxyz)  # C_b^n, perturbed below
    vel, lat, lon = tr.velocity_n, tr.latitude_rad, tr.longitude_rad
    h = -tr.depth_m
    if nav.initial_error:
        rng = np.random.default_rng(seed)
        e = cfg.eskf
        phi = rng.normal(0.0, e.p0_attitude_rad)
        vel = vel + rng.normal(0.0, e.p0_velocity_mps)
        d_en_u = rng.normal(0.0, e.p0_position_m)
        r_m, r_n = principal_radii(lat)
        lat = lat + d_en_u[1] / r_m
        lon = lon + d_en_u[0] / (r_n * math.cos(lat))
        h = h + d_en_u[2]
        # The filter's convention: C_est = exp(−[φ×]) C_true (twin.onboard.eskf).
        c_init = rotvec_to_dcm(*(-phi)) @ c_init
    init = InsNavState(0.0, lat, lon, h, np.asarray(vel, float), c_init)
    cam = next((x for x in suite.sensors if x.kind == "polarimeter"), None)
    knowledge = VehicleKnowledge(
        start_utc=scenario.start_utc,
        latitude_deg=scenario.place.latitude_deg,
        longitude_deg=scenario.place.longitude_deg,
        water_index=optics_config(scenario).water_index,
        calibration=cam.calibration() if cam is not None else None,  # type: ignore[attr-defined]
        camera=cam.name if cam is not None else "polarimeter",
    )
    return {v: Navigator(v, knowledge, init, cfg) for v in nav.variants}
