"""A filter variant's pending work taken in batches: one compiled call for many INS steps.

Between the readings that need the filter's state (a compass frame, the scorer's or the
autopilot's look at the estimate, a gravity update) a filter only integrates IMU samples and
takes depth readings: ten samples and one depth reading per 0.1 s in a sea trial, for each of
three variants. Taken one by one, each sample cost ~13 µs of Python (the reading's channels
turned into floats, the step's checks, the compiled INS step called, the filter's sums) for
~1 µs of arithmetic. :class:`ImuBatch` keeps the samples a
:class:`~twin.onboard.navigator.Navigator` has received, and the depth updates it has queued
among them, and when the state is next wanted (or a gravity update is due) runs them through
:func:`twin.onboard.imu_batch_kernel.run`: the same arithmetic in the same order as
:meth:`Eskf.predict_reading`, :meth:`Eskf.update_depth` and :meth:`Eskf.update_gravity` (so the
same state bit for bit, ``tests/onboard/test_imu_batch.py``), leaving to Python what Python did:
a sample with a time step out of range or a non-finite value (which raises or is skipped, naming
the channel, as configured) and an update the compiled algebra does not take (its numpy path).

A filter whose INS or time update is not the built-in one (an INS with a gravity model of its
own, a subclass that overrides a step) takes its samples one by one, as before (the navigator
keeps no batch for it); one whose updates are not the built-in ones takes them itself, each when
it comes (:meth:`ImuBatch.takes_updates`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from twin.core.messages import Reading
from twin.onboard import imu_batch_kernel as kernel
from twin.onboard.eskf import _H_DEPTH, Eskf
from twin.onboard.eskf_dynamics import _F_VARYING
from twin.onboard.eskf_results import Rejection
from twin.onboard.ins import EARTH_CONSTANTS, StrapdownIns

_STEPS = ("step", "step_reading", "_advance", "_end_step")
# The filter's methods the compiled updates stand for (each must be Eskf's own).
_UPDATES = (
    "update_depth",
    "update_gravity",
    "_propagate_and_update",
    "_applied",
    "_rate_q",
    "propagate_covariance",
)
_KIND = ("depth", "gravity")  # imu_batch_kernel.DEPTH, GRAVITY


def compiled_path(f: Eskf) -> bool:
    """Whether ``f``'s time update is the built-in one (so the compiled batch is its arithmetic)."""
    ins = f.ins
    return (
        ins.standard_gravity
        and all(getattr(type(ins), s) is getattr(StrapdownIns, s) for s in _STEPS)
        and type(f).predict_reading is Eskf.predict_reading
        and type(f)._after_step is Eskf._after_step
        and type(f).propagate_covariance is Eskf.propagate_covariance
    )


def batchable(reading: Reading) -> bool:
    """Whether a reading's channels are what the compiled batch reads: two float (3,) arrays.

    Anything else (a list, another shape) takes the Python step, which names the channel.
    """
    w = reading.values.get("angular_rate")
    f = reading.values.get("specific_force")
    return (
        type(w) is np.ndarray
        and type(f) is np.ndarray
        and w.shape == (3,)
        and f.shape == (3,)
        and w.dtype.kind == "f"
        and f.dtype.kind == "f"
    )


class ImuBatch:
    """The work a filter has received but not yet done (a compiled filter's only).

    The IMU samples, and the depth updates queued among them (:meth:`add_depth`). Each sample's
    stamp and channels are copied in when it arrives, so that a sensor which reuses its arrays
    cannot change a sample waiting here.

    Args:
        f: The filter the samples are for; :func:`compiled_path` must hold.
    """

    #: The depth and gravity updates in the batch's compiled calls; False: each by the filter's
    #: Python method when its reading or instant comes (the reference the tests and
    #: ``benchmarks/paired_switches.py`` hold the compiled updates to).
    compiled_updates: bool = True

    def __init__(self, f: Eskf) -> None:
        if not compiled_path(f):
            raise ValueError(
                "ImuBatch: this filter's time update is not the built-in one; take its "
                "samples one by one (Eskf.predict_reading)"
            )
        self.filter = f
        self.readings: list[Reading] = []
        self._ts = np.empty(64)
        self._ws = np.empty((64, 3))
        self._fs = np.empty((64, 3))
        # Queued depth updates: the samples before each, its depth (m).
        self._dpos = np.empty(8, dtype=np.int64)
        self._dval = np.empty(8)
        self._nd = 0
        # The outcome rows a call writes (code, kind, NIS, time): one per update at most.
        self._out = (np.empty(9, np.int64), np.empty(9, np.int64), np.empty(9), np.empty(9))
        self._consts: tuple[Any, ...] | None = None

    def __len__(self) -> int:
        return len(self.readings)

    @property
    def pending(self) -> bool:
        """Whether any sample or update waits to be done."""
        return bool(self.readings) or self._nd > 0

    def takes_updates(self) -> bool:
        """Whether the filter's depth and gravity updates are the built-in ones (compiled here).

        Checked on every call: a test or a tool may wrap a filter's method on the instance.
        """
        if not self.compiled_updates:
            return False
        f = self.filter
        cls = type(f)
        return all(getattr(cls, m) is getattr(Eskf, m) and m not in f.__dict__ for m in _UPDATES)

    def add(self, reading: Reading) -> None:
        """Keep one IMU reading (:func:`batchable`) for the next :meth:`flush`."""
        k = len(self.readings)
        if k == self._ts.shape[0]:
            self._grow(k + 1)
        self._ts[k] = reading.t
        self._ws[k] = reading.values["angular_rate"]
        self._fs[k] = reading.values["specific_force"]
        self.readings.append(reading)

    def add_block(self, readings: list[Reading], ts: list[float], samples: np.ndarray) -> None:
        """:meth:`add` of each reading in turn, their channels given as rows of ``samples``.

        Args:
            readings: The IMU readings (:func:`batchable`), in time order.
            ts: Their stamps.
            samples: (n, 6) [angular_rate, specific_force] of each, copied in.
        """
        k, n = len(self.readings), len(readings)
        if k + n > self._ts.shape[0]:
            self._grow(k + n)
        self._ts[k : k + n] = ts
        self._ws[k : k + n] = samples[:, 0:3]
        self._fs[k : k + n] = samples[:, 3:6]
        self.readings.extend(readings)

    def add_depth(self, depth_m: float) -> None:
        """Queue :meth:`Eskf.update_depth` after the samples kept so far (:meth:`takes_updates`).

        Raises:
            ValueError: The depth is not finite (as :meth:`Eskf.update_depth` says it).
        """
        if not math.isfinite(depth_m):
            raise ValueError(f"Eskf.update_depth depth_m = {depth_m!r}: must be finite")
        j = self._nd
        if j == self._dpos.shape[0]:
            self._dpos = np.concatenate([self._dpos, np.empty(j, np.int64)])
            self._dval = np.concatenate([self._dval, np.empty(j)])
            self._out = tuple(np.empty(2 * j + 1, a.dtype) for a in self._out)  # type: ignore[assignment]
        self._dpos[j] = len(self.readings)
        self._dval[j] = depth_m
        self._nd = j + 1

    def _grow(self, size: int) -> None:
        """Room for ``size`` samples at least (doubling), the kept ones kept."""
        m = self._ts.shape[0]
        while m < size:
            m *= 2
        k = len(self.readings)
        ts, ws, fs = np.empty(m), np.empty((m, 3)), np.empty((m, 3))
        ts[:k], ws[:k], fs[:k] = self._ts[:k], self._ws[:k], self._fs[:k]
        self._ts, self._ws, self._fs = ts, ws, fs

    def _constants(self) -> tuple[Any, ...]:
        """The filter's arrays and settings the kernel reads (fixed for its life)."""
        if self._consts is None:
            f = self.filter
            ins, cfg = f.ins, f.config
            self._consts = (
                ins.config.orthonormalize_every, ins._max_dt, ins.config.free_air_gravity,
                EARTH_CONSTANTS, f._cov_step, f._f, _F_VARYING, f._q_diag, f._qc,
                float(cfg.q_rate_gain), f._eye, _H_DEPTH, f._r_depth, f._gate[1],
                f._r_gravity, f._gate[3], cfg.gravity_models_accel_bias,
                float(cfg.static_accel_tol_mps2), float(cfg.static_rate_tol_rad_s),
            )  # fmt: skip
        return self._consts

    def flush(self, gravity_due: float | None = None) -> bool:
        """Do every kept sample and queued update, in order, as the filter's methods would.

        Args:
            gravity_due: Then :meth:`Eskf.update_gravity`, if the INS's clock has reached this
                instant (the navigator's due time less its tolerance); None: no gravity update.

        Returns:
            Whether the gravity update was made (its clock had reached ``gravity_due``).
        """
        readings = self.readings
        n, nd = len(readings), self._nd
        if not n and not nd and gravity_due is None:
            return False
        self.readings = []
        self._nd = 0
        f = self.filter
        ins = f.ins
        ts, ws, fs = self._ts, self._ws, self._fs
        dpos, dval = self._dpos, self._dval
        code, kind, nis, at = self._out
        consts = self._constants()
        gravity = gravity_due is not None
        i = u = 0
        while True:
            state = (ins.t, ins.lat, ins.lon, ins.h, ins._v, ins._c, ins._bg, ins._ba, ins._w,
                     ins._f, ins._steps)  # fmt: skip
            (why, i, u, outcome, state, f._pending_dt, f_sum, w_sum, f._n_sum, f._w2_dt, f.P,
             rows) = kernel.run(
                ts, ws, fs, i, n, dpos, dval, u, nd, gravity,
                gravity_due if gravity else 0.0, state, f._pending_dt, tuple(f._f_sum),
                tuple(f._w_sum), f._n_sum, f._w2_dt, f.P, consts, code, kind, nis, at,
            )  # fmt: skip
            (ins.t, ins.lat, ins.lon, ins.h, ins._v, ins._c, ins._bg, ins._ba, ins._w, ins._f,
             ins._steps) = state  # fmt: skip
            ins._cache.clear()
            f._f_sum, f._w_sum = list(f_sum), list(w_sum)
            for r in range(rows):
                what = _KIND[kind[r]]
                if code[r] == kernel.APPLIED:
                    f.counts[what] = f.counts.get(what, 0) + 1
                elif code[r] == kernel.GATED:
                    gate = f._gate[1 if what == "depth" else 3]
                    f.rejections.append(Rejection(float(at[r]), what, float(nis[r]), gate))
                else:  # NOT_STATIC
                    f.counts["not_static"] += 1
            if why == kernel.DONE:
                return outcome not in (-1, kernel.NOT_DUE)
            if why == kernel.REFUSED:
                # The Python step raises, or skips and counts, as configured, naming the channel.
                r = readings[i]
                kept = {"angular_rate": ws[i].copy(), "specific_force": fs[i].copy()}
                f.predict_reading(Reading(r.sensor, float(ts[i]), r.t_delivered, kept))
                i += 1
            elif u < nd:  # PYTHON_UPDATE: the update's numpy path (or its error), then on
                f.update_depth(float(dval[u]))
                u += 1
            else:  # PYTHON_UPDATE of the gravity update, the last of the work
                assert gravity_due is not None
                f.update_gravity()
                return True
