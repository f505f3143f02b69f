"""The scenario's world tables.

When and where (``start_utc``, ``[place]``), the water and its current, the sky and the sea
surface (``[optics]``), the gravity map (``[gravity]``).

Each ``read_*`` reads one table through :class:`~scenarios.reading._Table` (every problem
reported, none raised) and returns its dataclass, or None where a problem was reported.
"""

from __future__ import annotations

import dataclasses
from datetime import UTC, datetime
from typing import Any

from scenarios.ranges import (
    ATTENUATION_PER_M,
    BEAUFORT_FORCE,
    BEAUFORT_MPS,
    BERRY_DELTA_DEG,
    CIE_SKY_TYPE,
    COMPASS_DEG,
    CURRENT_SPEED_MPS,
    DENSITY_KG_M3,
    DEPOLARIZATION_RATIO,
    GUST_SIGMA_MPS,
    LATITUDE_DEG,
    LONGITUDE_DEG,
    MAP_CORRELATION_KM,
    MAP_ERROR_MGAL,
    MAP_POSITION_KM,
    MAP_RANGE_MGAL,
    MAP_SIZE_KM,
    MAP_SPACING_M,
    MSG_NAIVE_TIME,
    MSG_PROFILE_ORDER,
    MSG_START_RANGE,
    NON_NEGATIVE,
    POSITIVE,
    SALINITY_PSU,
    SCATTERING_PER_M,
    START_UTC_END,
    START_UTC_MIN,
    TEMPERATURE_C,
    TURBIDITY,
    UNIT_INTERVAL,
    WAVELENGTH_NM,
    WIND_SPEED_MPS,
    ZENITH_RADIANCE,
)
from scenarios.reading import (
    _MISSING,
    MSG_WRONG_TYPE,
    _all_set,
    _build,
    _show,
    _Table,
    _type_name,
)
from scenarios.schema import (
    BUBBLE_MODELS,
    CURRENT_KINDS,
    FLICKER_MODELS,
    GRAVITY_MAPS,
    PARTICLE_MODELS,
    SKY_POLARIZATION_MODELS,
    Current,
    Gravity,
    Optics,
    Place,
    ProfilePoint,
    Water,
    WaterIops,
)
from twin.core.extensions import WATER_BODIES
from twin.core.options import INLINE_WATER, PARTICLE_DOP_MAX, WATER_DEPOLARIZATION_RATIO


def read_start_utc(top: _Table) -> datetime | None:
    key, expected = "start_utc", "a timezone-aware datetime (TOML datetime or ISO-8601 string)"
    raw = top._raw(key, _MISSING, expected)
    if raw is _MISSING:
        return None
    errs, path = top.report, top.at(key)
    value = raw
    if isinstance(raw, str):
        try:
            value = datetime.fromisoformat(raw)
        except ValueError:
            errs.add(path, f"{_show(raw)} is not an ISO-8601 datetime; expected {expected}")
            return None
    if not isinstance(value, datetime):
        errs.add(
            path,
            MSG_WRONG_TYPE.format(value=_show(raw), type_name=_type_name(raw), expected=expected),
        )
        return None
    if value.tzinfo is None or value.utcoffset() is None:
        errs.add(path, MSG_NAIVE_TIME.format(value=_show(raw)))
        return None
    try:
        utc = value.astimezone(UTC)
    except OverflowError:  # an offset that moves year 1 or 9999 out of datetime's range
        utc = None
    if utc is None or not (START_UTC_MIN <= utc < START_UTC_END):
        errs.add(path, MSG_START_RANGE.format(value=_show(raw)))
        return None
    return utc


def read_place(t: _Table | None) -> Place | None:
    if t is None:
        return None
    place = _build(
        Place,
        latitude_deg=t.number("latitude_deg", LATITUDE_DEG),
        longitude_deg=t.number("longitude_deg", LONGITUDE_DEG),
    )
    t.finish()
    return place


def read_water(t: _Table | None) -> Water | None:
    if t is None:
        return None
    density = t.number("density_kg_m3", DENSITY_KG_M3, default=1025.0)
    temperature = t.number("temperature_c", TEMPERATURE_C, default=15.0)
    salinity = t.number("salinity_psu", SALINITY_PSU, default=35.0)
    jerlov = t.string("jerlov_type", choices=WATER_BODIES.names(), default="II")
    iops_t = t.table("iops", expected="a table: a_per_m, b_per_m, kd_per_m, source")
    iops, iops_ok = read_water_iops(iops_t)
    if iops_ok and iops is not None:
        if "jerlov_type" in t.data:
            t.report.add(
                t.at("jerlov_type"),
                f"{_show(t.data['jerlov_type'])} and [water.iops] both name the water; "
                "give one of them",
            )
            jerlov = None
        else:
            jerlov = INLINE_WATER
    seabed_given = "seabed_depth_m" in t.data
    seabed = t.number("seabed_depth_m", POSITIVE, default=None)
    peak_p = t.number("particle_peak_polarization", UNIT_INTERVAL, default=PARTICLE_DOP_MAX)
    delta = t.number(
        "depolarization_ratio", DEPOLARIZATION_RATIO, default=WATER_DEPOLARIZATION_RATIO
    )
    t.report.seabed_m = seabed
    t.finish()
    values = (density, temperature, salinity, jerlov, peak_p, delta)
    if not _all_set(*values) or (seabed_given and seabed is None) or not iops_ok:
        return None
    return Water(density, temperature, salinity, jerlov, seabed, peak_p, delta, iops)


def read_water_iops(t: _Table | None) -> tuple[WaterIops | None, bool]:
    """``[water.iops]``: (the water's own IOPs or None when absent, whether the table is valid)."""
    if t is None:
        return None, False
    if not t.data:
        return None, True
    a = t.number("a_per_m", ATTENUATION_PER_M)
    b = t.number("b_per_m", SCATTERING_PER_M)
    kd = t.number("kd_per_m", ATTENUATION_PER_M)
    source = t.string("source", non_empty=True, expected="a citation, or 'assumption: ...'")
    t.finish()
    if a is not None and kd is not None and kd < a:
        # K_d ≈ (a + b_b)/μ̄_d with μ̄_d ≤ 1: diffuse light cannot fade slower than it is absorbed.
        t.report.add(t.at("kd_per_m"), f"{kd!r} is below a_per_m = {a!r}; allowed: K_d >= a (m^-1)")
        return None, False
    iops = _build(WaterIops, a_per_m=a, b_per_m=b, kd_per_m=kd, source=source)
    return iops, iops is not None


_CURRENT_KEYS = {
    "none": ("kind",),
    "constant": ("kind", "speed_mps", "toward_deg"),
    "profile": ("kind", "profile"),
    "gauss_markov": ("kind", "speed_mps", "toward_deg", "sigma_mps", "tau_s"),
}


def read_current(t: _Table | None) -> Current | None:
    if t is None:
        return None
    kind = t.string("kind", choices=CURRENT_KINDS, default="none")
    if kind is None:
        return None  # the other keys depend on the kind: checking them would only add noise
    elsewhere = {k for keys in _CURRENT_KEYS.values() for k in keys}
    current: Current | None = Current()
    if kind == "constant":
        current = _build(
            Current,
            kind=kind,
            speed_mps=t.number("speed_mps", CURRENT_SPEED_MPS),
            toward_deg=t.number("toward_deg", COMPASS_DEG),
        )
    elif kind == "gauss_markov":
        current = _build(
            Current,
            kind=kind,
            speed_mps=t.number("speed_mps", CURRENT_SPEED_MPS, default=0.0),
            toward_deg=t.number("toward_deg", COMPASS_DEG, default=0.0),
            sigma_mps=t.number("sigma_mps", GUST_SIGMA_MPS),
            tau_s=t.number("tau_s", POSITIVE),
        )
    elif kind == "profile":
        current = _build(Current, kind=kind, profile=_profile(t))
    t.finish(elsewhere=elsewhere, context=f"by current.kind = {_show(kind)}")
    return current


def _profile(t: _Table) -> tuple[ProfilePoint, ...] | None:
    tables = t.tables(
        "profile",
        min_len=2,
        expected="an array of >= 2 {depth_m, speed_mps, toward_deg} tables, depths increasing",
    )
    if tables is None:
        return None
    points: list[ProfilePoint | None] = []
    prev: float | None = None
    for p in tables:
        if p is None:
            points.append(None)
            continue
        depth = p.number("depth_m", NON_NEGATIVE)
        if depth is not None and prev is not None and depth <= prev:
            t.report.add(p.at("depth_m"), MSG_PROFILE_ORDER.format(value=depth, prev=prev))
            depth = None
        prev = depth if depth is not None else prev
        points.append(
            _build(
                ProfilePoint,
                depth_m=depth,
                speed_mps=p.number("speed_mps", CURRENT_SPEED_MPS),
                toward_deg=p.number("toward_deg", COMPASS_DEG),
            )
        )
        p.finish()
    return tuple(p for p in points if p is not None) if _all_set(*points) else None


_NO_LAUNCH: Any = object()  # launch_km absent: the map's centre


def read_gravity(t: _Table | None) -> Gravity | None:
    if t is None:
        return None
    gravity = _build(
        Gravity,
        map=t.string("map", choices=GRAVITY_MAPS, default="none"),
        file=t.string("file", default=""),
        variable=t.string("variable", default=""),
        size_km=t.pair("size_km", MAP_SIZE_KM, default=(40.0, 40.0)),
        spacing_m=t.number("spacing_m", MAP_SPACING_M, default=500.0),
        map_seed=t.integer("map_seed", NON_NEGATIVE, default=0),
        correlation_km=t.number("correlation_km", MAP_CORRELATION_KM, default=5.0),
        range_mgal=t.number("range_mgal", MAP_RANGE_MGAL, default=78.0),
        stored_spacing_m=t.number("stored_spacing_m", MAP_SPACING_M, default=1000.0),
        map_error_mgal=t.number("map_error_mgal", MAP_ERROR_MGAL, default=1.7),
        matching=t.boolean("matching", default=True),
    )
    launch = t.pair("launch_km", MAP_POSITION_KM, default=_NO_LAUNCH)
    t.finish()
    if gravity is None or launch is None:
        return None
    if launch is not _NO_LAUNCH:
        gravity = dataclasses.replace(gravity, launch_km=launch)
    if gravity.map == "file" and not gravity.file:
        t.report.add(t.at("file"), 'missing; required with map = "file": a NetCDF/GeoTIFF path')
    # The stored map's spacing against the field's: twin.world.gravity_area.check_gravity (it
    # knows every map's node spacing and extent, a file's included).
    return gravity


def read_optics(t: _Table | None) -> Optics | None:
    if t is None:
        return None
    optics = _build(
        Optics,
        cie_sky_type=t.integer("cie_sky_type", CIE_SKY_TYPE, default=12),
        sky_polarization=t.string(
            "sky_polarization", choices=SKY_POLARIZATION_MODELS, default="rayleigh"
        ),
        dop_max=t.number("dop_max", UNIT_INTERVAL, default=0.75),
        berry_delta_deg=t.number("berry_delta_deg", BERRY_DELTA_DEG, default=30.0),
        zenith_radiance_w_m2_sr_nm=t.number(
            "zenith_radiance_w_m2_sr_nm", ZENITH_RADIANCE, default=0.05
        ),
        turbidity=t.number("turbidity", TURBIDITY, default=1.0),
        wind_speed_mps=_wind(t),
        wind_toward_deg=t.number("wind_toward_deg", COMPASS_DEG, default=0.0),
        wavelength_nm=t.number("wavelength_nm", WAVELENGTH_NM, default=500.0),
        bubbles=t.string("bubbles", choices=BUBBLE_MODELS, default="hall_novarini"),
        flicker=t.string("flicker", choices=FLICKER_MODELS, default="caustics"),
        particles=t.string("particles", choices=PARTICLE_MODELS, default="marine_snow"),
    )
    t.finish()
    return optics


def _wind(t: _Table) -> float | None:
    """optics.wind_speed_mps, or the speed of optics.wind_beaufort (one of them, not both)."""
    if "wind_beaufort" in t.data and "wind_speed_mps" in t.data:
        t.known += ["wind_beaufort", "wind_speed_mps"]
        t.report.add(
            t.at("wind_beaufort"),
            "given together with wind_speed_mps; expected one of them: a Beaufort force "
            "(integer 0–11) or a speed in m/s",
        )
        return None
    if "wind_beaufort" in t.data:
        force = t.integer("wind_beaufort", BEAUFORT_FORCE)
        return None if force is None else BEAUFORT_MPS[int(force)]
    return t.number("wind_speed_mps", WIND_SPEED_MPS, default=0.0)
