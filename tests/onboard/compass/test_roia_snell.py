"""ROI-A (fang2024) and Snell-window attitude (xin2024) on rendered frames with known truth."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter.render import OpticsConfig
from twin.frames import euler_to_dcm
from twin.onboard.compass import create
from twin.onboard.compass.base import CompassContext
from twin.onboard.compass.roia import RoiaConfig, RoiaMethod, p_scattered, tilt_rad
from twin.onboard.compass.snell import SnellConfig, SnellWindowMethod, meridian_basis

UTC = dt.datetime(2024, 6, 1, 12, 0)


def sun_vec(el_deg: float, az_deg: float) -> np.ndarray:
    el, az = math.radians(el_deg), math.radians(az_deg)
    return np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])


def ctx_for(sun: np.ndarray, roll=0.0, pitch=0.0, depth=2.0) -> CompassContext:
    return CompassContext(
        utc=UTC,
        latitude_deg=36.0,
        longitude_deg=120.0,
        roll_rad=math.radians(roll),
        pitch_rad=math.radians(pitch),
        depth_m=max(depth, 0.0),
        sun_enu=sun,
    )


def hdg_err(fix, heading_deg: float) -> float:
    return (fix.heading_deg - heading_deg + 180.0) % 360.0 - 180.0


@pytest.fixture(scope="module")
def ideal():
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure(OpticsConfig(jerlov_type="I"))
    return cam


@pytest.fixture(scope="module")
def noisy():
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type="II"))
    return cam


def render(cam, roll, pitch, heading, sun, depth=2.0, seed=0):
    c = euler_to_dcm(math.radians(roll), math.radians(pitch), math.radians(-heading))
    raw, truth = cam.render_offline(c, depth, sun, np.random.default_rng(seed))
    return raw, truth


def test_registered():
    assert isinstance(create("roia"), RoiaMethod)
    assert isinstance(create("snell"), SnellWindowMethod)


def test_eq12_is_rayleigh_scattering_of_refracted_sun():
    rng = np.random.default_rng(3)
    a_s, phi_s = 0.6, 1.0
    sw = np.array([math.sin(a_s) * math.cos(phi_s), math.sin(a_s) * math.sin(phi_s), math.cos(a_s)])
    a_p, phi_p = rng.uniform(0.01, 0.8, 50), rng.uniform(-3, 3, 50)
    d = np.stack([np.sin(a_p) * np.cos(phi_p), np.sin(a_p) * np.sin(phi_p), np.cos(a_p)], -1)
    e = np.cross(sw, d)
    et, ep = meridian_basis(d)
    ang = np.arctan2((e * ep).sum(-1), (e * et).sum(-1))
    diff = 0.5 * np.angle(np.exp(2j * (ang - p_scattered(a_s, a_p, phi_s - phi_p))))
    assert np.max(np.abs(diff)) < 1e-9
    assert tilt_rad(0.0, 0.0) == 0.0
    assert math.isclose(tilt_rad(math.radians(30), 0.0), math.radians(30))


@pytest.mark.parametrize(
    ("roll", "pitch", "heading", "el", "az"),
    [(0, 0, 30, 40, 120), (20, -10, 200, 55, 80), (-25, 30, 310, 25, 250)],
)
def test_roia_ideal_heading(ideal, roll, pitch, heading, el, az):
    sun = sun_vec(el, az)
    raw, _ = render(ideal, roll, pitch, heading, sun)
    fix = RoiaMethod().solve(raw, ideal.calibration(), ctx_for(sun, roll, pitch))
    assert fix.ok, fix.reason
    assert abs(hdg_err(fix, heading)) < 0.2
    assert fix.pixels_used > 100 and fix.eigen_gap > 10
    assert fix.covariance_body.shape == (3, 3) and np.all(np.isfinite(fix.covariance_body))
    assert abs(float(np.linalg.norm(fix.sun_body)) - 1) < 1e-12


def test_roia_needs_the_attitude_hint(ideal):
    """Tilted 25° with a level hint, the zenith region is off the zenith: the fix degrades."""
    sun = sun_vec(50, 100)
    raw, _ = render(ideal, 25, 0, 70, sun)
    cal = ideal.calibration()
    good = RoiaMethod().solve(raw, cal, ctx_for(sun, 25, 0))
    bad = RoiaMethod().solve(raw, cal, ctx_for(sun, 0, 0))
    assert good.ok and bad.ok
    assert abs(hdg_err(good, 70)) < 0.2
    assert abs(hdg_err(bad, 70)) > 5 * abs(hdg_err(good, 70)) + 1.0


def test_roia_noisy_heading(noisy):
    sun = sun_vec(45, 150)
    errs = []
    for seed, (r, p, h) in enumerate([(0, 0, 10), (15, -10, 120), (-20, 5, 250)]):
        raw, _ = render(noisy, r, p, h, sun, seed=seed)
        fix = RoiaMethod().solve(raw, noisy.calibration(), ctx_for(sun, r, p))
        assert fix.ok, fix.reason
        errs.append(abs(hdg_err(fix, h)))
    assert max(errs) < 1.5


@pytest.mark.parametrize(
    ("roll", "pitch", "heading", "el", "az"),
    [(0, 0, 30, 40, 120), (20, -10, 200, 55, 80), (-30, 25, 310, 30, 250), (0, -45, 10, 40, 30)],
)
def test_snell_ideal_attitude(ideal, roll, pitch, heading, el, az):
    sun = sun_vec(el, az)
    raw, _ = render(ideal, roll, pitch, heading, sun)
    fix = SnellWindowMethod().solve(raw, ideal.calibration(), ctx_for(sun))  # no hint used
    assert fix.ok, fix.reason
    # The window centroid carries ~0.5° of bias at low sun (the glow outside the window).
    assert abs(math.degrees(fix.roll_rad) - roll) < 1.0
    assert abs(math.degrees(fix.pitch_rad) - pitch) < 1.0
    assert abs(hdg_err(fix, heading)) < 0.5
    # Levelled with its own roll/pitch: sun_h's elevation is the ephemeris one.
    assert abs(fix.sun_h[2] - sun[2]) < 1e-9
    assert fix.extras["ambiguity_margin"] > 0.05


def test_snell_noisy_attitude(noisy):
    sun = sun_vec(35, 200)
    for seed, (r, p, h) in enumerate([(10, -20, 45), (-35, 15, 290)]):
        raw, _ = render(noisy, r, p, h, sun, seed=seed)
        fix = SnellWindowMethod().solve(raw, noisy.calibration(), ctx_for(sun))
        assert fix.ok, fix.reason
        assert abs(math.degrees(fix.roll_rad) - r) < 1.5
        assert abs(math.degrees(fix.pitch_rad) - p) < 1.5
        assert abs(hdg_err(fix, h)) < 1.0


def test_no_fix_at_night(ideal):
    sun_day = sun_vec(40, 100)
    raw, _ = render(ideal, 0, 0, 0, sun_day)
    night = sun_vec(-10, 100)
    for m in (RoiaMethod(), SnellWindowMethod()):
        fix = m.solve(raw, ideal.calibration(), ctx_for(night))
        assert not fix.ok and "night" in fix.reason and fix.sun_body is None


def test_no_fix_dark_and_deep(noisy):
    cal = noisy.calibration()
    sun = sun_vec(40, 100)
    dark = np.full((cal.height_px, cal.width_px), int(cal.black_level_dn), np.uint16)
    for m in (RoiaMethod(), SnellWindowMethod()):
        fix = m.solve(dark, cal, ctx_for(sun))
        assert not fix.ok and fix.reason
    deep, _ = render(noisy, 0, 0, 0, sun, depth=400.0)
    for m in (RoiaMethod(), SnellWindowMethod()):
        fix = m.solve(deep, cal, ctx_for(sun, depth=400.0))
        assert not fix.ok, m.name
        assert fix.reason


def test_deterministic(noisy):
    sun = sun_vec(40, 100)
    raw, _ = render(noisy, 10, 5, 33, sun)
    cal = noisy.calibration()
    for m in (RoiaMethod(), SnellWindowMethod()):
        a = m.solve(raw.copy(), cal, ctx_for(sun, 10, 5))
        b = m.solve(raw.copy(), cal, ctx_for(sun, 10, 5))
        assert a.ok and b.ok
        assert a.heading_rad == b.heading_rad
        np.testing.assert_array_equal(a.sun_body, b.sun_body)


def test_bad_input(ideal):
    cal = ideal.calibration()
    ctx = ctx_for(sun_vec(40, 100))
    for m in (RoiaMethod(), SnellWindowMethod()):
        with pytest.raises(ValueError, match="shape"):
            m.solve(np.zeros((10, 10), np.uint16), cal, ctx)
        with pytest.raises(ValueError, match="numpy"):
            m.solve([[1, 2]], cal, ctx)
        bad = np.zeros((cal.height_px, cal.width_px), np.float32)
        bad[0, 0] = np.nan
        with pytest.raises(ValueError, match="NaN"):
            m.solve(bad, cal, ctx)
        with pytest.raises(ValueError, match="calibration"):
            m.solve(np.zeros((cal.height_px, cal.width_px), np.uint16), None, ctx)
    with pytest.raises(ValueError, match="grey_fraction"):
        SnellConfig(grey_fraction=1.5)
    with pytest.raises(ValueError, match="zenith_radius_deg"):
        RoiaConfig(zenith_radius_deg=-1.0)
    with pytest.raises(ValueError, match="median_ksize"):
        SnellConfig(median_ksize=7)
