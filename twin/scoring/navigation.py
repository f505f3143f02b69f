"""Scoring the onboard filters against ground truth (world side: sees both).

For each filter variant, at the truth rate: heading error (estimate − truth, wrapped, degrees),
roll and pitch errors, horizontal position drift, and the attitude NEES ε = φᵀ P_φφ⁻¹ φ with
φ = ``eskf.attitude_error(C_est, C_true)`` (the filter's own error convention). The mean NEES over
N samples is compared with the two-sided 95 % chi-square bounds for 3N degrees of freedom divided
by N (Bar-Shalom's test): inside ⇒ the filter's attitude covariance is consistent. Samples are
correlated in time, so the bound is indicative, not exact; the per-sample fraction inside the
3-dof 95 % bound is reported too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.stats import chi2

from twin.core.arrays import Float64Array as FloatArray
from twin.core.frames import quat_to_dcm, wrap_deg180, wrap_pi
from twin.onboard.eskf import attitude_error
from twin.onboard.navigator import CompassEvent, Navigator
from twin.world.truth import Truth

_CHI2_3_95 = float(chi2.ppf(0.95, 3))


# What a sample keeps of the estimate and the truth until it is scored (VariantScore._settle).
_Raw = tuple[
    float, float, float, float, float, float, float, float, float, float, float, float,
    FloatArray, FloatArray, FloatArray,
]  # fmt: skip
# Samples kept before they are scored together (bounds the memory of a long run's raw samples).
_SETTLE_EVERY = 512


def _series(attr: str, doc: str) -> property:
    """A read-only series of :class:`VariantScore`, its pending samples scored first."""

    def get(self: VariantScore) -> list[float]:
        self._settle()
        return getattr(self, attr)  # type: ignore[no-any-return]

    return property(get, doc=doc)


class VariantScore:
    """Running error statistics of one variant.

    A sample keeps the estimate and the truth (:meth:`record`); the errors are computed for many
    samples at once when they are read (:meth:`_settle`, numpy over the samples), with the
    arithmetic of :meth:`last_sample`, the one-sample path, bit for bit
    (``tests/test_scoring_batch.py``): at 10 Hz for three variants the one-by-one path cost
    ~1.8 ms per simulated second.
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self._t: list[float] = []
        self._heading: list[float] = []
        self._heading_err: list[float] = []
        self._heading_sigma: list[float] = []
        self._roll_err: list[float] = []
        self._pitch_err: list[float] = []
        self._pos_err: list[float] = []
        self._nees: list[float] = []
        self._pending: list[_Raw] = []
        self._last: _Raw | None = None

    # The series, every sample recorded so far scored.
    t = _series("_t", "The truth samples' times (s).")
    heading = _series("_heading", "The estimated heading at each sample (degrees).")
    heading_err = _series("_heading_err", "Heading error, estimate − truth (degrees, wrapped).")
    heading_sigma = _series("_heading_sigma", "The filter's heading σ (degrees).")
    roll_err = _series("_roll_err", "Roll error (degrees).")
    pitch_err = _series("_pitch_err", "Pitch error (degrees).")
    pos_err = _series("_pos_err", "Horizontal position error (m).")
    nees = _series("_nees", "Attitude NEES (inf where the attitude block is singular).")

    def record(self, nav: Navigator, truth: Truth) -> None:
        """Keep the variant's estimate now and ``truth``, scored when read (class docstring)."""
        est = nav.estimate()
        east, north = nav.local_en(est)
        raw: _Raw = (
            truth.t, est.heading_deg, truth.heading_deg, est.roll, truth.roll_rad, est.pitch,
            truth.pitch_rad, east, north, float(truth.position_n[0]),
            float(truth.position_n[1]), est.heading_sigma_deg, est.c_bn,
            est.covariance[:3, :3].copy(), truth.quat_wxyz,
        )  # fmt: skip
        self._pending.append(raw)
        self._last = raw
        if len(self._pending) >= _SETTLE_EVERY:
            self._settle()

    def add(self, nav: Navigator, truth: Truth) -> dict[str, float]:
        """:meth:`record`, and this sample's errors (:meth:`last_sample`)."""
        self.record(nav, truth)
        return self.last_sample()

    def last_sample(self) -> dict[str, float]:
        """The last recorded sample's estimate and errors, scored on its own."""
        if self._last is None:
            return {}
        _, h, h_t, r, r_t, p, p_t, east, north, x_t, y_t, sigma, c_bn, p3, q = self._last
        c_true = quat_to_dcm(q)
        e_h = float(wrap_deg180(h - h_t))
        e_r = math.degrees(wrap_pi(r - r_t))
        e_p = math.degrees(wrap_pi(p - p_t))
        e_pos = math.hypot(east - x_t, north - y_t)
        phi = attitude_error(c_bn, c_true)
        try:
            nees = float(phi @ np.linalg.solve(p3, phi))
        except np.linalg.LinAlgError:
            nees = math.inf
        return {
            "east_m": east,
            "north_m": north,
            "roll_deg": math.degrees(r),
            "pitch_deg": math.degrees(p),
            "heading_deg": h,
            "heading_err_deg": e_h,
            "heading_sigma_deg": sigma,
            "roll_err_deg": e_r,
            "pitch_err_deg": e_p,
            "position_err_m": e_pos,
            "nees": nees,
        }

    def _settle(self) -> None:
        """Score the pending samples together: :meth:`last_sample`'s arithmetic, bit for bit.

        Elementwise numpy where it is the scalar code's own arithmetic (the wraps, degrees, the
        quaternion's matrix, the stacked matrix products and solves, one LAPACK call per
        sample as before); Python's ``math`` per sample where numpy's functions round
        differently (``hypot``, ``acos``, ``sin``).
        """
        raw = self._pending
        if not raw:
            return
        self._pending = []
        cols = list(zip(*raw, strict=True))
        t, h, h_t, r, r_t, p, p_t = (np.array(c) for c in cols[:7])
        east, north, x_t, y_t, sigma = cols[7:12]
        c_bn = np.array(cols[12])
        p3 = np.array(cols[13])
        q = np.array(cols[14], dtype=np.float64)
        self._t.extend(t.tolist())
        self._heading.extend(h.tolist())
        self._heading_err.extend(wrap_deg180(h - h_t).tolist())
        self._roll_err.extend(np.degrees(_wrap_pi(r - r_t)).tolist())
        self._pitch_err.extend(np.degrees(_wrap_pi(p - p_t)).tolist())
        self._heading_sigma.extend(sigma)
        self._pos_err.extend(
            math.hypot(e - x, n - y) for e, n, x, y in zip(east, north, x_t, y_t, strict=True)
        )
        phi = _attitude_errors(c_bn, _quats_to_dcm(q))
        try:
            sol = np.linalg.solve(p3, phi[..., None])[..., 0]
            self._nees.extend(float(a @ b) for a, b in zip(phi, sol, strict=True))
        except np.linalg.LinAlgError:  # a singular block: each sample on its own, as before
            for a, m in zip(phi, p3, strict=True):
                try:
                    self._nees.append(float(a @ np.linalg.solve(m, a)))
                except np.linalg.LinAlgError:
                    self._nees.append(math.inf)

    def summary(self, nav: Navigator) -> dict[str, Any]:
        """The metrics.json entry of this variant."""
        h = np.asarray(self.heading_err)
        n = len(h)
        out: dict[str, Any] = {"samples": n}
        if n == 0:
            return out
        nees = np.asarray(self.nees)
        finite = nees[np.isfinite(nees)]
        nf = max(len(finite), 1)
        lo = float(chi2.ppf(0.025, 3 * nf) / nf)
        hi = float(chi2.ppf(0.975, 3 * nf) / nf)
        mean_nees = float(finite.mean()) if len(finite) else math.inf
        ups = nav.updates
        rej: dict[str, int] = {}
        for r in nav.rejections:
            rej[r.kind] = rej.get(r.kind, 0) + 1
        out.update(
            heading_rmse_deg=_r(math.sqrt(float(np.mean(h * h)))),
            heading_mae_deg=_r(float(np.mean(np.abs(h)))),
            heading_max_deg=_r(float(np.max(np.abs(h)))),
            heading_final_deg=_r(float(h[-1])),
            heading_sigma_final_deg=_r(self.heading_sigma[-1]),
            roll_rmse_deg=_r(_rms(self.roll_err)),
            pitch_rmse_deg=_r(_rms(self.pitch_err)),
            position_drift_final_m=_r(self.pos_err[-1]),
            position_drift_max_m=_r(max(self.pos_err)),
            nees_attitude_mean=_r(mean_nees),
            nees_attitude_bounds_95=[_r(lo), _r(hi)],
            nees_attitude_consistent=bool(lo <= mean_nees <= hi),
            nees_attitude_within_95_fraction=_r(float(np.mean(nees <= _CHI2_3_95))),
            compass=(
                {
                    "method": nav.variant,
                    "frames": ups["frames"],
                    "fixes": ups["frames"] - ups["no_fix"],
                    "no_fix": ups["no_fix"],
                    "sun_updates_applied": ups["sun"],
                    "sun_updates_rejected": ups["sun_rejected"],
                    # Fused / fixes: a variant that fuses (almost) none equals INS (a warning).
                    "fused_fraction": _r(ups["sun"] / (ups["frames"] - ups["no_fix"]))
                    if ups["frames"] > ups["no_fix"]
                    else 0.0,
                }
                if nav.method is not None
                else None
            ),
            updates_applied=dict(nav.filter.counts),
            rejected=rej,
        )
        return out


def _rms(x: list[float]) -> float:
    a = np.asarray(x)
    return math.sqrt(float(np.mean(a * a))) if a.size else math.nan


def _r(x: float, nd: int = 4) -> float:
    return round(float(x), nd) if math.isfinite(x) else float(x)


def _wrap_pi(a: FloatArray) -> FloatArray:
    """:func:`twin.core.frames.wrap_pi` elementwise (the same fmod and adds)."""
    w = np.fmod(a + math.pi, 2.0 * math.pi)
    w = np.where(w <= 0.0, w + 2.0 * math.pi, w)
    return w - math.pi


def _quats_to_dcm(q: FloatArray) -> FloatArray:
    """:func:`twin.core.frames.quat_to_dcm` of (n, 4) quaternions: (n, 3, 3)."""
    w, x, y, z = q.T
    out = np.empty((len(q), 3, 3))
    out[:, 0, 0] = 1 - 2 * (y * y + z * z)
    out[:, 0, 1] = 2 * (x * y - w * z)
    out[:, 0, 2] = 2 * (x * z + w * y)
    out[:, 1, 0] = 2 * (x * y + w * z)
    out[:, 1, 1] = 1 - 2 * (x * x + z * z)
    out[:, 1, 2] = 2 * (y * z - w * x)
    out[:, 2, 0] = 2 * (x * z - w * y)
    out[:, 2, 1] = 2 * (y * z + w * x)
    out[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def _attitude_errors(c_est: FloatArray, c_true: FloatArray) -> FloatArray:
    """:func:`twin.onboard.eskf.attitude_error` of (n, 3, 3) stacks: (n, 3)."""
    m = c_est @ np.swapaxes(c_true, 1, 2)
    tr = np.trace(m, axis1=1, axis2=2)
    w = np.stack([m[:, 2, 1] - m[:, 1, 2], m[:, 0, 2] - m[:, 2, 0], m[:, 1, 0] - m[:, 0, 1]], 1)
    out = np.empty_like(w)
    for i, (tr_i, w_i) in enumerate(zip(tr.tolist(), w, strict=True)):
        a = math.acos(max(-1.0, min(1.0, 0.5 * (tr_i - 1.0))))
        k = 0.5 if a < 1e-8 else a / (2.0 * math.sin(a))
        out[i] = -k * w_i
    return out


@dataclass
class FixScore:
    """Every compass fix of one variant against truth: heading and solar-vector errors.

    The heading error is the fix's heading (through the onboard ephemeris) minus the true heading;
    the solar-vector error is the angle between the fix's body-frame sun and the true sun (in air)
    in the true body frame, from the truth that travelled with the frame.
    """

    name: str
    frames: int = 0
    fixes: int = 0
    unscored: int = 0
    t: list[float] = field(default_factory=list)
    heading_err: list[float] = field(default_factory=list)
    sun_err: list[float] = field(default_factory=list)

    def add(self, event: CompassEvent, truth: Truth | None, frame_truth: object) -> None:
        """Score one processed frame (``truth`` None: the frame's instant is not at hand)."""
        self.frames += 1
        fix = event.fix
        if not fix.ok:
            return
        self.fixes += 1
        if truth is None:
            self.unscored += 1
            return
        self.t.append(event.t)
        self.heading_err.append(
            float(wrap_deg180(fix.heading_deg - truth.heading_deg))
            if fix.heading_deg is not None
            else math.nan
        )
        sun_enu = getattr(frame_truth, "sun_enu", None)
        if fix.sun_body is not None and sun_enu is not None:
            s_true = quat_to_dcm(truth.quat_wxyz).T @ np.asarray(sun_enu, float)
            s_fix = np.asarray(fix.sun_body, float)
            c = float(s_true @ s_fix / (np.linalg.norm(s_true) * np.linalg.norm(s_fix)))
            self.sun_err.append(math.degrees(math.acos(max(-1.0, min(1.0, c)))))
        else:
            self.sun_err.append(math.nan)

    def summary(self) -> dict[str, Any]:
        h = np.asarray([x for x in self.heading_err if math.isfinite(x)])
        s = np.asarray([x for x in self.sun_err if math.isfinite(x)])
        out: dict[str, Any] = {
            "frames": self.frames,
            "fixes": self.fixes,
            "scored": len(self.t),
            "unscored_delayed": self.unscored,
        }
        if h.size:
            out |= {
                "heading_error_rmse_deg": _r(float(np.sqrt(np.mean(h * h)))),
                "heading_error_mean_deg": _r(float(np.mean(h))),
                "heading_error_max_deg": _r(float(np.max(np.abs(h)))),
            }
        if s.size:
            out |= {
                "sun_vector_error_mean_deg": _r(float(np.mean(s))),
                "sun_vector_error_median_deg": _r(float(np.median(s))),
                "sun_vector_error_max_deg": _r(float(np.max(s))),
            }
        return out
