"""Fossen's hydrodynamic wrench, compiled: :meth:`Hydrodynamics.wrench_f_reference`'s arithmetic.

The plant evaluates the wrench every physics step (100 Hz); in Python it is ~150 float operations
in several calls. Here the same expressions in the same order run as one compiled function of
plain floats. Without ``fastmath`` numba keeps IEEE semantics and does not fuse a·b + c; powers
are written ``math.pow`` (libm's ``pow``, which is what CPython's ``**`` on floats calls) rather
than ``**``, which numba expands into products; and the exponent 2 comes in as an argument
(``two``), because LLVM turns ``pow(x, 2.0)`` with a constant 2 into x·x, which differs from
libm's ``pow(x, 2)`` in the last bit for ~0.1 % of x (measured). So the result is the Python
method's bit for bit (``tests/test_plant.py`` checks it on random states);
the Python method stays as the reference.
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.kernel_cache import njit


@njit(cache=True, inline="always")
def _crossflow(v, r, h):  # type: ignore[no-untyped-def]
    """:func:`twin.world.hydrodynamics._crossflow`."""
    if abs(r) * h <= 1e-6 * max(abs(v), 1e-12) or abs(r) < 1e-12:
        return 2 * h * abs(v) * v, 4.0 / 3.0 * math.pow(h, 3.0) * abs(v) * r
    sa = v - r * h
    sb = v + r * h
    df = (math.pow(abs(sb), 3.0) - math.pow(abs(sa), 3.0)) / 3.0
    dg = (math.pow(sb, 3.0) * abs(sb) - math.pow(sa, 3.0) * abs(sa)) / 4.0
    return df / r, (dg - v * df) / (r * r)


@njit(cache=True, inline="always")
def _crossflow_strips(v, r, half_length, n):  # type: ignore[no-untyped-def]
    """:func:`twin.world.hydrodynamics._crossflow_strips`."""
    dx = 2.0 * half_length / n
    fy = 0.0
    ny = 0.0
    for i in range(n + 1):
        x = -half_length + i * dx
        s = v + x * r
        fy += abs(s) * s * dx
        ny += x * abs(s) * s * dx
    return fy, ny


@njit(cache=True)
def wrench_f(nu_r, rudder_rad, stern_rad, n_rps, k, strips):  # type: ignore[no-untyped-def]
    """The wrench [X, Y, Z, K, M, N] in f; ``k`` is :meth:`Hydrodynamics.kernel_constants`."""
    u, v, w, p, q, r = nu_r
    (
        xu, yv, zw, kp, mq, nr, d0, d1, d2, d3, d4, d5, cl_alpha, cd0, oswald_e, ar, rho, s_hull,
        half_length, k_cross, k_rudder, k_stern, fin_x, thrust_deduction, torque_on_hull,
        wake_fraction, prop_d, rho_d4, rho_d5, kt0, kq0, kt_slope, kq_slope, two,
    ) = k  # fmt: skip
    u_rel = math.sqrt(u * u + v * v + w * w)
    fade = math.exp(-3.0 * u_rel)
    ca0 = zw * w * q - yv * v * r
    ca1 = xu * u * r - zw * w * p
    ca2 = yv * v * p - xu * u * q
    ca3 = (zw - yv) * v * w + (nr - mq) * q * r
    ca4 = (kp - nr) * r * p
    ca5 = (mq - kp) * p * q
    t0 = -ca0 - d0 * fade * u
    t1 = -ca1 - d1 * fade * v
    t2 = -ca2 - d2 * w
    t3 = -ca3 - d3 * p
    t4 = -ca4 - d4 * q
    t5 = -ca5 - d5 * r
    if u_rel > 1e-9:
        alpha = math.atan2(w, u)
        cl = cl_alpha * alpha
        cd = cd0 + cl * cl / (math.pi * oswald_e * ar)
        qs = 0.5 * rho * u_rel * u_rel * s_hull
        f_drag = qs * cd
        f_lift = qs * cl
        ca_ = math.cos(alpha)
        sa_ = math.sin(alpha)
        t0 += -ca_ * f_drag + sa_ * f_lift
        t2 += -sa_ * f_drag - ca_ * f_lift
    if strips:
        fy, ny = _crossflow_strips(v, r, half_length, strips)
        fz, mz = _crossflow_strips(w, -q, half_length, strips)
    else:
        fy, ny = _crossflow(v, r, half_length)
        fz, mz = _crossflow(w, -q, half_length)
    t1 -= k_cross * fy
    t5 -= k_cross * ny
    t2 -= k_cross * fz
    t4 += k_cross * mz
    u_h2 = u * u + v * v
    u_v2 = u * u + w * w
    y_r = -k_rudder * u_h2 * rudder_rad
    z_s = k_stern * u_v2 * stern_rad
    t0 += -k_rudder * u_h2 * math.pow(rudder_rad, two) - k_stern * u_v2 * math.pow(stern_rad, two)
    t1 += y_r
    t2 += z_s
    t4 -= fin_x * z_s
    t5 += fin_x * y_r
    n_abs = abs(n_rps)
    if n_rps > 0:
        va_over_d = (1.0 - wake_fraction) * u / prop_d
        x_prop = rho_d4 * (kt0 * n_abs * n_rps + kt_slope * va_over_d * n_abs)
        k_prop = rho_d5 * (kq0 * n_abs * n_rps + kq_slope * va_over_d * n_abs)
    else:
        x_prop = rho_d4 * kt0 * n_abs * n_rps
        k_prop = rho_d5 * kq0 * n_abs * n_rps
    t0 += (1.0 - thrust_deduction) * x_prop
    t3 += torque_on_hull * k_prop
    return t0, t1, t2, t3, t4, t5


@njit(cache=True)
def body_wrench(  # type: ignore[no-untyped-def]
    xmat, qvel, depth, current, act, ids, passive, bias, k, strips, ma, buoyancy_n, radius,
    minv, rhs, applied,
):  # fmt: skip
    """:meth:`Plant._apply_hydrodynamics_reference`'s arithmetic, in its order: ``applied`` set.

    Args (in order): the body's C_b^n (9,); its free joint's velocities (6,); depth (m); the
    current (ENU, m/s, (3,)); MuJoCo's activations and the rudder, stern and propeller's indices
    in them; the joint's passive and bias forces (6,); :meth:`Hydrodynamics.kernel_constants`
    and the cross-flow strips; the body-frame added-mass diagonal (6,); the buoyancy (N) and the
    hull's radius (m); (M_RB + M_A)⁻¹ (6, 6) in the body frame; a (6,) scratch; the joint's
    applied forces (6,), written.
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = (
        xmat[0], xmat[1], xmat[2], xmat[3], xmat[4], xmat[5], xmat[6], xmat[7], xmat[8],
    )  # fmt: skip
    vx = qvel[0] - current[0]
    vy = qvel[1] - current[1]
    vz = qvel[2] - current[2]
    px, py, pz = qvel[3], qvel[4], qvel[5]
    bx = r00 * vx + r10 * vy + r20 * vz
    by = r01 * vx + r11 * vy + r21 * vz
    bz = r02 * vx + r12 * vy + r22 * vz
    tau = wrench_f((by, bx, -bz, py, px, -pz), act[ids[0]], act[ids[1]], act[ids[2]], k, strips)
    sub = (depth + radius) / (2 * radius)
    buoy = buoyancy_n * (1.0 if sub >= 1.0 else (0.0 if sub <= 0.0 else sub))
    t0 = tau[1] + r20 * buoy + ma[0] * (py * bz - pz * by)
    t1 = tau[0] + r21 * buoy + ma[1] * (pz * bx - px * bz)
    t2 = -tau[2] + r22 * buoy + ma[2] * (px * by - py * bx)
    t3, t4, t5 = tau[4], tau[3], -tau[5]
    fx = passive[0] - bias[0]
    fy = passive[1] - bias[1]
    fz = passive[2] - bias[2]
    rhs[0] = r00 * fx + r10 * fy + r20 * fz + t0
    rhs[1] = r01 * fx + r11 * fy + r21 * fz + t1
    rhs[2] = r02 * fx + r12 * fy + r22 * fz + t2
    rhs[3] = passive[3] - bias[3] + t3
    rhs[4] = passive[4] - bias[4] + t4
    rhs[5] = passive[5] - bias[5] + t5
    a = np.dot(minv, rhs)
    l0 = t0 - ma[0] * a[0]
    l1 = t1 - ma[1] * a[1]
    l2 = t2 - ma[2] * a[2]
    applied[0] = r00 * l0 + r01 * l1 + r02 * l2
    applied[1] = r10 * l0 + r11 * l1 + r12 * l2
    applied[2] = r20 * l0 + r21 * l1 + r22 * l2
    applied[3] = t3 - ma[3] * a[3]
    applied[4] = t4 - ma[4] * a[4]
    applied[5] = t5 - ma[5] * a[5]
