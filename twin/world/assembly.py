"""The world of a scenario: plant, current and sensors, assembled from the scenario's settings.

World side only: nothing here knows the vehicle computer. :mod:`twin.sim.build` adds the
onboard side (filters, guidance, autopilot) and steps both. The scenario loader calls
:func:`check_sensors` so that ``auv-twin validate`` builds every sensor exactly as a run does.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import sensors
from scenarios.schema import ExtraSensor, Hardware, Scenario
from sensors.polarimeter.optics.sky import SkySpec
from sensors.polarimeter.optics.water_body import WaterBody
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.unit.hardware import (
    CalibrationUncertainty,
    HardwareErrors,
    LensTolerance,
    MountingError,
)
from sensors.polarimeter.unit.lens import LensPolarization
from sensors.suite import SensorSuite
from twin.core.frames import heading_deg_to_yaw
from twin.world.current import Current, CurrentProfilePoint
from twin.world.gravity_area import check_gravity, gravity_field, launch_on_map
from twin.world.plant import Plant, PlantConfig


def build_current(scenario: Scenario, rng: np.random.Generator) -> Current:
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


def build_plant(scenario: Scenario, current: Current) -> Plant:
    """The plant of ``scenario``, reset to its initial state."""
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
    return plant


def make_sensor(
    kind: str,
    preset: str | None,
    overrides: tuple[tuple[str, Any], ...],
    *,
    name: str | None = None,
    site: str | None = None,
    field: str | None = None,
) -> sensors.Sensor:
    """Create a scenario's sensor; any error names the scenario field (``field``, or the slot's)."""
    try:
        return sensors.create(
            kind,
            preset,
            name=name,
            site=site,
            **{k: (tuple(v) if isinstance(v, list) else v) for k, v in overrides},
        )
    except KeyError as exc:  # an unknown kind or preset (KeyError quotes its message: unwrap)
        where = field or f"sensors.{kind}"
        raise ValueError(f"{where}: {exc.args[0] if exc.args else exc}") from exc
    except (ValueError, TypeError) as exc:  # an unknown or impossible override field
        where = field or (f"sensors.{kind}_overrides" if overrides else f"sensors.{kind}")
        raise ValueError(f"{where}: {exc}") from exc


def extra_sensor(e: ExtraSensor) -> sensors.Sensor:
    """One of the scenario's ``[sensors.extra.<name>]`` sensors."""
    return make_sensor(
        e.kind, e.preset, e.overrides, name=e.name, site=e.site, field=f"sensors.extra.{e.name}"
    )


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
        water_body=None
        if w.iops is None
        else WaterBody(w.iops.kd_per_m, w.iops.a_per_m, w.iops.b_per_m, w.iops.source),
        turbidity=o.turbidity,
        particle_dop_max=w.particle_peak_polarization,
        depolarization_ratio=w.depolarization_ratio,
        salinity_psu=w.salinity_psu,
        temperature_c=w.temperature_c,
        wavelength_nm=o.wavelength_nm,
        wind_speed_mps=o.wind_speed_mps,
        wind_toward_deg=o.wind_toward_deg,
        # Breaking waves need fetch: the tank scene's sea has none, so no bubbles there (the
        # offline tank trials get the same from Polarimeter.configure_tank).
        bubbles="ideal" if scenario.scene == "tank" else o.bubbles,
        flicker=o.flicker,
        # Nor marine snow in the tank's water.
        particles="ideal" if scenario.scene == "tank" else o.particles,
    )


def polarimeter_sensor(scenario: Scenario, preset: str | None = None) -> sensors.Sensor:
    """The scenario's polarimeter (or one from ``preset``), configured with its optics."""
    s = scenario.sensors
    name = preset or s.polarimeter
    if name is None:
        raise ValueError("sensors.polarimeter: the scenario has no polarimeter")
    cam = make_sensor("polarimeter", name, s.polarimeter_overrides if preset is None else ())
    try:
        cam.configure(optics_config(scenario))
    except (KeyError, ValueError, TypeError) as exc:
        raise ValueError(f"optics: {exc}") from exc
    try:
        cam.configure_hardware(hardware_errors(scenario.hardware))  # type: ignore[attr-defined]
    except ValueError as exc:
        raise ValueError(f"hardware: {exc}") from exc
    return cam


def hardware_errors(h: Hardware) -> HardwareErrors:
    """The polarimeter unit's error budget from the scenario's [hardware] table."""
    cal = (
        CalibrationUncertainty.ideal()
        if h.calibration == "ideal"
        else CalibrationUncertainty(
            focal_sigma_rel=h.focal_sigma_rel,
            principal_point_sigma_px=h.principal_point_sigma_px,
            polarizer_sigma_deg=h.polarizer_sigma_deg,
        )
    )
    mount = (
        MountingError.ideal()
        if h.mounting == "ideal"
        else MountingError(
            boresight_sigma_deg=h.boresight_sigma_deg,
            clock_offset_sigma_ms=h.clock_offset_sigma_ms,
        )
    )
    lens = LensPolarization.ideal() if h.lens == "ideal" else LensPolarization()
    tolerance = (
        LensTolerance(0.0, 0.0)
        if h.calibration == "ideal"
        else LensTolerance(
            focal_tolerance_rel=h.focal_tolerance_rel, decentre_sigma_um=h.decentre_sigma_um
        )
    )
    return HardwareErrors(
        cal,
        mount,
        lens,
        lens_compensation=h.lens_compensation,
        tolerance=tolerance,
        distortion_correction=h.distortion_correction,
    )


def scenario_sensors(scenario: Scenario) -> list[sensors.Sensor]:
    """The scenario's sensors, in the order that fixes each one's random stream.

    Append new sensors, never insert: :class:`sensors.suite.SensorSuite` spawns one stream per
    sensor in this order.
    """
    s = scenario.sensors
    out = [
        make_sensor("imu", s.imu, s.imu_overrides),
        make_sensor("depth", s.depth, s.depth_overrides),
    ]
    if s.polarimeter is not None:
        out.append(polarimeter_sensor(scenario))
    if s.gravimeter is not None:
        out.append(gravimeter_sensor(scenario))
    # After the built-in ones, in the file's order: adding one leaves the others' streams alone.
    out += [extra_sensor(e) for e in s.extra]
    return out


def gravimeter_sensor(scenario: Scenario) -> sensors.Sensor:
    """The scenario's gravimeter, reading the world's anomaly field (``gravity_area``)."""
    s = scenario.sensors
    assert s.gravimeter is not None
    meter = make_sensor("gravimeter", s.gravimeter, s.gravimeter_overrides)
    field = gravity_field(scenario)
    if field is None:
        raise ValueError(
            f"sensors.gravimeter: {s.gravimeter!r} needs a [gravity] map (the scenario has none)"
        )
    meter.configure_field(field, launch_on_map(scenario.gravity, field.extent_m))  # type: ignore[attr-defined]
    return meter


def check_sensors(scenario: Scenario) -> list[str]:
    """Every problem building the scenario's sensors would raise, as ``field: message`` lines.

    Builds each sensor as :func:`scenario_sensors` does (so ``validate`` and ``run`` agree by
    construction), one at a time so that all problems are reported, plus the rules that need a
    built sensor: the compass cannot process frames faster than the camera takes them.
    """
    s = scenario.sensors
    problems: list[str] = []
    built: dict[str, sensors.Sensor] = {}
    for kind, build in (
        ("imu", lambda: make_sensor("imu", s.imu, s.imu_overrides)),
        ("depth", lambda: make_sensor("depth", s.depth, s.depth_overrides)),
        *((("polarimeter", lambda: polarimeter_sensor(scenario)),) if s.polarimeter else ()),
        *(
            (
                (
                    "gravimeter",
                    lambda: make_sensor("gravimeter", s.gravimeter, s.gravimeter_overrides),
                ),
            )
            if s.gravimeter
            else ()
        ),
    ):
        try:
            built[kind] = build()
        except ValueError as exc:
            problems.append(str(exc))
    extras = _extra_sensors(scenario, problems)
    # The suite samples on the physics clock: a sensor faster than the physics would silently
    # sample at the physics rate while its noise model assumed its own (a wrong number).
    physics_hz = 1.0 / PlantConfig().timestep_s
    fields = {
        kind: f"sensors.{kind}_overrides" if getattr(s, f"{kind}_overrides") else f"sensors.{kind}"
        for kind in built
    } | {name: f"sensors.extra.{name}" for name in extras}
    for kind, sensor in (built | extras).items():
        field = fields[kind]
        if sensor.rate_hz > physics_hz + 1e-9:
            problems.append(
                f"{field}: rate_hz = {sensor.rate_hz:g} is above the physics rate; allowed "
                f"(0, {physics_hz:g}] Hz"
            )
        if sensor.delay_s >= scenario.duration_s:
            problems.append(
                f"{field}: delay_s = {sensor.delay_s:g} s: no reading would arrive before the run "
                f"ends; allowed [0, {scenario.duration_s:g}) s (duration_s)"
            )
    problems += check_gravity(scenario)
    nav = scenario.navigation
    cam = built.get("polarimeter")
    compass = [v for v in nav.variants if v != "ins"]
    if cam is not None and compass and nav.compass_rate_hz > cam.rate_hz + 1e-9:
        problems.append(
            f"navigation.compass_rate_hz: {nav.compass_rate_hz!r} is above the camera's frame "
            f"rate; allowed (0, {cam.rate_hz:g}] Hz (sensors.polarimeter {s.polarimeter!r}"
            f"{', with overrides' if s.polarimeter_overrides else ''})"
        )
    return problems


def _extra_sensors(scenario: Scenario, problems: list[str]) -> dict[str, sensors.Sensor]:
    """The scenario's extra sensors that build, each started on the vehicle as a run starts it.

    Its site, and whatever MJCF sensor its kind reads there, are tried on a plant, so that
    ``validate`` refuses what ``run`` would; each problem is appended to ``problems``.
    """
    built: dict[str, sensors.Sensor] = {}
    for e in scenario.sensors.extra:
        try:
            built[e.name] = extra_sensor(e)
        except ValueError as exc:
            problems.append(str(exc))
    if not built:
        return built
    plant = build_plant(scenario, Current("none"))
    sites = {plant.model.site(i).name for i in range(plant.model.nsite)}
    rng = np.random.default_rng(0)
    for e in scenario.sensors.extra:
        sensor = built.get(e.name)
        if sensor is None:
            continue
        if sensor.site not in sites:
            problems.append(
                f"sensors.extra.{e.name}: {'site' if e.site else 'default site'} "
                f"{sensor.site!r} is not on the vehicle; allowed: {sorted(sites)}"
            )
            continue
        try:
            sensor.reset(plant, rng)
            sensor.sample(plant, rng)
        except (KeyError, ValueError) as exc:
            msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
            problems.append(f"sensors.extra.{e.name}: {msg}")
    return built


def build_suite(scenario: Scenario, plant: Plant, seed: np.random.SeedSequence) -> SensorSuite:
    """The scenario's sensors on their schedule, reset on the plant."""
    suite = SensorSuite(scenario_sensors(scenario), seed=seed)
    suite.reset(plant)
    return suite
