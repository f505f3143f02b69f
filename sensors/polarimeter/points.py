"""Unresolved points in the polarimeter's view: bubbles under breaking seas and marine snow.

:class:`PointScatterers` is the part of :class:`~sensors.polarimeter.render.Polarimeter` that
draws each frame's bubbles (:mod:`~sensors.polarimeter.optics.bubbles`) and aggregates
(:mod:`~sensors.polarimeter.optics.particles`) and adds them to their pixels (its ``optics``,
``tank``, ``camera``, ``n_water``, ``_column``, ``_caustics``, ``_photon_scale``, the two point
streams and ``_omega_out``), as :class:`~sensors.polarimeter.fast_path.FastPath` is the fast path.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sensors.polarimeter.optics import bubbles as bubbles_mod
from sensors.polarimeter.optics import particles as particles_mod
from sensors.polarimeter.optics import surface as surface_mod
from twin.core.arrays import FloatArray

# The marine snow's population (a frozen dataclass: checked once, not per frame).
_MARINE_SNOW = particles_mod.MarineSnow()


class PointScatterers:
    """Bubbles and marine snow, drawn and added per frame (module docstring)."""

    # Set by the Polarimeter (declared here for the reader and the type checker).
    optics: Any
    tank: Any
    camera: Any
    n_water: float
    _column: Any
    _caustics: Any
    _photon_scale: float
    _bubble_rng: np.random.Generator | None
    _particle_rng: np.random.Generator | None
    _omega_out: tuple[float, NDArray[np.float64]] | None

    def _bubbles(self) -> bubbles_mod.BubblePopulation | None:
        """This sea's bubble population, or None (ideal, a flat sea, or a tank: no breakers)."""
        o = self.optics
        if o.bubbles == "ideal" or o.wind_speed_mps <= 0.0 or self.tank is not None:
            return None
        return bubbles_mod.BubblePopulation(o.wind_speed_mps)

    def _particles(self) -> particles_mod.MarineSnow | None:
        """The water's marine snow, or None (ideal, or a tank: tap water and milk have none)."""
        if self.optics.particles == "ideal" or self.tank is not None:
            return None
        return _MARINE_SNOW

    def _add_points(
        self,
        st: FloatArray,
        occluded: NDArray[np.bool_],
        c_cn: NDArray[np.float64],
        depth_m: float,
        sun: Any,
        kind: str,
    ) -> int:
        """Draw this frame's bubbles or aggregates; add each to its pixel's S0 (photons/s).

        An unresolved point of intensity I at range r reads as the radiance I/(r² Ω) in a pixel
        of solid angle Ω (outside the housing; :mod:`sensors.polarimeter.optics.bubbles`).
        Unpolarized:
        S1 = S2 = 0 in any basis. Points on occluded pixels are dropped (the hull's shadow and
        what lies behind it are not known). Returns how many were added.
        """
        sources = self._point_sources(depth_m, sun, kind)
        if sources is None:
            return 0
        draw, intensity, r = sources
        dirs = (draw.offsets_m / r[:, None]) @ c_cn  # ENU → camera frame (rows: c_cnᵀ d)
        cam = self.camera
        # Only the points within the lens's field are projected (about half of them): one more
        # than θ_max off the axis in the water is more than that behind the port too (a flat
        # port bends a ray from water into air away from the axis), so it misses every pixel.
        lim = cam.theta_max + 0.01  # 0.01 rad beyond the field: a margin for rounding only
        if lim < math.pi:
            near = np.flatnonzero(dirs[:, 2] > math.cos(lim))
            dirs = dirs[near]
        else:
            near = np.arange(dirs.shape[0])
        u, v, ok = cam.project_outside(dirs, self.n_water)
        h, w = cam.shape
        col = np.rint(np.asarray(u)).astype(np.int64)
        row = np.rint(np.asarray(v)).astype(np.int64)
        ok = np.asarray(ok) & (col >= 0) & (col < w) & (row >= 0) & (row < h)
        ok &= intensity[near] > 0
        sel = near[ok]
        pix = row[ok] * w + col[ok]  # flat pixel indices: one gather each below
        shown = ~occluded.reshape(-1)[pix]
        sel, pix = sel[shown], pix[shown]
        omega = self._outside_solid_angle().reshape(-1)[pix]
        r = r[sel]
        add = intensity[sel] / (r * r * omega) * self._photon_scale
        flat = st[..., 0].reshape(-1)
        np.add.at(flat, pix, add.astype(np.float32))
        return int(sel.size)

    def _point_sources(
        self, depth_m: float, sun: Any, kind: str
    ) -> tuple[bubbles_mod.BubbleDraw, NDArray[np.float64], NDArray[np.float64]] | None:
        """This frame's bubbles or aggregates: the draw, each one's intensity and range; or None."""
        if kind == "bubbles":
            pop: Any = self._bubbles()
            stream, g, albedo = self._bubble_rng, bubbles_mod.HG_G, 1.0
        else:
            pop = self._particles()
            stream, g, albedo = self._particle_rng, particles_mod.HG_G, particles_mod.ALBEDO
        if pop is None or depth_m <= 0.0 or stream is None:
            return None
        draw = pop.draw(depth_m, stream)
        if draw.radii_m.size == 0:
            return None
        sun_enu = np.asarray(getattr(sun, "direction_enu", sun), dtype=np.float64).reshape(3)
        beam = surface_mod.refract_sun_beam(sun_enu, self.n_water)
        sky = self.optics.sky
        e_sun = sky.sun_disc_radiance * math.pi * sky.sun_radius_rad**2 * beam.irradiance_factor
        assert self._column is not None
        intensity, r = bubbles_mod.bubble_radiance(
            draw, beam.look_dir, e_sun, self._column.water.c_per_m, g=g, albedo=albedo
        )
        if self._caustics is not None:  # the beam's caustics light the points too
            cf, (x0, y0) = self._caustics
            off = draw.offsets_m
            intensity = intensity * cf.factor_at(x0 + off[:, 0], y0 + off[:, 1], draw.depths_m)
        return draw, intensity, r

    def _outside_solid_angle(self) -> NDArray[np.float64]:
        """(H, W) each pixel's solid angle in the water, outside the housing.

        A dome leaves the lens's rays unbent. Through a flat port the étendue n² cos θ dΩ is
        conserved: Ω_out = Ω_lens cos θ_lens / (n² cos θ_out).
        """
        cam = self.camera
        if self._omega_out is None or self._omega_out[0] != self.n_water:
            sa = cam.pixel_solid_angle_sr.astype(np.float64)
            if cam.spec.housing == "flat":
                port = cam.outside(self.n_water)
                cos_l = np.abs(cam.rays[..., 2].astype(np.float64))
                cos_o = np.abs(port.directions[..., 2].astype(np.float64))
                sa = sa * cos_l / np.maximum(self.n_water**2 * cos_o, 1e-9)
            self._omega_out = (self.n_water, np.maximum(sa, 1e-12))
        return self._omega_out[1]
