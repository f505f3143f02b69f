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


@pytest.mark.parametrize("elevation_case", ["sunrise", "morning", "noon"])
def test_a_moving_observer_gets_its_own_place_without_a_new_spa_batch(elevation_case: str) -> None:
    """Anywhere in a tracker's 1° cell the direction is SPA's at the observer's own place.

    The geometric direction is turned to the place and refracted there, so the refraction is
    right at a low sun too (taken at the cell's centre it would be off by ~2e-3° per km there).
    """
    from twin.core.ephemeris import SunTracker

    hour, minute = {"sunrise": (21, 40), "morning": (23, 10), "noon": (4, 10)}[elevation_case]
    utc = dt.datetime(2021, 9, 2 if hour > 12 else 3, hour, minute, tzinfo=dt.UTC)  # UTC+8
    tracker = SunTracker(37.54, 122.06)
    for dlat, dlon in [(0.0049, 0.0), (0.0, -0.0049), (0.4, 0.0), (0.0, -0.45), (0.3, 0.35)]:
        lat, lon = 37.54 + dlat, 122.06 + dlon
        moved = tracker(utc, lat, lon).direction_enu
        exact = sun_position(utc, lat, lon).direction_enu
        assert _angle_deg(moved, exact) < 1e-4
        # ... and the correction is not a no-op: 500 m already turns the local axes by > 3e-4°,
        # three times the tolerance above.
        assert _angle_deg(tracker(utc).direction_enu, exact) > 3e-4
    assert len(tracker._knots) == tracker.batch  # one SPA batch served every place
    if elevation_case == "sunrise":  # the case where refraction matters: a sun just up
        assert 0.5 < math.degrees(math.asin(exact[2])) < 8.0


def test_epoch_seconds_are_pandas_own() -> None:
    """The frame path's epoch seconds equal pandas' to the bit, for every accepted time type."""
    import pandas as pd

    from twin.core.ephemeris import epoch_s

    for t in (
        dt.datetime(2021, 9, 3, 2, 30, 0, 123457),
        dt.datetime(2021, 9, 3, 2, 30, 0, 999999, tzinfo=dt.UTC),
        dt.datetime(2021, 9, 3, 10, 30, tzinfo=dt.timezone(dt.timedelta(hours=8))),
        dt.datetime(1969, 12, 31, 23, 59, 59, 5),
    ):
        ns = pd.DatetimeIndex([t]).as_unit("ns")
        ns = ns.tz_localize("UTC") if ns.tz is None else ns.tz_convert("UTC")
        assert epoch_s(t) == ns.asi8[0] / 1e9
    assert epoch_s("2021-09-03T02:30:00Z") == epoch_s(dt.datetime(2021, 9, 3, 2, 30))
    assert epoch_s(np.datetime64("2021-09-03T02:30:00")) == epoch_s(dt.datetime(2021, 9, 3, 2, 30))


def test_a_drifting_estimate_pays_one_spa_batch_per_cell() -> None:
    """A filter whose position estimate runs away (kilometres a frame) reuses its cell's knots."""
    from twin.core import ephemeris

    ephemeris._trackers.clear()
    utc = dt.datetime(2021, 9, 3, 2, 30, tzinfo=dt.UTC)
    for k in range(200):  # 200 frames, the estimate 550 m further north each frame: 110 km
        ephemeris.sun_direction_enu(utc + dt.timedelta(seconds=k), 37.54 + k * 0.005, 122.06)
    assert len(ephemeris._trackers) == 2  # 37.54° → 38.54°: the cells of 38° and 39°
    assert all(len(t._knots) == t.batch for t in ephemeris._trackers.values())
