"""The 15-state ESKF: F and H by finite differences, observability with the seed IMU, gating."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import scipy.linalg
from scipy.stats import chi2

from sensors import registry
from sensors.imu import DEG_PER_H, DEG_PER_RT_H, IMU_PRESETS, MICRO_G, Imu
from twin.core import earth
from twin.core.frames import euler_to_dcm, skew, wrap_pi
from twin.onboard import eskf as eskf_mod
from twin.onboard.eskf import (
    DIM,
    Eskf,
    EskfConfig,
    ImuGrade,
    attitude_error,
    error_dynamics,
)
from twin.onboard.ins import InsConfig, NavState, StrapdownIns, rotvec_to_dcm

LAT = math.radians(36.175)
LON = math.radians(120.482)
DEPTH = 10.0
SUN_ENU = np.array(
    [
        math.cos(math.radians(40)) * math.sin(math.radians(120)),
        math.cos(math.radians(40)) * math.cos(math.radians(120)),
        math.sin(math.radians(40)),
    ]
)  # fmt: skip  (elevation 40°, compass azimuth 120°)


class StaticWorld:
    """Minimal sensors.base.WorldView: a vehicle held still (see tests/onboard/test_ins.py)."""

    def __init__(self, rpy: tuple[float, float, float]):
        self.latitude_rad, self.longitude_rad, self.surface_z_m, self.t = LAT, LON, 0.0, 0.0
        self.c_bn = euler_to_dcm(*rpy)
        g = earth.normal_gravity(LAT)
        self._s = {
            "imu/gyro": np.zeros(3),
            "imu/accelerometer": self.c_bn.T @ np.array([0.0, 0.0, g]),
            "imu/linvel": np.zeros(3),
        }
        self._pos = np.array([0.0, 0.0, -DEPTH])

    def mj_sensor(self, name: str) -> np.ndarray:
        return self._s[name]

    def site_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        return self._pos, self.c_bn


# --- F and H by finite differences ---------------------------------------------------------

NOMINAL = {
    "lat": math.radians(37.0),
    "h": -20.0,
    "v": np.array([3.0, 5.0, 0.5]),
    "rpy": (0.1, -0.2, 0.8),
}
W_B = np.array([0.01, -0.02, 0.03])
F_B = np.array([0.3, -0.2, 9.9])


def _ins(phi, dv, dp, eps, nab) -> StrapdownIns:
    """An INS whose errors (estimate − truth) w.r.t. NOMINAL are the given ones."""
    c = rotvec_to_dcm(*(-np.asarray(phi))) @ euler_to_dcm(*NOMINAL["rpy"])  # exp(−[φ×]) C
    s = NavState(
        0.0, NOMINAL["lat"] + dp[0], 0.5 + dp[1], NOMINAL["h"] + dp[2], NOMINAL["v"] + dv, c
    )
    # Residual bias = true (0) − estimate: the INS's bias estimate is −ε, −∇.
    return StrapdownIns(s, gyro_bias=-np.asarray(eps), accel_bias=-np.asarray(nab))


def _errors(a: StrapdownIns, ref: StrapdownIns) -> np.ndarray:
    return np.concatenate(
        [
            attitude_error(a.c_bn, ref.c_bn),
            a.v - ref.v,
            [a.lat - ref.lat, a.lon - ref.lon, a.h - ref.h],
            -a.gyro_bias,
            -a.accel_bias,
        ]
    )


def _fd_jacobian(
    dt: float, dlatlon: float, n: int, w_b: np.ndarray, f_b: np.ndarray = F_B
) -> np.ndarray:
    """(δx(dt) − δx(0)) / dt per unit initial error (n INS steps), central differences."""
    ref = _ins(np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    for _ in range(n):
        ref.step(dt / n, w_b, f_b)
    steps = np.array([1e-5] * 3 + [1e-3] * 3 + [dlatlon, dlatlon, 1.0] + [1e-6] * 3 + [1e-4] * 3)
    jac = np.zeros((DIM, DIM))
    for i in range(DIM):
        rates = []
        for sign in (1.0, -1.0):
            x0 = np.zeros(DIM)
            x0[i] = sign * steps[i]
            ins = _ins(x0[0:3], x0[3:6], x0[6:9], x0[9:12], x0[12:15])
            for _ in range(n):
                ins.step(dt / n, w_b, f_b)
            rates.append((_errors(ins, ref) - x0) / dt)
        jac[:, i] = (rates[0] - rates[1]) / (2 * steps[i])
    return jac


def test_f_matches_finite_differences_of_the_mechanization() -> None:
    lat, h = NOMINAL["lat"], NOMINAL["h"]
    dgl = (earth.normal_gravity(lat + 1e-5, h) - earth.normal_gravity(lat - 1e-5, h)) / 2e-5
    dgh = (earth.normal_gravity(lat, h + 1) - earth.normal_gravity(lat, h - 1)) / 2.0
    c = euler_to_dcm(*NOMINAL["rpy"])
    # Scale to typical error sizes so every coupling is compared on a like footing:
    # φ 1 mrad, δv 0.1 m/s, δL δλ 1e-6 rad (6 m), δh 6 m, ε 1e-5 rad/s (2 °/h), ∇ 1e-3 m/s².
    d = np.array([1e-3] * 3 + [0.1] * 3 + [1e-6, 1e-6, 6.0] + [1e-5] * 3 + [1e-3] * 3)
    # Latitude and longitude (~0.6 rad) carry 1e-16 rad of rounding: their rows need a longer
    # span (1 s in 100 INS steps) and larger position perturbations to rise above it; the
    # other rows use one 1 ms step.
    others = [0, 1, 2, 3, 4, 5, 8, 9, 10, 11, 12, 13, 14]
    # F is evaluated at the start of the span, so over 1 s the nominal must not change: the body
    # must not turn (a turning C would move F[δv, ∇] = C by |ω| t) and the velocity must hold.
    # With F_B the tilted body accelerates at ≈ 2 m/s² horizontally, v_N grows from 5 to ≈ 7 m/s
    # and the finite difference of δL̇ over δh sees the mean −v̄_N/(R_M + h)², 21.5 % more than
    # F's instantaneous −v_N/(R_M + h)² (the colleague's open item: F was right). So the
    # position rows are differenced with the specific force that holds the velocity steady.
    g_n = np.array([0.0, 0.0, earth.normal_gravity(lat, h)])
    w_ie = earth.earth_rate_enu(lat)
    f_hold = c.T @ (g_n + np.cross(2 * w_ie + earth.transport_rate_enu(lat, h, NOMINAL["v"]),
                                    NOMINAL["v"]))  # fmt: skip
    w_hold = c.T @ (w_ie + earth.transport_rate_enu(lat, h, NOMINAL["v"]))
    cases = ((1e-3, 1e-7, 1, W_B, F_B, others), (1.0, 1e-6, 100, w_hold, f_hold, [6, 7]))
    for dt, dll, n, w, f_b, rows in cases:
        f = error_dynamics(lat, h, NOMINAL["v"], c, f_b, dgl, dgh)
        jac = _fd_jacobian(dt, dll, n, w, f_b)
        # One step of the mechanization is Φ = expm(F dt), so the finite-difference rate is
        # (expm(F dt) − I)/dt = F + ½ F² dt + …; compare with that.
        fd = (scipy.linalg.expm(f * dt) - np.eye(DIM)) / dt
        fs = (fd * d[None, :] / d[:, None])[rows]
        js = (jac * d[None, :] / d[:, None])[rows]
        # Left: the ignored ∂R/∂L terms (relative e² ≈ 0.7 %), O(dt²) and rounding
        # (≈ 1e-8 in these scaled units).
        np.testing.assert_allclose(js, fs, rtol=0.02, atol=3e-8, err_msg=f"dt={dt}")
    # And the couplings that matter are there with the documented signs.
    f = error_dynamics(lat, h, NOMINAL["v"], c, F_B, dgl, dgh)
    np.testing.assert_allclose(f[0:3, 9:12], -c)
    np.testing.assert_allclose(f[3:6, 0:3], skew(c @ F_B))
    # The open item, settled: ∂δL̇/∂δh = −v_N/(R_M + h)² to the finite difference's accuracy.
    r_m, _ = earth.principal_radii(lat)
    jac = _fd_jacobian(1.0, 1e-6, 100, w_hold, f_hold)
    assert jac[6, 8] == pytest.approx(-NOMINAL["v"][1] / (r_m + h) ** 2, rel=0.01)


def test_h_gravity_matches_finite_differences() -> None:
    c = euler_to_dcm(*NOMINAL["rpy"])
    g_n = np.array([0.0, 0.0, -earth.normal_gravity(LAT)])
    f_true = -c.T @ g_n

    def z(x: np.ndarray) -> np.ndarray:  # eq. 18 with C_est = exp(−[φ×]) C, f_meas = f + ∇
        c_est = rotvec_to_dcm(*(-x[0:3])) @ c
        return -c_est @ (f_true + x[12:15]) - g_n

    nav = Eskf(EskfConfig(), NavState(0.0, LAT, LON, -DEPTH, np.zeros(3), c))
    nav.ins.f_b = f_true
    jac = np.column_stack([(z(e * 1e-6) - z(-e * 1e-6)) / 2e-6 for e in np.eye(DIM)])
    h = np.zeros((3, DIM))
    h[:, 0:3] = skew(g_n)
    h[:, 12:15] = -c
    np.testing.assert_allclose(jac, h, atol=1e-6)
    # The paper's H_g = [(g^n×) 0]: for g^n = [0, 0, −g], a +φ_E tilt shows as −g φ_E on N.
    assert h[1, 0] == pytest.approx(-earth.normal_gravity(LAT))


def test_h_sun_matches_finite_differences() -> None:
    c = euler_to_dcm(*NOMINAL["rpy"])
    s_b = c.T @ SUN_ENU

    def z(x: np.ndarray) -> np.ndarray:  # eqs. 21–24: Z_s = C_est ŝ^b − s^n
        return rotvec_to_dcm(*(-x[0:3])) @ c @ s_b - SUN_ENU

    jac = np.column_stack([(z(e * 1e-6) - z(-e * 1e-6)) / 2e-6 for e in np.eye(DIM)])
    h = np.zeros((3, DIM))
    h[:, 0:3] = skew(SUN_ENU)
    np.testing.assert_allclose(jac, h, atol=1e-9)


def test_attitude_error_convention_and_heading_sign() -> None:
    c = euler_to_dcm(0.0, 0.0, 0.3)
    phi = np.array([1e-4, -2e-4, 3e-3])
    c_est = rotvec_to_dcm(*(-phi)) @ c  # = (I − [φ×]) C to first order
    np.testing.assert_allclose(c_est, (np.eye(3) - skew(phi)) @ c, atol=1e-5)
    np.testing.assert_allclose(attitude_error(c_est, c), phi, rtol=1e-9, atol=1e-15)
    nav = Eskf(EskfConfig(), NavState(0.0, LAT, LON, 0.0, np.zeros(3), c_est))
    est_heading = nav.estimate().heading_deg
    true_heading = (-math.degrees(0.3)) % 360
    # Level vehicle: compass heading error (estimate − truth) = +φ_U.
    assert est_heading - true_heading == pytest.approx(math.degrees(phi[2]), abs=1e-3)


# --- stationary runs with the seed IMU ------------------------------------------------------

RPY = (0.02, -0.03, math.radians(-50.0))


def seed_config(**kw) -> EskfConfig:
    """Paper defaults with P0 and Q matched to the lig2024 preset's error model."""
    base = EskfConfig(
        p0_gyro_bias_rad_s=(20 * DEG_PER_H,) * 3,  # the preset's turn-on bias σ
        p0_accel_bias_mps2=(1000 * MICRO_G,) * 3,  # turn-on 200 µg + 1 mrad misalignment × g
        q_attitude=(0.15 * DEG_PER_RT_H,) * 3,  # the preset's ARW
        q_gyro_bias=(1.0755 * 8 * DEG_PER_H * math.sqrt(2 / 300),) * 3,  # GM, σ√(2/τ)
        ins=InsConfig(free_air_gravity=False),
    )
    return dataclasses.replace(base, **kw)


def lig2024_grade() -> ImuGrade:
    """The lig2024 preset's datasheet as the vehicle declares it (worst axis for the VRW)."""
    s = IMU_PRESETS["lig2024"]
    return ImuGrade(
        gyro_noise_density=float(np.max(s.gyro_noise_density)),
        gyro_bias_instability=s.gyro_bias_instability,
        gyro_bias_corr_time_s=s.gyro_bias_corr_time_s,
        gyro_turn_on_bias=s.gyro_turn_on_bias,
        gyro_scale_factor=s.gyro_scale_factor,
        gyro_misalignment=s.gyro_misalignment,
        accel_noise_density=float(np.max(s.accel_noise_density)),
        accel_bias_instability=s.accel_bias_instability,
        accel_bias_corr_time_s=s.accel_bias_corr_time_s,
        accel_turn_on_bias=s.accel_turn_on_bias,
        accel_scale_factor=s.accel_scale_factor,
        accel_misalignment=s.accel_misalignment,
    )


def run_static(
    seconds: float,
    *,
    gravity: bool,
    sun: bool,
    seed: int = 11,
    sun_sigma: float = 0.01,
    config: EskfConfig | None = None,
) -> dict[str, np.ndarray]:
    world = StaticWorld(RPY)
    imu = registry.create("imu", "lig2024")
    assert isinstance(imu, Imu)
    ss = np.random.SeedSequence(seed).spawn(2)
    rng_imu, rng_sun = np.random.default_rng(ss[0]), np.random.default_rng(ss[1])
    imu.reset(world, rng_imu)
    nav = Eskf(
        seed_config() if config is None else config,
        NavState.from_euler(
            lat_rad=LAT, lon_rad=LON, h_m=-DEPTH, roll=RPY[0], pitch=RPY[1], yaw=RPY[2]
        ),
    )
    s_b_true = world.c_bn.T @ SUN_ENU
    cov_b = sun_sigma**2 * (np.eye(3) - np.outer(s_b_true, s_b_true))
    out: dict[str, list] = {k: [] for k in ("t", "roll", "pitch", "head", "sig_head", "nees")}
    dt = 0.01
    for k in range(1, round(seconds / dt) + 1):
        world.t = k * dt
        r = imu.sample(world, rng_imu)
        nav.predict_imu(dt, r["angular_rate"], r["specific_force"])
        if k % 10 == 0:
            if gravity:
                nav.update_gravity()
            if sun:
                noisy = s_b_true + sun_sigma * rng_sun.standard_normal(3)
                nav.update_sun(
                    sun_body=noisy / np.linalg.norm(noisy), sun_enu=SUN_ENU, covariance_body=cov_b
                )
        if k % 100 == 0:
            nav.update_depth(DEPTH)
            e = nav.estimate()
            phi = attitude_error(e.c_bn, world.c_bn)
            out["t"].append(e.t)
            out["roll"].append(wrap_pi(e.roll - RPY[0]))
            out["pitch"].append(wrap_pi(e.pitch - RPY[1]))
            out["head"].append(math.degrees(phi[2]))
            out["sig_head"].append(e.heading_sigma_deg)
            out["nees"].append(float(phi @ np.linalg.solve(e.covariance[0:3, 0:3], phi)))
    res = {k: np.array(v) for k, v in out.items()}
    res["rejections"] = np.array(len(nav.rejections))
    res["sun_rejections"] = np.array(sum(r.kind == "sun" for r in nav.rejections))
    return res


def test_gravity_aiding_bounds_roll_and_pitch_not_heading() -> None:
    r = run_static(300.0, gravity=True, sun=False)
    late = r["t"] > 60
    # Tilt stays bounded. With the paper's very loose R_g (0.1 g per axis) the horizontal gyro
    # biases (20 °/h turn-on) are learnt slowly, so the level error peaks near 0.3° before it
    # settles; it does not grow.
    assert np.degrees(np.abs(r["roll"][late])).max() < 0.5
    assert np.degrees(np.abs(r["pitch"][late])).max() < 0.5
    last = r["t"] > 200
    assert np.degrees(np.abs(r["roll"][last])).max() < 0.35
    # Heading: unobservable. Its σ only grows (≈ ε σ × t) and the truth error wanders off.
    assert np.all(np.diff(r["sig_head"]) > 0)
    assert r["sig_head"][-1] > 3 * r["sig_head"][0]
    assert abs(r["head"][-1]) > 0.3


def test_solar_aiding_bounds_heading_constant_bias_and_arw() -> None:
    """Gravity + sun at 10 Hz on a synthetic IMU: a 20 °/h-class constant gyro bias plus the
    seed's ARW. Heading (and the gyro bias) converge and stay inside ±3σ; σ stays bounded."""
    c = euler_to_dcm(*RPY)
    w = c.T @ earth.earth_rate_enu(LAT)
    f = c.T @ np.array([0.0, 0.0, earth.normal_gravity(LAT)])
    bias = np.array([1e-4, -0.8e-4, 0.6e-4])  # 20.6, 16.5, 12.4 °/h
    arw = 0.15 * DEG_PER_RT_H * 10.0  # σ per 100 Hz sample
    rng = np.random.default_rng(1)
    nav = Eskf(
        seed_config(),
        NavState.from_euler(
            lat_rad=LAT, lon_rad=LON, h_m=-DEPTH, roll=RPY[0], pitch=RPY[1], yaw=RPY[2]
        ),
    )
    s_b = c.T @ SUN_ENU
    cov_b = 1e-4 * (np.eye(3) - np.outer(s_b, s_b))
    heads, sigs = [], []
    for k in range(1, 30001):
        nav.predict_imu(0.01, w + bias + arw * rng.standard_normal(3), f)
        if k % 10 == 0:
            nav.update_gravity()
            noisy = s_b + 0.01 * rng.standard_normal(3)
            nav.update_sun(
                sun_body=noisy / np.linalg.norm(noisy), sun_enu=SUN_ENU, covariance_body=cov_b
            )
        if k % 100 == 0:
            nav.update_depth(DEPTH)
            e = nav.estimate()
            heads.append(math.degrees(attitude_error(e.c_bn, c)[2]))
            sigs.append(e.heading_sigma_deg)
    h, sg = np.array(heads[60:]), np.array(sigs[60:])
    assert np.abs(h).max() < 0.3  # deg, after 60 s
    assert sg.max() < 0.3 and sg[-1] < 1.2 * sg[0]  # bounded, not growing
    assert np.all(np.abs(h) < 3 * sg)
    np.testing.assert_allclose(nav.estimate().gyro_bias, bias, atol=0.15 * np.abs(bias).max())


STILL = InsConfig(free_air_gravity=False)  # the twin world's depth-independent gravity


@pytest.mark.measures
def test_solar_aiding_bounds_heading_with_the_seed_imu(record_property) -> None:
    """The full lig2024 sensor model, filter tuned from its datasheet (EskfConfig.for_imu)."""
    r = run_static(
        300.0, gravity=True, sun=True, config=EskfConfig.for_imu(lig2024_grade(), ins=STILL)
    )
    late = r["t"] > 60
    record_property("nees_attitude_imu_tuning", float(r["nees"][late].mean()))
    assert np.degrees(np.abs(r["roll"][late])).max() < 0.5
    assert np.degrees(np.abs(r["pitch"][late])).max() < 0.5
    assert np.abs(r["head"][late]).max() < 0.3  # deg (measured 0.20)
    assert r["sig_head"][late].max() < 0.3  # (measured 0.25)
    assert np.mean(np.abs(r["head"][late]) < 3 * r["sig_head"][late]) > 0.95
    # Consistent or conservative: the mean attitude NEES (3 dof) is not above 3 by more than
    # the 99 % chi-square bound for ~4 independent samples (one a minute; measured 0.93). The
    # default for_imu allowance for scale factor and misalignment at 0.05 rad/s is pure margin
    # for a vehicle at rest, so the NEES sits below 3.
    assert r["nees"][late].mean() < chi2.ppf(0.99, 3 * 4) / 4
    assert int(r["sun_rejections"]) <= 10  # ≈ 0.1 % of 3000 at the 0.999 gate (measured 5)


@pytest.mark.slow  # statistics over seeds (30 s); single-seed NEES checks stay in the default suite
def test_imu_tuned_filter_is_consistent_over_seeds() -> None:
    """Monte Carlo NEES with the seed IMU: within two-sided chi-square bounds.

    Two choices make the filter's claim testable rather than merely conservative: no
    rate-proportional allowance (the vehicle is at rest) and R_g = (0.01 m/s²)² instead of the
    paper's (0.1 g)² (the 0.1-s mean of the accelerometer has σ ≈ 2 mm/s²; the paper's value
    leaves the rotation about the sun vector, which only gravity observes, far looser than it
    is). Samples are taken one a minute after the first (4 per run, 4 runs: 16 samples, 48 dof),
    a deliberately small effective count: the along-sun attitude error decorrelates over tens
    of seconds. Measured: pooled mean NEES 2.6 (per run 1.8-4.9).
    """
    cfg = EskfConfig.for_imu(
        lig2024_grade(), typical_rate_rad_s=0.0, r_gravity_mps2=(0.01,) * 3, ins=STILL
    )
    samples = []
    for seed in (11, 12, 13, 14):
        r = run_static(300.0, gravity=True, sun=True, config=cfg, seed=seed)
        samples.append(r["nees"][r["t"] > 60][::60])
    nees = np.concatenate(samples)
    n = nees.size
    assert n == 16
    lo, hi = chi2.ppf(0.005, 3 * n) / n, chi2.ppf(0.995, 3 * n) / n  # 1.66, 4.81
    assert lo < nees.mean() < hi


@pytest.mark.measures
def test_paper_tuning_is_overconfident_with_the_seed_imu(record_property) -> None:
    """A measured finding: the paper's P0/Q (2 °/h, 10 µg, 5 µg/√Hz, no bias noise) with the
    lig2024 IMU claims 0.05° of heading while the error reaches 1°: NEES in the hundreds."""
    r = run_static(300.0, gravity=True, sun=True, config=EskfConfig(ins=STILL))
    late = r["t"] > 60
    record_property("nees_attitude_paper_tuning", float(r["nees"][late].mean()))
    assert r["nees"][late].mean() > 100.0  # measured 516 (seeds 12, 13: 39, 9 and ~275 sun
    # fixes rejected by the gate as the filter stops believing the truth)
    assert np.abs(r["head"][late]).max() > 0.5  # deg (measured 0.95)
    assert r["sig_head"][late].max() < 0.1  # what it claims (measured 0.05)


def test_velocity_noise_below_the_accelerometer_vrw_breaks_consistency() -> None:
    """The root cause of the seed-IMU inconsistency (formerly an xfail here): Q on δv.

    With the IMU's P0 and attitude noise but the paper's 5 µg/√Hz on δv against the
    accelerometer's 45/65 µg/√Hz, the depth updates make the filter trust the vertical velocity,
    so the vertical velocity random walk is read as accelerometer bias; through the gravity
    update's −C∇ term that tilts the solution about the one axis the sun does not observe (the
    sun direction: the error grows along s^n to 0.6°). Raising q_velocity to the VRW alone
    restores consistency (each IMU error source switched off in turn: only the z VRW matters).
    """
    bad = run_static(300.0, gravity=True, sun=True)  # seed_config(): q_velocity 5 µg/√Hz
    good = run_static(
        300.0,
        gravity=True,
        sun=True,
        config=seed_config(q_velocity=(45 * MICRO_G, 45 * MICRO_G, 65 * MICRO_G)),
    )
    late = bad["t"] > 60
    assert bad["nees"][late].mean() > 10.0  # measured 20
    assert good["nees"][late].mean() < 3.0  # measured 1.8
    assert np.abs(good["head"][late]).max() < 0.3


def test_runs_are_deterministic() -> None:
    a = run_static(20.0, gravity=True, sun=True, seed=5)
    b = run_static(20.0, gravity=True, sun=True, seed=5)
    for k in a:
        assert np.array_equal(a[k], b[k]), k


# --- gating, depth, bad input ----------------------------------------------------------------


def _nav(c: np.ndarray | None = None) -> Eskf:
    c = euler_to_dcm(*RPY) if c is None else c
    return Eskf(EskfConfig(), NavState(0.0, LAT, LON, -DEPTH, np.zeros(3), c))


def test_outlier_sun_vector_is_gated_recorded_and_not_applied() -> None:
    nav = _nav()
    c = nav.ins.c_bn.copy()
    wrong = euler_to_dcm(*RPY[:2], RPY[2] + math.radians(30.0)).T @ SUN_ENU  # 30° off
    res = nav.update_sun(sun_body=wrong, sun_enu=SUN_ENU)
    assert not res.applied and res.reason == "gate"
    assert len(nav.rejections) == 1
    rej = nav.rejections[0]
    assert rej.kind == "sun" and rej.t == 0.0 and rej.nis > rej.threshold
    assert np.array_equal(nav.ins.c_bn, c)
    good = nav.update_sun(sun_body=c.T @ SUN_ENU, sun_enu=SUN_ENU)
    assert good.applied and good.nis < 1e-12


def test_sun_update_accepts_a_compass_fix_and_skips_a_failed_one() -> None:
    from twin.onboard.compass.base import CompassFix, no_fix

    nav = _nav()
    assert nav.update_sun(no_fix("lig", "too dark")).reason == "no fix"
    s_b = nav.ins.c_bn.T @ SUN_ENU
    fix = CompassFix(
        "lig",
        True,
        sun_body=s_b,
        sun_enu=SUN_ENU,
        covariance_body=1e-4 * (np.eye(3) - np.outer(s_b, s_b)),
    )
    assert nav.update_sun(fix).applied


def test_depth_outlier_is_gated() -> None:
    nav = _nav()
    res = nav.update_depth(20.0, sigma_m=0.01)  # 10 m off with P0 σ_h = 1 m: NIS ≈ 100 > 10.8
    assert not res.applied and nav.rejections[-1].kind == "depth"
    assert nav.estimate().h_m == pytest.approx(-DEPTH)


def test_depth_update_applies_within_the_gate() -> None:
    nav = _nav()
    assert nav.update_depth(10.5, sigma_m=0.01).applied
    assert nav.estimate().depth_m == pytest.approx(10.5, abs=0.01)


def test_gravity_update_is_skipped_when_not_quasi_static() -> None:
    nav = _nav()
    f = nav.ins.c_bn.T @ np.array([0.0, 0.0, 9.8 + 1.0])
    res = nav.update_gravity(f, np.zeros(3))
    assert not res.applied and res.reason == "not quasi-static"
    res = nav.update_gravity(nav.ins.c_bn.T @ np.array([0.0, 0.0, 9.8]), np.array([0.0, 0.0, 0.1]))
    assert res.reason == "not quasi-static"


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"p0_attitude_rad": (0.1, -0.1, 0.1)}, "p0_attitude_rad"),
        ({"q_velocity": (0.1, math.nan, 0.1)}, "q_velocity"),
        ({"r_sun": (0.05, 0.05)}, "r_sun"),
        ({"gate_probability": 1.5}, "gate_probability"),
        ({"cov_step_s": 0.0}, "cov_step_s"),
        ({"gyro_bias_tau_s": -3.0}, "gyro_bias_tau_s"),
        ({"r_depth_m": math.inf}, "r_depth_m"),
    ],
)
def test_bad_config_names_the_field(kwargs, field) -> None:
    with pytest.raises(ValueError, match=field):
        EskfConfig(**kwargs)


def test_bad_measurements_name_the_field() -> None:
    nav = _nav()
    with pytest.raises(ValueError, match="sun_body"):
        nav.update_sun(sun_body=[np.nan, 0.0, 1.0], sun_enu=SUN_ENU)
    with pytest.raises(ValueError, match="sun_enu"):
        nav.update_sun(sun_body=[0.0, 0.0, 1.0], sun_enu=[0.0, 0.0, 3.0])
    with pytest.raises(ValueError, match="covariance_body"):
        nav.update_sun(sun_body=[0.0, 0.0, 1.0], sun_enu=SUN_ENU, covariance_body=np.eye(2))
    with pytest.raises(ValueError, match="depth_m"):
        nav.update_depth(math.nan)
    with pytest.raises(ValueError, match="specific_force"):
        nav.predict_imu(0.01, np.zeros(3), np.array([0.0, 0.0, np.nan]))
    with pytest.raises(ValueError, match="init"):
        Eskf(EskfConfig(), None)


# --- IMU-derived tuning ----------------------------------------------------------------------


def test_for_imu_derives_p0_and_q_from_the_datasheet() -> None:
    grade = lig2024_grade()
    cfg = EskfConfig.for_imu(grade, typical_rate_rad_s=0.0)
    gm = 0.664 / 0.6174  # σ_GM per unit bias instability
    assert cfg.p0_gyro_bias_rad_s[0] / DEG_PER_H == pytest.approx(math.hypot(20.0, gm * 8.0))
    g = earth.G0_MPS2
    p0_a = math.sqrt(
        200**2 + (gm * 20) ** 2 + (500e-6 * g / MICRO_G) ** 2 + (1e-3 * g / MICRO_G) ** 2
    )
    assert cfg.p0_accel_bias_mps2[2] / MICRO_G == pytest.approx(p0_a)
    # ARW 0.15 °/√h, but never below the paper's 0.16 °/√h on U; VRW the worst axis, 65 µg/√Hz.
    assert np.array(cfg.q_attitude) / DEG_PER_RT_H == pytest.approx([0.15, 0.15, 0.16])
    assert np.array(cfg.q_velocity) / MICRO_G == pytest.approx([65.0] * 3)
    assert cfg.q_gyro_bias[0] == pytest.approx(gm * 8 * DEG_PER_H * math.sqrt(2 / 300))
    assert cfg.gyro_bias_tau_s is None  # random walk: the turn-on part is a constant
    # The scale-factor/misalignment allowance: k ω̄ √T with k = √(s² + 2m²).
    allowed = EskfConfig.for_imu(grade, typical_rate_rad_s=0.05, manoeuvre_time_s=60.0)
    k = math.sqrt(500e-6**2 + 2 * 1e-3**2)
    q = math.hypot(grade.gyro_noise_density, k * 0.05 * math.sqrt(60.0))
    assert allowed.q_attitude == pytest.approx((q, q, q))
    # Overrides win; the rest stays the paper's.
    o = EskfConfig.for_imu(grade, r_sun=(0.02,) * 3, ins=InsConfig(free_air_gravity=False))
    assert o.r_sun == (0.02,) * 3 and o.ins.free_air_gravity is False
    assert o.r_gravity_mps2 == EskfConfig().r_gravity_mps2


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("gyro_noise_density", -1e-5),
        ("gyro_bias_instability", math.nan),
        ("gyro_bias_corr_time_s", 0.0),
        ("accel_turn_on_bias", math.inf),
        ("accel_scale_factor", 0.5),
        ("gyro_misalignment", "1 mrad"),
        ("accel_bias_corr_time_s", -300.0),
    ],
)
def test_bad_imu_grade_names_the_field(field, value) -> None:
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(lig2024_grade(), **{field: value})


def test_for_imu_rejects_bad_arguments_naming_them() -> None:
    with pytest.raises(ValueError, match="grade"):
        EskfConfig.for_imu({"gyro_noise_density": 1e-5})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="typical_rate_rad_s"):
        EskfConfig.for_imu(lig2024_grade(), typical_rate_rad_s=-1.0)
    with pytest.raises(ValueError, match="manoeuvre_time_s"):
        EskfConfig.for_imu(lig2024_grade(), manoeuvre_time_s=0.0)
    with pytest.raises(ValueError, match="datasheet_only"):
        EskfConfig.for_imu(lig2024_grade(), datasheet_only="yes")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="no_such_field"):
        EskfConfig.for_imu(lig2024_grade(), no_such_field=1.0)
    with pytest.raises(ValueError, match="q_velocity"):
        EskfConfig.for_imu(lig2024_grade(), q_velocity=(1.0, -1.0, 1.0))


# --- the hand-written algebra against filterpy ------------------------------------------------


def _random_spd(rng: np.random.Generator, n: int, scales: np.ndarray) -> np.ndarray:
    a = rng.standard_normal((n, n))
    return (a @ a.T / n + 0.1 * np.eye(n)) * np.outer(scales, scales)


def test_update_and_propagation_match_filterpy() -> None:
    from filterpy.kalman import predict as kf_predict
    from filterpy.kalman import update as kf_update

    rng = np.random.default_rng(3)
    scales = np.array([1e-2] * 3 + [0.1] * 3 + [1e-7, 1e-7, 1.0] + [1e-4] * 3 + [1e-3] * 3)
    nav = _nav()
    p0 = _random_spd(rng, DIM, scales)
    # Measurement update (the sun's 2-D form; gating off by construction of a small z).
    nav.P = p0.copy()
    h = rng.standard_normal((2, DIM)) * (1.0 / scales)[None, :] * 0.1
    r = _random_spd(rng, 2, np.array([0.01, 0.01]))
    z = 1e-4 * rng.standard_normal(2)
    captured = {}
    nav._feedback = lambda x: captured.setdefault("x", x)  # type: ignore[method-assign]
    res = nav._update_reference("sun", z, h, r)
    assert res.applied
    x_ref, p_ref = kf_update(np.zeros(DIM), p0, z, r, h)
    np.testing.assert_allclose(captured["x"] / scales, x_ref / scales, rtol=1e-9, atol=1e-12)
    pn = np.outer(scales, scales)
    np.testing.assert_allclose(nav.P / pn, 0.5 * (p_ref + p_ref.T) / pn, rtol=1e-9, atol=1e-12)
    # Covariance propagation: P ← Φ P Φᵀ + Q_d.
    nav = _nav()
    nav.P = p0.copy()
    nav.predict_imu(0.01, np.array([0.01, -0.02, 0.03]), nav.ins.c_bn.T @ np.array([0, 0, 9.8]))
    dt = nav._pending_dt
    fdt = nav.system_matrix() * dt
    phi = np.eye(DIM) + fdt + 0.5 * fdt @ fdt
    q = 0.5 * (phi @ nav._qc @ phi.T + nav._qc) * dt
    _, p_ref = kf_predict(np.zeros(DIM), p0, phi, q)
    nav.propagate_covariance()
    np.testing.assert_allclose(nav.P / pn, 0.5 * (p_ref + p_ref.T) / pn, rtol=1e-9, atol=1e-12)


def test_ins_state_arrays_are_read_only_views() -> None:
    nav = _nav()
    with pytest.raises(ValueError, match="read-only"):
        nav.ins.v[0] = 1.0
    nav.ins.v = np.array([1.0, 2.0, 3.0])  # replacing is the way
    np.testing.assert_array_equal(nav.estimate().v_enu, [1.0, 2.0, 3.0])
    est = nav.estimate()
    est.covariance[0, 0] = 99.0  # the estimate holds copies
    assert nav.P[0, 0] != 99.0


def test_azimuth_only_sun_update_matches_its_finite_difference_jacobian() -> None:
    c = euler_to_dcm(*NOMINAL["rpy"])
    s_b = c.T @ SUN_ENU
    rho = math.hypot(SUN_ENU[0], SUN_ENU[1])
    t = np.array([SUN_ENU[1], -SUN_ENU[0], 0.0]) / rho  # horizontal tangent: the azimuth row

    def z(x: np.ndarray) -> float:
        return float(t @ (rotvec_to_dcm(*(-x[0:3])) @ c @ s_b - SUN_ENU))

    jac = np.array([(z(e * 1e-6) - z(-e * 1e-6)) / 2e-6 for e in np.eye(DIM)])
    h = np.zeros(DIM)
    h[0:3] = np.cross(t, SUN_ENU)
    np.testing.assert_allclose(jac, h, atol=1e-9)
    # A pure azimuth error of δ (rad) appears as z ≈ −ρ δ (sun turned clockwise by the heading).
    assert abs(h[2]) == pytest.approx(rho, rel=1e-12)


def test_azimuth_only_sun_update_ignores_an_elevation_bias() -> None:
    """A sun 10° too high tilts the estimate through a full-vector update, not azimuth-only."""
    rpy = (0.0, 0.0, RPY[2])
    c = euler_to_dcm(*rpy)
    up = np.array([0.0, 0.0, 1.0])
    axis = np.cross(SUN_ENU, up)
    biased_n = rotvec_to_dcm(*(axis / np.linalg.norm(axis) * math.radians(10.0))) @ SUN_ENU
    assert math.degrees(math.acos(biased_n[2])) < math.degrees(math.acos(SUN_ENU[2])) - 9.9
    s_b = c.T @ biased_n  # same azimuth as the truth, elevation 10° too high
    cov = (0.5 * math.pi / 180) ** 2 * (np.eye(3) - np.outer(s_b, s_b))
    tilt = {}
    for mode in (False, True):
        nav = Eskf(
            EskfConfig(gate_probability=1.0), NavState(0.0, LAT, LON, -DEPTH, np.zeros(3), c)
        )
        for _ in range(20):
            nav.update_sun(sun_body=s_b, sun_enu=SUN_ENU, covariance_body=cov, azimuth_only=mode)
        e = nav.estimate()
        tilt[mode] = math.degrees(math.hypot(e.roll - rpy[0], e.pitch - rpy[1]))
        head_err = abs(wrap_pi(math.radians(e.heading_deg) + rpy[2]))
        if mode:
            assert math.degrees(head_err) < 0.05
    assert tilt[False] > 1.0  # the full vector drags the level towards the biased sun
    assert tilt[True] < 1e-6  # azimuth-only leaves roll and pitch alone


def test_azimuth_only_sun_update_is_skipped_near_the_zenith() -> None:
    nav = _nav()
    zenith = np.array([0.01, 0.0, 1.0]) / math.hypot(0.01, 1.0)
    res = nav.update_sun(sun_body=nav.ins.c_bn.T @ zenith, sun_enu=zenith, azimuth_only=True)
    assert not res.applied and res.reason == "sun near the zenith"


@pytest.mark.parametrize("free_air", [False, True])
def test_the_compiled_f_and_feedback_are_the_python_ones_bit_for_bit(free_air) -> None:
    # mechanization.fill_f / gravity_partials / correct replace the Python F and feedback
    # (issue #31): the same F and the same corrected state, to the last bit, on random states.
    rng = np.random.default_rng(3)
    cfg = dataclasses.replace(EskfConfig(), ins=InsConfig(free_air_gravity=free_air))
    for _ in range(3000):  # CPython's x ** 2 (libm pow) differs from x·x for ~0.1 % of x
        c = euler_to_dcm(*rng.uniform(-1.5, 1.5, 3))
        init = NavState(
            0.0, float(rng.uniform(-1.4, 1.4)), float(rng.uniform(-3.0, 3.0)),
            float(rng.normal(0.0, 300.0)), rng.normal(0.0, 2.0, 3), c,
        )  # fmt: skip
        fast, slow = Eskf(cfg, init), Eskf(cfg, init)
        f_b = tuple(rng.normal(0.0, 10.0, 3).tolist())
        fast.ins._f = slow.ins._f = f_b
        np.testing.assert_array_equal(fast._system_matrix(), slow._system_matrix_reference())
        x = rng.normal(0.0, [1e-2] * 3 + [0.1] * 3 + [1e-6] * 2 + [1.0] + [1e-4] * 6)
        fast._feedback(x)
        slow._feedback_reference(x)
        a, b = fast.ins, slow.ins
        assert (a._c, a._v, a.lat, a.lon, a.h, a._bg, a._ba) == (
            b._c, b._v, b.lat, b.lon, b.h, b._bg, b._ba
        )  # fmt: skip


def test_the_compiled_covariance_step_and_update_are_numpys_bit_for_bit() -> None:
    # eskf_kernels.propagate / update replace the numpy versions (issue #31): the same P, NIS,
    # state correction and gate decisions, to the last bit, for 1-, 2- and 3-row measurements.
    rng = np.random.default_rng(5)
    cfg = dataclasses.replace(EskfConfig(), gate_probability=0.99, q_rate_gain=0.1)
    for trial in range(200):
        init = NavState(
            0.0, LAT, LON, -DEPTH, rng.normal(0.0, 1.0, 3), euler_to_dcm(0.1, -0.2, 1.0)
        )
        fast, slow = Eskf(cfg, init), Eskf(cfg, init)
        a = rng.normal(0.0, 1e-2, (DIM, DIM))
        for e in (fast, slow):
            e.P = a @ a.T + 1e-6 * np.eye(DIM)
            e._pending_dt, e._w2_dt = 0.1, 1e-3
            e.ins._f = (0.1, -0.2, 9.8)
        fast.propagate_covariance()
        slow._propagate_reference()
        np.testing.assert_array_equal(fast.P, slow.P)
        m = trial % 3 + 1
        h = rng.normal(0.0, 1.0, (m, DIM))
        b = rng.normal(0.0, 1e-2, (m, m))
        r = b @ b.T + 1e-4 * np.eye(m)
        z = rng.normal(0.0, 0.3 if trial % 4 else 30.0, m)  # every 4th: gated out
        got = fast._update("sun", z, h, r)
        want = slow._update_reference("sun", z, h, r)
        assert (got.applied, got.nis) == (want.applied, want.nis)
        np.testing.assert_array_equal(fast.P, slow.P)
        assert (fast.ins._c, fast.ins._v, fast.ins.lat, fast.ins._bg) == (
            slow.ins._c, slow.ins._v, slow.ins.lat, slow.ins._bg
        )  # fmt: skip
        assert len(fast.rejections) == len(slow.rejections)


@pytest.mark.parametrize("free_air", [False, True])
def test_depth_and_gravity_updates_in_one_dispatch_are_the_two_steps_bit_for_bit(free_air) -> None:
    # Eskf._propagate_and_update (eskf_kernels.propagate_update_at, issue #31): the covariance
    # step and the update in one compiled call equal the numpy references one after the other:
    # the same P, state, NIS and gate decisions, for depth and gravity updates (gated or not).
    rng = np.random.default_rng(11)
    cfg = dataclasses.replace(
        EskfConfig(), ins=InsConfig(free_air_gravity=free_air), q_rate_gain=0.1
    )
    applied = gated = 0
    for trial in range(120):
        c = euler_to_dcm(*rng.uniform(-0.2, 0.2, 2), rng.uniform(-3.0, 3.0))
        init = NavState(0.0, LAT, LON, -DEPTH, rng.normal(0.0, 1.0, 3), c)
        fast, slow = Eskf(cfg, init), Eskf(cfg, init)
        a = rng.normal(0.0, 1e-2, (DIM, DIM))
        for e in (fast, slow):
            e.P = a @ a.T + 1e-6 * np.eye(DIM)
            e._pending_dt, e._w2_dt = (0.1, 1e-3) if trial % 5 else (0.0, 0.0)
            e.ins._f = (0.1, -0.2, 9.8)
        if trial % 2:
            d = DEPTH + rng.normal(0.0, 0.05 if trial % 3 else 30.0)  # every third: gated out
            got = fast.update_depth(d)
            slow._propagate_reference()
            want = slow._update_reference(
                "depth", np.array([slow.ins.h + d]), eskf_mod._H_DEPTH, slow._r_depth
            )
        else:
            f_b = slow.ins.c_bn.T @ np.array([0.0, 0.0, slow.ins.gravity(LAT, -DEPTH)])
            f_b = f_b + rng.normal(0.0, 0.01 if trial % 3 else 0.5, 3)
            for e in (fast, slow):
                e._f_sum, e._w_sum, e._n_sum = f_b.tolist(), [0.0, 0.0, 0.0], 1
            got = fast.update_gravity()
            if got.reason == "not quasi-static":
                continue
            # The reference: the same z and H, then the two steps with numpy.
            ins = slow.ins
            g = ins.gravity(ins.lat, ins.h)
            c0, c1, c2, c3, c4, c5, c6, c7, c8 = ins._c
            fx, fy, fz = (float(x) for x in f_b)
            z = np.array(
                [
                    -(c0 * fx + c1 * fy + c2 * fz),
                    -(c3 * fx + c4 * fy + c5 * fz),
                    g - (c6 * fx + c7 * fy + c8 * fz),
                ]
            )
            h = np.zeros((3, DIM))
            h[0, 1], h[1, 0] = g, -g
            if cfg.gravity_models_accel_bias:
                h[:, 12:15] = -ins.c_bn
            slow._f_sum, slow._w_sum, slow._n_sum = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0
            slow._propagate_reference()
            want = slow._update_reference("gravity", z, h, slow._r_gravity)
        assert (got.applied, got.nis) == (want.applied, want.nis)
        np.testing.assert_array_equal(fast.P, slow.P)
        a_, b_ = fast.ins, slow.ins
        assert (a_._c, a_._v, a_.lat, a_.lon, a_.h, a_._bg, a_._ba) == (
            b_._c, b_._v, b_.lat, b_.lon, b_.h, b_._bg, b_._ba
        )  # fmt: skip
        assert fast._pending_dt == slow._pending_dt and fast._w2_dt == slow._w2_dt
        applied += got.applied
        gated += got.reason == "gate"
    assert applied > 30 and gated > 5
