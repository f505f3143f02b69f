"""The polarimeter unit's error budget: calibration error and mounting, drawn per run."""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import numpy as np
import pytest

import sensors
from scenarios import parse_scenario
from scenarios.loader import ScenarioError
from scenarios.schema import HARDWARE_SIGMAS, Hardware
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.unit.hardware import (
    CalibrationUncertainty,
    HardwareErrors,
    HardwareUnit,
    MountingError,
)
from twin.core.frames import euler_to_dcm
from twin.onboard.compass import create
from twin.onboard.compass.base import CompassContext
from twin.world.assembly import hardware_errors

UTC = dt.datetime(2021, 7, 31, 4, 0, tzinfo=dt.UTC)
SUN = np.array([0.5 * math.cos(math.radians(40)), 0.866 * math.cos(math.radians(40)), 0.643])
SUN = SUN / np.linalg.norm(SUN)


def test_the_scenario_defaults_are_the_modules_sourced_defaults():
    h = Hardware()
    cal, mount, errs = CalibrationUncertainty(), MountingError(), HardwareErrors()
    for key in HARDWARE_SIGMAS["calibration"]:
        owner = next(o for o in (cal, errs.tolerance, errs) if hasattr(o, key))
        assert getattr(h, key) == getattr(owner, key)
    for key in HARDWARE_SIGMAS["mounting"]:
        assert getattr(h, key) == getattr(mount, key)
    assert hardware_errors(h) == HardwareErrors()
    assert hardware_errors(Hardware.ideal()).is_ideal
    assert not hardware_errors(Hardware.ideal()).drawn


def test_an_ideal_budget_draws_nothing_and_knows_the_camera_exactly():
    cam = sensors.create("polarimeter", "ideal_bin4")
    assert cam.hardware.is_ideal
    raw0, _ = cam.render_offline(np.eye(3), 3.0, SUN, np.random.default_rng(1))
    assert cam.unit is None
    assert cam.calibration() is cam.true_calibration()
    assert cam.clock_offset_s == 0.0
    again = sensors.create("polarimeter", "ideal_bin4")
    again.configure_hardware(HardwareErrors.ideal())
    raw1, _ = again.render_offline(np.eye(3), 3.0, SUN, np.random.default_rng(1))
    np.testing.assert_array_equal(raw0, raw1)


def test_the_draw_is_deterministic_and_has_the_declared_spread():
    true = sensors.create("polarimeter", "ideal_bin4").true_calibration()
    errs = HardwareErrors()
    a = errs.draw(true, 4, np.random.default_rng(7))
    b = errs.draw(true, 4, np.random.default_rng(7))
    assert a.calibration == b.calibration and a.clock_offset_s == b.clock_offset_s
    np.testing.assert_array_equal(a.boresight, b.boresight)
    units = [errs.draw(true, 4, np.random.default_rng(s)) for s in range(600)]
    f = np.array([u.calibration.focal_px / true.focal_px - 1.0 for u in units])
    pp = np.array([u.calibration.principal_point_px[0] - true.principal_point_px[0] for u in units])
    turn = np.array([u.calibration.layout_deg[0][0] - true.layout_deg[0][0] for u in units])
    off = np.array([u.clock_offset_s for u in units])
    bs = np.array([np.linalg.norm(_rotvec_of(u.boresight)) for u in units])
    # 600 draws: the sample σ is within ±10 % of σ with > 99 % probability.
    assert np.std(f) == pytest.approx(0.003, rel=0.1)
    assert np.std(pp) == pytest.approx(2.0 / 4, rel=0.1)  # full-resolution px → binned px
    assert np.std(turn) == pytest.approx(0.21, rel=0.1)
    assert np.std(off) == pytest.approx(5e-3, rel=0.1)
    # The rotation-vector norm of a 3-D Gaussian of σ per axis has RMS σ√3.
    assert math.degrees(np.sqrt(np.mean(bs**2))) == pytest.approx(0.19 * math.sqrt(3), rel=0.1)
    # Every analyser turns by the same angle (a turn of the layout, not a new layout).
    u = units[0].calibration
    d = np.asarray(u.layout_deg) - np.asarray(true.layout_deg)
    np.testing.assert_allclose(d, d[0, 0], atol=1e-12)


def _rotvec_of(r: np.ndarray) -> np.ndarray:
    angle = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1.0) / 2.0)))
    if angle < 1e-12:
        return np.zeros(3)
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return axis / (2.0 * math.sin(angle)) * angle


def test_changing_one_sigma_leaves_the_other_errors_of_a_seed_alone():
    true = sensors.create("polarimeter", "ideal_bin4").true_calibration()
    a = HardwareErrors().draw(true, 4, np.random.default_rng(3))
    b = HardwareErrors(CalibrationUncertainty(focal_sigma_rel=0.0)).draw(
        true, 4, np.random.default_rng(3)
    )
    assert b.calibration.focal_px == true.focal_px
    assert a.calibration.principal_point_px == b.calibration.principal_point_px
    assert a.clock_offset_s == b.clock_offset_s


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: CalibrationUncertainty(focal_sigma_rel=-0.1), "focal_sigma_rel"),
        (lambda: CalibrationUncertainty(principal_point_sigma_px=math.nan), "principal_point"),
        (lambda: MountingError(boresight_sigma_deg=45.0), "boresight_sigma_deg"),
        (lambda: MountingError(clock_offset_sigma_ms=True), "clock_offset_sigma_ms"),
    ],
)
def test_impossible_sigmas_are_clear_errors(make, field):
    with pytest.raises(ValueError, match=field):
        make()


def test_calibration_before_a_draw_says_what_to_do():
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure_hardware(HardwareErrors())
    with pytest.raises(RuntimeError, match="draw_unit"):
        cam.calibration()
    unit = cam.draw_unit(np.random.default_rng(0))
    assert cam.calibration() is unit.calibration
    assert cam.calibration() != cam.true_calibration()


def _heading(cam, c_cn, seed=0):
    raw, truth = cam.render_offline(c_cn, 3.0, SUN, np.random.default_rng(seed))
    ctx = CompassContext(UTC, 36.175, 120.482, depth_m=3.0, water_index=cam.n_water, sun_enu=SUN)
    fix = create("lig").solve(raw, cam.calibration(), ctx)
    assert fix.ok, fix.reason
    return fix, truth


def test_a_boresight_turn_about_the_optical_axis_is_a_heading_error_the_compass_cannot_see():
    """The world camera turned 1° about its axis; the vehicle believes the nominal mount."""
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure(OpticsConfig(jerlov_type="I"))
    c_cn = euler_to_dcm(0.0, 0.0, math.radians(30.0))
    nominal, _ = _heading(cam, c_cn)
    turned = sensors.create("polarimeter", "ideal_bin4")
    turned.configure(OpticsConfig(jerlov_type="I"))
    turned.configure_hardware(HardwareErrors(CalibrationUncertainty.ideal(), MountingError()))
    turned.draw_unit(np.random.default_rng(0))
    yaw_turn = euler_to_dcm(0.0, 0.0, math.radians(1.0))  # about the camera's z (optical axis)
    turned.unit = dataclasses.replace(turned.unit, boresight=yaw_turn)
    fix, truth = _heading(turned, c_cn)
    dh = (fix.heading_deg - nominal.heading_deg + 180.0) % 360.0 - 180.0
    assert abs(abs(dh) - 1.0) < 0.15, dh
    # The truth layers follow the true camera: the sun's pixel moved by ≈ 1° about the centre.
    _, truth0 = cam.render_offline(c_cn, 3.0, SUN, np.random.default_rng(0))
    cal = cam.true_calibration()
    cu, cv = cal.principal_point_px
    a0 = math.atan2(truth0.sun_pixel[1] - cv, truth0.sun_pixel[0] - cu)
    a1 = math.atan2(truth.sun_pixel[1] - cv, truth.sun_pixel[0] - cu)
    assert abs(abs(math.degrees(a1 - a0)) - 1.0) < 0.05


def test_the_compass_sees_only_the_onboard_calibration():
    """A principal point believed 6 px off moves the Snell-window attitude; the truth does not."""
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure(OpticsConfig(jerlov_type="I"))
    c_cn = euler_to_dcm(math.radians(10.0), 0.0, 0.0)
    raw, _ = cam.render_offline(c_cn, 2.0, SUN, np.random.default_rng(0))
    ctx = CompassContext(UTC, 36.175, 120.482, depth_m=2.0, water_index=cam.n_water, sun_enu=SUN)
    good = create("snell").solve(raw, cam.calibration(), ctx)
    cu, cv = cam.true_calibration().principal_point_px
    wrong = dataclasses.replace(cam.true_calibration(), principal_point_px=(cu + 6.0, cv))
    bad = create("snell").solve(raw, wrong, ctx)
    assert good.ok and bad.ok
    assert abs(math.degrees(good.roll_rad) - 10.0) < 0.3
    # 6 binned px of a 1.8 mm / 4 × 3.45 µm equidistant lens: 6 / f rad ≈ 2.6° of tilt.
    assert abs(math.degrees(bad.roll_rad - good.roll_rad)) > 1.0


def test_the_hardware_table_is_validated():
    base = {
        "name": "h",
        "duration_s": 10.0,
        "start_utc": "2021-07-31T04:00:00Z",
        "place": {"latitude_deg": 36.0, "longitude_deg": 120.0},
        "mission": {
            "kind": "legs",
            "legs": [{"heading_deg": 0.0, "speed_mps": 1.0, "duration_s": 10.0, "depth_m": 2.0}],
        },
    }
    s = parse_scenario({**base, "hardware": {"calibration": "ideal"}})
    assert s.hardware.calibration == "ideal" and s.hardware.focal_sigma_rel == 0.0
    assert s.hardware.mounting == "bracket" and s.hardware.boresight_sigma_deg == 0.19
    assert parse_scenario(s.to_dict()) == s
    with pytest.raises(ScenarioError) as err:
        parse_scenario(
            {
                **base,
                "hardware": {
                    "mounting": "ideal",
                    "boresight_sigma_deg": 0.5,
                    "focal_sigma_rel": -1.0,
                    "calibration": "perfect",
                    "wobble": 1,
                },
            }
        )
    msg = str(err.value)
    assert "hardware.boresight_sigma_deg: is set while hardware.mounting = 'ideal'" in msg
    assert "hardware.focal_sigma_rel: -1.0 is out of range" in msg
    assert 'hardware.calibration: "perfect" is not one of' in msg
    assert "hardware.wobble: unknown key" in msg


def test_a_unit_reports_its_misalignment():
    u = HardwareUnit(
        sensors.create("polarimeter", "ideal_bin4").true_calibration(),
        euler_to_dcm(0.0, math.radians(0.5), 0.0),
        0.0,
    )
    assert u.boresight_deg() == pytest.approx(0.5, abs=1e-9)


@pytest.mark.parametrize("method", ["lig", "pol", "snell", "roia"])
def test_a_badly_wrong_calibration_gives_a_finite_fix_or_says_why_not(method):
    """100 px of principal-point error and 15 % of focal length: no NaN reaches the filter."""
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure(OpticsConfig(jerlov_type="I"))
    raw, _ = cam.render_offline(np.eye(3), 3.0, SUN, np.random.default_rng(0))
    true = cam.true_calibration()
    cu, cv = true.principal_point_px
    wrong = dataclasses.replace(
        true, principal_point_px=(cu + 100.0, cv - 60.0), focal_px=true.focal_px * 1.15
    )
    ctx = CompassContext(UTC, 36.175, 120.482, depth_m=3.0, water_index=cam.n_water, sun_enu=SUN)
    fix = create(method).solve(raw, wrong, ctx)
    if fix.ok:
        assert np.all(np.isfinite(fix.sun_body)) and math.isfinite(fix.heading_deg)
        assert fix.covariance_body is None or np.all(np.isfinite(fix.covariance_body))
    else:
        assert fix.reason and fix.sun_body is None
