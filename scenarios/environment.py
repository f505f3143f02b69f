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
    BEAUFORT_FORCE,
    BEAUFORT_MPS,
    MSG_NAIVE_TIME,
    MSG_PROFILE_ORDER,
    MSG_START_RANGE,
    START_UTC_END,
    START_UTC_MIN,
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
    Current,
    Gravity,
    Optics,
    Place,
    ProfilePoint,
    Water,
    WaterIops,
)
from twin.core.options import INLINE_WATER


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
    t.of(Place)
    place = _build(
        Place, latitude_deg=t.number("latitude_deg"), longitude_deg=t.number("longitude_deg")
    )
    t.finish()
    return place


def read_water(t: _Table | None) -> Water | None:
    if t is None:
        return None
    t.of(Water)
    density = t.number("density_kg_m3")
    temperature = t.number("temperature_c")
    salinity = t.number("salinity_psu")
    jerlov = t.string("jerlov_type")
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
    seabed = t.number("seabed_depth_m")
    peak_p = t.number("particle_peak_polarization")
    delta = t.number("depolarization_ratio")
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
    t.of(WaterIops)
    a = t.number("a_per_m")
    b = t.number("b_per_m")
    kd = t.number("kd_per_m")
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
    t.of(Current)
    kind = t.string("kind")
    if kind is None:
        return None  # the other keys depend on the kind: checking them would only add noise
    elsewhere = {k for keys in _CURRENT_KEYS.values() for k in keys}
    current: Current | None = Current()
    if kind == "constant":
        current = _build(
            Current,
            kind=kind,
            speed_mps=t.number("speed_mps", default=_MISSING),  # required by this kind
            toward_deg=t.number("toward_deg", default=_MISSING),
        )
    elif kind == "gauss_markov":
        current = _build(
            Current,
            kind=kind,
            speed_mps=t.number("speed_mps"),
            toward_deg=t.number("toward_deg"),
            sigma_mps=t.number("sigma_mps", default=_MISSING),  # required by this kind
            tau_s=t.number("tau_s", default=_MISSING),
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
        p.of(ProfilePoint)
        depth = p.number("depth_m")
        if depth is not None and prev is not None and depth <= prev:
            t.report.add(p.at("depth_m"), MSG_PROFILE_ORDER.format(value=depth, prev=prev))
            depth = None
        prev = depth if depth is not None else prev
        points.append(
            _build(
                ProfilePoint,
                depth_m=depth,
                speed_mps=p.number("speed_mps"),
                toward_deg=p.number("toward_deg"),
            )
        )
        p.finish()
    return tuple(p for p in points if p is not None) if _all_set(*points) else None


_NO_LAUNCH: Any = object()  # launch_km absent: the map's centre


def read_gravity(t: _Table | None) -> Gravity | None:
    if t is None:
        return None
    t.of(Gravity)
    gravity = _build(
        Gravity,
        map=t.string("map"),
        file=t.string("file"),
        variable=t.string("variable"),
        size_km=t.pair("size_km"),
        spacing_m=t.number("spacing_m"),
        map_seed=t.integer("map_seed"),
        correlation_km=t.number("correlation_km"),
        range_mgal=t.number("range_mgal"),
        stored_spacing_m=t.number("stored_spacing_m"),
        map_error_mgal=t.number("map_error_mgal"),
        matching=t.boolean("matching"),
    )
    launch = t.pair("launch_km", default=_NO_LAUNCH)
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
    t.of(Optics)
    optics = _build(
        Optics,
        cie_sky_type=t.integer("cie_sky_type"),
        sky_polarization=t.string("sky_polarization"),
        dop_max=t.number("dop_max"),
        berry_delta_deg=t.number("berry_delta_deg"),
        zenith_radiance_w_m2_sr_nm=t.number("zenith_radiance_w_m2_sr_nm"),
        turbidity=t.number("turbidity"),
        wind_speed_mps=_wind(t),
        wind_toward_deg=t.number("wind_toward_deg"),
        wavelength_nm=t.number("wavelength_nm"),
        bubbles=t.string("bubbles"),
        flicker=t.string("flicker"),
        particles=t.string("particles"),
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
    return t.number("wind_speed_mps")
