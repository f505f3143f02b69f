"""Distortion correction off: the vehicle's camera model is the lens's datasheet (xin2024 §2.4)."""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import numpy as np
import pytest

import sensors
from scenarios import parse_scenario
from scenarios.loader import ScenarioError
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.unit.hardware import HardwareErrors, LensTolerance
from tests.scenario_helpers import minimal_scenario
from twin.core.frames import euler_to_dcm
from twin.onboard.compass.base import CompassContext
from twin.onboard.compass.snell import SnellWindowMethod
from twin.world.assembly import hardware_errors

UTC = dt.datetime(2021, 7, 31, 4, 0, tzinfo=dt.UTC)


def _true():
    return sensors.create("polarimeter", "phx050s_p_fe185c046_bin4").true_calibration()


def test_without_correction_the_vehicle_has_the_datasheets_equidistant_lens():
    true = _true()
    assert any(true.kb_coeffs)  # the preset's lens departs from equidistant
    on = HardwareErrors().draw(true, 4, np.random.default_rng(5))
    off = HardwareErrors(distortion_correction=False).draw(true, 4, np.random.default_rng(5))
    assert on.calibration.kb_coeffs == true.kb_coeffs
    assert off.calibration.kb_coeffs == (0.0, 0.0, 0.0, 0.0)
    # The same unit: its boresight, clock and analyser calibration do not depend on the switch.
    np.testing.assert_array_equal(on.boresight, off.boresight)
    assert on.clock_offset_s == off.clock_offset_s
    assert on.calibration.layout_deg == off.calibration.layout_deg
    # ... and the unit's calibration errors are those it had before the tolerances existed.
    cal_rng = np.random.default_rng(5).spawn(2)[0]
    assert on.calibration == HardwareErrors().calibration.draw(true, 4, cal_rng)


def test_the_tolerances_have_the_declared_spread():
    true = _true()
    tol = LensTolerance()
    assert tol.focal_tolerance_rel == pytest.approx(0.05 / math.sqrt(3))
    cals = [tol.nominal(true, np.random.default_rng(s)) for s in range(600)]
    f = np.array([c.focal_px / true.focal_px - 1.0 for c in cals])
    du = np.array([c.principal_point_px[0] - true.principal_point_px[0] for c in cals])
    # 600 draws: the sample σ is within ±10 % of σ with > 99 % probability.
    assert np.std(f) == pytest.approx(0.0289, rel=0.1)
    # 18 µm on 4 × 3.45 µm binned pixels.
    assert np.std(du) == pytest.approx(18.0 / 13.8, rel=0.1)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"focal_tolerance_rel": -0.01}, "focal_tolerance_rel"),
        ({"decentre_sigma_um": math.inf}, "decentre_sigma_um"),
    ],
)
def test_impossible_tolerances_are_clear_errors(kwargs, field):
    with pytest.raises(ValueError, match=field):
        LensTolerance(**kwargs)


def test_a_focal_length_error_scales_the_measured_tilt():
    """The window's centre sits at ρ = f θ: a model 3 % long reads the tilt 3 % short."""
    cam = sensors.create("polarimeter", "phx050s_p_fe185c046_bin4")
    cam.configure(OpticsConfig(jerlov_type="I"))
    sun = np.array([0.3, 0.5, 0.81])
    sun /= np.linalg.norm(sun)
    tilt = 35.0
    raw, _ = cam.render_offline(
        euler_to_dcm(math.radians(tilt), 0.0, 0.0), 0.5, sun, np.random.default_rng(2)
    )
    ctx = CompassContext(UTC, 36.0, 120.0, depth_m=0.5, water_index=cam.n_water, sun_enu=sun)
    true = cam.true_calibration()
    exact = SnellWindowMethod().solve(raw, true, ctx)
    long = dataclasses.replace(true, focal_px=true.focal_px * 1.03)
    wrong = SnellWindowMethod().solve(raw, long, ctx)
    assert exact.ok and wrong.ok
    assert abs(math.degrees(exact.roll_rad)) == pytest.approx(tilt, abs=0.3)
    assert abs(math.degrees(wrong.roll_rad)) == pytest.approx(tilt / 1.03, abs=0.3)


def _scenario(hardware):
    return minimal_scenario(hardware=hardware)


def test_the_scenario_table_switches_correction_off_and_rejects_bad_values():
    s = _scenario({"distortion_correction": False, "decentre_sigma_um": 30.0})
    errs = hardware_errors(s.hardware)
    assert not errs.distortion_correction and errs.tolerance.decentre_sigma_um == 30.0
    assert parse_scenario(s.to_dict()) == s
    ideal = hardware_errors(_scenario({"calibration": "ideal"}).hardware)
    assert ideal.distortion_correction  # an exact calibration is a corrected one
    with pytest.raises(ScenarioError) as err:
        _scenario(
            {"distortion_correction": "no", "focal_tolerance_rel": 0.5, "decentre_sigma_um": -1}
        )
    msg = str(err.value)
    assert "hardware.distortion_correction" in msg
    assert "hardware.focal_tolerance_rel: 0.5 is out of range" in msg
    assert "hardware.decentre_sigma_um: -1 is out of range" in msg
    with pytest.raises(ScenarioError, match="distortion_correction: is set while"):
        _scenario({"calibration": "ideal", "distortion_correction": False})


def test_a_run_without_correction_draws_a_nominal_unit():
    cam = sensors.create("polarimeter", "phx050s_p_fe185c046_bin4")
    cam.configure_hardware(HardwareErrors.ideal())
    assert not cam.hardware.drawn
    cam.configure_hardware(dataclasses.replace(HardwareErrors.ideal(), distortion_correction=False))
    assert cam.hardware.drawn  # a datasheet model is not the exact camera
    unit = cam.draw_unit(np.random.default_rng(0))
    assert unit.calibration.kb_coeffs == (0.0, 0.0, 0.0, 0.0)
    assert cam.calibration() is unit.calibration
