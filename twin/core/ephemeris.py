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
interpolates (the sun moves 0.04° in 10 s; the interpolated direction is within 1e-4° of a single
SPA call, checked in tests/onboard/test_ephemeris.py and tests/sensors/polarimeter/test_sun.py).

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

TimeLike = (
    dt.datetime | np.datetime64 | pd.Timestamp | str | Sequence[dt.datetime] | pd.DatetimeIndex
)


@dataclass(frozen=True, slots=True)
class SunPosition:
    """Apparent position of the sun at one instant (scalar fields) or many (arrays, shape (N,)).

    Attributes:
        utc: The instant(s), as a timezone-aware UTC ``pandas.DatetimeIndex``.
        apparent_zenith_rad: Refraction-corrected zenith angle.
        azimuth_rad: Compass azimuth, clockwise from North, in [0, 2π).
        elevation_rad: Refraction-corrected elevation = π/2 − apparent zenith.
        direction_enu: Unit vector(s) towards the sun, ENU, shape (3,) or (N, 3).
        is_night: Apparent elevation below :data:`NIGHT_ELEVATION_DEG`.
    """

    utc: pd.DatetimeIndex
    apparent_zenith_rad: float | FloatArray
    azimuth_rad: float | FloatArray
    elevation_rad: float | FloatArray
    direction_enu: FloatArray
    is_night: bool | NDArray[np.bool_]


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
    pressure_pa: float = 101325.0,
    temperature_c: float = 12.0,
    delta_t_s: float | None = None,
    atmos_refract_deg: float = 0.5667,
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
    az = np.radians(df["azimuth"].to_numpy(dtype=np.float64)) % (2.0 * math.pi)
    elev = np.radians(df["apparent_elevation"].to_numpy(dtype=np.float64))
    direction = direction_from_zenith_azimuth(zen, az)
    night = elev < NIGHT_ELEVATION_RAD
    if scalar:
        return SunPosition(
            idx, float(zen[0]), float(az[0]), float(elev[0]), direction[0], bool(night[0])
        )
    return SunPosition(idx, zen, az, elev, direction, night)


class SunTracker:
    """Per-frame sun positions for one place: SPA on a grid of knots, interpolated.

    One ``spa_python`` call costs ~5–20 ms (pandas and the full SPA series), too much for every
    10 Hz frame, while the sun moves only ~0.004°/s. The tracker evaluates SPA (vectorised) on knots
    ``knot_s`` apart, in batches of ``batch`` knots, caches them, and linearly interpolates the
    direction vector between the two knots around each instant (then renormalises). The error of
    linear interpolation is ≤ h²/8 · |d²s/dt²| ≤ h²Ω²/8 with Ω = 7.29e-5 rad/s the Earth's rotation:
    6.6e-8 rad (4e-6°) for h = 10 s — far below SPA's own ±3e-4°.

    Args:
        lat_deg: Geodetic latitude, degrees North.
        lon_deg: Longitude, degrees East.
        knot_s: Knot spacing in seconds, in (0, 600].
        batch: Knots computed per SPA call (≥ 2).
        **spa_kwargs: Passed to :func:`sun_position` (altitude_m, pressure_pa, temperature_c,
            delta_t_s, atmos_refract_deg).
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
        self._knots: dict[int, NDArray[np.float64]] = {}

    def _knot(self, k: int) -> NDArray[np.float64]:
        if k not in self._knots:
            if len(self._knots) > _MAX_KNOTS:  # a long campaign in one process: start afresh
                self._knots.clear()
            ks = np.arange(k, k + self.batch)
            ns = (ks * self.knot_s * 1e9).astype("int64")
            times = pd.DatetimeIndex(ns.astype("datetime64[ns]")).tz_localize("UTC")
            pos = sun_position(times, self.lat_deg, self.lon_deg, **self.spa_kwargs)
            for kk, d in zip(ks.tolist(), pos.direction_enu, strict=True):
                self._knots[kk] = d
        return self._knots[k]

    def __call__(
        self,
        utc: dt.datetime | np.datetime64 | pd.Timestamp | str,
        lat_deg: float | None = None,
        lon_deg: float | None = None,
    ) -> SunPosition:
        """The apparent sun position at one instant (interpolated between SPA knots).

        Args:
            utc: The instant.
            lat_deg: Where the observer is now, if not at the tracker's place (a moving vehicle):
                the direction is turned from the tracker's local ENU frame into the observer's
                (:func:`move_enu`). Must be given together with ``lon_deg``.
            lon_deg: Longitude of the observer, degrees East.
        """
        idx, scalar = _to_utc_index(utc)
        if not scalar:
            raise ValueError("SunTracker takes one instant; use sun_position() for many")
        t_s = idx.as_unit("ns").asi8[0] / 1e9  # pandas may store us or ns: ask for ns
        q = t_s / self.knot_s
        k = math.floor(q)
        w = q - k
        d = (1.0 - w) * self._knot(k) + w * self._knot(k + 1)
        if lat_deg is not None and lon_deg is not None:
            d = move_enu(d, self.lat_deg, self.lon_deg, lat_deg, lon_deg)
        d /= np.linalg.norm(d)
        zen = math.atan2(math.hypot(d[0], d[1]), d[2])
        az = math.atan2(d[0], d[1]) % (2.0 * math.pi)
        elev = math.pi / 2 - zen
        return SunPosition(idx, zen, az, elev, d, elev < NIGHT_ELEVATION_RAD)


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
    the Earth frame (1 km over 1.5e8 km turns it by 4e-7°) and only the local axes turn.
    What this does not carry over is the change of refraction with the new elevation: the local
    vertical turns by 0.009° per km, and refraction's slope is at most ~0.2 °/° near the horizon
    (Bennett 1982), so the apparent position is off by < 2e-3° per km at the horizon and < 3e-5°
    per km above 20° elevation. Trackers are kept per 0.01° cell (≈ 1 km), see
    :func:`sun_direction_enu`.
    """
    if lat0_deg == lat1_deg and lon0_deg == lon1_deg:
        return np.array(d_enu, dtype=np.float64)
    return _enu_axes(lat1_deg, lon1_deg) @ (_enu_axes(lat0_deg, lon0_deg).T @ d_enu)


# ---- the vehicle computer's view: a tracker per declared place --------------------------------

_trackers: dict[tuple[int, int], SunTracker] = {}


def _place(latitude_deg: float, longitude_deg: float) -> tuple[int, int]:
    if not (math.isfinite(latitude_deg) and -90.0 <= latitude_deg <= 90.0):
        raise ValueError(f"latitude_deg: {latitude_deg!r}; allowed [-90, 90]")
    if not (math.isfinite(longitude_deg) and -180.0 <= longitude_deg <= 360.0):
        raise ValueError(f"longitude_deg: {longitude_deg!r}; allowed [-180, 360]")
    lon = (longitude_deg + 180.0) % 360.0 - 180.0
    # One tracker per 0.01° cell (about 1 km): a vehicle crossing cells pays one SPA batch
    # (~12 ms) per kilometre, and within a cell the direction is turned exactly to the
    # observer's own place (move_enu). Keyed by 1e-4° before, which cost a batch every 11 m.
    return round(latitude_deg * 100), round(lon * 100)


def sun_zenith_azimuth(
    utc: dt.datetime, latitude_deg: float, longitude_deg: float
) -> tuple[float, float]:
    """Apparent zenith and compass azimuth (clockwise from North) of the sun, rad (exact SPA)."""
    _place(latitude_deg, longitude_deg)
    pos = sun_position(utc, latitude_deg, (longitude_deg + 180.0) % 360.0 - 180.0)
    return float(pos.apparent_zenith_rad), float(pos.azimuth_rad)


def sun_direction_enu(
    utc: dt.datetime, latitude_deg: float, longitude_deg: float
) -> NDArray[np.float64]:
    """Unit ENU vector towards the sun (apparent position), interpolated between SPA knots."""
    key = _place(latitude_deg, longitude_deg)
    tracker = _trackers.get(key)
    if tracker is None:
        if len(_trackers) > 1000:
            _trackers.clear()
        tracker = _trackers[key] = SunTracker(key[0] * 1e-2, key[1] * 1e-2)
    lon = (longitude_deg + 180.0) % 360.0 - 180.0
    return np.asarray(tracker(utc, latitude_deg, lon).direction_enu, dtype=np.float64)
