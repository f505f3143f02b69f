"""The IMU plugin on the real AUV model: true kinematics, Earth terms, error statistics."""

from __future__ import annotations

import dataclasses
import math

import allantools
import dm_env
import numpy as np
import pytest

from sensors import noise, registry
from sensors.imu import DEG_PER_H, DEG_PER_RT_H, MICRO_G, Imu, ImuSpec
from twin.core import earth
from twin.core.frames import euler_to_dcm

LAT = math.radians(45.0)
G45 = earth.normal_gravity(LAT)
OMEGA_N = earth.OMEGA_IE * math.cos(LAT)
OMEGA_U = earth.OMEGA_IE * math.sin(LAT)


def ideal_imu(**overrides) -> Imu:
    imu = registry.create("imu", "ideal", **overrides)
    assert isinstance(imu, Imu)
    return imu


def read(imu: Imu, world, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    imu.reset(world, rng)
    r = imu.sample(world, rng)
    return r["angular_rate"], r["specific_force"]


# --- truth and Earth kinematics -----------------------------------------------------------------


@pytest.mark.parametrize("heading_deg", [0.0, 90.0, 135.0, 270.0])
def test_level_at_rest_reads_gravity_and_earth_rate_in_body_axes(world, heading_deg) -> None:
    yaw = -math.radians(heading_deg)  # compass heading is clockwise, ENU yaw counter-clockwise
    world.place(rpy=(0.0, 0.0, yaw))
    omega, f = read(ideal_imu(), world)
    np.testing.assert_allclose(f, [0.0, 0.0, G45], atol=1e-12)
    # Body y (forward) points along the compass heading h and body x (right) along h + 90°, so the
    # north component of Earth rate projects as [−Ω_N sin h, Ω_N cos h]: heading east, the
    # right-hand side faces south.
    hc = math.radians(heading_deg)
    np.testing.assert_allclose(
        omega, [-OMEGA_N * math.sin(hc), OMEGA_N * math.cos(hc), OMEGA_U], atol=1e-15
    )


def test_tilted_at_rest_reads_gravity_and_earth_rate_rotated(world) -> None:
    rpy = (0.2, -0.3, 1.1)
    world.place(rpy=rpy)
    omega, f = read(ideal_imu(), world)
    c_bn = euler_to_dcm(*rpy).T  # C_n^b
    np.testing.assert_allclose(f, c_bn @ [0.0, 0.0, G45], atol=1e-12)
    np.testing.assert_allclose(omega, c_bn @ earth.earth_rate_enu(LAT), atol=1e-15)


def test_without_earth_kinematics_reads_mujoco_inertial_values(world) -> None:
    world.place(rpy=(0.0, 0.0, 0.7))
    omega, f = read(ideal_imu(earth_kinematics=False), world)
    np.testing.assert_array_equal(omega, [0.0, 0.0, 0.0])
    np.testing.assert_allclose(f, [0.0, 0.0, G45], atol=1e-12)


def test_constant_yaw_rate_is_read_back(world) -> None:
    r = 0.1  # rad/s, counter-clockwise seen from above
    world.place(omega_body=(0.0, 0.0, r))
    omega, f = read(ideal_imu(), world)
    # The site swings west at ω r = 0.01 m/s: a (tiny) transport rate v_E / (R_N + h) about north.
    _, r_n = earth.principal_radii(LAT)
    v_e = -r * 0.1
    en_n, en_u = v_e / (r_n - 10.0), v_e * math.tan(LAT) / (r_n - 10.0)
    np.testing.assert_allclose(omega, [0.0, OMEGA_N + en_n, r + OMEGA_U + en_u], atol=1e-15)
    # The site is 0.1 m ahead of the rotation axis: centripetal ω² r towards it, i.e. −y; plus the
    # Coriolis term of the site's own velocity.
    v = np.array([v_e, 0.0, 0.0])
    coriolis = np.cross(2 * earth.earth_rate_enu(LAT) + earth.transport_rate_enu(LAT, -10.0, v), v)
    np.testing.assert_allclose(f, np.array([0.0, -(r**2) * 0.1, G45]) + coriolis, atol=1e-12)


def test_body_rates_on_all_axes_are_read_back(world) -> None:
    w_b = (0.05, -0.02, 0.03)
    world.place(rpy=(0.1, 0.2, 0.3), omega_body=w_b)
    omega, _ = read(ideal_imu(), world)
    c_bn = euler_to_dcm(0.1, 0.2, 0.3).T
    np.testing.assert_allclose(omega, np.array(w_b) + c_bn @ earth.earth_rate_enu(LAT), atol=1e-15)


def test_coriolis_moving_north_pushes_specific_force_west_and_down(world) -> None:
    v_n = 2.0
    world.place(vel_world=(0.0, v_n, 0.0))  # heading north, body x = east
    omega, f = read(ideal_imu(), world)
    r_m, _ = earth.principal_radii(LAT)
    h = -10.0  # the imu site is at the body origin's height
    # Northern hemisphere: Coriolis deflects a northbound vehicle east (to the right), so holding a
    # straight course takes a westward force: f_x = −2 Ω sin L v_N < 0. Following the curved
    # Earth takes a downward one: f_z = g − v²/(R_M + h).
    assert f[0] < 0
    assert f[0] == pytest.approx(-2 * OMEGA_U * v_n, rel=1e-12)
    assert f[1] == pytest.approx(0.0, abs=1e-15)
    assert f[2] == pytest.approx(G45 - v_n**2 / (r_m + h), abs=1e-12)
    # The gyro also sees the local-level frame tilting north: ω_x = −v_N/(R_M + h).
    assert omega[0] == pytest.approx(-v_n / (r_m + h), rel=1e-12)


def test_coriolis_moving_east_is_the_eotvos_effect(world) -> None:
    v_e = 3.0
    world.place(vel_world=(v_e, 0.0, 0.0))
    _, f = read(ideal_imu(), world)
    _, r_n = earth.principal_radii(LAT)
    h = -10.0
    # An eastbound vehicle weighs less: f_z = g − 2 Ω cos L v_E − v_E²/(R_N + h).
    assert f[2] == pytest.approx(G45 - 2 * OMEGA_N * v_e - v_e**2 / (r_n + h), abs=1e-12)
    assert f[1] == pytest.approx(2 * OMEGA_U * v_e + v_e**2 * math.tan(LAT) / (r_n + h), rel=1e-12)


def test_enu_mechanization_reproduces_mujoco_motion(world) -> None:
    """The point of the Earth terms: an ENU INS fed ideal readings follows MuJoCo's trajectory."""
    rpy, v, a = (0.3, -0.2, 2.0), np.array([1.2, -0.8, 0.3]), np.array([0.05, -0.1, 0.02])
    world.place(rpy=rpy, vel_world=tuple(v), acc_world=tuple(a))
    omega, f = read(ideal_imu(), world)
    c_nb = euler_to_dcm(*rpy)
    h = float(world.site_pose("imu")[0][2])
    w_ie = earth.earth_rate_enu(LAT)
    w_en = earth.transport_rate_enu(LAT, h, v)
    v_dot = c_nb @ f - np.cross(2 * w_ie + w_en, v) + np.array([0.0, 0.0, -G45])
    np.testing.assert_allclose(v_dot, a, atol=1e-12)
    # Attitude: ω_nb^b = ω_ib^b − C_n^b ω_in^n must be MuJoCo's body rate (zero here).
    np.testing.assert_allclose(omega - c_nb.T @ (w_ie + w_en), 0.0, atol=1e-15)


# --- the spec ------------------------------------------------------------------------------------


def test_lig2024_preset_matches_navigation_md_si_table() -> None:
    s = Imu.PRESETS["lig2024"]
    assert s.gyro_noise_density == pytest.approx(4.363e-5, rel=1e-3)
    assert s.gyro_bias_instability == pytest.approx(3.879e-5, rel=1e-3)
    assert s.accel_noise_density == pytest.approx((4.413e-4, 4.413e-4, 6.374e-4), rel=1e-3)
    assert s.accel_bias_instability == pytest.approx(1.961e-4, rel=1e-3)
    assert s.rate_hz == 100.0


def test_from_datasheet_unit_conversions() -> None:
    s = ImuSpec.from_datasheet(
        gyro_arw_deg_rt_h=1.0,
        gyro_bias_instability_deg_h=1.0,
        gyro_rrw_deg_h_rt_h=60.0,
        gyro_scale_factor_ppm=100.0,
        gyro_misalignment_mrad=2.0,
        accel_vrw_ug_rt_hz=[10.0, 20.0, 30.0],
        accel_bias_rw_ug_rt_h=60.0,
    )
    assert s.gyro_noise_density == pytest.approx(math.radians(1.0) / 60.0)
    assert s.gyro_bias_instability == pytest.approx(math.radians(1.0) / 3600.0)
    assert s.gyro_rate_random_walk == pytest.approx(math.radians(1.0) / 3600.0)  # 60 °/h/√h
    assert s.gyro_scale_factor == pytest.approx(1e-4)
    assert s.gyro_misalignment == pytest.approx(2e-3)
    assert s.accel_noise_density == pytest.approx((9.80665e-5, 1.96133e-4, 2.941995e-4))
    assert s.accel_random_walk == pytest.approx(9.80665e-6 * 60.0 / 60.0)
    assert DEG_PER_H == pytest.approx(4.84813681e-6)
    assert DEG_PER_RT_H * 0.15 == pytest.approx(4.363e-5, rel=1e-3)
    assert MICRO_G == pytest.approx(9.80665e-6)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("gyro_noise_density", -1e-5),
        ("gyro_bias_instability", math.nan),
        ("accel_turn_on_bias", math.inf),
        ("accel_noise_density", (1e-4, 1e-4)),
        ("accel_noise_density", (1e-4, -1e-4, 1e-4)),
        ("gyro_scale_factor", "big"),
        ("earth_kinematics", 1),
        ("rate_hz", 0.0),
    ],
)
def test_validate_names_the_field_value_and_range(field, value) -> None:
    spec = dataclasses.replace(ImuSpec(), **{field: value})
    with pytest.raises(ValueError, match=field) as info:
        spec.validate()
    assert repr(value) in str(info.value)
    assert ">" in str(info.value) or "true or false" in str(info.value)


def test_lists_become_tuples_and_presets_validate() -> None:
    spec = ImuSpec(accel_noise_density=[1e-4, 2e-4, 3e-4])
    assert spec.accel_noise_density == (1e-4, 2e-4, 3e-4)
    hash(spec)
    for preset in Imu.PRESETS.values():
        preset.validate()
    assert set(Imu.PRESETS) == {"lig2024", "tactical_fog", "hg9900", "ideal"}


def test_registry_create_with_preset_and_overrides() -> None:
    imu = registry.create("imu", "lig2024", name="imu2", gyro_bias_corr_time_s=100.0)
    assert isinstance(imu, Imu) and imu.name == "imu2" and imu.site == "imu"
    assert imu.spec.gyro_bias_corr_time_s == 100.0
    assert imu.spec.gyro_noise_density == Imu.PRESETS["lig2024"].gyro_noise_density
    assert registry.create("imu").spec == ImuSpec()
    with pytest.raises(KeyError, match="unknown imu preset 'navigation_grade'"):
        registry.create("imu", "navigation_grade")
    with pytest.raises(ValueError, match="gyro_arw"):
        registry.create("imu", "lig2024", gyro_arw=0.1)
    with pytest.raises(ValueError, match="gyro_turn_on_bias"):
        registry.create("imu", "lig2024", gyro_turn_on_bias=-1.0)
    with pytest.raises(KeyError, match="unknown sensor kind"):
        registry.create("magnetometer")


def test_channel_specs_match_samples_and_describe_is_json(world) -> None:
    import json

    imu = registry.create("imu", "lig2024")
    rng = np.random.default_rng(0)
    imu.reset(world, rng)
    out = imu.sample(world, rng)
    specs = imu.channel_specs()
    assert set(out) == set(specs) == {"angular_rate", "specific_force"}
    for name, spec in specs.items():
        assert isinstance(spec, dm_env.specs.Array)
        spec.validate(out[name])
    json.dumps(imu.describe())


def test_sample_before_reset_and_missing_mjcf_sensor_are_errors(world) -> None:
    imu = registry.create("imu", "ideal")
    with pytest.raises(RuntimeError, match="reset"):
        imu.sample(world, np.random.default_rng(0))
    wrong = registry.create("imu", "ideal", site="depth")
    with pytest.raises(KeyError, match="depth/gyro"):
        wrong.reset(world, np.random.default_rng(0))


# --- errors and their statistics -----------------------------------------------------------------


@pytest.mark.measures
def test_white_noise_std_matches_density_times_root_rate(world, collect, record_property) -> None:
    """Fast statistical test: only the white noise switched on, per-axis accelerometer density."""
    lig = Imu.PRESETS["lig2024"]
    imu = registry.create(
        "imu",
        "ideal",
        gyro_noise_density=lig.gyro_noise_density,
        accel_noise_density=lig.accel_noise_density,
    )
    rng = np.random.default_rng(42)
    imu.reset(world, rng)
    n = 20000
    data = collect(imu, world, rng, n)
    gyro_std = data["angular_rate"].std(axis=0)
    accel_std = data["specific_force"].std(axis=0)
    spec = np.concatenate(
        [np.broadcast_to(lig.gyro_noise_density, 3), np.asarray(lig.accel_noise_density)]
    )
    record_property(
        "imu_white_std_vs_spec_max_rel",
        float(np.abs(np.concatenate([gyro_std, accel_std]) / (spec * 10.0) - 1.0).max()),
    )
    np.testing.assert_allclose(gyro_std, lig.gyro_noise_density * 10.0, rtol=0.03)
    np.testing.assert_allclose(accel_std, np.array(lig.accel_noise_density) * 10.0, rtol=0.03)
    # navigation.md §2.1 discrete σ at 100 Hz: 4.36e-4 rad/s, 4.41e-3 and 6.37e-3 m/s².
    assert gyro_std.mean() == pytest.approx(4.36e-4, rel=0.03)
    assert accel_std[2] == pytest.approx(6.37e-3, rel=0.03)


@pytest.mark.measures
def test_allan_deviation_at_1s_gives_the_arw_and_vrw(world, collect, record_property) -> None:
    """The full lig2024 model: σ_A(1 s) = N (IEEE-952 read-off, navigation.md §1.6), within 10 %."""
    imu = registry.create("imu", "lig2024")
    rng = np.random.default_rng(7)
    imu.reset(world, rng)
    data = collect(imu, world, rng, 30000)  # 300 s at 100 Hz
    lig = imu.spec
    arw = [
        allantools.oadev(data["angular_rate"][:, i], rate=100.0, data_type="freq", taus=[1.0])[1][0]
        for i in range(3)
    ]
    vrw = [
        allantools.oadev(data["specific_force"][:, i], rate=100.0, data_type="freq", taus=[1.0])[1][
            0
        ]
        for i in range(3)
    ]
    rel = np.concatenate(
        [
            np.asarray(arw) / lig.gyro_noise_density - 1.0,
            np.asarray(vrw) / np.asarray(lig.accel_noise_density) - 1.0,
        ]
    )
    record_property("imu_allan_1s_vs_spec_min_abs_rel", float(np.abs(rel).min()))
    record_property("imu_allan_1s_vs_spec_max_abs_rel", float(np.abs(rel).max()))
    np.testing.assert_allclose(arw, lig.gyro_noise_density, rtol=0.10)
    np.testing.assert_allclose(vrw, lig.accel_noise_density, rtol=0.10)


def _allan_floor_check(world, collect, *, rate_hz: float, tau_c: float, seconds: float, seed: int):
    """Measured vs analytic (white + Gauss–Markov) Allan deviation of the lig2024 gyro."""
    imu = registry.create(
        "imu", "lig2024", rate_hz=rate_hz, gyro_bias_corr_time_s=tau_c, accel_bias_corr_time_s=tau_c
    )
    rng = np.random.default_rng(seed)
    imu.reset(world, rng)
    data = collect(imu, world, rng, int(seconds * rate_hz))
    lig = imu.spec
    sigma_gm = noise.gauss_markov_sigma_for_bias_instability(lig.gyro_bias_instability)
    tau_peak = noise.GM_ADEV_PEAK_TAU_RATIO * tau_c
    taus = tau_peak * np.array([0.5, 1.0, 2.0])
    measured = np.mean(
        [
            allantools.oadev(data["angular_rate"][:, i], rate=rate_hz, data_type="freq", taus=taus)[
                1
            ]
            for i in range(3)
        ],
        axis=0,
    )
    expected = np.sqrt(
        noise.gauss_markov_adev(taus, sigma_gm, tau_c) ** 2 + lig.gyro_noise_density**2 / taus
    )
    floor = 0.664 * lig.gyro_bias_instability  # the flicker floor the GM peak stands in for
    return measured, expected, floor, taus


def gm_part(adev: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """The Allan deviation left after removing the lig2024 gyro's white noise N²/τ."""
    n = Imu.PRESETS["lig2024"].gyro_noise_density
    return np.sqrt(adev**2 - n**2 / taus)


@pytest.mark.slow  # an Allan-deviation floor from a long record (statistical)
def test_bias_instability_floor_short_correlation_time(world, collect) -> None:
    """Fast: τ_c shortened to 3 s (the GM Allan curve is scale-free in τ/τ_c)."""
    measured, expected, floor, taus = _allan_floor_check(
        world, collect, rate_hz=100.0, tau_c=3.0, seconds=1200.0, seed=8
    )
    np.testing.assert_allclose(measured, expected, rtol=0.12)
    # At the peak the GM part is the flicker floor 0.664 B (white noise adds N²/τ on top here).
    assert gm_part(measured, taus)[1] == pytest.approx(floor, rel=0.15)


@pytest.mark.slow
def test_bias_instability_floor_with_the_preset_correlation_time(world, collect) -> None:
    """The lig2024 preset as shipped (τ_c = 300 s), at 10 Hz to keep the loop short."""
    measured, expected, floor, taus = _allan_floor_check(
        world, collect, rate_hz=10.0, tau_c=300.0, seconds=40 * 567.0, seed=9
    )
    np.testing.assert_allclose(measured, expected, rtol=0.15)
    assert gm_part(measured, taus)[1] == pytest.approx(floor, rel=0.15)


def test_turn_on_errors_are_drawn_per_seed(world) -> None:
    imu = registry.create("imu", "lig2024")
    spec = imu.spec
    draws = []
    for seed in range(400):
        imu.reset(world, np.random.default_rng(seed))
        e = imu.current_errors()
        draws.append(
            np.concatenate(
                [
                    e.gyro.turn_on,
                    e.accel.turn_on,
                    np.diag(e.gyro.matrix) - 1,
                    [e.accel.matrix[0, 1]],
                ]
            )
        )
    draws = np.array(draws)
    # 400 draws: the std estimate is good to ~3.5 % (1σ); allow 15 %.
    np.testing.assert_allclose(draws[:, 0:3].std(axis=0), spec.gyro_turn_on_bias, rtol=0.15)
    np.testing.assert_allclose(draws[:, 3:6].std(axis=0), spec.accel_turn_on_bias, rtol=0.15)
    np.testing.assert_allclose(draws[:, 6:9].std(axis=0), spec.gyro_scale_factor, rtol=0.15)
    assert draws[:, 9].std() == pytest.approx(spec.accel_misalignment, rel=0.15)
    imu.reset(world, np.random.default_rng(1))
    a = imu.current_errors()
    imu.reset(world, np.random.default_rng(1))
    b = imu.current_errors()
    np.testing.assert_array_equal(a.gyro.turn_on, b.gyro.turn_on)
    np.testing.assert_array_equal(a.accel.matrix, b.accel.matrix)


def test_current_errors_explain_the_reading(world) -> None:
    world.place(rpy=(0.1, 0.05, -0.4), omega_body=(0.01, 0.0, 0.02))
    imu = registry.create("imu", "lig2024")
    rng = np.random.default_rng(3)
    imu.reset(world, rng)
    for k in range(5):
        world.set_time(0.01 * k)
        out = imu.sample(world, rng)
    omega, f = imu.ideal_outputs(world)
    e = imu.current_errors()
    np.testing.assert_allclose(
        out["angular_rate"], e.gyro.matrix @ omega + e.gyro.bias + e.gyro.noise, atol=1e-18
    )
    np.testing.assert_allclose(
        out["specific_force"], e.accel.matrix @ f + e.accel.bias + e.accel.noise, atol=1e-15
    )
    np.testing.assert_allclose(
        e.gyro.bias, e.gyro.turn_on + e.gyro.instability + e.gyro.random_walk
    )
    assert np.all(np.diag(e.gyro.matrix) != 1.0) and np.all(e.gyro.instability != 0.0)


def test_rate_random_walk_accumulates(world, collect) -> None:
    imu = registry.create("imu", "ideal", gyro_rate_random_walk=1e-4, accel_random_walk=1e-3)
    rng = np.random.default_rng(5)
    imu.reset(world, rng)
    collect(imu, world, rng, 101)  # 1 s
    e = imu.current_errors()
    assert np.all(e.gyro.random_walk != 0.0) and np.all(e.accel.random_walk != 0.0)
    np.testing.assert_array_equal(e.gyro.turn_on, 0.0)


def test_same_seed_bit_identical_different_seed_different(world, collect) -> None:
    def run(seed: int) -> dict[str, np.ndarray]:
        imu = registry.create("imu", "lig2024")
        rng = np.random.default_rng(seed)
        world.set_time(0.0)
        imu.reset(world, rng)
        return collect(imu, world, rng, 200)

    a, b, c = run(2024), run(2024), run(2025)
    for ch in ("angular_rate", "specific_force"):
        np.testing.assert_array_equal(a[ch], b[ch])
        assert not np.any(a[ch] == c[ch])


def test_changing_one_error_leaves_the_other_realisations_alone(world, collect) -> None:
    """Fixed draws per sample: a sweep over one parameter keeps common random numbers."""

    def run(**overrides) -> tuple[dict[str, np.ndarray], object]:
        imu = registry.create("imu", "lig2024", **overrides)
        rng = np.random.default_rng(99)
        world.set_time(0.0)
        imu.reset(world, rng)
        return collect(imu, world, rng, 50), imu.current_errors()

    (base, e_base), (quiet, e_quiet) = run(), run(gyro_noise_density=0.0)
    np.testing.assert_array_equal(base["specific_force"], quiet["specific_force"])
    np.testing.assert_array_equal(e_base.gyro.bias, e_quiet.gyro.bias)
    np.testing.assert_array_equal(e_base.gyro.matrix, e_quiet.gyro.matrix)
    np.testing.assert_allclose(
        base["angular_rate"][-1] - quiet["angular_rate"][-1], e_base.gyro.noise, atol=1e-18
    )
