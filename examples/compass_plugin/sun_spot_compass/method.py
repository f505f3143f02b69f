"""The sun-spot compass: the refracted sun is the brightest spot in Snell's window.

The oldest skylight compass there is, and the simplest: where the sun stands clear of the sea
surface, its refracted disc is the brightest thing the upward camera sees. The method takes the
brightest ``top_fraction`` of the super-pixels inside the image circle, weighs their rays by
intensity, levels the mean ray with the INS's roll and pitch, undoes the refraction at a flat sea
(Snell: the azimuth stays, sin θ_air = n sin θ_water) and hands the solar vector on like every
other method (a heading through the ephemeris, a covariance from the spot's spread).

It uses no polarization at all: the comparison with LIG and POL (``compare.toml``) shows what
polarization buys under water, where the sun's spot is blurred by scattering and waves.

Written against auv-twin's public API only: ``CompassMethod`` (one ``solve_frame``), the frame
prologue's checked inputs, ``finish_fix``; ``stokes_from_mosaic`` and the calibration's rays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twin.onboard.compass import CompassFix, CompassMethod, no_fix
from twin.onboard.compass.base import Frame, finish_fix
from twin.onboard.polarization import stokes_from_mosaic


@dataclass(frozen=True)
class SunSpotConfig:
    """The method's parameters (``[navigation.methods.sun_spot]`` in a scenario).

    Attributes:
        top_fraction: Share of the image circle's super-pixels, the brightest, that make the
            spot (0 < f ≤ 0.1).
        min_contrast: The spot's mean over the image circle's median; below it there is no
            spot to track (overcast, deep or turbid water): no fix.
    """

    top_fraction: float = 0.002
    min_contrast: float = 3.0

    def __post_init__(self) -> None:
        if not (isinstance(self.top_fraction, int | float) and 0 < self.top_fraction <= 0.1):
            raise ValueError(
                f"SunSpotConfig.top_fraction: {self.top_fraction!r}; allowed: (0, 0.1]"
            )
        if not (isinstance(self.min_contrast, int | float) and self.min_contrast >= 1):
            raise ValueError(f"SunSpotConfig.min_contrast: {self.min_contrast!r}; allowed: >= 1")


class SunSpotCompass(CompassMethod):
    """The brightest spot in Snell's window, refracted back into the sky: a solar vector."""

    name = "sun_spot"
    config_type = SunSpotConfig

    def solve_frame(self, frame: Frame) -> CompassFix:
        cfg = self.config
        cal, ctx = frame.calibration, frame.ctx
        img = stokes_from_mosaic(frame.raw, cal.layout_deg, black_level_dn=cal.black_level_dn)
        rays, valid = cal.rays("superpixel")
        s0 = np.asarray(img.s0, dtype=np.float64)[valid]
        r = rays[valid]
        n = max(round(cfg.top_fraction * s0.size), 1)
        top = np.argpartition(s0, -n)[-n:]
        spot = float(s0[top].mean())
        floor = float(np.median(s0))
        if not (spot > cfg.min_contrast * max(floor, 1e-9)):
            return no_fix(self.name, f"no sun spot: contrast {spot / max(floor, 1e-9):.2f}", n)
        w = s0[top] / s0[top].sum()
        look_c = (w[:, None] * r[top]).sum(axis=0)  # towards the refracted sun, camera frame
        look_b = cal.c_c_b @ look_c
        look_h = ctx.c_b_h @ (look_b / np.linalg.norm(look_b))
        # Undo the refraction at a flat sea: azimuth kept, sin θ_air = n sin θ_water.
        sin_w = math.hypot(look_h[0], look_h[1])
        if look_h[2] <= 0 or ctx.water_index * sin_w >= 1.0:
            return no_fix(self.name, "the spot lies outside Snell's window", n)
        if ctx.depth_m > 0:
            sin_a = ctx.water_index * sin_w
            scale = sin_a / sin_w if sin_w > 0 else 0.0
            sun_h = np.array([look_h[0] * scale, look_h[1] * scale, math.sqrt(1 - sin_a**2)])
        else:
            sun_h = look_h
        sun_body = ctx.c_b_h.T @ sun_h
        # The spot's angular spread as the direction's 1σ: its pixels are not independent
        # samples (one blurred disc), so the spread itself, not the spread over √n; at least
        # 0.5°, the disc's own radius at the scale of a binned pixel.
        spread = float(np.sqrt(w @ np.sum((r[top] - look_c) ** 2, axis=1)))
        sigma = max(spread, math.radians(0.5))
        cov = sigma**2 * np.eye(3)
        return finish_fix(self.name, sun_body, ctx, frame.sun_enu, cov, pixels_used=n)
