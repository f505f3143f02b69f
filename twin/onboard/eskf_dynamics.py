"""The ESKF's error state and its continuous error dynamics F (15×15).

State (paper eq. 16), all errors defined as *estimate − truth*::

    X = [φ_E, φ_N, φ_U,  δv_E, δv_N, δv_U,  δL, δλ, δh,  ε_x, ε_y, ε_z,  ∇_x, ∇_y, ∇_z]

* φ (rad): misalignment of the computed navigation frame. **Convention** (the paper's eqs. 18
  and 22, Titterton/Qin; navigation.md §1.8)::

      C_b^n_est = (I − [φ×]) C_b^n_true      (exactly: exp(−[φ×]) C_b^n_true)

  so a positive φ_U turns the computed frame so that the estimated yaw is yaw_true − φ_U, i.e.
  the compass heading error (estimate − truth, degrees clockwise) is +φ_U for a level vehicle.
  Groves' δψ is −φ. :func:`attitude_error` computes φ from an estimated and a true C_b^n.
* δv (m/s, ENU); δL, δλ (rad) and δh (m).
* ε (rad/s), ∇ (m/s²): the *residual* gyro and accelerometer biases in **body axes**, i.e. true
  bias minus the INS's current bias estimate (measured = true + bias). The paper labels them
  E, N, U; body axes are what a bias is constant in when the vehicle turns, so we use those
  (for a level vehicle heading north they coincide up to the axis permutation).

Error dynamics (continuous, ENU; navigation.md §1.8, Titterton & Weston §12.3)::

    φ̇  = −ω_in × φ + δω_in − C_b^n ε
    δv̇ = f^n × φ + C_b^n ∇ − (2ω_ie + ω_en) × δv + v × (2δω_ie + δω_en) + δg
    δL̇ = δv_N / (R_M + h) − v_N δh / (R_M + h)²
    δλ̇ = δv_E sec L / (R_N + h) + v_E sec L tan L δL / (R_N + h) − v_E sec L δh / (R_N + h)²
    δḣ = δv_U
    ε̇ = −ε / τ_g + w_g,  ∇̇ = −∇ / τ_a + w_a        (τ = ∞: random walk / random constant)

The filter (:mod:`twin.onboard.eskf`) refills F's state-dependent entries at every covariance
step (:func:`_f_varying_part`, plain floats; :func:`twin.onboard.mechanization.fill_f` compiled);
``tests/onboard/test_eskf.py`` checks every element against finite differences of the INS.
"""

from __future__ import annotations

import math

import numpy as np

from twin.core import earth
from twin.core.arrays import Float64Array as FloatArray

DIM = 15
PHI = slice(0, 3)
DV = slice(3, 6)
DP = slice(6, 9)
BG = slice(9, 12)
BA = slice(12, 15)
I_LAT, I_LON, I_H = 6, 7, 8


def attitude_error(c_est: FloatArray, c_true: FloatArray) -> FloatArray:
    """φ such that C_est = exp(−[φ×]) C_true (the filter's convention), in radians.

    For NEES: e = [attitude_error(C_est, C_true), v_est − v_true, L_est − L_true, ...] against
    the estimate's covariance.
    """
    m = np.asarray(c_est, dtype=np.float64) @ np.asarray(c_true, dtype=np.float64).T
    # log of the rotation m = exp([r×]); φ = −r.
    cos_a = max(-1.0, min(1.0, 0.5 * (np.trace(m) - 1.0)))
    a = math.acos(cos_a)
    w = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    k = 0.5 if a < 1e-8 else a / (2.0 * math.sin(a))
    return -k * w


def error_dynamics(
    lat: float,
    h: float,
    v_enu: FloatArray,
    c_bn: FloatArray,
    f_b: FloatArray,
    dg_dlat: float = 0.0,
    dg_dh: float = 0.0,
    gyro_bias_tau_s: float | None = None,
    accel_bias_tau_s: float | None = None,
) -> FloatArray:
    """The continuous error-dynamics matrix F (15×15) at a nominal state (module docstring).

    Args:
        lat: Latitude (rad).
        h: Height (m).
        v_enu: Velocity (m/s).
        c_bn: Attitude C_b^n.
        f_b: Bias-compensated specific force (m/s², body).
        dg_dlat: ∂γ/∂L (m/s²/rad) of the INS's gravity model.
        dg_dh: ∂γ/∂h (1/s²).
        gyro_bias_tau_s: Gauss–Markov correlation time of ε (None: ∞).
        accel_bias_tau_s: Same for ∇.
    """
    f = _f_constant_part(gyro_bias_tau_s, accel_bias_tau_s)
    v = np.asarray(v_enu, dtype=np.float64).reshape(3).tolist()
    c = np.asarray(c_bn, dtype=np.float64).reshape(9).tolist()
    fb = np.asarray(f_b, dtype=np.float64).reshape(3).tolist()
    f.reshape(-1)[_F_VARYING] = _f_varying_part(lat, h, v, c, fb, dg_dlat, dg_dh)
    return f


def _f_constant_part(gyro_bias_tau_s: float | None, accel_bias_tau_s: float | None) -> FloatArray:
    """F with only its state-independent entries set (the filter keeps one and refills it)."""
    f = np.zeros((DIM, DIM))
    f[I_H, 5] = 1.0  # δḣ = δv_U
    if gyro_bias_tau_s is not None:
        f[BG, BG] = -np.eye(3) / gyro_bias_tau_s
    if accel_bias_tau_s is not None:
        f[BA, BA] = -np.eye(3) / accel_bias_tau_s
    return f


# F's state-dependent entries (row, column), in the order _f_varying_part returns their values.
_F_ENTRIES = (
    [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)]  # φ, φ: −[ω_in×]
    + [(0, 4), (1, 3), (2, 3)]  # φ, δv: M_v
    + [(1, 6), (2, 6)]  # φ, δL: ∂(ω_ie + ω_en)/∂L
    + [(0, 8), (1, 8), (2, 8)]  # φ, δh: ∂ω_en/∂h
    + [(i, 9 + j) for i in range(3) for j in range(3)]  # φ, ε: −C
    + [(3, 1), (3, 2), (4, 0), (4, 2), (5, 0), (5, 1)]  # δv, φ: [f^n×]
    + [(3, 3), (3, 4), (3, 5), (4, 3), (4, 4), (4, 5), (5, 3), (5, 4)]  # δv, δv
    + [(3, 6), (4, 6), (5, 6)]  # δv, δL: [v×](2 ∂ω_ie/∂L + ∂ω_en/∂L) − ∂γ/∂L on U
    + [(3, 8), (4, 8), (5, 8)]  # δv, δh: [v×] ∂ω_en/∂h − ∂γ/∂h on U
    + [(3 + i, 12 + j) for i in range(3) for j in range(3)]  # δv, ∇: C
    + [(6, 4), (6, 8), (7, 3), (7, 6), (7, 8)]  # δL̇, δλ̇
)
_F_VARYING = np.array([r * DIM + c for r, c in _F_ENTRIES])


def _f_varying_part(
    lat: float,
    h: float,
    v: list[float],
    c: list[float],
    f_b: list[float],
    dg_dlat: float,
    dg_dh: float,
) -> list[float]:
    """The values of F's :data:`_F_ENTRIES` (module docstring's error dynamics), plain floats.

    Written out element by element: F is rebuilt at every covariance step, and 57 float
    expressions cost a few µs where the equivalent block algebra on 3×3 numpy arrays costs ~50.
    ``tests/onboard/test_eskf.py`` checks every element against finite differences of the INS.
    """
    sl, cl = math.sin(lat), math.cos(lat)
    tl, secl = sl / cl, 1.0 / cl
    d = 1.0 - earth.E2 * sl * sl
    r_n = earth.A_M / math.sqrt(d)
    r_m = r_n * (1.0 - earth.E2) / d
    rm_h, rn_h = r_m + h, r_n + h
    ve, vn, vu = v
    om = earth.OMEGA_IE
    # ω_in = ω_ie + ω_en and a = 2ω_ie + ω_en
    we, wn, wu = -vn / rm_h, om * cl + ve / rn_h, om * sl + ve * tl / rn_h
    ae, an, au = we, wn + om * cl, wu + om * sl
    # ∂ω_en/∂h and 2 ∂ω_ie/∂L + ∂ω_en/∂L (∂R/∂L neglected: relative e² ≈ 0.7 %)
    d0, d1, d2 = vn / rm_h**2, -ve / rn_h**2, -ve * tl / rn_h**2
    den_dl_u = ve * secl * secl / rn_h
    u1, u2 = -2.0 * om * sl, 2.0 * om * cl + den_dl_u
    c0, c1, c2, c3, c4, c5, c6, c7, c8 = c
    fx, fy, fz = f_b
    fe = c0 * fx + c1 * fy + c2 * fz  # f^n = C f^b
    fn = c3 * fx + c4 * fy + c5 * fz
    fu = c6 * fx + c7 * fy + c8 * fz
    return [
        wu, -wn, -wu, we, wn, -we,
        -1.0 / rm_h, 1.0 / rn_h, tl / rn_h,
        -om * sl, om * cl + den_dl_u,
        d0, d1, d2,
        -c0, -c1, -c2, -c3, -c4, -c5, -c6, -c7, -c8,
        -fu, fn, fu, -fe, -fn, fe,
        (-vu + vn * tl) / rn_h, au, -an,
        -au - ve * tl / rn_h, -vu / rm_h, ae,
        an + ve / rn_h, -ae + vn / rm_h,
        -vu * u1 + vn * u2, -ve * u2, ve * u1 - dg_dlat,
        -vu * d1 + vn * d2, vu * d0 - ve * d2, -vn * d0 + ve * d1 - dg_dh,
        c0, c1, c2, c3, c4, c5, c6, c7, c8,
        1.0 / rm_h, -vn / rm_h**2, secl / rn_h, ve * secl * tl / rn_h, -ve * secl / rn_h**2,
    ]  # fmt: skip
