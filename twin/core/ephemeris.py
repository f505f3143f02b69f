"""The one sun ephemeris: NREL SPA (pvlib), apparent position, interpolated between knots.

Shared contract (``twin.core``): the world renders the sky with it (the polarimeter's sun stage,
:mod:`sensors.polarimeter.optics.sun`) and the vehicle computer computes the sun's direction with it
from
what it knows (declared place, its clock's UTC), as a real vehicle computer would.

The position is pvlib's port of the NREL Solar Position Algorithm (Reda & Andreas 2004, Solar
Energy 76(5):577, corrigendum 81(6):838; stated uncertainty ±0.0003°), called through
:func:`pvlib.solarposition.spa_python` (optics.md §5). The *apparent* (refraction-corrected)
position is used everywhere downstream: it is where the sun is seen from the sea surface, and the
direction Snell refraction starts from.

Angles are radians; azimuth is the compass azimuth (clockwise from North, pvlib's convention), and
``direction_enu`` is the unit vector from the observer towards the sun in the ENU navigation frame
(x East, y North, z Up; :mod:`twin.core.frames`):
``(sin Z sin A, sin Z cos A, cos Z)`` for apparent zenith Z and compass azimuth A.

One SPA evaluation costs 5–20 ms (pandas and the full series), too much for every frame of every
filter variant: :class:`SunTracker` evaluates SPA at knots every 10 s, 64 knots a call, and
interpolates the geometric direction, then refracts it at the observer's place as SPA does (the
sun moves 0.04° in 10 s; the direction is within 1e-4° of a single SPA call at the observer's
place, checked in tests/onboard/test_ephemeris.py and tests/sensors/polarimeter/test_sun.py).

Night: :data:`NIGHT_ELEVATION_DEG` = −0.833°, the conventional sunset/sunrise of the sun's upper
limb (solar semi-diameter 0.2667° + standard horizon refraction 0.5667°). SPA applies refraction
only while the sun is within that band of the horizon, so an apparent elevation below −0.833° means
the whole disc has set. Twilight sky light is not modelled: the sky stage renders a night sky
(:mod:`sensors.polarimeter.optics.sky`).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pvlib
from numpy.typing import NDArray

from twin.core.arrays import FloatArray

_MAX_KNOTS = 100_000

#: Apparent solar elevation (degrees) below which it is night: upper limb below the horizon.
NIGHT_ELEVATION_DEG = -0.833
NIGHT_ELEVATION_RAD = math.radians(NIGHT_ELEVATION_DEG)

# SPA's refraction inputs when none are given (pvlib's spa_python defaults): the standard
# atmosphere's sea-level pressure, 12 °C, and the horizon refraction SPA uses to decide when to
# refract. One place for them: sun_position and SunTracker's own refraction both read these.
DEFAULT_PRESSURE_PA = 101325.0
DEFAULT_TEMPERATURE_C = 12.0
DEFAULT_ATMOS_REFRACT_DEG = 0.5667

TimeLike = (
    dt.datetime | np.datetime64 | pd.Timestamp | str | Sequence[dt.datetime] | pd.DatetimeIndex
)


@dataclass(frozen=True, slots=True)
class SunPosition:
    """Apparent position of the sun at one instant (scalar fields) or many (arrays, shape (N,)).

    Attributes:
        utc: The instant(s): a timezone-aware UTC ``pandas.DatetimeIndex`` from
            :func:`sun_position`; the instant as given to a :class:`SunTracker`.
        apparent_zenith_rad: Refraction-corrected zenith angle.
        azimuth_rad: Compass azimuth, clockwise from North, in [0, 2π).
        elevation_rad: Refraction-corrected elevation = π/2 − apparent zenith.
        direction_enu: Unit vector(s) towards the sun, ENU, shape (3,) or (N, 3).
        is_night: Apparent elevation below :data:`NIGHT_ELEVATION_DEG`.
        zenith_rad: Geometric topocentric zenith angle, before refraction (SPA's θ₀); NaN
            where only the apparent position is known (:class:`SunTracker`).
    """

    utc: pd.DatetimeIndex
    apparent_zenith_rad: float | FloatArray
    azimuth_rad: float | FloatArray
    elevation_rad: float | FloatArray
    direction_enu: FloatArray
    is_night: bool | NDArray[np.bool_]
    zenith_rad: float | FloatArray = math.nan


def direction_from_zenith_azimuth(
    zenith_rad: float | FloatArray, azimuth_rad: float | FloatArray
) -> NDArray[np.float64]:
    """ENU unit vector(s) of zenith angle Z and compass azimuth A (clockwise from North).

    ``(sin Z sin A, sin Z cos A, cos Z)``; broadcasts, output shape (..., 3).
    """
    z = np.asarray(zenith_rad, dtype=np.float64)
    a = np.asarray(azimuth_rad, dtype=np.float64)
    sz = np.sin(z)
    return np.stack(np.broadcast_arrays(sz * np.sin(a), sz * np.cos(a), np.cos(z)), axis=-1)


def _to_utc_index(utc: TimeLike) -> tuple[pd.DatetimeIndex, bool]:
    """A UTC DatetimeIndex from the accepted time types, and whether the input was scalar."""
    scalar = isinstance(utc, dt.datetime | np.datetime64 | pd.Timestamp | str)
    try:
        idx = pd.DatetimeIndex([utc] if scalar else utc)
    except (TypeError, ValueError) as err:
        raise ValueError(
            f"utc must be a datetime, datetime64, ISO string or a sequence of them: {err}"
        ) from err
    if idx.hasnans:
        raise ValueError("utc must not contain NaT")
    # Naive times are UTC (the scenario clock is UTC); aware ones are converted.
    idx = idx.tz_localize("UTC") if idx.tz is None else idx.tz_convert("UTC")
    return idx, scalar


def _check_finite(name: str, value: float, lo: float = -math.inf, hi: float = math.inf) -> float:
    v = float(value)
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name} must be a finite number in [{lo:g}, {hi:g}], got {value!r}")
    return v


def sun_position(
    utc: TimeLike,
    lat_deg: float,
    lon_deg: float,
    *,
    altitude_m: float = 0.0,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    temperature_c: float = DEFAULT_TEMPERATURE_C,
    delta_t_s: float | None = None,
    atmos_refract_deg: float = DEFAULT_ATMOS_REFRACT_DEG,
) -> SunPosition:
    """Apparent solar position for a place and UTC instant(s), by NREL SPA (pvlib).

    Args:
        utc: Instant(s): datetime (naive = UTC, aware = converted), numpy datetime64, ISO string,
            pandas Timestamp/DatetimeIndex, or a sequence of these (vectorised; one SPA call).
        lat_deg: Geodetic latitude, degrees North, in [−90, 90].
        lon_deg: Longitude, degrees East, in [−180, 180].
        altitude_m: Observer height above the ellipsoid (sea level = 0), in [−1000, 10000].
        pressure_pa: Surface air pressure for the refraction correction, in (0, 2e5].
        temperature_c: Air temperature for the refraction correction, in [−90, 60].
        delta_t_s: TT − UT1 in seconds; None = pvlib's polynomial estimate for each date
            (``pvlib.spa.calculate_deltat``, ≈69 s in 2024–2026; 1 s of ΔT moves the sun by ~4e-3°).
        atmos_refract_deg: Refraction at sunrise/sunset used by SPA to decide when to refract.

    Returns:
        The :class:`SunPosition`; scalar fields for a scalar ``utc``, arrays of shape (N,) else.
    """
    idx, scalar = _to_utc_index(utc)
    lat = _check_finite("lat_deg", lat_deg, -90.0, 90.0)
    lon = _check_finite("lon_deg", lon_deg, -180.0, 180.0)
    alt = _check_finite("altitude_m", altitude_m, -1000.0, 10000.0)
    pressure = _check_finite("pressure_pa", pressure_pa, 0.0, 2e5)
    if pressure <= 0:
        raise ValueError(f"pressure_pa must be > 0, got {pressure_pa!r}")
    temp = _check_finite("temperature_c", temperature_c, -90.0, 60.0)
    refr = _check_finite("atmos_refract_deg", atmos_refract_deg, 0.0, 5.0)
    delta_t: float | NDArray[np.float64]
    if delta_t_s is not None:
        delta_t = _check_finite("delta_t_s", delta_t_s, -1e4, 1e4)
    else:
        # pvlib's own estimate, on numpy arrays: spa_python would compute the same polynomial on
        # the pandas index, element by element through pandas arithmetic, which costs ~75 ms a
        # call (a fifth of a sea trial's wall time). Same formula, same numbers.
        delta_t = pvlib.spa.calculate_deltat(
            idx.year.to_numpy(dtype=np.float64), idx.month.to_numpy(dtype=np.float64)
        )

    df = pvlib.solarposition.spa_python(
        idx,
        lat,
        lon,
        altitude=alt,
        pressure=pressure,
        temperature=temp,
        delta_t=delta_t,
        atmos_refract=refr,
        how="numpy",
    )
    zen = np.radians(df["apparent_zenith"].to_numpy(dtype=np.float64))
    geometric = np.radians(df["zenith"].to_numpy(dtype=np.float64))
    az = np.radians(df["azimuth"].to_numpy(dtype=np.float64)) % (2.0 * math.pi)
    elev = np.radians(df["apparent_elevation"].to_numpy(dtype=np.float64))
    direction = direction_from_zenith_azimuth(zen, az)
    night = elev < NIGHT_ELEVATION_RAD
    if scalar:
        return SunPosition(
            idx,
            float(zen[0]),
            float(az[0]),
            float(elev[0]),
            direction[0],
            bool(night[0]),
            float(geometric[0]),
        )
    return SunPosition(idx, zen, az, elev, direction, night, geometric)


class SunTracker:
    """Per-frame sun positions: SPA's geometric direction on a grid of knots, refracted per place.

    One ``spa_python`` call costs ~2–20 ms (pandas and the full SPA series), too much for every
    frame, while the sun moves only ~0.004°/s. The tracker evaluates SPA (vectorised) on knots
    ``knot_s`` apart, in batches of ``batch`` knots, and keeps SPA's *geometric* topocentric
    direction (before refraction). Each instant linearly interpolates that direction between
    its two knots (error ≤ h²Ω²/8 with Ω = 7.29e-5 rad/s the Earth's rotation: 6.6e-8 rad,
    4e-6°, for h = 10 s), turns it into the observer's ENU frame (:func:`move_enu`: the sun is
    far, so only the local axes turn), then applies SPA's own refraction correction
    (``pvlib.spa.atmospheric_refraction_correction``, the function SPA itself calls) at the
    observer's elevation, as SPA would at that place. What the move leaves out is the change of
    the solar parallax (8.8″ in all) with the place: ≤ 8.8″ · d / R_E, 4e-5° at d = 111 km, so
    one tracker serves a 1° cell (:func:`sun_direction_enu`) — a vehicle whose estimate drifts
    does not pay an SPA batch per kilometre. SPA's own uncertainty is ±3e-4°.

    Args:
        lat_deg: Geodetic latitude, degrees North.
        lon_deg: Longitude, degrees East.
        knot_s: Knot spacing in seconds, in (0, 600].
        batch: Knots computed per SPA call (≥ 2).
        **spa_kwargs: Passed to :func:`sun_position` (altitude_m, pressure_pa, temperature_c,
            delta_t_s, atmos_refract_deg); the refraction uses the same pressure, temperature
            and horizon refraction.
    """

    def __init__(
        self,
        lat_deg: float,
        lon_deg: float,
        *,
        knot_s: float = 10.0,
        batch: int = 64,
        **spa_kwargs: float | None,
    ) -> None:
        self.lat_deg = _check_finite("lat_deg", lat_deg, -90.0, 90.0)
        self.lon_deg = _check_finite("lon_deg", lon_deg, -180.0, 180.0)
        self.knot_s = _check_finite("knot_s", knot_s, 0.0, 600.0)
        if self.knot_s <= 0:
            raise ValueError(f"knot_s must be > 0, got {knot_s!r}")
        if isinstance(batch, bool) or not isinstance(batch, int) or batch < 2:
            raise ValueError(f"batch must be an integer >= 2, got {batch!r}")
        self.batch = batch
        self.spa_kwargs = spa_kwargs
        # SPA's refraction inputs, sun_position's defaults where not given (pressure in mbar, as
        # SPA takes it).
        given = {k: float(v) for k, v in spa_kwargs.items() if v is not None}
        self._pressure_mbar = given.get("pressure_pa", DEFAULT_PRESSURE_PA) / 100.0
        self._temperature_c = given.get("temperature_c", DEFAULT_TEMPERATURE_C)
        self._atmos_refract_deg = given.get("atmos_refract_deg", DEFAULT_ATMOS_REFRACT_DEG)
        self._knots: dict[int, NDArray[np.float64]] = {}

    def _knot(self, k: int) -> NDArray[np.float64]:
        if k not in self._knots:
            if len(self._knots) > _MAX_KNOTS:  # a long campaign in one process: start afresh
                self._knots.clear()
            ks = np.arange(k, k + self.batch)
            ns = (ks * self.knot_s * 1e9).astype("int64")
            times = pd.DatetimeIndex(ns.astype("datetime64[ns]")).tz_localize("UTC")
            pos = sun_position(times, self.lat_deg, self.lon_deg, **self.spa_kwargs)
            geometric = direction_from_zenith_azimuth(pos.zenith_rad, pos.azimuth_rad)
            for kk, d in zip(ks.tolist(), geometric, strict=True):
                self._knots[kk] = d
        return self._knots[k]

    def direction(
        self, t_s: float, lat_deg: float | None = None, lon_deg: float | None = None
    ) -> NDArray[np.float64]:
        """The apparent ENU direction at ``t_s`` seconds since the Unix epoch (UTC).

        Args:
            t_s: The instant.
            lat_deg: Where the observer is, if not at the tracker's place (a moving vehicle):
                given together with ``lon_deg``.
            lon_deg: Longitude of the observer, degrees East.
        """
        q = t_s / self.knot_s
        k = math.floor(q)
        w = q - k
        d = (1.0 - w) * self._knot(k) + w * self._knot(k + 1)
        if lat_deg is not None and lon_deg is not None:
            d = move_enu(d, self.lat_deg, self.lon_deg, lat_deg, lon_deg)
        east, north, up = d.tolist()
        horizontal = math.hypot(east, north)
        e0 = math.degrees(math.atan2(up, horizontal))
        e = e0 + self._refraction_deg(e0)
        if horizontal == 0.0:  # the sun in the zenith: no azimuth to keep
            return np.array([0.0, 0.0, 1.0 if e > 0 else -1.0])
        c = math.cos(math.radians(e)) / horizontal
        return np.array([east * c, north * c, math.sin(math.radians(e))])

    def _refraction_deg(self, e0_deg: float) -> float:
        """SPA's refraction correction (deg) of a geometric elevation ``e0_deg``."""
        return float(
            pvlib.spa.atmospheric_refraction_correction(
                self._pressure_mbar, self._temperature_c, e0_deg, self._atmos_refract_deg
            )
        )

    def __call__(
        self,
        utc: dt.datetime | np.datetime64 | pd.Timestamp | str,
        lat_deg: float | None = None,
        lon_deg: float | None = None,
    ) -> SunPosition:
        """The apparent sun position at one instant (:meth:`direction`).

        Args:
            utc: The instant.
            lat_deg: Where the observer is now, if not at the tracker's place (a moving vehicle):
                must be given together with ``lon_deg``.
            lon_deg: Longitude of the observer, degrees East.
        """
        if not isinstance(utc, dt.datetime | np.datetime64 | pd.Timestamp | str):
            raise ValueError("SunTracker takes one instant; use sun_position() for many")
        # No pandas index on this path: it runs on every frame, where building one cost
        # ~0.3 ms (cold between frames, measured in a trial); ``utc`` is kept as given.
        d = self.direction(epoch_s(utc), lat_deg, lon_deg)
        zen = math.atan2(math.hypot(d[0], d[1]), d[2])
        az = math.atan2(d[0], d[1]) % (2.0 * math.pi)
        elev = math.pi / 2 - zen
        return SunPosition(utc, zen, az, elev, d, elev < NIGHT_ELEVATION_RAD)  # type: ignore[arg-type]


def _enu_axes(lat_deg: float, lon_deg: float) -> NDArray[np.float64]:
    """Rows: the East, North and Up unit vectors of the geodetic ENU frame, in ECEF."""
    la, lo = math.radians(lat_deg), math.radians(lon_deg)
    sla, cla, slo, clo = math.sin(la), math.cos(la), math.sin(lo), math.cos(lo)
    return np.array([[-slo, clo, 0.0], [-sla * clo, -sla * slo, cla], [cla * clo, cla * slo, sla]])


def move_enu(
    d_enu: NDArray[np.float64], lat0_deg: float, lon0_deg: float, lat1_deg: float, lon1_deg: float
) -> NDArray[np.float64]:
    """A direction to a far body seen from place 0, expressed in the ENU frame of place 1.

    The sun is 1.5e11 m away, so moving the observer by kilometres leaves its direction fixed in
    the Earth frame (1 km over 1.5e8 km turns it by 4e-7°) and only the local axes turn. Turn
    the geometric direction and refract it at the new place (:meth:`SunTracker.direction`):
    refraction depends on the elevation at the observer, not at place 0.
    """
    if lat0_deg == lat1_deg and lon0_deg == lon1_deg:
        return np.array(d_enu, dtype=np.float64)
    return _enu_axes(lat1_deg, lon1_deg) @ (_enu_axes(lat0_deg, lon0_deg).T @ d_enu)


# ---- the vehicle computer's view: a tracker per declared place --------------------------------

_trackers: dict[tuple[int, int], SunTracker] = {}

_EPOCH_AWARE = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
_EPOCH_NAIVE = dt.datetime(1970, 1, 1)


def epoch_s(utc: dt.datetime | np.datetime64 | pd.Timestamp | str) -> float:
    """Seconds since the Unix epoch of one instant (naive = UTC), as pandas would give them.

    A ``datetime`` is converted without pandas (~1 µs instead of ~30 µs: this runs on every
    frame of every filter variant), to the same integer nanoseconds, so the same float.
    """
    if type(utc) is dt.datetime:
        delta = utc - (_EPOCH_NAIVE if utc.tzinfo is None else _EPOCH_AWARE)
        ns = (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000
        return ns / 1e9
    idx, scalar = _to_utc_index(utc)
    if not scalar:
        raise ValueError("epoch_s takes one instant")
    return float(idx.as_unit("ns").asi8[0] / 1e9)


def place_cell(latitude_deg: float, longitude_deg: float) -> tuple[int, int]:
    """The 1° cell whose :class:`SunTracker` serves a place (latitude, wrapped longitude).

    Within a cell the geometric direction is turned to the observer's own place and refracted
    there (:meth:`SunTracker.direction`); what is left is the solar parallax's change, ≤ 4e-5°
    over a cell. So a vehicle (or an estimate) that moves pays one SPA batch per 111 km. (It
    was one per 0.01° cell, about a kilometre, while the refraction was taken at the cell's
    centre: a drifting estimate paid a batch on nearly every frame.)
    """
    if not (math.isfinite(latitude_deg) and -90.0 <= latitude_deg <= 90.0):
        raise ValueError(f"latitude_deg: {latitude_deg!r}; allowed [-90, 90]")
    if not (math.isfinite(longitude_deg) and -180.0 <= longitude_deg <= 360.0):
        raise ValueError(f"longitude_deg: {longitude_deg!r}; allowed [-180, 360]")
    lon = (longitude_deg + 180.0) % 360.0 - 180.0
    return round(latitude_deg), round(lon) if round(lon) < 180 else -180


def tracker_for(latitude_deg: float, longitude_deg: float) -> SunTracker:
    """The shared tracker of a place's cell (:func:`place_cell`), made on first use."""
    key = place_cell(latitude_deg, longitude_deg)
    tracker = _trackers.get(key)
    if tracker is None:
        if len(_trackers) > 1000:
            _trackers.clear()
        tracker = _trackers[key] = SunTracker(float(key[0]), float(key[1]))
    return tracker


def sun_zenith_azimuth(
    utc: dt.datetime, latitude_deg: float, longitude_deg: float
) -> tuple[float, float]:
    """Apparent zenith and compass azimuth (clockwise from North) of the sun, rad (exact SPA)."""
    place_cell(latitude_deg, longitude_deg)
    pos = sun_position(utc, latitude_deg, (longitude_deg + 180.0) % 360.0 - 180.0)
    return float(pos.apparent_zenith_rad), float(pos.azimuth_rad)


def sun_direction_enu(
    utc: dt.datetime, latitude_deg: float, longitude_deg: float
) -> NDArray[np.float64]:
    """Unit ENU vector towards the sun (apparent position) at a place (:class:`SunTracker`)."""
    tracker = tracker_for(latitude_deg, longitude_deg)
    lon = (longitude_deg + 180.0) % 360.0 - 180.0
    return tracker.direction(epoch_s(utc), latitude_deg, lon)
