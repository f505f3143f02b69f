"""A filter variant's IMU samples taken in batches: one compiled call for many INS steps.

Between the readings that need the filter's state (a depth or gravity update, a compass frame,
the scorer's or the autopilot's look at the estimate) a filter only integrates IMU samples: ten
of them per depth reading in a sea trial, for each of three variants. Taken one by one, each
costs ~13 µs of Python (the reading's channels turned into floats, the step's checks, the
compiled INS step called, the filter's sums) for ~1 µs of arithmetic. :class:`ImuBatch` keeps
the samples a :class:`~twin.onboard.navigator.Navigator` has received and, when the state is
next wanted, runs them through :func:`twin.onboard.mechanization.advance_samples`: the same
arithmetic in the same order as :meth:`Eskf.predict_reading` (so the same state bit for bit,
``tests/onboard/test_imu_batch.py``), leaving to Python what Python did: the covariance step
each ``cov_step_s``, and a sample with a time step out of range or a non-finite value (which
raises or is skipped, naming the channel, as configured).

A filter whose INS or time update is not the built-in one (an INS with a gravity model of its
own, a subclass that overrides a step) takes its samples one by one, as before (the navigator
keeps no batch for it).
"""

from __future__ import annotations

import numpy as np

from twin.core.messages import Reading
from twin.onboard import mechanization
from twin.onboard.eskf import Eskf
from twin.onboard.ins import EARTH_CONSTANTS, StrapdownIns

_STEPS = ("step", "step_reading", "_advance", "_end_step")


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
    """The IMU samples a filter has received but not yet integrated (a compiled filter's only).

    Each sample's stamp and channels are copied in when it arrives, so that a sensor which
    reuses its arrays cannot change a sample waiting here.

    Args:
        f: The filter the samples are for; :func:`compiled_path` must hold.
    """

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

    def __len__(self) -> int:
        return len(self.readings)

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

    def _grow(self, size: int) -> None:
        """Room for ``size`` samples at least (doubling), the kept ones kept."""
        m = self._ts.shape[0]
        while m < size:
            m *= 2
        k = len(self.readings)
        ts, ws, fs = np.empty(m), np.empty((m, 3)), np.empty((m, 3))
        ts[:k], ws[:k], fs[:k] = self._ts[:k], self._ws[:k], self._fs[:k]
        self._ts, self._ws, self._fs = ts, ws, fs

    def flush(self) -> None:
        """Integrate every kept sample, in order, as :meth:`Eskf.predict_reading` would."""
        readings = self.readings
        n = len(readings)
        if not n:
            return
        self.readings = []
        f = self.filter
        ins = f.ins
        cfg = ins.config
        ts, ws, fs = self._ts, self._ws, self._fs
        i = 0
        while i < n:
            (status, k, t, lat, lon, h, v, c, w_b, f_b, steps, pending, f_sum, w_sum, n_sum,
             w2_dt) = mechanization.advance_samples(
                ts, ws, fs, i, n, ins.t, ins.lat, ins.lon, ins.h, ins._v, ins._c, ins._bg,
                ins._ba, ins._steps, cfg.orthonormalize_every, ins._max_dt,
                cfg.free_air_gravity, EARTH_CONSTANTS, f._pending_dt, f._cov_step,
                tuple(f._f_sum), tuple(f._w_sum), f._n_sum, f._w2_dt,
            )  # fmt: skip
            if k > i:
                ins.t, ins.lat, ins.lon, ins.h, ins._v, ins._c = t, lat, lon, h, v, c
                ins._w, ins._f, ins._steps = w_b, f_b, steps
                ins._cache.clear()
                f._pending_dt, f._n_sum, f._w2_dt = pending, n_sum, w2_dt
                f._f_sum, f._w_sum = list(f_sum), list(w_sum)
            if status == mechanization.PROPAGATE:
                f.propagate_covariance()
            elif status == mechanization.REFUSED:
                # The Python step raises, or skips and counts, as configured, naming the channel.
                r = readings[k]
                kept = {"angular_rate": ws[k].copy(), "specific_force": fs[k].copy()}
                f.predict_reading(Reading(r.sensor, float(ts[k]), r.t_delivered, kept))
                k += 1
            i = k
