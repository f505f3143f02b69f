"""Strapdown INS: ideal stationary run, pyins oracle, seed-IMU heading drift, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensors import registry
from sensors.imu import Imu
from twin.core import earth
from twin.core.frames import F_FROM_B, euler_to_dcm, wrap_pi
from twin.core.messages import Reading
from twin.onboard.ins import InsConfig, NavState, StrapdownIns

LAT = math.radians(45.0)
LON = math.radians(120.0)
DEPTH = 10.0


class StaticWorld:
    """A minimal sensors.base.WorldView for an IMU on a vehicle held still (no MuJoCo step).

    MuJoCo's accelerometer at rest reads the world's gravity [0, 0, γ(lat)] rotated into the
    site axes and its gyro reads zero; the IMU model adds the Earth terms (sensors/imu.py).
    """

    def __init__(self, rpy: tuple[float, float, float], lat: float = LAT, depth: float = DEPTH):
        self.latitude_rad = lat
        self.longitude_rad = LON
        self.surface_z_m = 0.0
        self.t = 0.0
        self.c_bn = euler_to_dcm(*rpy)
        g = earth.normal_gravity(lat)  # the world's gravity is depth-independent γ(lat)
        self._s = {
            "imu/gyro": np.zeros(3),
            "imu/accelerometer": self.c_bn.T @ np.array([0.0, 0.0, g]),
            "imu/linvel": np.zeros(3),
        }
        self._pos = np.array([0.0, 0.0, -depth])

    def mj_sensor(self, name: str) -> np.ndarray:
        return self._s[name]

    def site_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        return self._pos, self.c_bn


def make_imu(preset: str, world: StaticWorld, seed: int) -> tuple[Imu, np.random.Generator]:
    imu = registry.create("imu", preset)
    assert isinstance(imu, Imu)
    rng = np.random.default_rng(seed)
    imu.reset(world, rng)
    return imu, rng


def init_state(rpy: tuple[float, float, float], lat: float = LAT) -> NavState:
    return NavState.from_euler(
        lat_rad=lat, lon_rad=LON, h_m=-DEPTH, roll=rpy[0], pitch=rpy[1], yaw=rpy[2]
    )


# --- stationary, ideal IMU -------------------------------------------------------------------


def test_stationary_ideal_imu_does_not_drift_for_10_minutes() -> None:
    rpy = (0.05, -0.1, 0.7)
    world = StaticWorld(rpy)
    imu, rng = make_imu("ideal", world, 0)
    # The world's gravity has no height gradient: the matching INS gravity model.
    ins = StrapdownIns(init_state(rpy), InsConfig(free_air_gravity=False))
    dt = 0.01
    for k in range(1, 60001):
        world.t = k * dt
        r = imu.sample(world, rng)
        ins.step(dt, r["angular_rate"], r["specific_force"])
    s = ins.state()
    r_m, r_n = earth.principal_radii(LAT)
    assert s.t == pytest.approx(600.0)
    assert abs(s.lat_rad - LAT) * r_m < 1e-4  # m
    assert abs(s.lon_rad - LON) * r_n * math.cos(LAT) < 1e-4
    assert abs(s.h_m + DEPTH) < 1e-4  # vertical channel: unstable, but nothing to amplify
    assert np.abs(s.v_enu).max() < 1e-6
    assert np.abs(s.c_bn - world.c_bn).max() < 1e-9


def test_ideal_imu_with_free_air_ins_sees_only_the_gravity_model_difference() -> None:
    # The world's gravity is γ(lat) at every depth; a free-air INS at 10 m depth extrapolates
    # γ(1 + 2·10/a), 3.1e-5 m/s² more, so its vertical channel sinks by ≈ ½ Δγ t² (plus the
    # slow instability). Over 60 s: ≈ 0.056 m. This pins the documented model split.
    rpy = (0.0, 0.0, 0.0)
    world = StaticWorld(rpy)
    imu, rng = make_imu("ideal", world, 0)
    ins = StrapdownIns(init_state(rpy))
    for k in range(1, 6001):
        world.t = k * 0.01
        r = imu.sample(world, rng)
        ins.step(0.01, r["angular_rate"], r["specific_force"])
    dg = earth.normal_gravity(LAT, -DEPTH) - earth.normal_gravity(LAT)
    assert dg > 0
    expected = -0.5 * dg * 60.0**2
    assert ins.h + DEPTH == pytest.approx(expected, rel=0.02)


# --- pyins oracle ----------------------------------------------------------------------------


@pytest.mark.measures
def test_mechanization_agrees_with_pyins_on_a_sine_velocity_trajectory(record_property) -> None:
    import pyins.sim as pyins_sim  # a declared test dependency (python-ins): fail, never skip
    import pyins.strapdown as pyins_strapdown
    import pyins.transform as pyins_transform

    dt, total = 0.01, 300.0
    # NED mean velocity with a sinusoidal part: pitch and heading follow the velocity (pyins).
    traj, imu = pyins_sim.generate_sine_velocity_motion(
        dt,
        total,
        [37.5, 122.0, -15.0],
        [3.0, 1.5, 0.2],
        velocity_change_amplitude=[1.0, 1.0, 0.2],
        velocity_change_period=60.0,
        sensor_type="increment",
    )
    inc = pyins_strapdown.compute_increments_from_imu(imu, "increment")
    p0 = traj.iloc[0]
    oracle = pyins_strapdown.Integrator(p0)
    oracle_traj = oracle.integrate(inc)

    # pyins: NED and body forward-right-down (FRD). Ours: ENU and body right-forward-up. Both
    # permutations are F_FROM_B (symmetric, its own inverse): v_enu = T v_ned, θ_b = T θ_frd,
    # C_b^n(ours) = T C_frd^ned T.
    t = F_FROM_B
    c0 = t @ pyins_transform.mat_from_rph(p0[["roll", "pitch", "heading"]].to_numpy()) @ t
    init = NavState(
        0.0,
        math.radians(p0["lat"]),
        math.radians(p0["lon"]),
        float(p0["alt"]),
        t @ p0[["VN", "VE", "VD"]].to_numpy(float),
        c0,
    )
    import pyins.earth as pyins_earth  # declared test dependency: fail, never skip

    class PyinsGravityIns(StrapdownIns):
        """Our mechanization with pyins' gravity γ₀(1 − 2h/a), so that only the algorithm and
        the frames are compared (ours adds the (f + m − 2f sin²L) and h² terms of TR8350.2:
        ≈ 1e-6 m/s² at 75 m depth, ≈ 4 cm of height after 300 s)."""

        def gravity(self, lat: float, h: float) -> float:
            return float(pyins_earth.gravity(math.degrees(lat), h))

    ins = PyinsGravityIns(init)
    theta = inc[["theta_x", "theta_y", "theta_z"]].to_numpy() @ t.T
    dv = inc[["dv_x", "dv_y", "dv_z"]].to_numpy() @ t.T
    dts = inc["dt"].to_numpy()
    for k in range(len(inc)):
        ins.step_increments(float(dts[k]), theta[k], dv[k])
    ref = oracle_traj.iloc[-1]
    truth = traj.iloc[-1]
    s = ins.state()
    r_m, r_n = earth.principal_radii(s.lat_rad)
    north_m = (s.lat_rad - math.radians(ref["lat"])) * r_m
    east_m = (s.lon_rad - math.radians(ref["lon"])) * r_n * math.cos(s.lat_rad)
    c_ref = t @ pyins_transform.mat_from_rph(ref[["roll", "pitch", "heading"]].to_numpy()) @ t
    # Same algorithm, same increments, same gravity: what is left is float rounding (and the
    # order of operations). 300 s of a manoeuvring vehicle (≈ 1 km) must agree to 1 mm,
    # 1e-6 m/s and 1e-9 rad.
    record_property("ins_vs_pyins_300s_position_m", float(max(abs(north_m), abs(east_m))))
    record_property("ins_vs_pyins_300s_height_m", float(abs(s.h_m - ref["alt"])))
    record_property(
        "ins_vs_pyins_300s_velocity_mps",
        float(np.abs(s.v_enu - t @ ref[["VN", "VE", "VD"]].to_numpy(float)).max()),
    )
    record_property(
        "ins_vs_pyins_300s_attitude_rad", float(np.abs(s.c_bn @ c_ref.T - np.eye(3)).max())
    )
    assert abs(north_m) < 1e-3 and abs(east_m) < 1e-3
    assert abs(s.h_m - ref["alt"]) < 1e-3
    np.testing.assert_allclose(s.v_enu, t @ ref[["VN", "VE", "VD"]].to_numpy(float), atol=1e-6)
    phi = np.abs(s.c_bn @ c_ref.T - np.eye(3)).max()
    assert phi < 1e-9
    # And both follow pyins' own truth to its integration accuracy.
    assert abs(s.h_m - truth["alt"]) < 0.05
    assert abs((s.lat_rad - math.radians(truth["lat"])) * r_m) < 0.5


def test_rate_input_with_constant_rates_matches_increment_input() -> None:
    rpy = (0.1, 0.2, -0.3)
    init = init_state(rpy)
    w = np.array([0.01, -0.02, 0.05])
    f = np.array([0.1, 0.3, 9.7])
    a, b = StrapdownIns(init), StrapdownIns(init)
    for _ in range(1000):
        a.step(0.01, w, f)
        th = w * 0.01
        b.step_increments(0.01, th, f * 0.01 + 0.5 * np.cross(th, f * 0.01))
    np.testing.assert_allclose(a.c_bn, b.c_bn, atol=1e-14)
    np.testing.assert_allclose(a.v, b.v, atol=1e-12)


# --- the seed's IMU, unaided ---------------------------------------------------------------


def test_seed_imu_unaided_heading_drifts_as_the_gyro_bias_predicts() -> None:
    rpy = (0.0, 0.0, math.radians(-30.0))  # level: body z is up, heading drift = ∫ b_z dt
    world = StaticWorld(rpy)
    imu, rng = make_imu("lig2024", world, 7)
    ins = StrapdownIns(init_state(rpy), InsConfig(free_air_gravity=False))
    dt, n = 0.01, 60000
    integral_bz = 0.0
    for k in range(1, n + 1):
        world.t = k * dt
        r = imu.sample(world, rng)
        # The bias that acted on this sample (the GM part moves; integrate it, rectangle rule).
        integral_bz += float(imu.current_errors().gyro.bias[2]) * dt
        ins.step(dt, r["angular_rate"], r["specific_force"])
    yaw_err = wrap_pi(ins.state().euler[2] - rpy[2])
    # Positive z rate turns the computed yaw counter-clockwise: yaw error = +∫ b_z dt.
    # Residual terms: ARW (0.15 °/√h ⇒ 0.061° in 10 min), scale factor (500 ppm of
    # Ω sin L ⇒ 0.0004°), misalignment × Earth rate (1 mrad ⇒ 0.001°), the tilt coupling of the
    # Earth rate through the drifting level (≲ 0.1° here). Tolerance 0.25° + 3 %.
    predicted = integral_bz
    assert abs(math.degrees(predicted)) > 1.0  # this seed drifts (20 °/h turn-on σ): a real check
    assert abs(math.degrees(yaw_err - predicted)) < 0.25 + 0.03 * abs(math.degrees(predicted))


# --- bad input, determinism ----------------------------------------------------------------


def test_nan_in_a_reading_raises_naming_the_channel() -> None:
    ins = StrapdownIns(init_state((0.0, 0.0, 0.0)))
    with pytest.raises(ValueError, match="specific_force"):
        ins.step(0.01, np.zeros(3), np.array([0.0, np.nan, 9.8]))
    with pytest.raises(ValueError, match="angular_rate"):
        ins.step(0.01, np.array([np.inf, 0.0, 0.0]), np.zeros(3))
    with pytest.raises(ValueError, match="dt"):
        ins.step(0.0, np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="max_dt_s"):
        ins.step(5.0, np.zeros(3), np.zeros(3))
    assert ins.t == 0.0


def test_nan_reading_is_skipped_and_counted_when_configured() -> None:
    ins = StrapdownIns(init_state((0.0, 0.0, 0.0)), InsConfig(on_nonfinite="skip"))
    before = ins.state()
    assert ins.step(0.01, np.zeros(3), np.array([np.nan, 0.0, 9.8])) is False
    assert ins.skipped == 1
    after = ins.state()
    assert after.t == before.t and np.array_equal(after.c_bn, before.c_bn)
    assert np.all(np.isfinite(after.v_enu))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"max_dt_s": -1.0}, "max_dt_s"),
        ({"on_nonfinite": "ignore"}, "on_nonfinite"),
        ({"orthonormalize_every": 0}, "orthonormalize_every"),
        ({"free_air_gravity": 1}, "free_air_gravity"),
    ],
)
def test_bad_config_names_the_field(kwargs, field) -> None:
    with pytest.raises(ValueError, match=field):
        InsConfig(**kwargs)


def test_bad_initial_state_names_the_field() -> None:
    with pytest.raises(ValueError, match="lat_rad"):
        NavState(0.0, math.nan, 0.0, 0.0)
    with pytest.raises(ValueError, match="v_enu"):
        NavState(0.0, 0.1, 0.0, 0.0, np.array([1.0, np.nan, 0.0]))
    with pytest.raises(ValueError, match="c_bn"):
        NavState(0.0, 0.1, 0.0, 0.0, np.zeros(3), 2.0 * np.eye(3))


def test_step_reading_uses_time_stamps_and_is_deterministic() -> None:
    rpy = (0.0, 0.05, 1.0)

    def run() -> NavState:
        world = StaticWorld(rpy)
        imu, rng = make_imu("lig2024", world, 3)
        ins = StrapdownIns(init_state(rpy))
        for k in range(1, 501):
            world.t = k * 0.01
            v = imu.sample(world, rng)
            ins.step_reading(Reading("imu", world.t, world.t, v))
        return ins.state()

    a, b = run(), run()
    assert a.t == 5.0
    assert np.array_equal(a.c_bn, b.c_bn) and np.array_equal(a.v_enu, b.v_enu)
    assert (a.lat_rad, a.lon_rad, a.h_m) == (b.lat_rad, b.lon_rad, b.h_m)


@pytest.mark.parametrize("free_air", [False, True])
def test_the_compiled_step_is_the_python_step_bit_for_bit(free_air) -> None:
    # twin.onboard.mechanization.advance replaces StrapdownIns._advance_reference (issue #31):
    # the same state after a step, to the last bit, over random states and increments.
    rng = np.random.default_rng(7)
    fast = StrapdownIns(init_state((0.0, 0.0, 0.0)), InsConfig(free_air_gravity=free_air))
    slow = StrapdownIns(init_state((0.0, 0.0, 0.0)), InsConfig(free_air_gravity=free_air))
    for _ in range(5000):  # CPython's x ** 2 (libm pow) differs from x·x for ~0.1 % of x
        c = euler_to_dcm(*rng.uniform(-math.pi / 2, math.pi / 2, 3)).reshape(-1)
        state = (
            float(rng.uniform(-1.4, 1.4)),
            float(rng.uniform(-3.0, 3.0)),
            float(rng.normal(0.0, 200.0)),
            tuple(rng.normal(0.0, 2.0, 3).tolist()),
            tuple(c.tolist()),
        )
        theta = tuple(rng.normal(0.0, 0.02, 3).tolist())
        dv = tuple(rng.normal(0.0, 0.2, 3).tolist())
        for ins in (fast, slow):
            ins.lat, ins.lon, ins.h, ins._v, ins._c = state
        fast._advance(0.01, theta, dv)
        slow._advance_reference(0.01, theta, dv)
        assert (fast.lat, fast.lon, fast.h, fast._v, fast._c) == (
            slow.lat, slow.lon, slow.h, slow._v, slow._c
        )  # fmt: skip
        assert fast._steps == slow._steps and fast.t == slow.t
