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

from twin.core.frames import quat_to_dcm, wrap_deg180, wrap_pi
from twin.onboard.eskf import attitude_error
from twin.onboard.navigator import CompassEvent, Navigator
from twin.world.truth import Truth

_CHI2_3_95 = float(chi2.ppf(0.95, 3))


@dataclass
class VariantScore:
    """Running error statistics of one variant."""

    name: str
    t: list[float] = field(default_factory=list)
    heading_err: list[float] = field(default_factory=list)
    heading_sigma: list[float] = field(default_factory=list)
    roll_err: list[float] = field(default_factory=list)
    pitch_err: list[float] = field(default_factory=list)
    pos_err: list[float] = field(default_factory=list)
    nees: list[float] = field(default_factory=list)

    def add(self, nav: Navigator, truth: Truth) -> dict[str, float]:
        """Score the variant's estimate now against ``truth``; returns this sample's errors."""
        est = nav.estimate()
        c_true = quat_to_dcm(truth.quat_wxyz)
        e_h = float(wrap_deg180(est.heading_deg - truth.heading_deg))
        e_r = math.degrees(wrap_pi(est.roll - truth.roll_rad))
        e_p = math.degrees(wrap_pi(est.pitch - truth.pitch_rad))
        east, north = nav.local_en(est)
        e_pos = math.hypot(east - float(truth.position_n[0]), north - float(truth.position_n[1]))
        phi = attitude_error(est.c_bn, c_true)
        p = est.covariance[:3, :3]
        try:
            nees = float(phi @ np.linalg.solve(p, phi))
        except np.linalg.LinAlgError:
            nees = math.inf
        self.t.append(truth.t)
        self.heading_err.append(e_h)
        self.heading_sigma.append(est.heading_sigma_deg)
        self.roll_err.append(e_r)
        self.pitch_err.append(e_p)
        self.pos_err.append(e_pos)
        self.nees.append(nees)
        return {
            "east_m": east,
            "north_m": north,
            "roll_deg": math.degrees(est.roll),
            "pitch_deg": math.degrees(est.pitch),
            "heading_deg": est.heading_deg,
            "heading_err_deg": e_h,
            "heading_sigma_deg": est.heading_sigma_deg,
            "roll_err_deg": e_r,
            "pitch_err_deg": e_p,
            "position_err_m": e_pos,
            "nees": nees,
        }

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
