"""One strapdown step, compiled: :meth:`twin.onboard.ins.StrapdownIns._advance`'s arithmetic.

The INS steps at the IMU's rate for every filter variant (300 steps a simulated second in a sea
trial with three variants), and in Python each step is ~80 float operations spread over several
calls (the Earth's radii, the Coriolis and transport terms, two Rodrigues exponentials, two 3×3
products). Here the same expressions, in the same order, run as one compiled function of plain
floats: without ``fastmath`` numba keeps IEEE semantics and does not contract a·b + c into an
FMA, and ``math.sin``/``cos``/``sqrt`` call the same libm as CPython, so the result is the
Python step's bit for bit (``tests/onboard/test_ins.py`` checks it on random states). The Python
version stays in :class:`~twin.onboard.ins.StrapdownIns` as the reference.

Constants are the Earth model's (:mod:`twin.core.earth`), passed in so that the two cannot
drift apart.
"""

from __future__ import annotations

import math

from twin.core.kernel_cache import njit


@njit(cache=True, inline="always")
def _gravity(lat, h, ge, k_som, e2, a_m, f, m_ratio, two):  # type: ignore[no-untyped-def]
    """:func:`twin.core.earth.normal_gravity` with the constants as arguments.

    Its ``x ** 2`` is libm's ``pow(x, 2)`` in CPython; ``two`` comes in as an argument so that
    LLVM cannot turn ``pow`` into x·x (which differs in the last bit for ~0.1 % of x).
    """
    s2 = math.pow(math.sin(lat), two)
    g0 = ge * (1.0 + k_som * s2) / math.sqrt(1.0 - e2 * s2)
    if h == 0.0:
        return g0
    free_air = 2.0 / a_m * (1.0 + f + m_ratio - 2.0 * f * s2) * h
    return g0 * (1.0 - free_air + 3.0 * math.pow(h / a_m, two))


@njit(cache=True, inline="always")
def _rotvec_exp(x, y, z):  # type: ignore[no-untyped-def]
    """:func:`twin.onboard.ins._rotvec_exp`."""
    n2 = x * x + y * y + z * z
    if n2 > 1e-6:
        n = math.sqrt(n2)
        c = math.cos(n)
        k1 = math.sin(n) / n
        k2 = (1.0 - c) / n2
    else:
        n4 = n2 * n2
        c = 1.0 - n2 / 2.0 + n4 / 24.0
        k1 = 1.0 - n2 / 6.0 + n4 / 120.0
        k2 = 0.5 - n2 / 24.0 + n4 / 720.0
    return (
        k2 * x * x + c, k2 * x * y - k1 * z, k2 * x * z + k1 * y,
        k2 * y * x + k1 * z, k2 * y * y + c, k2 * y * z - k1 * x,
        k2 * z * x - k1 * y, k2 * z * y + k1 * x, k2 * z * z + c,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _mul33(a, b):  # type: ignore[no-untyped-def]
    """:func:`twin.onboard.ins._mul33`."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = a
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = b
    return (
        a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8,
        a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8,
        a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8,
    )  # fmt: skip


@njit(cache=True)
def advance(dt, theta, dv_b, lat, lon, h, v, c, free_air, earth):  # type: ignore[no-untyped-def]
    """One step; returns (lat, lon, h, v (3-tuple), C (9-tuple)) after it.

    Args: dt (s); theta, dv_b (3-tuples): the step's rotation vector and Δv (body); lat, lon,
    h, v, c: the INS state (C_b^n row-major); free_air: the gravity model's height term
    (``InsConfig.free_air_gravity``); earth: (A_M, E2, OMEGA_IE, GAMMA_E, K_SOMIGLIANA, F,
    M_RATIO, 2.0), the last the exponent of :func:`_gravity`'s squares.
    """
    a_m, e2, omega, ge, k_som, f, m_ratio, two = earth
    v_e, v_n, v_u = v
    sl, cl = math.sin(lat), math.cos(lat)
    tl = sl / cl
    d = 1.0 - e2 * sl * sl
    r_n = a_m / math.sqrt(d)
    r_m = r_n * (1.0 - e2) / d
    rm_h, rn_h = r_m + h, r_n + h
    ie_n, ie_u = omega * cl, omega * sl
    chi_e = -v_n / rm_h
    chi_n = ie_n + v_e / rn_h
    chi_u = ie_u + v_e * tl / rn_h
    bx, by, bz = dv_b
    dvn0 = c[0] * bx + c[1] * by + c[2] * bz
    dvn1 = c[3] * bx + c[4] * by + c[5] * bz
    dvn2 = c[6] * bx + c[7] * by + c[8] * bz
    a_e, a_n, a_u = chi_e, chi_n + ie_n, chi_u + ie_u
    hg = h + 0.5 * v_u * dt
    g = _gravity(lat, hg if free_air else 0.0, ge, k_som, e2, a_m, f, m_ratio, two)
    ve1 = v_e + dvn0 + (-(a_n * v_u - a_u * v_n) - 0.5 * (chi_n * dvn2 - chi_u * dvn1)) * dt
    vn1 = v_n + dvn1 + (-(a_u * v_e - a_e * v_u) - 0.5 * (chi_u * dvn0 - chi_e * dvn2)) * dt
    vu1 = v_u + dvn2 + (-(a_e * v_n - a_n * v_e) - 0.5 * (chi_e * dvn1 - chi_n * dvn0) - g) * dt
    me, mn, mu = 0.5 * (v_e + ve1), 0.5 * (v_n + vn1), 0.5 * (v_u + vu1)
    lat1 = lat + mn / rm_h * dt
    lon1 = lon + me / (rn_h * cl) * dt
    h1 = h + mu * dt
    c_nav = _rotvec_exp(mn / rm_h * dt, -(ie_n + me / rn_h) * dt, -(ie_u + me * tl / rn_h) * dt)
    c1 = _mul33(c_nav, _mul33(c, _rotvec_exp(theta[0], theta[1], theta[2])))
    return lat1, lon1, h1, (ve1, vn1, vu1), c1


@njit(cache=True)
def gravity_partials(lat, h, free_air, earth):  # type: ignore[no-untyped-def]
    """:meth:`twin.onboard.eskf.Eskf.gravity_partials` (central differences of γ), compiled."""
    a_m, e2, _, ge, k_som, f, m_ratio, two = earth
    dl, dh = 1e-5, 1.0

    def g(la, hh):  # type: ignore[no-untyped-def]
        return _gravity(la, hh if free_air else 0.0, ge, k_som, e2, a_m, f, m_ratio, two)

    return (
        (g(lat + dl, h) - g(lat - dl, h)) / (2 * dl),
        (g(lat, h + dh) - g(lat, h - dh)) / (2 * dh),
    )


@njit(cache=True)
def fill_f(out, index, lat, h, v, c, f_b, dg_dlat, dg_dh, earth):  # type: ignore[no-untyped-def]
    """Write :func:`twin.onboard.eskf_dynamics._f_varying_part`'s values into ``out[index]``.

    The same expressions in the same order (squares through libm's ``pow``, as there).
    """
    a_m, e2, om, _, _, _, _, two = earth
    sl, cl = math.sin(lat), math.cos(lat)
    tl, secl = sl / cl, 1.0 / cl
    d = 1.0 - e2 * sl * sl
    r_n = a_m / math.sqrt(d)
    r_m = r_n * (1.0 - e2) / d
    rm_h, rn_h = r_m + h, r_n + h
    ve, vn, vu = v
    we, wn, wu = -vn / rm_h, om * cl + ve / rn_h, om * sl + ve * tl / rn_h
    ae, an, au = we, wn + om * cl, wu + om * sl
    rm_h2, rn_h2 = math.pow(rm_h, two), math.pow(rn_h, two)
    d0, d1, d2 = vn / rm_h2, -ve / rn_h2, -ve * tl / rn_h2
    den_dl_u = ve * secl * secl / rn_h
    u1, u2 = -2.0 * om * sl, 2.0 * om * cl + den_dl_u
    c0, c1, c2, c3, c4, c5, c6, c7, c8 = c
    fx, fy, fz = f_b
    fe = c0 * fx + c1 * fy + c2 * fz
    fn = c3 * fx + c4 * fy + c5 * fz
    fu = c6 * fx + c7 * fy + c8 * fz
    values = (
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
        1.0 / rm_h, -vn / rm_h2, secl / rn_h, ve * secl * tl / rn_h, -ve * secl / rn_h2,
    )  # fmt: skip
    for k in range(len(values)):
        out[index[k]] = values[k]


@njit(cache=True)
def correct(c, v, lat, lon, h, bg, ba, e):  # type: ignore[no-untyped-def]
    """:meth:`twin.onboard.ins.StrapdownIns.correct_floats` on the state, compiled.

    ``e`` is the filter's 15 error estimates (φ, δv, δL, δλ, δh, δb_g, δb_a); returns the new
    (C, v, lat, lon, h, b_g, b_a).
    """
    c1 = _mul33(_rotvec_exp(e[0], e[1], e[2]), c)
    v1 = (v[0] - e[3], v[1] - e[4], v[2] - e[5])
    bg1 = (bg[0] + e[9], bg[1] + e[10], bg[2] + e[11])
    ba1 = (ba[0] + e[12], ba[1] + e[13], ba[2] + e[14])
    return c1, v1, lat - e[6], lon - e[7], h - e[8], bg1, ba1


@njit(cache=True, inline="always")
def orthonormalize(c):  # type: ignore[no-untyped-def]
    """One Newton step towards the nearest rotation: C (3I − CᵀC) / 2 (row-major 9-tuple).

    The INS's, every ``InsConfig.orthonormalize_every`` steps, called from Python and inlined
    in :func:`advance_samples`.
    """
    c0, c1, c2, c3, c4, c5, c6, c7, c8 = c
    s00 = c0 * c0 + c3 * c3 + c6 * c6
    s01 = c0 * c1 + c3 * c4 + c6 * c7
    s02 = c0 * c2 + c3 * c5 + c6 * c8
    s11 = c1 * c1 + c4 * c4 + c7 * c7
    s12 = c1 * c2 + c4 * c5 + c7 * c8
    s22 = c2 * c2 + c5 * c5 + c8 * c8
    m = (3.0 - s00, -s01, -s02, -s01, 3.0 - s11, -s12, -s02, -s12, 3.0 - s22)
    p = _mul33(c, m)
    return (
        0.5 * p[0], 0.5 * p[1], 0.5 * p[2], 0.5 * p[3], 0.5 * p[4], 0.5 * p[5],
        0.5 * p[6], 0.5 * p[7], 0.5 * p[8],
    )  # fmt: skip


#: Why :func:`advance_samples` stopped: every sample done; after a step that brought the
#: covariance's pending time to its step (the caller propagates, then calls again); before a
#: sample the Python path must take (a time step out of range or a non-finite value: it raises
#: or skips, as configured, naming the channel).
DONE, PROPAGATE, REFUSED = 0, 1, 2


@njit(cache=True)
def advance_samples(  # type: ignore[no-untyped-def]
    ts, ws, fs, start, stop, t, lat, lon, h, v, c, bg, ba, steps, every, max_dt, free_air, earth,
    pending, cov_step, f_sum, w_sum, n_sum, w2_dt,
):  # fmt: skip
    """IMU samples ``start`` … ``stop − 1`` through the INS and the filter's step bookkeeping.

    Per sample, :meth:`twin.onboard.eskf.Eskf.predict_reading`'s arithmetic in its order:
    the INS step (:meth:`StrapdownIns.step`: bias removal, the rotation-compensated Δv,
    :func:`advance`, the periodic re-orthonormalization, the clock set to the sample's stamp)
    and the filter's sums (``Eskf._after_step``). The same IEEE operations as the Python path
    (no fastmath, no contraction), so its state bit for bit (``tests/onboard/test_imu_batch.py``).

    Args: ts, ws, fs ((n,), (n, 3), (n, 3) float64: stamps, angular rates, specific forces);
    start, stop (the samples to take); then the INS state (t, lat, lon, h, v, C, b_g, b_a, the
    step count), its re-orthonormalization period and largest step, the gravity model's flag and
    constants (:func:`advance`), then the filter's pending covariance time and its step, the
    sums of f and ω, their count and ∫‖ω‖² dt.

    Returns:
        (status, next sample, t, lat, lon, h, v, C, ω, f (the last compensated sample), steps,
        pending, f_sum, w_sum, n_sum, w2_dt); status is :data:`DONE`, :data:`PROPAGATE` or
        :data:`REFUSED`.
    """
    wx = wy = wz = fx = fy = fz = 0.0
    k = start
    status = DONE
    while k < stop:
        dt = ts[k] - t
        if not (0.0 < dt <= max_dt):
            status = REFUSED
            break
        w0, w1, w2 = ws[k, 0], ws[k, 1], ws[k, 2]
        f0, f1, f2 = fs[k, 0], fs[k, 1], fs[k, 2]
        if not math.isfinite(w0 + w1 + w2 + f0 + f1 + f2):
            status = REFUSED
            break
        wx, wy, wz = w0 - bg[0], w1 - bg[1], w2 - bg[2]
        fx, fy, fz = f0 - ba[0], f1 - ba[1], f2 - ba[2]
        h2 = 0.5 * dt * dt
        dv = (
            fx * dt + h2 * (wy * fz - wz * fy),
            fy * dt + h2 * (wz * fx - wx * fz),
            fz * dt + h2 * (wx * fy - wy * fx),
        )
        lat, lon, h, v, c = advance(
            dt, (wx * dt, wy * dt, wz * dt), dv, lat, lon, h, v, c, free_air, earth
        )
        steps += 1
        if steps % every == 0:
            c = orthonormalize(c)
        t = ts[k]
        f_sum = (f_sum[0] + fx, f_sum[1] + fy, f_sum[2] + fz)
        w_sum = (w_sum[0] + wx, w_sum[1] + wy, w_sum[2] + wz)
        n_sum += 1
        w2_dt += (wx * wx + wy * wy + wz * wz) * dt
        pending += dt
        k += 1
        if pending >= cov_step:
            status = PROPAGATE
            break
    return (
        status, k, t, lat, lon, h, v, c, (wx, wy, wz), (fx, fy, fz), steps, pending, f_sum,
        w_sum, n_sum, w2_dt,
    )  # fmt: skip
