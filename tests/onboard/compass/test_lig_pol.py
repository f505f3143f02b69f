"""LIG and POL compass methods on rendered frames with known truth (ideal/noisy bin4 cameras).

Tolerances are what the twin's world model allows, not what the paper reports: the rendered
in-water radiance is *not* a function of the scattering angle alone (sky gradation, Fresnel and
path-length fall-off, and the multiply scattered light of the radiative-transfer field are
centred on the zenith or on the refracted sun), so LIG's elevation carries a bias even in clear
water, while its azimuth (heading) is protected by the solar-meridian symmetry. POL is nearly
exact at 2 m and its apparent sun drifts towards the zenith with depth (what transport gives:
validation/results/campaigns/compass_underwater/report.md).
"""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter.render import OpticsConfig
from twin.core.frames import euler_to_dcm
from twin.onboard.compass import available, create
from twin.onboard.compass.analysis_grid import analysis_geometry, block_intensity
from twin.onboard.compass.base import CompassContext
from twin.onboard.polarization import stokes_from_mosaic

UTC = dt.datetime(2021, 7, 31, 4, 0, tzinfo=dt.UTC)


def _sun(az_deg: float, el_deg: float) -> np.ndarray:
    az, el = math.radians(az_deg), math.radians(el_deg)
    return np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])


@pytest.fixture(scope="module")
def ideal():
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure(OpticsConfig(jerlov_type="II"))
    return cam


def _frame(cam, depth, sun, roll=0.0, pitch=0.0, yaw=0.0, seed=0):
    c_b_n = euler_to_dcm(math.radians(roll), math.radians(pitch), math.radians(yaw))
    raw, _truth = cam.render_offline(c_b_n, depth, sun, np.random.default_rng(seed))
    ctx = CompassContext(
        UTC,
        36.175,
        120.482,
        roll_rad=math.radians(roll),
        pitch_rad=math.radians(pitch),
        depth_m=depth,
        water_index=cam.n_water,
        sun_enu=sun,
    )
    return raw, ctx, c_b_n.T @ sun, (-yaw) % 360.0


def _errors(fix, sun_body_true, heading_true):
    """(zenith error, heading error) in degrees; zenith in the body frame."""
    dz = math.degrees(math.acos(fix.sun_body[2]) - math.acos(sun_body_true[2]))
    dh = (fix.heading_deg - heading_true + 180.0) % 360.0 - 180.0
    return dz, dh


def test_registered():
    assert {"lig", "pol"} <= set(available())


def test_lig_intensity_is_block_mean_of_shared_s0(ideal):
    raw, _, _, _ = _frame(ideal, 5.0, _sun(120, 40))
    cal = ideal.calibration()
    geo = analysis_geometry(cal, 4)
    s0, _ = block_intensity(raw, cal, geo)
    ref = stokes_from_mosaic(raw, cal.layout_deg, black_level_dn=cal.black_level_dn).s0
    h, w = s0.shape
    ref_b = ref[: 2 * h, : 2 * w].reshape(h, 2, w, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(s0, ref_b, rtol=1e-5, atol=1e-2)


@pytest.mark.parametrize("az,el", [(120.0, 40.0), (250.0, 60.0)])
def test_pol_accurate_shallow_clear(ideal, az, el):
    raw, ctx, sb, hdg = _frame(ideal, 2.0, _sun(az, el), yaw=-30.0)
    fix = create("pol").solve(raw, ideal.calibration(), ctx)
    assert fix.ok, fix.reason
    dz, dh = _errors(fix, sb, hdg)
    assert abs(dh) < 1.0 and abs(dz) < 4.0
    assert fix.pixels_used > 1000 and fix.eigen_gap > 10
    assert np.all(np.isfinite(fix.covariance_body))


@pytest.mark.parametrize("az,el", [(120.0, 40.0), (250.0, 60.0)])
def test_lig_accurate_clear(ideal, az, el):
    raw, ctx, sb, hdg = _frame(ideal, 5.0, _sun(az, el), yaw=-30.0)
    fix = create("lig").solve(raw, ideal.calibration(), ctx)
    assert fix.ok, fix.reason
    dz, dh = _errors(fix, sb, hdg)
    assert abs(dh) < 1.0  # azimuth: protected by the solar-meridian symmetry
    # Elevation: the world's radiance is not sun-centred. The sky's scattered light, brighter
    # towards the sun's azimuth but low in the sky, pulls LIG's apparent sun by 13–23° here
    # (measured; validation/results/campaigns/compass_underwater/report.md across depth and
    # water); a broken
    # fit is off by tens of degrees more.
    assert abs(dz) < 30.0
    assert fix.heading_sigma_rad is not None and fix.heading_sigma_rad > 0


@pytest.mark.parametrize("name", ["lig", "pol"])
@pytest.mark.parametrize(
    "az,roll,pitch,yaw",
    [(30.0, -6.0, 3.0, 100.0), (300.0, 4.0, 8.0, 0.0), (200.0, 8.0, -5.0, 170.0)],
)
def test_tilted_heading_and_sun_side(ideal, name, az, roll, pitch, yaw):
    """Tilted vehicle with the roll/pitch hint from truth; the sun on any side (sun/anti-sun)."""
    raw, ctx, sb, hdg = _frame(ideal, 5.0, _sun(az, 50.0), roll, pitch, yaw)
    fix = create(name).solve(raw, ideal.calibration(), ctx)
    assert fix.ok, fix.reason
    _, dh = _errors(fix, sb, hdg)
    assert abs(dh) < 2.0  # an unresolved sun/anti-sun would be 180°
    assert fix.sun_h[2] > 0


def test_pol_bias_grows_with_depth(ideal):
    """Multiply scattered light pulls POL's apparent sun towards the zenith with depth."""
    sun = _sun(120.0, 40.0)
    dz = []
    for depth in (2.0, 15.0):
        raw, ctx, sb, hdg = _frame(ideal, depth, sun)
        fix = create("pol").solve(raw, ideal.calibration(), ctx)
        dz.append(_errors(fix, sb, hdg)[0])
    assert dz[1] < dz[0] - 5.0


def test_night_is_no_fix(ideal):
    raw, ctx, _, _ = _frame(ideal, 5.0, _sun(120, 40))
    night = CompassContext(UTC, 36.0, 120.0, water_index=ctx.water_index, sun_enu=_sun(0, -10))
    for name in ("lig", "pol"):
        fix = create(name).solve(raw, ideal.calibration(), night)
        assert not fix.ok and "night" in fix.reason and fix.sun_body is None


def test_deep_and_dark_frames_are_no_fix():
    cam = sensors.create("polarimeter", "phx050s_p_bin4")  # fixed 700 µs exposure, noisy
    cam.configure(OpticsConfig(jerlov_type="II"))
    cal = cam.calibration()
    raw, ctx, _, _ = _frame(cam, 200.0, _sun(120, 40))
    dark = np.full_like(raw, int(cal.black_level_dn))
    for name in ("lig", "pol"):
        for frame in (raw, dark):
            fix = create(name).solve(frame, cal, ctx)
            assert not fix.ok and "too dark" in fix.reason


@pytest.mark.parametrize("name", ["lig", "pol"])
def test_noisy_camera_and_determinism(name):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type="II"))
    raw, ctx, sb, hdg = _frame(cam, 5.0, _sun(120, 40), 3.0, -2.0, 20.0, seed=3)
    a = create(name).solve(raw, cam.calibration(), ctx)
    b = create(name).solve(raw.copy(), cam.calibration(), ctx)
    assert a.ok, a.reason
    assert abs(_errors(a, sb, hdg)[1]) < 2.0
    np.testing.assert_array_equal(a.sun_body, b.sun_body)
    np.testing.assert_array_equal(a.covariance_body, b.covariance_body)
    assert a.pixels_used == b.pixels_used and a.extras == b.extras


@pytest.mark.parametrize("name", ["lig", "pol"])
def test_bad_input_names_the_field(ideal, name):
    raw, ctx, _, _ = _frame(ideal, 5.0, _sun(120, 40))
    with pytest.raises(ValueError, match=r"raw\.shape"):
        create(name).solve(raw[:, :-2], ideal.calibration(), ctx)
    with pytest.raises(ValueError, match="raw"):
        create(name).solve(raw.tolist(), ideal.calibration(), ctx)  # type: ignore[arg-type]


def test_config_validation_names_the_field():
    from twin.onboard.compass.lig import LigConfig
    from twin.onboard.compass.pol import PolConfig

    with pytest.raises(ValueError, match=r"LigConfig\.median_ksize"):
        LigConfig(median_ksize=7)
    with pytest.raises(ValueError, match=r"PolConfig\.min_dop"):
        PolConfig(min_dop=2.0)
