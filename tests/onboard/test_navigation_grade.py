"""A navigation-grade INS: the HG9900 preset, gyrocompass alignment, the datasheet tuning.

Why these exist (docs/gravity.md): a filter given the LIG paper's floors and a fixed allowance for
rate-proportional gyro errors believes a navigation-grade unit's level drifts 47 times faster than
its datasheet says, and weak couplings then walk its tilt — each 0.01° a Schuler velocity error
of ~0.1–1 m/s.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from scenarios import parse_scenario
from scenarios.loader import ScenarioError
from sensors.imu import IMU_PRESETS
from twin.app.cli import main
from twin.core import earth
from twin.onboard.alignment import AlignmentError, gyrocompass_sigma
from twin.onboard.eskf import Eskf, EskfConfig
from twin.onboard.ins import NavState
from twin.sim.build import _imu_grade, build_simulation

LAT = math.radians(37.54)
DEG_PER_H = math.radians(1.0) / 3600.0
MICRO_G = 1e-6 * earth.G0_MPS2


def grade(name: str):
    return _imu_grade(IMU_PRESETS[name])


# ---- the preset ----------------------------------------------------------------------------------
def test_the_hg9900_preset_has_its_brochure_values():
    s = IMU_PRESETS["hg9900"]
    assert s.gyro_turn_on_bias / DEG_PER_H == pytest.approx(0.0035)
    assert s.gyro_noise_density / (math.radians(1.0) / 60.0) == pytest.approx(0.002)
    assert s.gyro_scale_factor == pytest.approx(5e-6)
    assert s.accel_turn_on_bias / MICRO_G == pytest.approx(25.0)
    assert s.accel_scale_factor == pytest.approx(100e-6)
    s.validate()


# ---- gyrocompass alignment -----------------------------------------------------------------------
def test_gyrocompassing_leaves_the_textbook_tilt_and_heading():
    g = grade("hg9900")
    tilt, heading = gyrocompass_sigma(g, LAT, 600.0)
    accel = math.hypot(g.accel_turn_on_bias, g.accel_gm_sigma)
    assert tilt == pytest.approx(accel / earth.G0_MPS2)  # 25 µg → 2.5e-5 rad
    gyro = math.sqrt(g.gyro_turn_on_bias**2 + g.gyro_gm_sigma**2 + g.gyro_noise_density**2 / 600)
    assert heading == pytest.approx(gyro / (earth.OMEGA_IE * math.cos(LAT)))
    assert 0.02 < math.degrees(heading) < 0.04  # bias ⊕ 10 min of ARW over 11.9 °/h of Earth rate
    # A longer alignment averages the ARW down, never the bias.
    _, longer = gyrocompass_sigma(g, LAT, 6000.0)
    assert longer < heading
    bias_only = math.hypot(g.gyro_turn_on_bias, g.gyro_gm_sigma) / (earth.OMEGA_IE * math.cos(LAT))
    assert longer > bias_only
    # The tactical FOG finds north to ~1.5°; its tilt is 100 µg / g.
    tilt_fog, heading_fog = gyrocompass_sigma(grade("tactical_fog"), LAT)
    assert 1.0 < math.degrees(heading_fog) < 2.0
    assert tilt_fog == pytest.approx(
        math.hypot(100.0 * MICRO_G, grade("tactical_fog").accel_gm_sigma) / earth.G0_MPS2
    )


def test_a_mems_gyro_or_a_polar_latitude_cannot_gyrocompass():
    with pytest.raises(AlignmentError, match=r"cannot find north at latitude 37\.5"):
        gyrocompass_sigma(grade("lig2024"), LAT)
    with pytest.raises(AlignmentError, match="heading σ"):
        gyrocompass_sigma(grade("hg9900"), math.radians(89.99))


# ---- the datasheet tuning ------------------------------------------------------------------------
def test_the_datasheet_tuning_drops_the_paper_floors_and_splits_the_accelerometer_p0():
    g = grade("hg9900")
    cfg = EskfConfig.for_imu(g, datasheet_only=True, manoeuvre_time_s=60.0)
    assert cfg.q_attitude == pytest.approx((g.gyro_noise_density,) * 3)
    assert cfg.q_velocity == pytest.approx((0.0,) * 3)  # the brochure lists no VRW
    k = math.sqrt(g.gyro_scale_factor**2 + 2 * g.gyro_misalignment**2)
    assert cfg.q_rate_gain == pytest.approx(k * math.sqrt(60.0))
    a_xy, _, a_z = cfg.p0_accel_bias_mps2
    assert a_xy == pytest.approx(
        math.sqrt(
            g.accel_turn_on_bias**2 + g.accel_gm_sigma**2 + (g.accel_misalignment * 9.80665) ** 2
        )
    )
    assert a_z == pytest.approx(
        math.sqrt(
            g.accel_turn_on_bias**2 + g.accel_gm_sigma**2 + (g.accel_scale_factor * 9.80665) ** 2
        )
    )
    # The default tuning keeps the floors: 0.01 °/√h level, 0.16 °/√h heading, and the fixed
    # allowance folded in.
    paper_floored = EskfConfig.for_imu(g)
    assert min(paper_floored.q_attitude) > 10 * g.gyro_noise_density
    assert paper_floored.q_rate_gain == 0.0


def _attitude_variance_after(cfg: EskfConfig, rate_rad_s: float, seconds: float) -> float:
    init = NavState.from_euler(lat_rad=LAT, lon_rad=0.0, h_m=-20.0)
    f = Eskf(cfg, init)
    p0 = f.P[0, 0]
    g = earth.G0_MPS2
    dt = 0.01
    w = np.array([0.0, 0.0, rate_rad_s])
    for _ in range(round(seconds / dt)):
        f.predict_imu(dt, w, np.array([0.0, 0.0, g]))
    f.propagate_covariance()
    return f.P[0, 0] - p0


def test_the_rate_allowance_follows_the_measured_turn_rate():
    g = grade("hg9900")
    cfg = EskfConfig.for_imu(g, datasheet_only=True)
    still = _attitude_variance_after(cfg, 0.0, 100.0)
    turning = _attitude_variance_after(cfg, 0.05, 100.0)
    # At rest the level's variance grows by the ARW alone (plus the bias states' share).
    assert still < 3.0 * g.gyro_noise_density**2 * 100.0
    # Turning at 0.05 rad/s it grows by the allowance (k √T · ω)² per second as well.
    extra = (cfg.q_rate_gain * 0.05) ** 2 * 100.0
    assert turning - still == pytest.approx(extra, rel=0.15)


# ---- the scenario ------------------------------------------------------------------------------
BASE: dict = {
    "name": "n",
    "duration_s": 60.0,
    "start_utc": "2021-09-03T02:00:00Z",
    "place": {"latitude_deg": 37.54, "longitude_deg": 122.06},
    "initial": {"depth_m": 20.0, "heading_deg": 90.0, "speed_mps": 1.5},
    "mission": {
        "kind": "legs",
        "legs": [{"heading_deg": 90.0, "speed_mps": 1.5, "duration_s": 60.0, "depth_m": 20.0}],
    },
    "sensors": {"imu": "hg9900"},
    "navigation": {"variants": ["ins"], "tuning": "datasheet", "alignment": "gyrocompass"},
}


def _data(**changes) -> dict:
    data = {**BASE}
    for key, value in changes.items():
        data[key] = {**data.get(key, {}), **value} if isinstance(value, dict) else value
    return data


def test_a_gyrocompassed_filter_starts_with_the_alignments_errors():
    sim = build_simulation(parse_scenario(_data()))
    cfg = sim.navigators["ins"].config.eskf
    tilt, heading = gyrocompass_sigma(grade("hg9900"), LAT)
    assert cfg.p0_attitude_rad == pytest.approx((tilt, tilt, heading))
    assert cfg.q_rate_gain > 0.0


@pytest.mark.parametrize(
    ("navigation", "sensors", "message"),
    [
        ({"tuning": "paper"}, {}, r'navigation\.alignment: "gyrocompass" needs the IMU'),
        ({}, {"imu": "lig2024"}, r"navigation\.alignment: .* cannot find north"),
        ({"alignment": "level"}, {}, r"navigation\.alignment"),
        ({"tuning": "best"}, {}, r"navigation\.tuning"),
    ],
)
def test_an_alignment_the_imu_cannot_do_is_a_clear_error(navigation, sensors, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(_data(navigation=navigation, sensors=sensors))


def test_validate_and_run_agree_that_a_mems_imu_cannot_gyrocompass(tmp_path, capsys):
    text = (Path(__file__).parents[2] / "scenarios" / "default.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('sun_measurement = "azimuth"', 'alignment = "gyrocompass"'))
    assert main(["validate", str(bad)]) != 0
    err = capsys.readouterr().err
    assert "navigation.alignment" in err and "cannot find north" in err
    assert "Traceback" not in err
    assert main(["run", str(bad), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "navigation.alignment" in capsys.readouterr().err


def test_speed_control_is_checked_and_propeller_ignores_the_speed_estimate():
    with pytest.raises(ScenarioError, match=r"autopilot\.speed_control"):
        parse_scenario(_data(autopilot={"speed_control": "cruise"}))
    data = _data(autopilot={"attitude_source": "estimate", "speed_control": "propeller"})
    sim = build_simulation(parse_scenario(data))
    assert sim.autopilot.speed_feedback is False
    from twin.onboard.control.autopilot import NavState, Setpoint

    nav = NavState(0.0, 0.0, 20.0, 0.0, 0.0, 0.0, 0.0, 0.0, speed_mps=3.0)  # a wrong speed
    sp = Setpoint(1.5, 20.0, 0.0)
    first = sim.autopilot.update(nav, sp, 0.1).propeller_rps
    for _ in range(100):
        later = sim.autopilot.update(nav, sp, 0.1).propeller_rps
    assert later == pytest.approx(first)  # no integral on the speed error
