"""The filter's covariance step and Kalman update, compiled: the numpy versions' arithmetic.

:meth:`twin.onboard.eskf.Eskf.propagate_covariance` and :meth:`~twin.onboard.eskf.Eskf._update`
each make ~12 numpy calls on 15×15 and 15×m arrays, and numpy's per-call cost is most of their
time (every filter variant updates depth and gravity at 10 Hz). Here the same operations, in the
same order, run in one compiled call each. numba's ``@`` on 2-D float64 arrays calls the same
BLAS routines numpy's does, and the element-wise steps are IEEE operations in the same order, so
the results are the numpy versions' bit for bit (``tests/onboard/test_eskf.py`` checks it on
random states); ``P + Pᵀ`` is formed into a new array, as numpy's buffered ``p += p.T`` does.
The numpy versions stay in :class:`~twin.onboard.eskf.Eskf` as the references.
"""

from __future__ import annotations

import numpy as np

from twin.core.kernel_cache import njit
from twin.onboard import mechanization


@njit(cache=True)
def propagate(p, f, dt, q_diag, qc, eye):  # type: ignore[no-untyped-def]
    """Φ P Φᵀ + Q_d with Φ = I + FΔt + ½(FΔt)², Q_d = ½ (Φ Q_c Φᵀ + Q_c) Δt, symmetrized."""
    fdt = f * dt
    phi = fdt @ fdt
    phi *= 0.5
    phi += fdt
    phi += eye
    q = (phi * q_diag) @ phi.T
    q += qc
    q *= 0.5 * dt
    p1 = phi @ p @ phi.T
    p1 += q
    p2 = p1 + p1.T
    p2 *= 0.5
    return p2


@njit(cache=True)
def _inverse_spd(s):  # type: ignore[no-untyped-def]
    """(ok, S⁻¹): the closed forms of :func:`twin.onboard.eskf_algebra.inverse_spd`, or ok False."""
    m = s.shape[0]
    if m == 1:
        return True, 1.0 / s
    if m == 2:
        a, b, d = s[0, 0], s[0, 1], s[1, 1]
        det = a * d - b * b
        if det > 0.0:
            return True, np.array([[d, -b], [-b, a]]) / det
    elif m == 3:
        a, b, c = s[0, 0], s[0, 1], s[0, 2]
        d, e = s[1, 1], s[1, 2]
        f = s[2, 2]
        c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
        det = a * c00 + b * c01 + c * c02
        if det > 0.0:
            inv = np.array(
                [
                    [c00, c01, c02],
                    [c01, a * f - c * c, b * c - a * e],
                    [c02, b * c - a * e, a * d - b * b],
                ]
            )
            return True, inv / det
    return False, s


@njit(cache=True)
def update(p, h, r, z, threshold):  # type: ignore[no-untyped-def]
    """Gate, then the Joseph-form update: (status, NIS, P⁺, δx).

    status: 0 = S has no closed-form inverse here (the caller takes the numpy path), 1 = gated
    out (P⁺ is P), 2 = applied. The algebra is ``Eskf._update``'s, in its order.
    """
    pht = p @ h.T
    s = h @ pht
    s += r
    ok, s_inv = _inverse_spd(s)
    empty = np.zeros(p.shape[0])
    if not ok:
        return 0, 0.0, p, empty
    y = s_inv @ z
    nis = 0.0
    for i in range(z.shape[0]):
        nis += z[i] * y[i]
    if not nis < threshold:
        return 1, nis, p, empty
    k = pht @ s_inv
    ikh_p = p - k @ pht.T
    m = ikh_p @ h.T
    m -= k @ r
    p1 = ikh_p - m @ k.T
    p2 = p1 + p1.T
    p2 *= 0.5
    return 2, nis, p2, k @ z


@njit(cache=True)
def propagate_at(p, f, index, lat, h, v, c, f_b, free_air, earth, dt, q_diag, qc, eye):  # type: ignore[no-untyped-def]
    """:meth:`~twin.onboard.eskf.Eskf.propagate_covariance`'s three calls in one.

    F's varying entries refilled in place (``f``, the filter's own array) at the INS's state
    (:func:`~twin.onboard.mechanization.gravity_partials`, then
    :func:`~twin.onboard.mechanization.fill_f`), then :func:`propagate`: the same calls in the
    same order, so the same P bit for bit, for one dispatch instead of three.
    """
    dgl, dgh = mechanization.gravity_partials(lat, h, free_air, earth)
    mechanization.fill_f(f.reshape(-1), index, lat, h, v, c, f_b, dgl, dgh, earth)
    return propagate(p, f, dt, q_diag, qc, eye)


@njit(cache=True)
def update_at(p, hm, r, z, threshold, c, v, lat, lon, h, bg, ba):  # type: ignore[no-untyped-def]
    """:func:`update`, then the INS's correction when it was applied, in one dispatch.

    Returns (status, NIS, P⁺, (C, v, lat, lon, h, b_g, b_a)): the state corrected by
    :func:`~twin.onboard.mechanization.correct` (``Eskf._feedback``'s arithmetic) when status is
    2, as given otherwise.
    """
    status, nis, p1, dx = update(p, hm, r, z, threshold)
    if status == 2:
        return status, nis, p1, mechanization.correct(c, v, lat, lon, h, bg, ba, dx)
    return status, nis, p1, (c, v, lat, lon, h, bg, ba)


@njit(cache=True)
def propagate_update_at(  # type: ignore[no-untyped-def]
    dt,
    p,
    f,
    index,
    lat,
    lon,
    h,
    v,
    c,
    f_b,
    bg,
    ba,
    free_air,
    earth,
    q_diag,
    qc,
    eye,
    hm,
    r,
    z,
    threshold,
):
    """:func:`propagate_at` (when ``dt`` > 0) then :func:`update_at`, in one dispatch.

    ``Eskf.propagate_covariance`` then ``Eskf._update``: the same calls in the same order.
    Returns (status, NIS, the propagated P, P⁺, the state), P⁺ and the state as
    :func:`update_at` gives them; the propagated P for the numpy path (status 0).
    """
    if dt > 0.0:
        p = propagate_at(p, f, index, lat, h, v, c, f_b, free_air, earth, dt, q_diag, qc, eye)
    status, nis, p1, state = update_at(p, hm, r, z, threshold, c, v, lat, lon, h, bg, ba)
    return status, nis, p, p1, state


@njit(cache=True)
def gravity_rows(g, c, models_accel_bias):  # type: ignore[no-untyped-def]
    """The gravity update's H (3 × 15): [[g^n×] 0 0 0 −C], −C only when it models b_a."""
    hm = np.zeros((3, 15))
    hm[0, 1] = g
    hm[1, 0] = -g
    if models_accel_bias:
        for i in range(3):
            for j in range(3):
                hm[i, 12 + j] = -c[3 * i + j]
    return hm
