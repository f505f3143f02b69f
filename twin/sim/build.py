"""The vehicle's build: one scenario and one seed → a :class:`~twin.sim.step.Simulation`.

:func:`build_simulation` assembles the world (:mod:`twin.world.assembly`: plant, current,
sensors) and the vehicle computer (onboard filter variants, guidance, autopilot); the build checks
(:func:`check_navigation`) are what ``validate`` shares with ``run``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import numpy as np

from scenarios.schema import Navigation, Scenario
from sensors.suite import SensorSuite
from twin.core.earth import principal_radii
from twin.core.frames import quat_to_dcm
from twin.core.mission import PlannedMission
from twin.onboard import compass
from twin.onboard.aids import create_aid
from twin.onboard.alignment import AlignmentError, gyrocompass_sigma
from twin.onboard.control.autopilot import Autopilot, NavSource, PropellerMap
from twin.onboard.control.guidance import Guidance
from twin.onboard.control.navsource import EstimateNav
from twin.onboard.eskf import EskfConfig, ImuGrade
from twin.onboard.gravity.matching import StoredMap
from twin.onboard.gravity.pcrb import GainsModel
from twin.onboard.gravity.planner import PlannedPath, plan
from twin.onboard.ins import InsConfig, rotvec_to_dcm
from twin.onboard.ins import NavState as InsNavState
from twin.onboard.navigator import Navigator, NavigatorConfig, VehicleKnowledge
from twin.sim.navsources import TruthNav
from twin.sim.step import Simulation
from twin.world.assembly import (
    build_current,
    build_plant,
    build_suite,
    extra_sensor,
    make_sensor,
    optics_config,
)
from twin.world.gravity_area import gravity_field, launch_on_map, stored_map
from twin.world.hydrodynamics import Hydrodynamics
from twin.world.plant import Plant
from twin.world.vehicle import VehicleParams

# Order of the root seed's children. Append new consumers at the end: existing streams then stay
# the same when a new stochastic component is added.
SEED_SENSORS, SEED_CURRENT, SEED_NAV, SEED_MAP = 0, 1, 2, 3
_N_SEED_CHILDREN = 4


def propeller_map(sim_plant: Plant) -> PropellerMap:
    """The vehicle's declared speed–rpm curve (its datasheet / acceptance-trial table).

    Tabulated once from the *declared* vehicle parameters in a fresh hydrodynamic model, not from
    the plant's own object: the autopilot knows the curve the vehicle was sold with.
    """
    p = sim_plant.params
    return _propeller_map(p, sim_plant.config.water_density_kg_m3, sim_plant.gravity_mps2)


@functools.lru_cache(maxsize=32)
def _propeller_map(p: VehicleParams, density: float, gravity: float) -> PropellerMap:
    # 401 steady-speed root solves, ~1.1 s: cached per process, so a campaign worker pays it once
    # per vehicle and water, not once per run (the map is immutable; the inputs frozen).
    declared = Hydrodynamics(p, density, gravity)
    top = declared.steady_speed_mps(p.prop_max_rpm / 60.0)
    speeds = np.linspace(0.0, top, 401)
    return PropellerMap(
        tuple(float(s) for s in speeds),
        tuple(declared.rps_for_speed(float(s)) if s > 0 else 0.0 for s in speeds),
    )


def build_simulation(scenario: Scenario, seed: int | None = None) -> Simulation:
    """Build and reset the simulation of ``scenario`` (seed defaults to the scenario's)."""
    seed = scenario.seed if seed is None else seed
    children = np.random.SeedSequence(seed).spawn(_N_SEED_CHILDREN)
    current = build_current(scenario, np.random.default_rng(children[SEED_CURRENT]))
    plant = build_plant(scenario, current)
    suite = build_suite(scenario, plant, children[SEED_SENSORS])
    stored = _stored_map(scenario, suite, children[SEED_MAP])
    navigators = _navigators(scenario, plant, suite, children[SEED_NAV], stored)
    ini = scenario.initial
    mission = scenario.mission
    route = None
    lookahead = 8.0  # Guidance's default: a few vehicle lengths
    if isinstance(mission, PlannedMission):
        assert stored is not None  # the loader refuses a planned mission without a map
        route = plan_route(mission, stored, (ini.position_m[0], ini.position_m[1]), navigators)
        lookahead = mission.lookahead_m or float(min(stored.grid.spacing_m))
        mission = mission.legs_along(route.nodes_m - np.asarray(stored.launch_m))
    # Wheel-over radius: a little over the REMUS model's full-rudder turning radius at cruise
    # (17.9 m at 1.5 m/s, tests/test_plant.py), so the turn is flyable with rudder in reserve.
    guidance = Guidance(
        mission, (ini.position_m[0], ini.position_m[1]), lookahead_m=lookahead, turn_radius_m=20.0
    )
    autopilot = Autopilot(
        propeller_map(plant),
        max_rps=plant.params.prop_max_rpm / 60.0,
        max_fin_rad=plant.params.fin_max_rad,
        speed_feedback=scenario.autopilot.speed_control == "feedback",
    )
    nav: NavSource = TruthNav(plant)
    if scenario.autopilot.attitude_source == "estimate":
        steer = scenario.navigation.steering_variant
        assert steer is not None  # the loader refuses "estimate" without variants
        nav = EstimateNav(navigators[steer])
    sim = Simulation(scenario, seed, plant, suite, guidance, autopilot, nav, navigators)
    sim.stored_map, sim.route = stored, route
    return sim


def check_navigation(scenario: Scenario) -> list[str]:
    """What building the filters would refuse, as ``field: message`` lines (``validate`` = ``run``).

    An IMU that cannot find north at the scenario's latitude cannot gyrocompass.
    """
    nav = scenario.navigation
    problems = _method_problems(nav) + _aid_problems(scenario)
    if not nav.variants or nav.alignment != "gyrocompass" or nav.tuning == "paper":
        return problems
    s = scenario.sensors
    try:
        spec = make_sensor("imu", s.imu, s.imu_overrides).spec
    except ValueError:
        return problems  # check_sensors reports the IMU itself
    try:
        gyrocompass_sigma(_imu_grade(spec), math.radians(scenario.place.latitude_deg))
    except AlignmentError as exc:
        problems.append(f'navigation.alignment: "gyrocompass" with sensors.imu {s.imu!r}: {exc}')
    return problems


def _method_problems(nav: Navigation) -> list[str]:
    """Each configured compass method built as a run builds it; what that would raise."""
    problems = []
    for name, params in nav.methods:
        try:
            compass.create(name, **dict(params))
        except (ValueError, TypeError) as exc:
            problems.append(f"navigation.methods.{name}: {exc}")
    return problems


def _aid_problems(scenario: Scenario) -> list[str]:
    """What a run would raise for each navigation aid: built, and fed the channels it reads.

    Each aid is built with its parameters as a run builds it, and its sensor must give every
    channel in the aid's ``channels``.
    """
    problems = []
    extras = {e.name: e for e in scenario.sensors.extra}
    for sensor, name, params in scenario.navigation.aids:
        try:
            aid = create_aid(name, **dict(params))
        except (ValueError, TypeError) as exc:
            problems.append(f"navigation.aids.{sensor}: {exc}")
            continue
        if sensor not in extras:
            continue  # the loader reports an aid without its sensor
        try:
            given = extra_sensor(extras[sensor]).channel_specs()
        except ValueError:
            continue  # check_sensors reports the sensor itself
        missing = [c for c in aid.channels if c not in given]
        if missing:
            problems.append(
                f"navigation.aids.{sensor}: aid {name!r} reads {missing}, which sensor "
                f"{sensor!r} (kind {extras[sensor].kind!r}) does not give; it gives {sorted(given)}"
            )
    return problems


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


def _stored_map(
    scenario: Scenario, suite: SensorSuite, seed: np.random.SeedSequence
) -> StoredMap | None:
    """The anomaly map the vehicle carries (drawn per run from ``seed``), or None.

    A vehicle with a gravimeter and gravity matching switched on carries one, and so does one
    with a planned mission (it plans on it). It is told the map's σ_m and the gravimeter's
    datasheet noise (its declared knowledge).
    """
    g = scenario.gravity
    meter = next((x for x in suite.sensors if x.kind == "gravimeter"), None)
    planned = isinstance(scenario.mission, PlannedMission)
    if not planned and (meter is None or not g.matching):
        return None
    field = gravity_field(scenario)
    assert field is not None  # the loader refuses a gravimeter without a map
    grid = stored_map(scenario, field, np.random.default_rng(seed))
    return StoredMap(
        grid,
        launch_on_map(g, field.extent_m),
        sigma_map_mgal=g.map_error_mgal,
        sigma_gravimeter_mgal=float(meter.spec.noise_mgal) if meter is not None else 0.0,  # type: ignore[attr-defined]
    )


def plan_route(
    mission: PlannedMission,
    stored: StoredMap,
    start_en: tuple[float, float],
    navigators: dict[str, Navigator],
) -> PlannedPath:
    """The vehicle's route at launch: PCRB-A* on its own stored map (wang2023 §3).

    The bound's model is the vehicle's: its speed, its filter's initial position variance (the
    paper's 1 km² without a filter), the mission's Q_t and the stored map's R (eq. 3).
    """
    p0 = 1.0e6
    if navigators:
        nav = next(iter(navigators.values()))
        p0 = float(max(nav.config.eskf.p0_position_m)) ** 2
    model = GainsModel(
        speed_mps=mission.speed_mps,
        p0_m2=max(p0, 1e-6),
        q_rate_m2_per_s=mission.q_rate_m2_per_s,
        sigma_mgal=math.sqrt(stored.variance_mgal2),
    )
    e0, n0 = stored.launch_m
    start = (e0 + start_en[0], n0 + start_en[1])
    goal = (e0 + mission.goal_m[0], n0 + mission.goal_m[1])
    return plan(stored.grid, start, goal, model)


def navigator_config(scenario: Scenario, imu_spec: Any) -> NavigatorConfig:
    """The filter variants' configuration: the scenario's ``[navigation]`` and the IMU's grade.

    Shared by the simulation and ``auv-twin replay`` (a log replayed under the same scenario
    runs the same filters).
    """
    nav = scenario.navigation
    # The world's gravity does not change with depth (sensors/imu.py): the vehicle's INS is
    # given the same model, so that the twin has no gravity-model error of its own.
    ins = InsConfig(free_air_gravity=False)
    grade = _imu_grade(imu_spec)
    eskf = (
        EskfConfig(gate_probability=nav.gate_probability, ins=ins)
        if nav.tuning == "paper"
        else EskfConfig.for_imu(
            grade,
            gate_probability=nav.gate_probability,
            ins=ins,
            datasheet_only=nav.tuning == "datasheet",
        )
    )
    if nav.alignment == "gyrocompass":
        # The loader refused an IMU that cannot gyrocompass here (check_navigation).
        tilt, heading = gyrocompass_sigma(grade, math.radians(scenario.place.latitude_deg))
        eskf = dataclasses.replace(eskf, p0_attitude_rad=(tilt, tilt, heading))
    return NavigatorConfig(
        map_aiding=scenario.gravity.matching,
        compass_rate_hz=nav.compass_rate_hz,
        gravity_aiding=nav.gravity_aiding,
        depth_aiding=nav.depth_aiding,
        sun_azimuth_only=nav.sun_measurement == "azimuth",
        eskf=eskf,
    )


def _navigators(
    scenario: Scenario,
    plant: Plant,
    suite: SensorSuite,
    seed: np.random.SeedSequence,
    stored: StoredMap | None = None,
) -> dict[str, Navigator]:
    """The onboard filter variants, started from one shared (perturbed) launch alignment.

    Every variant starts from the same initial solution — truth perturbed by one draw from the
    filter's P0 when ``navigation.initial_error`` — so that their comparison is paired.
    """
    nav = scenario.navigation
    if not nav.variants:
        return {}
    cfg = navigator_config(scenario, suite["imu"].spec)
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
        gravity_map=stored,
    )
    # Each variant its own aids (an aid may keep state), on the same readings.
    return {
        v: Navigator(
            v,
            knowledge,
            init,
            cfg,
            method_params=nav.method_params(v),
            aids={s: create_aid(a, **dict(p)) for s, a, p in nav.aids},
        )
        for v in nav.variants
    }
