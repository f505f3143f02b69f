"""The vehicle's ephemeris: interpolated SPA agrees with exact SPA and with the world's sun."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

from sensors.polarimeter.optics.sun import sun_position
from twin.core.ephemeris import sun_direction_enu, sun_zenith_azimuth


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(min(1.0, float(np.dot(a, b)))))


@pytest.mark.parametrize("seconds", [0.0, 3.7, 5.0, 9.999, 1234.5, 86399.0])
def test_interpolated_direction_matches_exact_spa(seconds: float) -> None:
    utc = dt.datetime(2021, 9, 3, 2, 0, tzinfo=dt.UTC) + dt.timedelta(seconds=seconds)
    z, a = sun_zenith_azimuth(utc, 37.54, 122.06)
    exact = np.array([math.sin(z) * math.sin(a), math.sin(z) * math.cos(a), math.cos(z)])
    assert (
        _angle_deg(sun_direction_enu(utc, 37.54, 122.06), exact) < 1e-4
    )  # SPA batch vs single call differ by ~6e-5° (pvlib), far below any sensor
    world = sun_position(utc, 37.54, 122.06).direction_enu  # the renderer's sun
    assert (
        _angle_deg(sun_direction_enu(utc, 37.54, 122.06), world) < 1e-4
    )  # SPA batch vs single call differ by ~6e-5° (pvlib), far below any sensor


def test_naive_times_are_utc_and_bad_places_name_the_field() -> None:
    aware = dt.datetime(2021, 9, 3, 2, 0, tzinfo=dt.UTC)
    naive = dt.datetime(2021, 9, 3, 2, 0)
    np.testing.assert_array_equal(
        sun_direction_enu(aware, 37.54, 122.06), sun_direction_enu(naive, 37.54, 122.06)
    )
    with pytest.raises(ValueError, match="latitude_deg"):
        sun_direction_enu(aware, 95.0, 0.0)
    with pytest.raises(ValueError, match="longitude_deg"):
        sun_direction_enu(aware, 0.0, float("nan"))


@pytest.mark.parametrize("elevation_case", ["morning", "noon"])
def test_a_moving_observer_gets_its_own_place_without_a_new_spa_batch(elevation_case: str) -> None:
    """Within a tracker's 0.01° cell the direction is turned to the observer's exact place."""
    from twin.core.ephemeris import SunTracker

    hour = 23 if elevation_case == "morning" else 4  # UTC; Weihai is UTC+8
    utc = dt.datetime(2021, 9, 3, hour, 10, tzinfo=dt.UTC)
    tracker = SunTracker(37.54, 122.06)
    for dlat, dlon in [(0.0049, 0.0), (0.0, -0.0049), (0.004, 0.004), (0.03, 0.05)]:
        lat, lon = 37.54 + dlat, 122.06 + dlon
        moved = tracker(utc, lat, lon).direction_enu
        exact = sun_position(utc, lat, lon).direction_enu
        assert _angle_deg(moved, exact) < 1e-4
        # ... and the correction is not a no-op: 500 m already turns the local axes by > 1e-3°.
        assert _angle_deg(tracker(utc).direction_enu, exact) > 1e-3
    assert len(tracker._knots) == tracker.batch  # one SPA batch served every place
