"""Stage 2 of the polarimeter chain: where the sun is.

The world and the vehicle computer share one ephemeris, :mod:`twin.core.ephemeris` (NREL SPA via
pvlib, apparent position, knots interpolated by :class:`SunTracker`); this stage names what the
chain uses from it.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twin.core.ephemeris import (
    NIGHT_ELEVATION_DEG,
    NIGHT_ELEVATION_RAD,
    SunPosition,
    SunTracker,
    TimeLike,
    direction_from_zenith_azimuth,
    place_cell,
    sun_position,
)

__all__ = [
    "NIGHT_ELEVATION_DEG",
    "NIGHT_ELEVATION_RAD",
    "SunPosition",
    "SunTracker",
    "TimeLike",
    "direction_from_zenith_azimuth",
    "is_night",
    "place_cell",
    "sun_position",
    "sun_vector",
]


def sun_vector(sun: SunPosition | ArrayLike) -> NDArray[np.float64]:
    """The validated ENU unit vector towards the sun, from a :class:`SunPosition` or a 3-vector."""
    s = np.asarray(sun.direction_enu if isinstance(sun, SunPosition) else sun, dtype=np.float64)
    if s.shape != (3,) or not np.all(np.isfinite(s)):
        raise ValueError(f"sun direction must be a finite 3-vector (one instant), got {s!r}")
    if abs(float(np.linalg.norm(s)) - 1.0) > 1e-6:
        raise ValueError(
            f"sun direction must be a unit vector (|s| = 1 within 1e-6), got |s| = "
            f"{float(np.linalg.norm(s))!r}"
        )
    return s


def is_night(sun: SunPosition | ArrayLike) -> bool:
    """Whether the sun's apparent elevation is below the night threshold (sun.py)."""
    s = sun_vector(sun)
    return bool(s[2] < math.sin(NIGHT_ELEVATION_RAD))
