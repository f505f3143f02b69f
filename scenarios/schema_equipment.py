"""A scenario's tables of the vehicle's equipment and computer.

Sensors, the camera unit's hardware budget, navigation, the autopilot and the recording: part of
the scenario schema (:mod:`scenarios.schema` re-exports every name here), frozen dataclasses
whose fields are each declared once (:func:`twin.core.fields.declared`), read by
:mod:`scenarios.equipment` and :mod:`scenarios.mission` (the autopilot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, TypeAlias

from scenarios import ranges as R
from twin.core.extensions import COMPASS_METHODS, INS_ONLY, SENSORS
from twin.core.fields import Range, declared
from twin.core.options import LENS_MODELS

OverrideValue: TypeAlias = int | float | tuple[int | float, ...]
AttitudeSource: TypeAlias = Literal["truth", "estimate"]
ATTITUDE_SOURCES: tuple[str, ...] = ("truth", "estimate")
SPEED_CONTROLS: tuple[str, ...] = ("feedback", "propeller")


# ---- vehicle computer and recording -----------------------------------------------------------


#: The names of the scenario's own sensors (its fields above ``extra``): an extra sensor takes
#: another.
SENSOR_SLOTS: tuple[str, ...] = ("imu", "depth", "polarimeter", "gravimeter")


@dataclass(frozen=True, slots=True)
class ExtraSensor:
    """One more sensor on the vehicle (``[sensors.extra.<name>]``).

    Attributes:
        name: Its name in the run (readings, recording): a Python identifier, not a slot's.
        kind: A sensor kind (``twin.core.extensions.SENSORS``: built in or installed).
        preset: A preset of the kind's class, or None for its spec's defaults.
        site: The MJCF site it is mounted at, or None for the class's default.
        overrides: The spec's fields changed, ``(field, value)`` sorted by field.
    """

    name: str
    kind: str = declared(choices=SENSORS.names)
    preset: str | None = None
    site: str | None = None
    overrides: tuple[tuple[str, OverrideValue], ...] = ()


@dataclass(frozen=True, slots=True)
class Sensors:
    """Sensor presets and spec-field overrides.

    Overrides are ``(field, value)`` pairs sorted by field, so the dataclass stays hashable; pass
    them on as ``registry.create("imu", s.imu, **dict(s.imu_overrides))``. The preset and field
    names are checked by the consumer against ``sensors.registry``.

    Attributes:
        imu: The IMU's preset (``sensors.imu``).
        depth: The depth gauge's preset (``sensors.depth``).
        imu_overrides: The IMU spec's fields changed from the preset.
        depth_overrides: The depth gauge spec's fields changed from the preset.
        polarimeter: The skylight polarization camera's preset, or none for a trial without one.
        polarimeter_overrides: The camera spec's fields changed from the preset.
        gravimeter: The marine gravimeter's preset, or none (it needs a ``[gravity]`` map).
        gravimeter_overrides: The gravimeter spec's fields changed from the preset.
        extra: More sensors by name (``[sensors.extra.<name>]``): each a ``kind`` (a built-in
            sensor kind or an installed package's), an optional ``preset`` and ``site`` (an MJCF
            site of the vehicle) and its spec's fields; sampled and recorded after the built-in
            ones, in the file's order (each with its own random stream).
    """

    imu: str = declared("lig2024")
    depth: str = declared("ms5837_30ba")
    imu_overrides: tuple[tuple[str, OverrideValue], ...] = ()
    depth_overrides: tuple[tuple[str, OverrideValue], ...] = ()
    # The skylight polarization camera: a preset name, or None for a trial without one (it is
    # the expensive sensor; trials about the vehicle alone run faster without it).
    polarimeter: str | None = None
    polarimeter_overrides: tuple[tuple[str, OverrideValue], ...] = ()
    # The marine gravimeter (sensors.gravimeter): a preset name, or None. It needs a
    # [gravity] map.
    gravimeter: str | None = None
    gravimeter_overrides: tuple[tuple[str, OverrideValue], ...] = ()
    extra: tuple[ExtraSensor, ...] = ()


CALIBRATION_MODELS: tuple[str, ...] = ("checkerboard", "ideal")
MOUNTING_MODELS: tuple[str, ...] = ("bracket", "ideal")


@dataclass(frozen=True, slots=True)
class Hardware:
    """The polarimeter unit's error budget (``sensors.polarimeter.unit.hardware``), drawn per run.

    Each model is ``"ideal"`` or its real form, whose σ default to the sourced values of
    ``sensors.polarimeter.unit.hardware`` (tests/sensors/polarimeter/test_hardware.py keeps the two
    in step). A σ may be set only for a model that is not ideal.

    Attributes:
        calibration: ``"checkerboard"``: the onboard calibration is off the true camera by the
            σ below; ``"ideal"``: the vehicle knows its camera exactly.
        focal_sigma_rel: Relative 1σ of the onboard focal length.
        principal_point_sigma_px: 1σ of each principal-point coordinate (full-resolution px).
        polarizer_sigma_deg: 1σ of a common turn of the analyser layout (deg).
        distortion_correction: The vehicle's camera geometry comes from the unit's calibration
            session (xin2024 §2.4); False: from the lens's datasheet, an ideal equidistant
            projection off the unit's true lens by the two tolerances below.
        focal_tolerance_rel: 1σ of the datasheet focal length against the unit's (ISO 517).
        decentre_sigma_um: 1σ of the optical axis off the sensor's centre, each axis (µm).
        mounting: ``"bracket"``: the camera is turned from the IMU by an unknown boresight and
            stamps its frames off the IMU's clock; ``"ideal"``: neither.
        boresight_sigma_deg: 1σ of each boresight rotation component (deg).
        clock_offset_sigma_ms: 1σ of the camera's clock offset (ms).
        lens: ``"fresnel"``: the lens's own diattenuation and retardance, growing with field
            angle (``sensors.polarimeter.unit.lens``); ``"ideal"``: a polarization-neutral lens.
        lens_compensation: The unit's lens is measured on the simulated bench of xin2024 §2.3
            and the vehicle undoes what it found (``twin.onboard.lens``); False: uncompensated.
    """

    # The σ bounds: far beyond any real unit, short of values that break the geometry (a focal
    # length off by 20 %, a camera turned by 10°).
    calibration: str = declared("checkerboard", choices=CALIBRATION_MODELS)
    focal_sigma_rel: float = declared(0.003, Range(0.0, 0.2))
    principal_point_sigma_px: float = declared(2.0, Range(0.0, 200.0))
    polarizer_sigma_deg: float = declared(0.21, Range(0.0, 10.0))
    distortion_correction: bool = declared(True)
    focal_tolerance_rel: float = declared(0.05 / math.sqrt(3.0), Range(0.0, 0.2))
    decentre_sigma_um: float = declared(18.0, Range(0.0, 1000.0))
    mounting: str = declared("bracket", choices=MOUNTING_MODELS)
    boresight_sigma_deg: float = declared(0.19, Range(0.0, 10.0))
    clock_offset_sigma_ms: float = declared(5.0, Range(0.0, 1000.0))
    lens: str = declared("fresnel", choices=LENS_MODELS)
    lens_compensation: bool = declared(True)

    @classmethod
    def ideal(cls) -> Hardware:
        return cls(calibration="ideal", mounting="ideal", lens="ideal")


def nav_variants() -> tuple[str, ...]:
    """Navigation filter variants: :data:`INS_ONLY`, then every compass method.

    A compass method's solar vector also aids the filter (POL/INS, LIG/INS, ...). The names are
    the registry's (:data:`twin.core.extensions.COMPASS_METHODS`: the project's methods and
    installed plug-ins); ``<method>_paper`` is the method as its paper writes it, ``<method>``
    the twin's refinement (docs/compass_methods.md lists the departures and their effects).
    """
    return (INS_ONLY, *COMPASS_METHODS.names())


NAV_TUNINGS: tuple[str, ...] = ("imu", "datasheet", "paper")
NAV_ALIGNMENTS: tuple[str, ...] = ("paper", "gyrocompass")
SUN_MEASUREMENTS: tuple[str, ...] = ("vector", "azimuth")


@dataclass(frozen=True, slots=True)
class Navigation:
    """The onboard navigation filters run inside the loop, side by side on one sensor stream.

    Attributes:
        variants: Filter variants (:func:`nav_variants`); empty = no onboard navigation.
        steer_on: The variant the autopilot follows when ``autopilot.attitude_source`` is
            ``"estimate"``; None = the first compass variant (else the first variant).
        compass_rate_hz: How often the compass methods process a polarimeter frame (≤ the
            camera's rate; frames in between are not processed).
        gravity_aiding: Gravity-vector updates when quasi-static (LIG paper eqs. 18–19).
        depth_aiding: Depth-gauge updates of the height.
        initial_error: Start the filters from truth perturbed by a draw from P0 (True), or
            from truth exactly (False).
        gate_probability: Chi-square probability of the innovation (NIS) gate; a measurement
            whose NIS exceeds that quantile is rejected and recorded. 1.0 turns gating off (every
            measurement is fused, as the LIG paper's filter does).
        sun_measurement: ``"vector"``: the full solar vector aids all three attitude angles (the
            LIG paper's eqs. 20–24); ``"azimuth"``: only its azimuth (the heading), leaving roll
            and pitch to gravity — robust to the compass's elevation bias under water.
        tuning: ``"imu"``: P0 and Q from the declared IMU's datasheet (``EskfConfig.for_imu``),
            never below the LIG paper's values; ``"datasheet"``: from the datasheet alone, with
            the rate-proportional gyro errors following the measured turn rate (for a
            navigation-grade IMU, which the paper's floors would swamp); ``"paper"``: the LIG
            paper's §3.3 values as printed (overconfident for the paper's own IMU model:
            docs/navigation.md).
        alignment: The filters' initial attitude σ. ``"paper"``: the LIG paper's 0.5° per
            axis; ``"gyrocompass"``: what a 10-minute stationary fine alignment leaves with the
            declared IMU (tilt = accelerometer bias / g, heading = gyro error / horizontal Earth
            rate: ``twin.onboard.alignment``); refused for an IMU that cannot find north.
        methods: Each compass method's parameters, ``(name, ((field, value), ...))``: its
            config's fields (``[navigation.methods.<name>]`` in a scenario file), checked by
            building the method as a run does.
        aids: Sensors whose readings the filters fuse through a navigation aid, ``(sensor, aid,
            ((parameter, value), ...))`` (``[navigation.aids.<sensor>] aid = "<name>"`` and the
            aid's parameters; ``twin.onboard.aids``): an extra sensor's readings as filter
            updates, in every variant.
    """

    variants: tuple[str, ...] = ()
    steer_on: str | None = None
    compass_rate_hz: float = declared(1.0, R.CAMERA_RATE_HZ)
    gravity_aiding: bool = declared(True)
    depth_aiding: bool = declared(True)
    initial_error: bool = declared(True)
    gate_probability: float = declared(0.999, R.GATE_PROBABILITY)
    sun_measurement: str = declared("azimuth", choices=SUN_MEASUREMENTS)
    tuning: str = declared("imu", choices=NAV_TUNINGS)
    alignment: str = declared("paper", choices=NAV_ALIGNMENTS)
    methods: tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] = ()
    aids: tuple[tuple[str, str, tuple[tuple[str, Any], ...]], ...] = ()

    def method_params(self, name: str) -> dict[str, Any]:
        """The parameters given to compass method ``name`` (empty: its defaults)."""
        return dict(next((p for n, p in self.methods if n == name), ()))

    @property
    def steering_variant(self) -> str | None:
        if self.steer_on is not None:
            return self.steer_on
        compass = [v for v in self.variants if v != INS_ONLY]
        return compass[0] if compass else (self.variants[0] if self.variants else None)


@dataclass(frozen=True, slots=True)
class Autopilot:
    """The autopilot's loop rate and where it reads attitude from.

    ``"estimate"`` needs the navigation filter; until it exists the consumer may refuse it.
    ``speed_control``: ``"feedback"`` holds speed with the propeller map plus an integral on the
    navigation source's speed; ``"propeller"`` with the declared propeller map alone (open-loop
    revolutions, as a vehicle without a water-speed sensor runs: steering on the estimate, its
    speed would be the INS's ground speed, which carries the INS's velocity error).
    """

    rate_hz: float = declared(10.0, R.RATE_HZ)
    attitude_source: AttitudeSource = declared("truth", choices=ATTITUDE_SOURCES)
    speed_control: str = declared("feedback", choices=SPEED_CONTROLS)


@dataclass(frozen=True, slots=True)
class Recording:
    """What the run records. The chase camera is rendered only where a GL context exists."""

    truth_rate_hz: float = declared(10.0, R.RATE_HZ)
    camera: bool = declared(True)
    camera_rate_hz: float = declared(1.0, R.CAMERA_RATE_HZ)
    camera_width: int = declared(320, R.CAMERA_WIDTH)
    camera_height: int = declared(240, R.CAMERA_HEIGHT)
    # Polarimeter images (intensity, AoP, DoP) logged at most this often; frames are large.
    polarimeter_log_rate_hz: float = declared(1.0, R.CAMERA_RATE_HZ)


#: [hardware]: each model's σ keys (set only when the model is not ideal).
HARDWARE_SIGMAS: dict[str, tuple[str, ...]] = {
    "calibration": (
        "focal_sigma_rel",
        "principal_point_sigma_px",
        "polarizer_sigma_deg",
        "distortion_correction",
        "focal_tolerance_rel",
        "decentre_sigma_um",
    ),
    "mounting": ("boresight_sigma_deg", "clock_offset_sigma_ms"),
    "lens": ("lens_compensation",),
}
