"""Caustics: the sun beam focused by the waves into the flickering net a diver sees.

World side. Each wave facet refracts the sun's beam its own way, so under a rough sea the beam's
irradiance is no longer uniform at depth: the facets' rays converge into bright filaments and
leave dark cells between them, and the pattern moves as the waves do. The camera sees this as
flicker of the water's sun-lit path radiance (and of the bubbles the beam lights), not of the
sky it sees through Snell's window, whose wobble the wavy surface already gives.

**Model: geometric optics on the twin's own wave field.** A regular lattice of entry points p
(``oversample``² per cell of :class:`~sensors.polarimeter.optics.waves.WaveSurface`'s periodic
grid)
carries equal shares of the beam's flux through the mean surface (the flux through a horizontal
area is E cos θ_sun whatever the facet's tilt), weighted by each facet's Fresnel transmittance.
Each share is refracted by its facet's normal into t(p) and lands at depth z at
q = p + z t_h/|t_z|. Spreading the shares over the grid at each tabulated depth by
cloud-in-cell (periodic) and dividing by the flat sea's gives F(x, y, z), the irradiance relative
to a flat sea's; F has a mean of 1 over the grid at every depth (the mean transmitted flux is the
flat sea's within a few per cent, which the column's own wave tables carry; here only the
pattern). Multiple facets focusing on one point (beyond the first caustic) are summed, as the
flux counting does by itself. The regular lattice has no Poisson noise: with a flat sea every
cell receives the same share exactly.

Limits (those of the slope field, ``waves.WaveSurface``): slopes only (no elevation), Gaussian
statistics, decimetre correlation length (a modelling choice there, and the caustics' scale
follows it), no travelling waves. Rays are straight below the surface (the beam's own
scattering blurs caustics with depth in real water; not modelled, so deep flicker is an upper
bound). The sun's disc (0.53°) blurs the pattern by z·0.0093/n, under a cell (7.5 cm) to 8 m;
ignored.

**Along a camera ray.** The single-scattered sun light a pixel receives is the integral along
its ray of β(Θ) E(s) e^(−c s) ds with E ∝ e^(−c z(s)/μ_s) F(s): the pixel's flicker factor is the
weighted mean of F along the ray (:meth:`CausticField.ray_factor`, Gauss–Legendre in s). The
multiply-scattered light is left as it is: it has crossed many caustic cells.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from sensors.polarimeter.optics import surface as surface_mod
from sensors.polarimeter.optics import waves as waves_mod
from twin.core import options

FlickerModel = Literal["caustics", "ideal"]
FLICKER_MODELS = options.FLICKER_MODELS  # declared in twin.core.options (the scenario offers it)

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(8)


class CausticField:
    """F(x, y, z): the refracted sun beam's irradiance under the waves relative to a flat sea.

    Args:
        waves: The sea's slope field at this frame.
        sun_enu: (3,) unit ENU direction towards the sun in air (above the horizon).
        n_water: Water index.
        max_depth_m: Deepest tabulated level (deeper points take its pattern).
        levels: Number of depth levels from 0 to ``max_depth_m``.
        oversample: Entry points per grid cell per axis.
    """

    def __init__(
        self,
        waves: waves_mod.WaveSurface,
        sun_enu: NDArray[np.float64],
        n_water: float,
        max_depth_m: float,
        *,
        levels: int = 24,
        oversample: int = 4,
    ) -> None:
        if not (math.isfinite(max_depth_m) and max_depth_m > 0):
            raise ValueError(f"max_depth_m: {max_depth_m!r}; allowed: > 0 m")
        if levels < 2 or oversample < 1:
            raise ValueError(f"levels >= 2 and oversample >= 1, got {levels!r}, {oversample!r}")
        sea = waves.sea
        g, h = sea.grid_size, sea.cell_m
        self.grid_size, self.cell_m = g, h
        self.period_m = g * h
        self.depths_m = np.linspace(0.0, float(max_depth_m), levels)
        s = np.asarray(sun_enu, dtype=np.float64).reshape(3)
        m = g * oversample
        # Entry points at the centres of an m × m lattice over the periodic grid.
        c = (np.arange(m) + 0.5) * (self.period_m / m)
        px, py = np.meshgrid(c, c, indexing="ij")
        normals = waves_mod.slopes_to_normals(waves.slopes_at(px, py).astype(np.float64))
        d_in = np.broadcast_to(-s, normals.shape)
        ref = surface_mod.refract(d_in, normals, 1.0, n_water)
        t = ref.directions
        down = np.maximum(-t[..., 2], 1e-3)
        dx, dy = t[..., 0] / down, t[..., 1] / down
        # Fresnel flux transmittance of each facet (a facet the beam grazes or misses: 0).
        wt = surface_mod.fresnel_elements(np.clip(ref.cos_i, 0.0, 1.0), 1.0, n_water, "flux").m00
        wt = np.where(ref.transmitted, wt, 0.0).ravel()
        self._mean_displacement = (float(np.mean(dx)), float(np.mean(dy)))
        fields = np.empty((levels, g, g))
        for k, z in enumerate(self.depths_m):
            fields[k] = self._splat((px + z * dx).ravel(), (py + z * dy).ravel(), wt)
        self.fields = fields

    def _splat(self, x: NDArray, y: NDArray, wt: NDArray) -> NDArray[np.float64]:
        """Cloud-in-cell of weighted points onto the periodic grid, normalised to a mean of 1."""
        g, h = self.grid_size, self.cell_m
        fx, fy = x / h - 0.5, y / h - 0.5  # cell centres at (i + 0.5) h
        i0, j0 = np.floor(fx), np.floor(fy)
        tx, ty = fx - i0, fy - j0
        i0 = i0.astype(np.int64) % g
        j0 = j0.astype(np.int64) % g
        i1, j1 = (i0 + 1) % g, (j0 + 1) % g
        out = np.zeros(g * g)
        for ii, jj, w in (
            (i0, j0, (1 - tx) * (1 - ty)),
            (i1, j0, tx * (1 - ty)),
            (i0, j1, (1 - tx) * ty),
            (i1, j1, tx * ty),
        ):
            out += np.bincount(ii * g + jj, weights=w * wt, minlength=g * g)
        mean = out.mean()
        return (out / mean if mean > 0 else np.ones(g * g)).reshape(g, g)

    def factor_at(self, east_m: NDArray, north_m: NDArray, depth_m: NDArray) -> NDArray:
        """F at points (any shape): bilinear in the periodic plane, linear in depth."""
        g, h = self.grid_size, self.cell_m
        fx = np.asarray(east_m, dtype=np.float64) / h - 0.5
        fy = np.asarray(north_m, dtype=np.float64) / h - 0.5
        i0, j0 = np.floor(fx), np.floor(fy)
        tx, ty = fx - i0, fy - j0
        i0 = i0.astype(np.int64) % g
        j0 = j0.astype(np.int64) % g
        i1, j1 = (i0 + 1) % g, (j0 + 1) % g
        zs = self.depths_m
        fz = np.clip(np.asarray(depth_m, dtype=np.float64), 0.0, zs[-1]) / (zs[1] - zs[0])
        k0 = np.minimum(np.floor(fz).astype(np.int64), zs.size - 2)
        tz = fz - k0
        out = np.zeros(np.shape(fx))
        f = self.fields
        for kk, wz in ((k0, 1 - tz), (k0 + 1, tz)):
            out += wz * (
                f[kk, i0, j0] * (1 - tx) * (1 - ty)
                + f[kk, i1, j0] * tx * (1 - ty)
                + f[kk, i0, j1] * (1 - tx) * ty
                + f[kk, i1, j1] * tx * ty
            )
        return out

    def ray_factor(
        self,
        look_enu: NDArray,
        camera_east_north_m: tuple[float, float],
        depth_m: float,
        sun_look: NDArray[np.float64],
        c_per_m: float,
    ) -> NDArray[np.float64]:
        """Each ray's flicker factor: the mean of F along it, weighted as its sun-lit path is.

        Args:
            look_enu: (N, 3) unit ENU look directions from the camera.
            camera_east_north_m: Camera East, North (m).
            depth_m: Camera depth (> 0).
            sun_look: (3,) ENU direction towards the refracted sun (in water).
            c_per_m: Beam attenuation c (> 0).

        Returns:
            (N,) factors (1 = the flat sea's light).
        """
        w = np.asarray(look_enu, dtype=np.float64)
        mu = max(float(np.asarray(sun_look)[2]), 1e-3)
        wz = w[:, 2]
        # Along s the weight is exp(−c s − c z(s)/μ) with z(s) = depth − s w_z: rate k.
        k = c_per_m * (1.0 - wz / mu)
        up = wz > 1e-3
        s_surface = np.where(up, depth_m / np.maximum(wz, 1e-3), np.inf)
        # Integrate to the surface, or over ~4 e-foldings of the weight where it decays first.
        k_pos = np.maximum(k, 0.25 * c_per_m)
        s_max = np.minimum(s_surface, 4.0 / k_pos)
        s = 0.5 * s_max[:, None] * (_NODES[None, :] + 1.0)  # (N, 8)
        wt = _WEIGHTS[None, :] * np.exp(-k[:, None] * s)
        x0, y0 = camera_east_north_m
        f = self.factor_at(x0 + s * w[:, :1], y0 + s * w[:, 1:2], depth_m - s * w[:, 2:3])
        return np.sum(wt * f, axis=1) / np.sum(wt, axis=1)


__all__ = ["FLICKER_MODELS", "CausticField", "FlickerModel"]
