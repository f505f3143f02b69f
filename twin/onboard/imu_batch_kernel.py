"""A batch's pending work in one compiled call: IMU samples, depth updates, a gravity update.

Between two looks at a filter's state a sea trial's variant integrates ten IMU samples, takes a
depth reading somewhere among them and a gravity update after the last (10 Hz each). Taken as
:class:`~twin.onboard.imu_batch.ImuBatch` took them before (its switch
``compiled_updates`` off), that is two flushes and two updates: five compiled calls and the
Python between them, per variant and per 0.1 s (``benchmarks/paired_switches.py`` times the
two). :func:`run` does the same work in one call: the samples through
:func:`twin.onboard.mechanization.advance_samples` (the covariance step each ``cov_step_s`` by
:func:`twin.onboard.eskf_kernels.propagate_at`), each queued depth update at its place among
them and, when asked, the gravity update after them, each by
:func:`twin.onboard.eskf_kernels.propagate_update_at`: the calls
:meth:`~twin.onboard.eskf.Eskf.propagate_covariance`, :meth:`~twin.onboard.eskf.Eskf.update_depth`
and :meth:`~twin.onboard.eskf.Eskf.update_gravity` make, with the same arguments in the same
order, so the same state bit for bit (``tests/onboard/test_imu_batch.py``).

It stops and hands back to Python (which takes that one item its own way, then calls again)
where Python does something else: a sample the INS refuses (a time step out of range, a
non-finite value: :data:`REFUSED`), and an update whose innovation covariance has no closed-form
inverse or whose mean sample is not finite (:data:`PYTHON_UPDATE`: the update is left undone,
the state as before it, for the Python method to make, numpy path or error included).
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.kernel_cache import njit
from twin.onboard import eskf_kernels, mechanization

# Why a call returned.
DONE, REFUSED, PYTHON_UPDATE = 0, 1, 2

# An update's outcome (one row each of ``out_code``, ``out_kind``, ``out_nis``, ``out_t``).
GATED, APPLIED = 1, 2  # eskf_kernels.update's statuses
NOT_STATIC, NO_SAMPLES, NOT_DUE = 3, 4, 5  # the gravity update's skips
DEPTH, GRAVITY = 0, 1  # the outcome's kind


@njit(cache=True)
def _rate_q(q_diag, qc, gain, w2_dt, dt):  # type: ignore[no-untyped-def]
    """:meth:`~twin.onboard.eskf.Eskf._rate_q`: Q_c's diagonal and Q_c with the rate allowance."""
    if gain > 0.0:
        q = q_diag.copy()
        add = gain * gain * w2_dt / dt
        for i in range(3):  # PHI
            q[i] += add
        return q, np.diag(q)
    return q_diag, qc


@njit(cache=True)
def _propagate_and_update(z, hm, r, gate, lat, lon, h, v, c, f_b, bg, ba, pending, w2_dt, p,
                          consts):  # type: ignore[no-untyped-def]  # fmt: skip
    """:meth:`~twin.onboard.eskf.Eskf._propagate_and_update` at this state.

    Returns (status, NIS, P, pending, w2_dt, (C, v, L, λ, h, b_g, b_a)): status 0 (Python's
    numpy path) with everything as given; else P propagated (and updated when applied), the
    state corrected when applied.
    """
    (_, _, free_air, earth, _, fmat, index, q_diag, qc, gain, eye) = consts[:11]
    if pending > 0.0:
        qd, qcd = _rate_q(q_diag, qc, gain, w2_dt, pending)
    else:
        qd, qcd = q_diag, qc
    status, nis, p0, p1, corrected = eskf_kernels.propagate_update_at(
        pending, p, fmat, index, lat, lon, h, v, c, f_b, bg, ba, free_air, earth, qd, qcd, eye,
        hm, r, z, gate,
    )  # fmt: skip
    kept = (c, v, lat, lon, h, bg, ba)
    if status == 0:
        return 0, 0.0, p, pending, w2_dt, kept
    w2 = 0.0 if pending > 0.0 else w2_dt  # _rate_q's reset, when it ran
    if status == APPLIED:
        return APPLIED, nis, p1, 0.0, w2, corrected
    return status, nis, p0, 0.0, w2, kept


@njit(cache=True)
def _gravity_update(t, lat, lon, h, v, c, bg, ba, f_b, pending, f_sum, w_sum, n_sum, w2_dt, p,
                    consts):  # type: ignore[no-untyped-def]  # fmt: skip
    """:meth:`~twin.onboard.eskf.Eskf.update_gravity` from the mean sample, at this state.

    Returns (outcome, NIS, P, pending, f_sum, w_sum, n_sum, w2_dt, (C, v, L, λ, h, b_g, b_a));
    outcome 0 (Python's: the numpy path, or the error a non-finite mean raises) changes nothing.
    """
    (_, _, free_air, earth, _, _, _, _, _, _, _, _, _, _, r_gravity, gate3, models_bias, tol_a,
     tol_w) = consts  # fmt: skip
    kept = (c, v, lat, lon, h, bg, ba)
    if n_sum == 0:
        return NO_SAMPLES, 0.0, p, pending, f_sum, w_sum, n_sum, w2_dt, kept
    n = n_sum
    fx, fy, fz = f_sum[0] / n, f_sum[1] / n, f_sum[2] / n
    wx, wy, wz = w_sum[0] / n, w_sum[1] / n, w_sum[2] / n
    if not math.isfinite(fx + fy + fz + wx + wy + wz):
        return 0, 0.0, p, pending, f_sum, w_sum, n_sum, w2_dt, kept
    zero = (0.0, 0.0, 0.0)
    a_m, e2, omega, ge, k_som, flat, m_ratio, two = earth
    g = mechanization._gravity(lat, h if free_air else 0.0, ge, k_som, e2, a_m, flat, m_ratio, two)
    ie_n, ie_u = omega * math.cos(lat), omega * math.sin(lat)
    rx = wx - c[3] * ie_n - c[6] * ie_u
    ry = wy - c[4] * ie_n - c[7] * ie_u
    rz = wz - c[5] * ie_n - c[8] * ie_u
    if (
        abs(math.sqrt(fx * fx + fy * fy + fz * fz) - g) > tol_a
        or math.sqrt(rx * rx + ry * ry + rz * rz) > tol_w
    ):
        return NOT_STATIC, 0.0, p, pending, zero, zero, 0, w2_dt, kept
    z = np.empty(3)
    z[0] = -(c[0] * fx + c[1] * fy + c[2] * fz)
    z[1] = -(c[3] * fx + c[4] * fy + c[5] * fz)
    z[2] = g - (c[6] * fx + c[7] * fy + c[8] * fz)
    hm = eskf_kernels.gravity_rows(g, c, models_bias)
    status, nis, p1, pending1, w2, state = _propagate_and_update(
        z, hm, r_gravity, gate3, lat, lon, h, v, c, f_b, bg, ba, pending, w2_dt, p, consts
    )
    if status == 0:
        return 0, 0.0, p, pending, f_sum, w_sum, n_sum, w2_dt, kept
    return status, nis, p1, pending1, zero, zero, 0, w2, state


@njit(cache=True)
def run(  # type: ignore[no-untyped-def]
    ts, ws, fs, k, stop, dpos, dval, u, nd, gravity, gdue,
    ins, pending, f_sum, w_sum, n_sum, w2_dt, p,
    consts, out_code, out_kind, out_nis, out_t,
):  # fmt: skip
    """Samples ``k`` … ``stop − 1``, the depth updates ``u`` … ``nd − 1`` among them, then gravity.

    Args: ts, ws, fs (the batch's stamps, rates and forces); k, stop (the samples to take);
    dpos, dval (a queued depth update's place, the samples before it, and its depth); u, nd (the
    updates to take); gravity, gdue (make the gravity update after the samples when the INS's
    clock has reached ``gdue``); ins (t, L, λ, h, v, C, b_g, b_a, ω, f, steps); the filter's
    pending covariance time, sums of f and ω, their count, ∫‖ω‖² dt and P; consts (the filter's
    fixed arrays and settings, :meth:`~twin.onboard.imu_batch.ImuBatch._constants`); the
    outcome rows to write (code, kind, NIS, time).

    Returns:
        (why, next sample, next depth update, the gravity update's outcome (-1: not asked),
        ins, pending, f_sum, w_sum, n_sum, w2_dt, P, outcome rows written).
    """
    (every, max_dt, free_air, earth, cov_step, fmat, index, q_diag, qc, gain, eye, h_depth,
     r_depth, gate1, _, _, _, _, _) = consts  # fmt: skip
    t, lat, lon, h, v, c, bg, ba, w_b, f_b, steps = ins
    n_out = 0
    why = DONE
    outcome = -1
    while True:
        end = dpos[u] if u < nd else stop
        while k < end:
            (st, k2, t, lat, lon, h, v, c, wb, fb, steps, pending, f_sum, w_sum, n_sum,
             w2_dt) = mechanization.advance_samples(
                ts, ws, fs, k, end, t, lat, lon, h, v, c, bg, ba, steps, every, max_dt,
                free_air, earth, pending, cov_step, f_sum, w_sum, n_sum, w2_dt,
            )  # fmt: skip
            if k2 > k:
                w_b, f_b = wb, fb
            k = k2
            if st == mechanization.REFUSED:
                why = REFUSED
                break
            if st == mechanization.PROPAGATE:  # Eskf.propagate_covariance (pending > 0 here)
                qd, qcd = _rate_q(q_diag, qc, gain, w2_dt, pending)
                w2_dt = 0.0
                p = eskf_kernels.propagate_at(
                    p, fmat, index, lat, h, v, c, f_b, free_air, earth, pending, qd, qcd, eye
                )
                pending = 0.0
        if why != DONE or u >= nd:
            break
        # Eskf.update_depth(d): z = h + d, then Eskf._propagate_and_update.
        z = np.empty(1)
        z[0] = h + dval[u]
        status, nis, p1, pending1, w2, corrected = _propagate_and_update(
            z, h_depth, r_depth, gate1, lat, lon, h, v, c, f_b, bg, ba, pending, w2_dt, p, consts
        )
        if status == 0:  # Python's numpy path: the update left undone
            why = PYTHON_UPDATE
            break
        p, pending, w2_dt = p1, pending1, w2
        c, v, lat, lon, h, bg, ba = corrected
        out_code[n_out] = status
        out_kind[n_out] = DEPTH
        out_nis[n_out] = nis
        out_t[n_out] = t
        n_out += 1
        u += 1
    if why == DONE and gravity:
        outcome = NOT_DUE
        if t >= gdue:
            (outcome, nis, p, pending, f_sum, w_sum, n_sum, w2_dt,
             corrected) = _gravity_update(
                t, lat, lon, h, v, c, bg, ba, f_b, pending, f_sum, w_sum, n_sum, w2_dt, p,
                consts,
            )  # fmt: skip
            if outcome == 0:
                why = PYTHON_UPDATE
                outcome = -1
            else:
                c, v, lat, lon, h, bg, ba = corrected
                if outcome != NO_SAMPLES:
                    out_code[n_out] = outcome
                    out_kind[n_out] = GRAVITY
                    out_nis[n_out] = nis
                    out_t[n_out] = t
                    n_out += 1
    state = (t, lat, lon, h, v, c, bg, ba, w_b, f_b, steps)
    return why, k, u, outcome, state, pending, f_sum, w_sum, n_sum, w2_dt, p, n_out
