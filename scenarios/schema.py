"""The sea-trial schema: frozen dataclasses that a validated scenario file becomes.

Every value keeps the name and unit it has in the TOML file (degrees, metres, seconds, compass
headings clockwise from North, positions as ``(East, North)``), so a reader can go from a file to a
field without a conversion table. Converting to radians and ENU yaw is the consumer's job (see
:mod:`twin.core.frames`), done once where the value is used.

The dataclasses do no validation of their own: :mod:`scenarios.loader` checks a file completely,
collecting every problem, before it builds them. Build scenarios in code through
:func:`scenarios.loader.parse_scenario` (a mapping in, a checked :class:`Scenario` out) rather than
by calling the constructors, which would accept anything.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Any, Literal, TypeAlias

from scenarios import ranges as R
from scenarios.ranges import TANK_FLOOR_DEPTH_M as TANK_FLOOR_DEPTH_M
from scenarios.ranges import TANK_LENGTH_M as TANK_LENGTH_M
from scenarios.ranges import TANK_MAX_DEPTH_M as TANK_MAX_DEPTH_M
from scenarios.ranges import TANK_WIDTH_M as TANK_WIDTH_M
from scenarios.schema_equipment import (  # noqa: F401  (re-exported: the schema's names)
    ATTITUDE_SOURCES,
    CALIBRATION_MODELS,
    HARDWARE_SIGMAS,
    MOUNTING_MODELS,
    NAV_ALIGNMENTS,
    NAV_TUNINGS,
    SENSOR_SLOTS,
    SPEED_CONTROLS,
    SUN_MEASUREMENTS,
    AttitudeSource,
    Autopilot,
    ExtraSensor,
    Hardware,
    Navigation,
    OverrideValue,
    Recording,
    Sensors,
    nav_variants,
)
from twin.core.extensions import WATER_BODIES
from twin.core.fields import declared
from twin.core.mission import (
    MISSION_KINDS,
    HeadingLeg,
    LawnmowerMission,
    Leg,
    LegsMission,
    Mission,
    MissionKind,
    PlannedMission,
    StationKeepingMission,
    Vec2,
    WaypointLeg,
)

# The mission plan is the shared contract between the scenario and the vehicle's guidance; it is
# defined in twin/core/mission.py and re-exported here, where scenario code looks for it.
# The allowed values their owners declare (the loader checks against them; re-exported).
from twin.core.options import BUBBLE_MODELS as BUBBLE_MODELS
from twin.core.options import FLICKER_MODELS as FLICKER_MODELS
from twin.core.options import JERLOV_TYPES as JERLOV_TYPES
from twin.core.options import LENS_MODELS as LENS_MODELS
from twin.core.options import PARTICLE_DOP_MAX, WATER_DEPOLARIZATION_RATIO
from twin.core.options import PARTICLE_MODELS as PARTICLE_MODELS

__mission_exports__ = (
    MISSION_KINDS,
    HeadingLeg,
    LawnmowerMission,
    Leg,
    LegsMission,
    MissionKind,
    PlannedMission,
    StationKeepingMission,
    WaypointLeg,
)

# ---- allowed values (the loader validates against these; consumers may use them too) ----------

SceneName: TypeAlias = Literal["open_sea", "tank"]
SCENES: tuple[str, ...] = ("open_sea", "tank")

JerlovType: TypeAlias = Literal["I", "IA", "IB", "II", "III", "1C", "3C", "5C", "7C", "9C"]
# The Literal for type checkers; the values: twin.core.options.JERLOV_TYPES (test_schema ties them).

CurrentKind: TypeAlias = Literal["none", "constant", "profile", "gauss_markov"]
CURRENT_KINDS: tuple[str, ...] = ("none", "constant", "profile", "gauss_markov")


def _enu_from_compass(speed_mps: float, toward_deg: float) -> Vec2:
    """(East, North) components of a speed moving toward a compass direction."""
    a = math.radians(toward_deg)
    return (speed_mps * math.sin(a), speed_mps * math.cos(a))


# ---- sections ----------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Place:
    """Where on Earth the trial is: fixes the sun's position with the start time."""

    latitude_deg: float = declared(allowed=R.LATITUDE_DEG)
    longitude_deg: float = declared(allowed=R.LONGITUDE_DEG)


@dataclass(frozen=True, slots=True)
class WaterIops:
    """A water's own inherent optical properties at 500 nm, given in the scenario.

    Attributes:
        a_per_m: Absorption coefficient a (m⁻¹), in (0, 100].
        b_per_m: Scattering coefficient b, the water molecules' share included (m⁻¹), in
            [0, 100]; the particles' share (b minus sea water's 0.0029) scatters with the project's
            Fournier–Forand phase function, P and δ.
        kd_per_m: Diffuse attenuation of downwelling irradiance K_d (m⁻¹), in (0, 100] and at
            least a (K_d ≈ (a + b_b)/μ̄_d with μ̄_d ≤ 1).
        source: Where a, b and K_d come from: a citation of the measurement, or "assumption: …".
    """

    a_per_m: float = declared(allowed=R.ATTENUATION_PER_M)
    b_per_m: float = declared(allowed=R.SCATTERING_PER_M)
    kd_per_m: float = declared(allowed=R.ATTENUATION_PER_M)
    source: str = declared()


@dataclass(frozen=True, slots=True)
class Water:
    """The water body.

    ``seabed_depth_m`` is None for bottomless open sea, and always in the tank, whose floor is part
    of the scene at :data:`TANK_FLOOR_DEPTH_M`. ``particle_peak_polarization`` (P, the particles'
    −m12/m11 near 90°; measured 0.6–0.9 over diverse natural waters) and
    ``depolarization_ratio`` (δ of the water molecules; 0.039 fresh, 0.0425–0.046 at S = 35) shape
    the scattering phase matrix; their defaults and sources:
    :mod:`sensors.polarimeter.optics.scattering`. ``jerlov_type`` names the water body: one of
    Jerlov's types or one an installed package adds (``twin.core.extensions.WATER_BODIES``);
    or ``iops`` (the ``[water.iops]`` table) gives the water's own a, b and K_d with their
    source, and then ``jerlov_type`` is ``"inline"`` (a light-field table for those values is
    computed on first use and cached).

    Attributes:
        density_kg_m3: Sea water's density (buoyancy and the depth gauge's pressure).
        temperature_c: Water temperature (the refractive index, Quan & Fry).
        salinity_psu: Practical salinity (the refractive index; δ depends on it too).
        jerlov_type: The water body's name: a Jerlov type or an installed package's water body;
            ``"inline"`` when ``[water.iops]`` gives the water's own properties (not both).
        iops: The water's own absorption, scattering and K_d at 500 nm with their source
            (``[water.iops]``), instead of a named water body.
        seabed_depth_m: Depth of a flat seabed (none: bottomless open sea).
        particle_peak_polarization: The particles' peak linear polarization P (−m12/m11 near
            90°; measured 0.6–0.9).
        depolarization_ratio: The water molecules' depolarization ratio δ (0.0425–0.046 at
            S = 35).
    """

    density_kg_m3: float = declared(1025.0, R.DENSITY_KG_M3)
    temperature_c: float = declared(15.0, R.TEMPERATURE_C)
    salinity_psu: float = declared(35.0, R.SALINITY_PSU)
    jerlov_type: JerlovType | str = declared("II", choices=WATER_BODIES.names)
    seabed_depth_m: float | None = declared(None, R.POSITIVE)
    particle_peak_polarization: float = declared(PARTICLE_DOP_MAX, R.UNIT_INTERVAL)
    depolarization_ratio: float = declared(WATER_DEPOLARIZATION_RATIO, R.DEPOLARIZATION_RATIO)
    iops: WaterIops | None = None


@dataclass(frozen=True, slots=True)
class ProfilePoint:
    """One point of a depth profile of the current."""

    depth_m: float = declared(allowed=R.NON_NEGATIVE)
    speed_mps: float = declared(allowed=R.CURRENT_SPEED_MPS)
    toward_deg: float = declared(allowed=R.COMPASS_DEG)


@dataclass(frozen=True, slots=True)
class Current:
    """The water current. Fields that the ``kind`` does not use keep their defaults.

    * ``none``: still water.
    * ``constant``: ``speed_mps`` toward ``toward_deg`` at every depth.
    * ``profile``: ``profile`` points, interpolated linearly in depth
      (see :meth:`mean_velocity_en`).
    * ``gauss_markov``: mean ``speed_mps`` toward ``toward_deg`` plus a first-order Gauss-Markov
      gust on each horizontal axis with standard deviation ``sigma_mps`` and correlation time
      ``tau_s``.

    ``toward_deg`` is the compass direction the water flows *toward* (oceanographic convention;
    the opposite of the meteorological "from").
    """

    kind: CurrentKind = declared("none", choices=CURRENT_KINDS)
    speed_mps: float = declared(0.0, R.CURRENT_SPEED_MPS)
    toward_deg: float = declared(0.0, R.COMPASS_DEG)
    profile: tuple[ProfilePoint, ...] = ()
    sigma_mps: float = declared(0.0, R.GUST_SIGMA_MPS)
    tau_s: float = declared(60.0, R.POSITIVE)

    def mean_velocity_en(self, depth_m: float) -> Vec2:
        """The mean (deterministic) current at a depth as (East, North) in m/s.

        A profile is interpolated linearly in depth on the velocity's East and North components
        (not on speed and direction, which would make a profile turning through North jump by
        360 degrees), and held constant above its first and below its last point.
        The Gauss-Markov gust is not included: its state belongs to the world's random stream.
        """
        if self.kind == "none":
            return (0.0, 0.0)
        if self.kind != "profile":
            return _enu_from_compass(self.speed_mps, self.toward_deg)
        pts = self.profile
        if depth_m <= pts[0].depth_m:
            return _enu_from_compass(pts[0].speed_mps, pts[0].toward_deg)
        for lo, hi in itertools.pairwise(pts):
            if depth_m <= hi.depth_m:
                w = (depth_m - lo.depth_m) / (hi.depth_m - lo.depth_m)
                e0, n0 = _enu_from_compass(lo.speed_mps, lo.toward_deg)
                e1, n1 = _enu_from_compass(hi.speed_mps, hi.toward_deg)
                return (e0 + w * (e1 - e0), n0 + w * (n1 - n0))
        return _enu_from_compass(pts[-1].speed_mps, pts[-1].toward_deg)


@dataclass(frozen=True, slots=True)
class Initial:
    """The vehicle's state at t = 0.

    Angles are degrees; heading is compass, clockwise from North; roll and pitch follow
    :mod:`twin.core.frames` (pitch nose up positive, roll starboard down positive).
    """

    position_m: Vec2 = declared((0.0, 0.0))
    depth_m: float = declared(0.0, R.NON_NEGATIVE)
    heading_deg: float = declared(0.0, R.COMPASS_DEG)
    roll_deg: float = declared(0.0, R.ROLL_DEG)
    pitch_deg: float = declared(0.0, R.PITCH_DEG)
    speed_mps: float = declared(0.0, R.VEHICLE_SPEED_MPS)


# ---- missions: the shared contract, twin/core/mission.py ---------------------------------


# sensors.polarimeter.optics.sky.POLARIZATIONS (a heavy import for the schema: tied by a test
# instead).
SKY_POLARIZATION_MODELS: tuple[str, ...] = ("rayleigh", "berry")


@dataclass(frozen=True, slots=True)
class Optics:
    """The sky and the sea surface as the polarimeter sees them (water itself: :class:`Water`).

    Attributes:
        cie_sky_type: CIE standard general sky type, 1 (overcast) ... 15; 12 = clear, low
            turbidity (ISO 15469).
        sky_polarization: "rayleigh" (single scattering) or "berry" (four neutral points).
        dop_max: Maximum degree of polarization of the sky.
        berry_delta_deg: Berry model: angular separation of the Babinet and Brewster points.
        zenith_radiance_w_m2_sr_nm: Absolute zenith sky radiance at ``wavelength_nm``.
        turbidity: Multiplier on the water type's particle scattering (1 = the Jerlov type).
        wind_speed_mps: Wind speed at 12.5 m for Cox–Munk surface slopes; 0 = flat surface. A
            scenario may give ``wind_beaufort`` (force 0–11) instead: the middle of WMO's range
            for that force (``scenarios.ranges.BEAUFORT_MPS``).
        wind_toward_deg: Compass direction the wind blows toward.
        wavelength_nm: The one wavelength the optics are evaluated at.
        bubbles: ``"hall_novarini"``: the breaking waves' bubbles within a metre or two of the
            surface, bright unpolarized points in the camera's view
            (``sensors.polarimeter.optics.bubbles``; none on a flat sea, nor in the tank scene,
            which
            has no breaking waves); ``"ideal"``: none.
        flicker: ``"caustics"``: the waves focus the sun's beam into the moving net that the
            water's sun-lit light carries (``sensors.polarimeter.optics.caustics``); ``"ideal"``: a
            uniform beam under the waves.
        particles: ``"marine_snow"``: suspended aggregates through the water column, bright
            unpolarized points in the camera's view (``sensors.polarimeter.optics.particles``; none
            in
            the tank scene); ``"ideal"``: none.
    """

    cie_sky_type: int = declared(12, R.CIE_SKY_TYPE)
    sky_polarization: str = declared("rayleigh", choices=SKY_POLARIZATION_MODELS)
    dop_max: float = declared(0.75, R.UNIT_INTERVAL)
    berry_delta_deg: float = declared(30.0, R.BERRY_DELTA_DEG)
    zenith_radiance_w_m2_sr_nm: float = declared(0.05, R.ZENITH_RADIANCE)
    turbidity: float = declared(1.0, R.TURBIDITY)
    wind_speed_mps: float = declared(0.0, R.WIND_SPEED_MPS)
    wind_toward_deg: float = declared(0.0, R.COMPASS_DEG)
    wavelength_nm: float = declared(500.0, R.WAVELENGTH_NM)
    bubbles: str = declared("hall_novarini", choices=BUBBLE_MODELS)
    flicker: str = declared("caustics", choices=FLICKER_MODELS)
    particles: str = declared("marine_snow", choices=PARTICLE_MODELS)


GRAVITY_MAPS: tuple[str, ...] = ("none", "seafloor", "random", "wang2023", "file")


@dataclass(frozen=True, slots=True)
class Gravity:
    """The gravity field of the operating area and the vehicle's stored map of it (wang2023).

    World side: the field (``twin.world.gravity``); onboard: the stored map the vehicle carries
    (``twin.onboard.gravity.matching``), the field at a coarser spacing with the map's error.

    Attributes:
        map: ``"none"``; ``"seafloor"``: a synthetic abyssal seafloor of ``size_km`` forward
            modelled at ``spacing_m`` (seeded by ``map_seed``); ``"random"``: a map of
            ``size_km`` drawn by its statistics (``twin.world.gravity_random``: a Gaussian
            random field of correlation length ``correlation_km`` scaled to the range
            ``range_mgal``, seeded by ``map_seed``, each seed an independent map);
            ``"wang2023"``: the 100 × 100 km
            map of the PCRB study's tests (``twin.world.gravity.wang2023_seafloor``, 1 km);
            ``"file"``: a NetCDF/GeoTIFF grid (``file``, ``variable``) resampled to ``spacing_m``.
        file: Path of the grid file (``map = "file"``), relative to the working directory.
        variable: Its data variable ('' = the only one).
        size_km: (East, North) extent of a ``"seafloor"`` or ``"random"`` map.
        spacing_m: Node spacing of the world's field (``"seafloor"``, ``"random"``, ``"file"``).
        map_seed: Seed of the synthetic map (the area is the same for every run).
        correlation_km: ``"random"``: correlation length L of the covariance exp(−r²/L²)
            [assumption, 5 km: see ``twin.world.gravity_random``].
        range_mgal: ``"random"``: the map's max − min (wang2023 §4: 78 mGal).
        launch_km: Where the launch point (the scenario's place, ENU origin) lies on the map
            (East, North, km from the map's lower-left corner); None = the map's centre.
        stored_spacing_m: Node spacing δ of the vehicle's stored map: every k-th node of the
            field (a multiple of the field's spacing).
        map_error_mgal: 1σ error of the stored map's nodes, σ_m (wang2023: its Sandwell region
            "better than 1.7 mGal"), drawn per run; also what the vehicle is told.
        matching: The navigation filters fuse the gravimeter against the stored map (needs
            ``sensors.gravimeter``).
    """

    map: str = declared("none", choices=GRAVITY_MAPS)
    file: str = declared("")
    variable: str = declared("")
    size_km: Vec2 = declared((40.0, 40.0), R.MAP_SIZE_KM)
    spacing_m: float = declared(500.0, R.MAP_SPACING_M)
    map_seed: int = declared(0, R.NON_NEGATIVE)
    correlation_km: float = declared(5.0, R.MAP_CORRELATION_KM)
    range_mgal: float = declared(78.0, R.MAP_RANGE_MGAL)
    launch_km: Vec2 | None = declared(None, R.MAP_POSITION_KM)
    stored_spacing_m: float = declared(1000.0, R.MAP_SPACING_M)
    map_error_mgal: float = declared(1.7, R.MAP_ERROR_MGAL)
    matching: bool = declared(True)


# ---- the scenario ------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Scenario:
    """One sea trial, validated. ``start_utc`` is timezone-aware, in UTC."""

    name: str
    duration_s: float = declared(allowed=R.DURATION_S)
    start_utc: datetime
    place: Place
    mission: Mission
    description: str = declared("")
    seed: int = declared(0, R.SEED)
    scene: SceneName = declared("open_sea", choices=SCENES)
    water: Water = field(default_factory=Water)
    current: Current = field(default_factory=Current)
    initial: Initial = field(default_factory=Initial)
    sensors: Sensors = field(default_factory=Sensors)
    optics: Optics = field(default_factory=Optics)
    autopilot: Autopilot = field(default_factory=Autopilot)
    recording: Recording = field(default_factory=Recording)
    navigation: Navigation = field(default_factory=Navigation)
    hardware: Hardware = field(default_factory=Hardware)
    gravity: Gravity = field(default_factory=Gravity)

    def utc_at(self, t_s: float) -> datetime:
        """The UTC instant of simulation time ``t_s`` (seconds since the start)."""
        return self.start_utc + timedelta(seconds=t_s)

    @property
    def end_utc(self) -> datetime:
        """The UTC instant the run ends."""
        return self.utc_at(self.duration_s)

    def replace_seed(self, seed: int) -> Scenario:
        """A copy with another root seed (Monte Carlo runs of one trial).

        Raises:
            ValueError: ``seed`` is not an int >= 0.
        """
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f"seed must be an int >= 0, got {seed!r}")
        return dataclasses.replace(self, seed=seed)

    def to_dict(self) -> dict[str, Any]:
        """The scenario as a JSON-able dict in the file's own layout.

        ``parse_scenario(s.to_dict()) == s``: the dict is a valid scenario, with every default
        written out, so a metrics file records exactly what ran.
        """
        out: dict[str, Any] = {
            "name": self.name,
            "description": self.description,
            "seed": self.seed,
            "duration_s": self.duration_s,
            "start_utc": self.start_utc.astimezone(UTC).isoformat().replace("+00:00", "Z"),
            "scene": self.scene,
            "place": _plain(self.place),
            "water": _plain(self.water),
            "current": _current_dict(self.current),
            "initial": _plain(self.initial),
            "mission": _mission_dict(self.mission),
            "sensors": {
                "imu": self.sensors.imu,
                "depth": self.sensors.depth,
                "imu_overrides": {k: _plain(v) for k, v in self.sensors.imu_overrides},
                "depth_overrides": {k: _plain(v) for k, v in self.sensors.depth_overrides},
                **(
                    {
                        "polarimeter": self.sensors.polarimeter,
                        "polarimeter_overrides": {
                            k: _plain(v) for k, v in self.sensors.polarimeter_overrides
                        },
                    }
                    if self.sensors.polarimeter is not None
                    else {}
                ),
                **(
                    {
                        "gravimeter": self.sensors.gravimeter,
                        "gravimeter_overrides": {
                            k: _plain(v) for k, v in self.sensors.gravimeter_overrides
                        },
                    }
                    if self.sensors.gravimeter is not None
                    else {}
                ),
                **(
                    {"extra": {e.name: _extra_dict(e) for e in self.sensors.extra}}
                    if self.sensors.extra
                    else {}
                ),
            },
            "optics": _plain(self.optics),
            "autopilot": _plain(self.autopilot),
            "recording": _plain(self.recording),
            "navigation": _navigation_dict(self.navigation),
            "hardware": _hardware_dict(self.hardware),
            "gravity": {k: v for k, v in _plain(self.gravity).items() if v is not None},
        }
        if self.water.seabed_depth_m is None:
            del out["water"]["seabed_depth_m"]
        # One of the two names the water: a Jerlov type (or plug-in's body), or its own IOPs.
        del out["water"]["jerlov_type" if self.water.iops is not None else "iops"]
        return out


def _extra_dict(e: ExtraSensor) -> dict[str, Any]:
    out: dict[str, Any] = {"kind": e.kind}
    out |= {k: v for k, v in (("preset", e.preset), ("site", e.site)) if v is not None}
    return out | {k: _plain(v) for k, v in e.overrides}


def _navigation_dict(nav: Navigation) -> dict[str, Any]:
    skip = ("methods", "aids")
    out = {k: v for k, v in _plain(nav).items() if v is not None and k not in skip}
    if nav.methods:
        out["methods"] = {name: {k: _plain(v) for k, v in params} for name, params in nav.methods}
    if nav.aids:
        out["aids"] = {s: {"aid": a} | {k: _plain(v) for k, v in p} for s, a, p in nav.aids}
    return out


def _plain(value: Any) -> Any:
    """Dataclasses to dicts and tuples to lists, recursively (JSON's shapes)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def _current_dict(c: Current) -> dict[str, Any]:
    # Only the keys the kind uses: the loader rejects the others, and the dict must load back.
    keys = {
        "none": (),
        "constant": ("speed_mps", "toward_deg"),
        "profile": ("profile",),
        "gauss_markov": ("speed_mps", "toward_deg", "sigma_mps", "tau_s"),
    }[c.kind]
    return {"kind": c.kind, **{k: _plain(getattr(c, k)) for k in keys}}


def _hardware_dict(h: Hardware) -> dict[str, Any]:
    # Only the σ of real models: the loader rejects a σ given for an ideal one.
    out: dict[str, Any] = {}
    for model, sigmas in HARDWARE_SIGMAS.items():
        out[model] = getattr(h, model)
        if out[model] != "ideal":
            out.update({k: getattr(h, k) for k in sigmas})
    return out


def _mission_dict(m: Mission) -> dict[str, Any]:
    return {"kind": m.kind, **_plain(m)}
