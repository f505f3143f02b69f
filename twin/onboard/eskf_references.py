"""The filter's numpy references: what its compiled paths compute, written with numpy.

:class:`~twin.onboard.eskf.Eskf` runs its covariance step, its F, its Kalman update and its
feedback compiled (:mod:`twin.onboard.eskf_kernels`, :mod:`twin.onboard.mechanization`); these
are the same operations with numpy and Python floats, kept as the references the compiled ones
equal bit for bit (``tests/onboard/test_eskf.py``), and the path of an S without a closed-form
inverse. A mixin of :class:`Eskf`: it reads and writes the filter's own state.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twin.core.arrays import Float64Array as FloatArray
from twin.onboard.eskf_algebra import inverse_spd
from twin.onboard.eskf_dynamics import _F_VARYING, _f_varying_part
from twin.onboard.eskf_results import MeasurementKind, Rejection, UpdateResult

if TYPE_CHECKING:
    from twin.onboard.eskf import Eskf


class EskfReferences:
    """:class:`~twin.onboard.eskf.Eskf`'s numpy references (module docstring)."""

    def _system_matrix_reference(self: Eskf) -> FloatArray:
        """:meth:`_system_matrix` in Python (the reference)."""
        ins = self.ins
        dgl, dgh = self.gravity_partials()
        self._f_flat[_F_VARYING] = _f_varying_part(ins.lat, ins.h, ins._v, ins._c, ins._f, dgl, dgh)
        return self._f

    def _propagate_reference(self: Eskf) -> None:
        """:meth:`propagate_covariance` with numpy (the reference)."""
        dt = self._pending_dt
        if dt <= 0.0:
            return
        fdt = self._system_matrix() * dt
        phi = fdt @ fdt
        phi *= 0.5
        phi += fdt
        phi += self._eye
        q_diag, qc = self._rate_q(dt)
        # Q_d = ½ (Φ Q_c Φᵀ + Q_c) Δt, Q_c diagonal: Φ Q_c Φᵀ = (Φ · q) Φᵀ.
        q = (phi * q_diag) @ phi.T
        q += qc
        q *= 0.5 * dt
        p = phi @ self.P @ phi.T
        p += q
        p += p.T  # symmetrize (numpy buffers the overlapping transpose)
        p *= 0.5
        self.P = p
        self._pending_dt = 0.0

    def _update_reference(
        self: Eskf, kind: MeasurementKind, z: FloatArray, h: FloatArray, r: FloatArray
    ) -> UpdateResult:
        """:meth:`_update` with numpy (the reference)."""
        # x is zero here, so the innovation is z itself.
        p = self.P
        pht = p @ h.T
        s = h @ pht
        s += r
        s_inv = inverse_spd(s)
        zl = z.tolist()
        nis = sum(a * b for a, b in zip(zl, (s_inv @ z).tolist(), strict=True))
        threshold = self._gate[len(zl)]
        if not nis < threshold:
            self.rejections.append(Rejection(self.t, kind, nis, threshold))
            return UpdateResult(kind, self.t, False, nis, "gate")
        k = pht @ s_inv
        ikh_p = p - k @ pht.T  # (I − KH) P
        m = ikh_p @ h.T
        m -= k @ r
        p = ikh_p - m @ k.T  # (I − KH) P (I − KH)ᵀ + K R Kᵀ
        p += p.T
        p *= 0.5
        self.P = p
        self._feedback(k @ z)
        self.counts[kind] = self.counts.get(kind, 0) + 1
        return UpdateResult(kind, self.t, True, nis)

    def _feedback_reference(self: Eskf, x: FloatArray) -> None:
        """:meth:`_feedback` through the INS's Python correction (the reference)."""
        e = x.tolist()
        self.ins.correct_floats(
            (e[0], e[1], e[2]),
            (e[3], e[4], e[5]),
            e[6],
            e[7],
            e[8],
            (e[9], e[10], e[11]),
            (e[12], e[13], e[14]),
        )
