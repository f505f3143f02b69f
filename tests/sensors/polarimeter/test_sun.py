from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pandas as pd
import pytest

from sensors.polarimeter.optics.sun import (
    NIGHT_ELEVATION_DEG,
    SunTracker,
    direction_from_zenith_azimuth,
    sun_position,
)

# NREL SPA reference case (Reda & Andreas 2004, Table A5.1; optics.md §5): Golden, Colorado.
SPA_CASE = {
    "utc": dt.datetime(2003, 10, 17, 12, 30, 30, tzinfo=dt.timezone(dt.timedelta(hours=-7))),
    "lat_deg": 39.742476,
    "lon_deg": -105.1786,
    "altitude_m": 1830.14,
    "pressure_pa": 82000.0,
    "temperature_c": 11.0,
    "delta_t_s": 67.0,
    "atmos_refract_deg": 0.5667,
}
SPA_ZENITH_DEG = 50.11162  # topocentric zenith angle (refraction-corrected)
SPA_AZIMUTH_DEG = 194.34024


def _spa_case() -> dict:
    kw = dict(SPA_CASE)
    return {"utc": kw.pop("utc"), "lat_deg": kw.pop("lat_deg"), "lon_deg": kw.pop("lon_deg"), **kw}


def test_nrel_spa_reference_case() -> None:
    kw = _spa_case()
    sun = sun_position(kw.pop("utc"), kw.pop("lat_deg"), kw.pop("lon_deg"), **kw)
    assert math.degrees(sun.apparent_zenith_rad) == pytest.approx(SPA_ZENITH_DEG, abs=1e-4)
    assert math.degrees(sun.azimuth_rad) == pytest.approx(SPA_AZIMUTH_DEG, abs=1e-4)
    assert sun.elevation_rad == pytest.approx(math.pi / 2 - sun.apparent_zenith_rad, abs=1e-12)
    assert sun.is_night is False


def test_direction_enu_is_consistent() -> None:
    kw = _spa_case()
    sun = sun_position(kw.pop("utc"), kw.pop("lat_deg"), kw.pop("lon_deg"), **kw)
    d = sun.direction_enu
    assert d.shape == (3,)
    assert np.linalg.norm(d) == pytest.approx(1.0, abs=1e-12)
    assert math.acos(d[2]) == pytest.approx(sun.apparent_zenith_rad, abs=1e-12)
    # Compass azimuth, clockwise from North: atan2(East, North).
    assert math.atan2(d[0], d[1]) % (2 * math.pi) == pytest.approx(sun.azimuth_rad, abs=1e-12)
    # Azimuth 194° (SSW): the sun is south and slightly west.
    assert d[1] < 0 and d[0] < 0
    np.testing.assert_allclose(
        direction_from_zenith_azimuth(math.radians(90), math.radians(90)), [1, 0, 0], atol=1e-15
    )


def test_time_inputs_are_equivalent() -> None:
    aware = SPA_CASE["utc"]
    naive_utc = aware.astimezone(dt.UTC).replace(tzinfo=None)
    kw = {"delta_t_s": 67.0}
    ref = sun_position(aware, 39.742476, -105.1786, **kw)
    for t in (naive_utc, np.datetime64(naive_utc), pd.Timestamp(aware), "2003-10-17T19:30:30"):
        other = sun_position(t, 39.742476, -105.1786, **kw)
        assert other.apparent_zenith_rad == pytest.approx(ref.apparent_zenith_rad, abs=1e-12)
        assert other.azimuth_rad == pytest.approx(ref.azimuth_rad, abs=1e-12)


def test_vectorised_over_times_matches_scalar_calls() -> None:
    t0 = dt.datetime(2024, 6, 21, 0, 0, tzinfo=dt.UTC)
    times = [t0 + dt.timedelta(hours=h) for h in range(0, 24, 5)]
    many = sun_position(times, 43.5, 6.3)
    assert many.direction_enu.shape == (len(times), 3)
    for i, t in enumerate(times):
        one = sun_position(t, 43.5, 6.3)
        assert many.apparent_zenith_rad[i] == pytest.approx(one.apparent_zenith_rad, abs=1e-12)
        np.testing.assert_allclose(many.direction_enu[i], one.direction_enu, atol=1e-12)
        assert bool(many.is_night[i]) == one.is_night


def test_night_threshold() -> None:
    # Marseille, 21 June 2024: sunset ≈ 19:15 UTC. Scan across it.
    t0 = dt.datetime(2024, 6, 21, 19, 0, tzinfo=dt.UTC)
    times = [t0 + dt.timedelta(minutes=m) for m in range(0, 40, 2)]
    sun = sun_position(times, 43.3, 5.37)
    elev_deg = np.degrees(sun.elevation_rad)
    np.testing.assert_array_equal(sun.is_night, elev_deg < NIGHT_ELEVATION_DEG)
    assert not sun.is_night[0] and sun.is_night[-1]
    midnight = sun_position(dt.datetime(2024, 6, 21, 23, 0, tzinfo=dt.UTC), 43.3, 5.37)
    assert midnight.is_night and np.isfinite(midnight.direction_enu).all()
    assert midnight.direction_enu[2] < 0


def test_tracker_matches_spa() -> None:
    tracker = SunTracker(43.3, 5.37, knot_s=10.0, delta_t_s=69.0)
    t0 = dt.datetime(2024, 3, 20, 9, 0, 3, 250000, tzinfo=dt.UTC)
    for s in (0.0, 0.1, 4.9, 123.4, 3600.0):
        t = t0 + dt.timedelta(seconds=s)
        a = tracker(t)
        b = sun_position(t, 43.3, 5.37, delta_t_s=69.0)
        ang = math.atan2(
            np.linalg.norm(np.cross(a.direction_enu, b.direction_enu)),
            float(a.direction_enu @ b.direction_enu),
        )
        assert math.degrees(ang) < 1e-5
        assert a.azimuth_rad == pytest.approx(b.azimuth_rad, abs=1e-6)
        assert a.is_night == b.is_night
    with pytest.raises(ValueError, match="one instant"):
        tracker([t0, t0])


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"lat_deg": 91.0}, "lat_deg"),
        ({"lon_deg": float("nan")}, "lon_deg"),
        ({"pressure_pa": 0.0}, "pressure_pa"),
        ({"temperature_c": 150.0}, "temperature_c"),
        ({"delta_t_s": float("inf")}, "delta_t_s"),
        ({"utc": "not a time"}, "utc"),
    ],
)
def test_validation(kwargs: dict, field: str) -> None:
    args = {"utc": dt.datetime(2024, 1, 1, tzinfo=dt.UTC), "lat_deg": 10.0, "lon_deg": 20.0}
    args.update(kwargs)
    with pytest.raises(ValueError, match=field):
        sun_position(args.pop("utc"), args.pop("lat_deg"), args.pop("lon_deg"), **args)


def test_the_numpy_delta_t_path_gives_pvlibs_own_numbers() -> None:
    # sun_position computes pvlib's ΔT estimate on numpy arrays (fast) instead of letting
    # spa_python compute it on the pandas index: the positions must be pvlib's to the last bit.
    import pandas as pd
    import pvlib

    idx = pd.date_range("2021-09-03T02:00Z", periods=64, freq="10s")
    ours = sun_position(idx, 37.54, 122.06)
    ref = pvlib.solarposition.spa_python(
        idx,
        37.54,
        122.06,
        pressure=101325.0,
        temperature=12.0,
        delta_t=None,
        atmos_refract=0.5667,
        how="numpy",
    )
    np.testing.assert_array_equal(
        np.radians(ref["azimuth"].to_numpy()) % (2 * np.pi), ours.azimuth_rad
    )
    np.testing.assert_array_equal(
        np.radians(ref["apparent_zenith"].to_numpy()), ours.apparent_zenith_rad
    )
