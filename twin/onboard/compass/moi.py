"""Liang et al. 2020: the moment-of-inertia (MOI) skylight compass and its two baselines.

The registered compass methods ``"moi"``, ``"patz"`` and ``"ht"``: a raw frame → Stokes → the
solar–antisolar meridian of the AoP image (:mod:`twin.onboard.compass.moi_axis`, the paper's
three methods, their geometry and the sun / anti-sun decision) → a compass fix.

Only the azimuth is measured; the solar vector's elevation is the ephemeris elevation, and the
roll/pitch hint only expresses the horizontal vector in the body frame (the method itself assumes
a level camera; beyond ``max_tilt_rad`` there is no fix).

Speed: ``benchmarks/results/compass_timing.md`` (the camera's frame); on the paper's 2048×2448
AoP image each trial of the ``moi_noise`` campaign records its ``solve_s`` per method.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from twin.core.calibration import CameraCalibration
from twin.onboard.compass.base import (
    CompassFix,
    CompassMethod,
    Frame,
    finish_fix,
    no_fix,
)
from twin.onboard.compass.moi_axis import (  # noqa: F401  (re-exported)
    AxisEstimate,
    Grid,
    Liang2020Config,
    MethodName,
    _Geometry,
    _geometry,
    abs_aoplm,
    estimate_axis,
    rayleigh_abs_aoplm,
    resolve_sun_side,
)
from twin.onboard.lens import compensate_grid
from twin.onboard.polarization import stokes_from_mosaic

# ---- the CompassMethod wrappers -----------------------------------------------------------------


def _intensity_side(
    s0: NDArray[np.float32], usable: NDArray[np.bool_], g: _Geometry, axis: float
) -> tuple[float, float]:
    """(sun azimuth, relative contrast): the brighter half of P' (split ⟂ the SM-ASM)."""
    ii, jj = np.nonzero(usable)
    x = (jj - g.j0) * g.scale
    y = -(ii - g.i0) * g.scale
    along = x * math.sin(axis) + y * math.cos(axis)
    vals = s0[ii, jj].astype(np.float64)
    fwd, back = vals[along > 0], vals[along < 0]
    if fwd.size == 0 or back.size == 0:
        return axis, 0.0
    a, b = float(fwd.mean()), float(back.mean())
    contrast = abs(a - b) / max(a + b, 1e-300)
    return (axis if a >= b else axis + math.pi) % (2 * math.pi), contrast


class _Liang2020(CompassMethod):
    """Shared ``solve_frame``: raw mosaic → Stokes → AoP-level estimate → CompassFix."""

    config_type = Liang2020Config

    def estimate(
        self,
        aop: NDArray[np.floating],
        calibration: CameraCalibration,
        **kwargs: object,
    ) -> AxisEstimate:
        """:func:`estimate_axis` with this method and config."""
        return estimate_axis(self.name, aop, calibration, config=self.config, **kwargs)  # type: ignore[arg-type]

    def solve_frame(self, frame: Frame) -> CompassFix:
        cfg = self.config
        raw, calibration, ctx, sun_enu = frame.raw, frame.calibration, frame.ctx, frame.sun_enu
        elev = frame.sun_elevation_rad
        if elev < cfg.min_sun_elevation_rad:
            return no_fix(self.name, f"sun {math.degrees(elev):.1f}° below the usable elevation")
        # The optical axis in the horizontal frame: the paper's methods assume it at the zenith.
        c_h_c = ctx.c_b_h @ calibration.c_c_b
        tilt = math.acos(max(-1.0, min(1.0, float(c_h_c[2, 2]))))
        if tilt > cfg.max_tilt_rad:
            return no_fix(
                self.name,
                f"camera {math.degrees(tilt):.1f}° off the zenith; the method needs it pointing up",
            )
        kind = cfg.stokes_method
        pol = stokes_from_mosaic(
            raw,
            layout_deg=calibration.layout_deg,
            method=kind,
            saturation_dn=calibration.saturation_dn,
        )
        if calibration.lens_table:
            pol = compensate_grid(pol, calibration, kind)
        mask = (
            ~pol.saturated
            & (pol.s0 > np.float32(cfg.min_s0_dn))
            & (pol.dop >= np.float32(cfg.min_dop))
        )
        est = self.estimate(pol.aop, calibration, kind=kind, mask=mask, sun_elevation_rad=elev)
        if not est.ok:
            return no_fix(self.name, est.reason, est.pixels_used)
        assert est.sun_azimuth_rad is not None
        sun_az, source = est.sun_azimuth_rad, 0.0
        if est.side_margin < cfg.min_side_margin:
            # Sun near the horizon: the AoP cannot tell sun from anti-sun; the circumsolar sky can.
            g = _geometry(calibration, kind, cfg.radius_px)
            sun_az, contrast = _intensity_side(pol.s0, g.disc & mask, g, est.axis_rad)
            source = 1.0
            if contrast < cfg.min_intensity_contrast:
                return no_fix(
                    self.name,
                    "sun/anti-sun ambiguity unresolved (sun near the horizon, flat intensity)",
                    est.pixels_used,
                )
        # The measured azimuth is in the camera's image plane, level by assumption: carry the
        # direction to the horizontal frame, put the ephemeris elevation on it.
        d_c = np.array([math.sin(sun_az), math.cos(sun_az), 0.0])
        d_h = c_h_c @ d_c
        d_h[2] = 0.0
        d_h /= np.linalg.norm(d_h)
        ce, se = math.cos(elev), math.sin(elev)
        sun_h = np.array([ce * d_h[0], ce * d_h[1], se])
        t_az = np.array([-d_h[1], d_h[0], 0.0])
        t_el = np.cross(sun_h, t_az)
        cov_h = (est.sigma_rad * ce) ** 2 * np.outer(
            t_az, t_az
        ) + cfg.elevation_sigma_rad**2 * np.outer(t_el, t_el)
        c_b_h = ctx.c_b_h
        sun_body = c_b_h.T @ sun_h
        cov_body = c_b_h.T @ cov_h @ c_b_h
        return finish_fix(
            self.name,
            sun_body,
            ctx,
            sun_enu,
            cov_body,
            pixels_used=est.pixels_used,
            residual=est.residual,
            eigen_gap=est.eigen_gap,
            axis_rad=est.axis_rad,
            side_margin=est.side_margin,
            side_from_intensity=source,
            model_rms_rad=est.model_rms_rad,
            tilt_rad=tilt,
            **est.extras,
        )


class MoiCompass(_Liang2020):
    """Moment-of-inertia symmetry axis of the |AOPLM| image (liang2020 §2, eqs. 1–8)."""

    name = "moi"


class PatzCompass(_Liang2020):
    """Polarization at the zenith (liang2020 §4, its refs. 23–28)."""

    name = "patz"


class HoughCompass(_Liang2020):
    """Hough transform of the SM-ASM band (liang2020 §4, Lu et al. 2015)."""

    name = "ht"
