"""Stage 2 of the polarimeter chain: where the sun is.

The world and the vehicle computer share one ephemeris, :mod:`twin.core.ephemeris` (NREL SPA via
pvlib, apparent position, knots interpolated by :class:`SunTracker`); this stage names what the
chain uses from it.
"""

from __future__ import annotations

from twin.core.ephemeris import (
    NIGHT_ELEVATION_DEG,
    NIGHT_ELEVATION_RAD,
    SunPosition,
    SunTracker,
    TimeLike,
    direction_from_zenith_azimuth,
    sun_position,
)

__all__ = [
    "NIGHT_ELEVATION_DEG",
    "NIGHT_ELEVATION_RAD",
    "SunPosition",
    "SunTracker",
    "TimeLike",
    "direction_from_zenith_azimuth",
    "sun_position",
]
