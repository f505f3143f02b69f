"""ROI-A (fang2024) and Snell-window attitude (xin2024) on rendered frames with known truth."""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter.render import OpticsConfig
from twin.core.frames import euler_to_dcm
from twin.onboard.compass import create
from twin.onboard.compass.base import CompassContext
from twin.onboard.compass.geometry import meridian_basis
from twin.onboard.compass.roia import RoiaConfig, RoiaMethod, p_scattered, tilt_rad, zenith_crop
from twin.onboard.compass.snell import SnellWindowMethod, robust_sinusoid
from twin.onboard.compass.snell_config import SnellConfig
from twin.onboard.compass.working_frame import (
    bin_mosaic,
    binned_calibration,
    binning_for,
    evectors_at,
    to_stokes,
)

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
    # A high sun. In the radiative-transfer light field the Snell-window method fails for suns at
    # or below ~50–60° elevation at 2 m of Jerlov II (roll errors of 9–30°, or no Hough line
    # through the zenith): the forward-scattered aureole swamps the rim on the sun's side
    # (validation/results/campaigns/snell_attitude/report.md). That is a result about the
    # method, kept visible there; this test checks the method where it works.
    sun = sun_vec(70, 200)
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
    # Sun well inside the window (as test_snell_noisy_attitude): at 40° of elevation the Snell
    # method's brightness test of the 180° ambiguity is marginal in this light field
    # (validation/results/campaigns/snell_attitude/report.md).
    sun = sun_vec(70, 100)
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


# ---- speed-ups: working frame, crops, resampled Stokes ------------------------------------------
def test_evectors_at_matches_calibration():
    """evectors_at on arbitrary rays = CameraCalibration.evectors on its grid, both mappings."""
    import dataclasses

    base = sensors.create("polarimeter", "ideal_bin4").calibration()
    rng = np.random.default_rng(5)
    for mapping in ("meridional", "orthographic"):
        cal = dataclasses.replace(base, polarization_mapping=mapping)
        rays, valid = cal.rays("superpixel")
        aop = rng.uniform(-math.pi / 2, math.pi / 2, rays.shape[:2])
        ref = cal.evectors(aop, "superpixel")
        sel = valid & (rays[..., 2] > 0.05)
        got = evectors_at(cal, rays[sel], aop[sel])
        np.testing.assert_allclose(got, ref[sel], atol=1e-12)


def test_bin_mosaic_registered_and_calibrated():
    """Binning 4× in software gives the on-sensor binning-4 camera's geometry and registration."""
    full = sensors.create("polarimeter", "phx050s_p").calibration()
    binned = sensors.create("polarimeter", "phx050s_p_bin4").calibration()
    assert binning_for(full, 640) == 4 and binning_for(binned, 640) == 1
    assert binning_for(full, None) == 1
    cal4 = binned_calibration(full, 4)
    assert (cal4.width_px, cal4.height_px) == (binned.width_px, binned.height_px)
    assert math.isclose(cal4.focal_px, binned.focal_px)
    np.testing.assert_allclose(cal4.principal_point_px, binned.principal_point_px)
    # A ramp is reproduced at the binned pixels' nominal positions b·k + (b − 1)/2, every phase.
    for b in (2, 4, 8):
        v, u = np.mgrid[0:128, 0:96].astype(np.float64)
        out = bin_mosaic((3.0 * u + 7.0 * v).astype(np.float32), b)
        vb, ub = np.mgrid[0 : 128 // b, 0 : 96 // b]
        nominal = 3.0 * (b * ub + (b - 1) / 2) + 7.0 * (b * vb + (b - 1) / 2)
        np.testing.assert_allclose(out[2:-2, 2:-2], nominal[2:-2, 2:-2], atol=1e-3)
    # A clipped source pixel keeps its binned pixel clipped.
    raw = np.full((32, 32), 1000, np.uint16)
    raw[9, 10] = 4095
    out = bin_mosaic(raw, 4, saturation_dn=4095)
    assert out[3, 2] == 4095  # raw (9, 10): phase (1, 0) of binned super-pixel (1, 1)
    assert 1 <= np.count_nonzero(out >= 4095) <= 4  # and the neighbours its kernel reaches


def test_robust_sinusoid_rejects_a_sector():
    phi = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    y = 0.84 + 0.05 * np.cos(phi) - 0.02 * np.sin(phi)
    y = y + np.random.default_rng(1).normal(0, 1e-3, phi.size)
    y[40:110] -= 0.2  # the sun's glow: a 70° sector of wrong edges
    (c0, c1, c2), n_in = robust_sinusoid(phi, y, floor=1e-4)
    assert abs(c0 - 0.84) < 1e-3 and abs(c1 - 0.05) < 1e-3 and abs(c2 + 0.02) < 1e-3
    assert 280 <= n_in <= 300


@pytest.mark.parametrize(("roll", "pitch"), [(0, 25), (-50, 0), (0, -50)])
def test_snell_rim_fit_recovers_from_a_far_start(noisy, roll, pitch):
    """The rim fit converges from a centroid 12° off (the glow's pull; the benchmark outliers)."""
    sun = sun_vec(35, 150)
    raw, _ = render(noisy, roll, pitch, 137.0, sun, seed=4)
    cal = noisy.calibration()
    m = SnellWindowMethod()
    pol = to_stokes(raw, cal)
    truth = euler_to_dcm(math.radians(roll), math.radians(pitch), 0.0).T @ [0.0, 0.0, 1.0]
    for az in (0.0, 2.0, 4.0):
        t1 = np.cross(truth, [1.0, 0.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(truth, t1)
        off = math.radians(12.0)
        z0 = math.cos(off) * truth + math.sin(off) * (math.cos(az) * t1 + math.sin(az) * t2)
        lg = np.log(np.maximum(0.5 * pol.s0, 1.0)).astype(np.float32)
        z, n_in = m._fit_rim(cal, lg, z0, math.asin(1 / 1.338))
        err = math.degrees(math.acos(min(1.0, float(z @ truth))))
        assert err < 0.25, (az, err)
        assert n_in > 100


def test_full_resolution_frame():
    """2448×2048: Snell works on the binned working frame, ROI-A on a crop; both accurate."""
    cam = sensors.create("polarimeter", "phx050s_p")
    cam.configure(OpticsConfig(jerlov_type="II"))
    cal = cam.calibration()
    sun = sun_vec(70, 200)  # well inside the window (see test_snell_noisy_attitude)
    r, p, h = 10.0, -20.0, 45.0
    raw, _ = render(cam, r, p, h, sun, seed=2)
    fs = SnellWindowMethod().solve(raw, cal, ctx_for(sun))
    assert fs.ok, fs.reason
    assert fs.extras["work_binning"] == 4
    assert abs(math.degrees(fs.roll_rad) - r) < 0.3
    assert abs(math.degrees(fs.pitch_rad) - p) < 0.3
    # 0.80° measured: the sky's polarized scattered light (radiative transfer with the sky
    # model's sky) bends the window's AoE pattern that the meridian fit reads; 0.3° before it.
    assert abs(hdg_err(fs, h)) < 1.0
    fr = RoiaMethod().solve(raw, cal, ctx_for(sun, r, p))
    assert fr.ok, fr.reason
    assert abs(hdg_err(fr, h)) < 0.3
    # The zenith-region crop is whole super-pixels and holds the region.
    zen = euler_to_dcm(math.radians(r), math.radians(p), 0.0).T @ [0.0, 0.0, 1.0]
    v0, v1, u0, u1 = zenith_crop(cal, zen, math.radians(7.6))
    assert all(x % 2 == 0 for x in (v0, v1, u0, u1))
    rays, valid = cal.rays("superpixel")
    inside = valid & (rays @ zen >= math.cos(math.radians(7.6)))
    vv, uu = np.nonzero(inside)
    assert 2 * vv.min() >= v0 + 2 and 2 * vv.max() + 2 <= v1 - 2
    assert 2 * uu.min() >= u0 + 2 and 2 * uu.max() + 2 <= u1 - 2


@pytest.mark.parametrize("scale", [0.99, 0.995, 1.005, 1.01, 1.02])
def test_snell_survives_a_focal_length_error_in_the_onboard_calibration(scale):
    """The onboard focal length off by 0.5–2 %: the rim fit still finds the window.

    Clear water (Jerlov I), sun 35° up: measured 0.04–0.26° roll error for 1–2 % (0.03° with
    the true focal length); a rim fit that locked on the wrong radius would be off by degrees.
    """
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type="I"))
    sun = sun_vec(35, 100)
    raw, _ = render(cam, 10, 5, 33, sun)
    cal = dataclasses.replace(cam.calibration(), focal_px=cam.calibration().focal_px * scale)
    fix = SnellWindowMethod().solve(raw, cal, ctx_for(sun, 10, 5))
    assert fix.ok, fix.reason
    assert abs(math.degrees(fix.roll_rad) - 10.0) < 0.5
    assert abs(math.degrees(fix.pitch_rad) - 5.0) < 0.5
    assert abs(hdg_err(fix, 33.0)) < 0.5
