"""The vehicle's sun ephemeris: NREL SPA (pvlib) for the declared place and the clock's UTC.

Onboard twin of ``sensors.polarimeter.sun`` (which the world renders with): the vehicle computes the
sun's direction itself, from what it knows, as a real vehicle computer would. One SPA evaluation
costs 5–20 ms (pandas and the full series), too much for every frame of every filter variant, so
:func:`sun_direction_enu` evaluates SPA at knots every 10 s, 64 knots a call, and interpolates
between them (the sun moves 0.04° in 10 s; the interpolated direction is within 1e-4° of a single
SPA call, checked in tests/onboard/test_ephemeris.py).
"""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pandas as pd
import pvlib
from numpy.typing import NDArray

_KNOT_S = 10.0
_BATCH = 64
_knots: dict[tuple[int, int, int], NDArray[np.float64]] = {}


def _check(utc: dt.datetime, latitude_deg: float, longitude_deg: float) -> pd.Timestamp:
    if not (math.isfinite(latitude_deg) and -90.0 <= latitude_deg <= 90.0):
        raise ValueError(f"latitude_deg: {latitude_deg!r}; allowed [-90, 90]")
    if not (math.isfinite(longitude_deg) and -180.0 <= longitude_deg <= 360.0):
        raise ValueError(f"longitude_deg: {longitude_deg!r}; allowed [-180, 360]")
    ts = pd.Timestamp(utc)
    return ts.tz_localize("UTC") if ts.tzinfo is None else ts.tz_convert("UTC")


def sun_zenith_azimuth(
    utc: dt.datetime, latitude_deg: float, longitude_deg: float
) -> tuple[float, float]:
    """Apparent zenith and compass azimuth (clockwise from North) of the sun, rad (exact SPA)."""
    ts = _check(utc, latitude_deg, longitude_deg)
    sp = pvlib.solarposition.spa_python(
        pd.DatetimeIndex([ts]), latitude_deg, longitude_deg, how="numpy"
    )
    return math.radians(float(sp["apparent_zenith"].iloc[0])), math.radians(
        float(sp["azimuth"].iloc[0])
    )


def _direction(zenith_rad: NDArray[np.float64], azimuth_rad: NDArray[np.float64]):
    sz = np.sin(zenith_rad)
    return np.stack([sz * np.sin(azimuth_rad), sz * np.cos(azimuth_rad), np.cos(zenith_rad)], -1)


def _knot(k: int, lat_e6: int, lon_e6: int) -> NDArray[np.float64]:
    key = (k, lat_e6, lon_e6)
    if key not in _knots:
        ks = np.arange(k, k + _BATCH)
        times = pd.DatetimeIndex(
            (ks * _KNOT_S * 1e9).astype("int64").astype("datetime64[ns]")
        ).tz_localize("UTC")
        sp = pvlib.solarposition.spa_python(times, lat_e6 * 1e-6, lon_e6 * 1e-6, how="numpy")
        dirs = _direction(
            np.radians(sp["apparent_zenith"].to_numpy()), np.radians(sp["azimuth"].to_numpy())
        )
        if len(_knots) > 100_000:  # a long campaign in one process: start afresh
            _knots.clear()
        for kk, d in zip(ks.tolist(), dirs, strict=True):
            _knots[(kk, lat_e6, lon_e6)] = d
    return _knots[key]


def sun_direction_enu(
    utc: dt.datetime, latitude_deg: float, longitude_deg: float
) -> NDArray[np.float64]:
    """Unit ENU vector towards the sun (apparent position), interpolated between SPA knots.

    The position is rounded to 1e-4° (11 m) for the knot cache: the sun's direction changes by
    less than 1e-4° over that distance.
    """
    ts = _check(utc, latitude_deg, longitude_deg)
    lat_e6 = round(latitude_deg * 1e4) * 100
    lon_e6 = round(longitude_deg * 1e4) * 100
    q = ts.as_unit("ns").value / 1e9 / _KNOT_S
    k = math.floor(q)
    w = q - k
    d = (1.0 - w) * _knot(k, lat_e6, lon_e6) + w * _knot(k + 1, lat_e6, lon_e6)
    return d / np.linalg.norm(d)
