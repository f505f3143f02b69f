"""The vehicle's sun ephemeris: NREL SPA (pvlib) for the declared place and the clock's UTC.

Onboard twin of ``sensors.polarimeter.sun`` (which the world renders with): the vehicle computes the
sun's direction itself, from what it knows, as a real vehicle computer would.
"""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pandas as pd
import pvlib
from numpy.typing import NDArray


def sun_zenith_azimuth(
    utc: dt.datetime, latitude_deg: float, longitude_deg: float
) -> tuple[float, float]:
    """Apparent zenith and compass azimuth (clockwise from North) of the sun, radians."""
    ts = pd.Timestamp(utc)
    ts = ts.tz_localize("UTC") if ts.tzinfo is None else ts.tz_convert("UTC")
    sp = pvlib.solarposition.spa_python(
        pd.DatetimeIndex([ts]), latitude_deg, longitude_deg, how="numpy"
    )
    return math.radians(float(sp["apparent_zenith"].iloc[0])), math.radians(
        float(sp["azimuth"].iloc[0])
    )


def sun_direction_enu(
    utc: dt.datetime, latitude_deg: float, longitude_deg: float
) -> NDArray[np.float64]:
    """Unit ENU vector towards the sun (apparent position)."""
    z, a = sun_zenith_azimuth(utc, latitude_deg, longitude_deg)
    return np.array([math.sin(z) * math.sin(a), math.sin(z) * math.cos(a), math.cos(z)])
