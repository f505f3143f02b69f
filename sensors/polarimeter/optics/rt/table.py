"""The light-field table: the reference, tabulated over sun zenith and depth, for the renderer.

For one water body (a, b_w, b_p, b_bp/b_p at one wavelength; the optical depth c z and the
single-scattering albedo b/c follow from them) the table holds, from
:func:`sensors.polarimeter.optics.rt.reference.solve`:

* ``sun``: the **multiply scattered** Stokes radiance of the refracted sun beam (everything but the
  direct beam and the closed-form single scattering the renderer computes itself), per unit
  downwelling plane irradiance of the beam just below the surface, at in-water sun zeniths
  ``sun_zenith_water_deg`` × planes × look-direction bins;
* ``sky_uniform``: all the scattered light of a uniform unpolarized sky (per unit plane irradiance
  below the surface; azimuthally symmetric, so (planes, look zenith) only), for a night sky;
* the downwelling irradiances at the planes (for depth interpolation) and the standard error of
  the sun field's radiance;

and, per sky model, all the scattered light of the sky model's own sky at the same sun nodes
(:mod:`sensors.polarimeter.optics.rt.sky_table`). The renderer's direct sky light is exact; its
scattered
part comes from there. (Replacing the sky by a uniform unpolarized one of the same irradiance, as
this table did before, dilutes the window's polarization: at 2 m in Jerlov II the scattered sky
light inside the window has a flux-weighted DoP of 0.22 from the Rayleigh sky, 0.015 from the
uniform one.)

Per frame, :meth:`LightFieldTable.frame` interpolates to the frame's sun zenith (linear) and depth
(linear in the field normalised by E_d, E_d itself log-linear; past the deepest plane the shape is
held and E_d decays at the deepest planes' rate — the asymptotic regime), and returns a
:class:`FrameField` the per-pixel kernel samples bilinearly, never across Snell's window edge
(the upwelling light's total internal reflection makes a step there).

Tables for the Jerlov types (:data:`sensors.polarimeter.optics.water.JERLOV_500NM`, turbidity 1) and
the default sky (:class:`sensors.polarimeter.optics.sky.SkySpec`) ship in
``sensors/polarimeter/optics/data/lightfield_jerlov_500nm.npz``, built by
``python -m sensors.polarimeter.optics.rt.build``; any other water, or another sky, is computed on
first use (a minute or two on one core for most waters; a sky alone, a fraction of that) and
cached under ``$AUV_TWIN_CACHE`` (default ``~/.cache/auv-twin``).
"""

from __future__ import annotations

import bisect
import dataclasses
import functools
import math
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar, NamedTuple

import numpy as np
from numpy.typing import NDArray

from sensors.polarimeter.optics.rt import decompose, frame_kernel, poles, reference, store
from sensors.polarimeter.optics.rt.frame_field import NONE, FrameField
from sensors.polarimeter.optics.rt.frame_field import blend as blend
from sensors.polarimeter.optics.rt.grid import DATA_FILE as DATA_FILE
from sensors.polarimeter.optics.rt.grid import FIRST_USE_PHOTONS as FIRST_USE_PHOTONS
from sensors.polarimeter.optics.rt.grid import MODEL_VERSION as MODEL_VERSION
from sensors.polarimeter.optics.rt.grid import SHIPPED_PHOTONS as SHIPPED_PHOTONS
from sensors.polarimeter.optics.rt.grid import SUN_ZENITH_AIR_DEG as SUN_ZENITH_AIR_DEG
from sensors.polarimeter.optics.rt.grid import TABLE_INDEX as TABLE_INDEX
from sensors.polarimeter.optics.rt.grid import TABLE_PLANES as TABLE_PLANES
from sensors.polarimeter.optics.rt.grid import WIND_NODES_MPS as WIND_NODES_MPS
from sensors.polarimeter.optics.rt.grid import WaterKey as WaterKey
from twin.core.arrays import FloatArray

if TYPE_CHECKING:
    from sensors.polarimeter.optics.rt.sky_table import SkyTable


class _FrameGrid(NamedTuple):
    """:attr:`LightFieldTable._grid`: the bins' geometry as the per-frame look-up uses it."""

    n_in: int  # look-zenith bins inside Snell's window
    tc: float  # the window's edge (rad), a bin edge
    centres_in: FloatArray  # the inside bins' centres (rad)
    zenith_first: bool  # the first edge is the zenith
    nadir_last: bool  # the last edge is the nadir
    theta_in: FloatArray  # the padded inside rows' look zeniths (rad)
    theta_out: FloatArray  # … and the outside rows'
    phi: FloatArray  # the azimuth bins' centres (rad)


# No warp: :func:`frame_kernel.at`'s empty row and weight arrays.
_NO_ROWS = np.zeros(0, dtype=np.intp)
_NO_WEIGHTS = np.zeros(0, dtype=np.float64)


@dataclass(frozen=True)
class LightFieldTable:
    """Multiply scattered light of one water body over sun zenith and depth (module docstring)."""

    #: Interpolate a frame's fields in one compiled pass each (:mod:`.frame_kernel`); False:
    #: numpy (:meth:`_at_numpy`, the reference it equals bit for bit).
    compiled: ClassVar[bool] = True

    key: WaterKey
    sun_zenith_water_deg: FloatArray
    planes: FloatArray
    theta_edges_deg: FloatArray
    n_phi: int
    sun: FloatArray
    sun_se: FloatArray
    e_down_sun: FloatArray
    sky_uniform: FloatArray
    e_down_sky_uniform: FloatArray
    photons: int
    aureole: FloatArray
    aureole_se: FloatArray
    aureole_psi_edges_deg: FloatArray

    # ---- build, save, load -------------------------------------------------------------------
    @classmethod
    def build(
        cls, key: WaterKey, photons: int = FIRST_USE_PHOTONS, seed: int = 0, workers: int = 1
    ) -> LightFieldTable:
        """Run the reference for every sun node and the uniform sky (``workers`` processes)."""
        grid = reference.Grid(planes=TABLE_PLANES)
        jobs = [("sun", z) for z in SUN_ZENITH_AIR_DEG] + [("sky", 0.0)]
        seeds = np.random.SeedSequence(seed).spawn(len(jobs))
        args = [
            (key, src, z, grid, photons, int(s.generate_state(1)[0]), None)
            for (src, z), s in zip(jobs, seeds, strict=True)
        ]
        fields = store.run_jobs(args, workers)
        suns, sky = fields[:-1], fields[-1]
        return cls(
            key=key,
            sun_zenith_water_deg=np.array([f.sun_zenith_water_deg for f in suns]),
            planes=np.asarray(TABLE_PLANES, dtype=float),
            theta_edges_deg=np.asarray(grid.theta_edges_deg, dtype=float),
            n_phi=grid.n_phi,
            sun=np.stack([f.multiple for f in suns]).astype(np.float32),
            sun_se=np.stack([f.multiple_se[..., 0] for f in suns]).astype(np.float16),
            e_down_sun=np.stack([f.e_down for f in suns]),
            sky_uniform=sky.total.mean(axis=2).astype(np.float32),  # azimuthally symmetric
            e_down_sky_uniform=np.asarray(sky.e_down),
            photons=int(photons),
            aureole=np.stack([f.aureole for f in suns]).astype(np.float32),
            aureole_se=np.stack([f.aureole_se[..., 0] for f in suns]).astype(np.float32),
            aureole_psi_edges_deg=np.asarray(grid.aureole_psi_edges_deg, dtype=float),
        )

    def arrays(self, prefix: str = "") -> dict[str, np.ndarray]:
        """The table as named arrays (for ``np.savez``)."""
        k = self.key
        return {
            f"{prefix}key": np.array(
                [
                    k.a_per_m,
                    k.b_molecular_per_m,
                    k.b_particle_per_m,
                    k.particle_backscatter_ratio,
                    k.wind_speed_mps,
                    k.particle_dop_max,
                    k.depolarization_ratio,
                ]
            ),
            f"{prefix}sun_zenith_water_deg": self.sun_zenith_water_deg,
            f"{prefix}planes": self.planes,
            f"{prefix}theta_edges_deg": self.theta_edges_deg,
            f"{prefix}n_phi": np.array(self.n_phi),
            # Per unit E_d of its plane, the field spans a few decades: float16 keeps 3 digits
            # (the Monte Carlo error is ~3 %) in half the bytes.
            f"{prefix}sun_per_ed": store.per_ed(self.sun, self.e_down_sun[:, :, None, None, None]),
            f"{prefix}sun_se_per_ed": store.per_ed(self.sun_se, self.e_down_sun[:, :, None, None]),
            f"{prefix}e_down_sun": self.e_down_sun,
            f"{prefix}sky": self.sky_uniform,
            f"{prefix}e_down_sky": self.e_down_sky_uniform,
            f"{prefix}photons": np.array(self.photons),
            f"{prefix}aureole_per_ed": store.per_ed(
                self.aureole, self.e_down_sun[:, :, None, None, None], np.float32
            ),
            f"{prefix}aureole_se_per_ed": store.per_ed(
                self.aureole_se, self.e_down_sun[:, :, None, None], np.float32
            ),
            f"{prefix}aureole_psi_edges_deg": self.aureole_psi_edges_deg,
        }

    @classmethod
    def from_arrays(
        cls, d: dict[str, np.ndarray] | np.lib.npyio.NpzFile, prefix: str = ""
    ) -> LightFieldTable:
        """Inverse of :meth:`arrays`."""
        ed = np.asarray(d[f"{prefix}e_down_sun"], dtype=float)
        return cls(
            key=WaterKey.from_array(d[f"{prefix}key"]),
            sun_zenith_water_deg=np.asarray(d[f"{prefix}sun_zenith_water_deg"], dtype=float),
            planes=np.asarray(d[f"{prefix}planes"], dtype=float),
            theta_edges_deg=np.asarray(d[f"{prefix}theta_edges_deg"], dtype=float),
            n_phi=int(d[f"{prefix}n_phi"]),
            sun=np.nan_to_num(
                np.asarray(d[f"{prefix}sun_per_ed"], dtype=np.float32) * ed[:, :, None, None, None]
            ),
            sun_se=np.nan_to_num(
                np.asarray(d[f"{prefix}sun_se_per_ed"], dtype=np.float32) * ed[:, :, None, None]
            ),
            e_down_sun=ed,
            sky_uniform=np.asarray(d[f"{prefix}sky"], dtype=np.float32),
            e_down_sky_uniform=np.asarray(d[f"{prefix}e_down_sky"], dtype=float),
            photons=int(d[f"{prefix}photons"]),
            aureole=np.nan_to_num(
                np.asarray(d[f"{prefix}aureole_per_ed"], dtype=np.float32)
                * ed[:, :, None, None, None]
            ),
            aureole_se=np.nan_to_num(
                np.asarray(d[f"{prefix}aureole_se_per_ed"], dtype=np.float32) * ed[:, :, None, None]
            ),
            aureole_psi_edges_deg=np.asarray(d[f"{prefix}aureole_psi_edges_deg"], dtype=float),
        )

    @functools.cached_property
    def _smooth(self) -> FloatArray:
        """The sun field, its rings at the poles made smooth (:func:`poles.smooth`)."""
        return poles.smooth(self.sun, self.n_phi)

    @functools.cached_property
    def aureole_grid(self) -> FloatArray:
        """(S, P, n_ψ + 2, n_ω + 2, 3) the aureole, tapered and padded for the kernel."""
        return decompose.pad_aureole(self.aureole, self.aureole_psi_edges_deg)

    @functools.cached_property
    def aureole_psi(self) -> FloatArray:
        """The padded aureole rows' angles from the refracted sun (radians)."""
        return decompose.aureole_rows(self.aureole_psi_edges_deg)

    @property
    def aureole_dom(self) -> float:
        """The aureole's position-angle bin width (radians)."""
        return math.pi / self.aureole.shape[3]

    @functools.cached_property
    def remainder(self) -> FloatArray:
        """The smoothed sun field less the aureole's and the reflection's bin means.

        (:mod:`sensors.polarimeter.optics.rt.decompose`; the reflection on a flat sea only.)
        Computed once per machine and table (:func:`store.derived`): about a second of numpy.
        """
        inputs = (
            self.key,
            self.sun,
            self.aureole,
            self.aureole_psi_edges_deg,
            self.theta_edges_deg,
            self.sun_zenith_water_deg,
            self.n_phi,
            tuple(self.planes),
        )
        return store.derived("remainder", inputs, self._remainder)

    def _remainder(self) -> FloatArray:
        """:attr:`remainder`, computed."""
        rem = poles.smooth(self.sun, self.n_phi).astype(np.float64)
        edges = self.theta_edges_deg
        sa = reference.Grid(
            planes=TABLE_PLANES, theta_edges_deg=tuple(edges.tolist()), n_phi=self.n_phi
        ).solid_angle_mu()
        for i, th in enumerate(self.sun_zenith_water_deg):
            binner = decompose.AureoleBinner(
                math.radians(float(th)),
                self.aureole_psi_edges_deg,
                self.aureole.shape[3],
                edges,
                self.n_phi,
                sa,
            )
            for k in range(len(self.planes)):
                rem[i, k] -= binner.mean(
                    self.aureole_grid[i, k], self.aureole_psi, self.aureole_dom
                )
        # The nodes' suns in air, from the table's own refracted suns (Snell at its index).
        air = [
            math.degrees(math.asin(min(TABLE_INDEX * math.sin(math.radians(float(t))), 1.0)))
            for t in self.sun_zenith_water_deg
        ]
        beams = [decompose.beam_terms(self.key, z, TABLE_INDEX) for z in air]
        rem = remainder_of(rem, self.key, beams=beams)
        rem = poles.smooth(rem, self.n_phi, REMAINDER_POLE_ROWS)
        return decompose.conserve(rem, edges, _n_inside(edges)).astype(np.float32)

    @functools.cached_property
    def sky_uniform_nodes(self) -> FloatArray:
        """:attr:`sky_uniform` as node values that conserve its bin means (night sky)."""
        edges = self.theta_edges_deg
        out = decompose.conserve(self.sky_uniform[:, :, None, :], edges, _n_inside(edges))
        return out[:, :, 0, :].astype(np.float32)

    # ---- per frame -----------------------------------------------------------------------------
    def frame(
        self,
        sun_zenith_water_rad: float,
        tau_c: float,
        e_sun_plane: float,
        e_sky_plane: float,
        n_water: float = TABLE_INDEX,
        sky: SkyTable | None = None,
    ) -> FrameField:
        """The scattered-light grid of one frame.

        Args:
            sun_zenith_water_rad: Zenith of the refracted sun in this frame's water.
            tau_c: The camera's optical depth c z (>= 0).
            e_sun_plane: Downwelling plane irradiance of the sun beam just below the surface.
            e_sky_plane: Downwelling plane irradiance of the sky just below the surface.
            n_water: This frame's index: the sun zenith is mapped to the table's water by the
                ratio of the critical angles, so that a grazing sun stays grazing.
            sky: The sky model's table
                (:func:`~sensors.polarimeter.optics.rt.sky_table.sky_table_for`);
                None: the uniform unpolarized
                sky (a night sky).
        """
        i, f = self._node(sun_zenith_water_rad, n_water)
        sun_t = self.remainder
        flat = self.key.wind_speed_mps == 0.0
        zn = self._sun_zenith_rad
        th_frame = (1.0 - f) * zn[i] + f * zn[i + 1]
        # Each node's warp (rows and weights) depends on the frame's sun only: once per frame.
        warps = None
        if 0.0 < f < 1.0:
            warps = (
                self._warp_rows(float(zn[i]), th_frame),
                self._warp_rows(float(zn[i + 1]), th_frame),
            )

        def at(tab: FloatArray, ed: FloatArray, tau: float, warp: bool = True) -> FloatArray:
            w = warps if warp else None
            ca, cb = self._depth_coefs(ed[i], tau), self._depth_coefs(ed[i + 1], tau)
            if ca is None or cb is None or not self.compiled:  # past the deepest plane: numpy
                return self._at_numpy(tab, ed, tau, i, f, w)
            out = np.empty(tab.shape[2:], dtype=np.float64)
            (ka, ta), (kb, tb) = w if w is not None else ((_NO_ROWS, _NO_WEIGHTS),) * 2
            frame_kernel.at(tab, i, ca, cb, ka, ta.reshape(-1), kb, tb.reshape(-1), f, out)
            return out

        sun = at(sun_t, self.e_down_sun, tau_c)
        up = e_sun_plane * at(sun_t, self.e_down_sun, 0.0) if flat else None
        if sky is None:
            # The night's uniform sky keeps its reflection in the bins (it is dim and smooth).
            sky_f = self._at_depth(self.sky_uniform_nodes, self.e_down_sky_uniform, tau_c)
            sky_f = sky_f[:, None, :]
        else:
            sky_t = sky.remainder
            sky_f = at(sky_t, sky.e_down, tau_c)
            if up is not None:
                up = up + e_sky_plane * at(sky_t, sky.e_down, 0.0)
        g = e_sun_plane * sun + e_sky_plane * sky_f
        field = self._pad(g.astype(np.float32))
        aur = e_sun_plane * at(self.aureole_grid, self.e_down_sun, tau_c, warp=False)
        gr = self._grid
        up_grid = (
            NONE
            if up is None
            else self._pad_rows(up.astype(np.float32)[gr.n_in :], False, gr.nadir_last)
        )
        return dataclasses.replace(
            field,
            aureole=np.ascontiguousarray(aur, dtype=np.float32),
            aureole_psi=self.aureole_psi,
            aureole_dom=self.aureole_dom,
            up=up_grid,
        )

    @functools.cached_property
    def _grid(self) -> _FrameGrid:
        """The table's fixed geometry that every frame uses (computed once)."""
        edges = np.radians(np.asarray(self.theta_edges_deg, dtype=float))
        n_in = _n_inside(self.theta_edges_deg)
        thetas = []
        for e in (edges[: n_in + 1], edges[n_in:]):
            thetas.append(np.concatenate([[e[0]], 0.5 * (e[1:] + e[:-1]), [e[-1]]]))
        return _FrameGrid(
            n_in=n_in,
            tc=float(edges[n_in]),
            centres_in=0.5 * (edges[1 : n_in + 1] + edges[:n_in]),
            zenith_first=bool(edges[0] == 0.0),
            nadir_last=bool(edges[-1] == math.pi),
            theta_in=thetas[0],
            theta_out=thetas[1],
            phi=(np.arange(self.n_phi) + 0.5) * math.pi / self.n_phi,
        )

    @functools.cached_property
    def _planes_list(self) -> list[float]:
        return [float(p) for p in self.planes]

    @functools.cached_property
    def _sun_zenith_rad(self) -> FloatArray:
        return np.radians(self.sun_zenith_water_deg)

    def _warp_rows(self, th_node: float, th_frame: float) -> tuple[NDArray[np.intp], FloatArray]:
        """:meth:`_warp`'s source rows k and weights t for a node's sun and the frame's."""
        gr = self._grid
        n_in, tc, c = gr.n_in, gr.tc, gr.centres_in
        src = np.interp(c, [0.0, th_frame, tc], [0.0, th_node, tc])
        k = np.clip(np.searchsorted(c, src) - 1, 0, n_in - 2)
        t = np.clip((src - c[k]) / (c[k + 1] - c[k]), 0.0, 1.0)[:, None, None]
        return k, t

    def _warp(self, field: FloatArray, k: NDArray[np.intp], t: FloatArray) -> FloatArray:
        """A node's field inside Snell's window with its sun moved to this frame's sun.

        Between sun nodes the light near the sun follows the sun while the window's edge stays:
        the rows inside the window are resampled (linearly in θ between their nodes) at
        θ' = warp(θ), piecewise linear with warp(0) = 0, warp(θ_frame) = θ_node and
        warp(θ_c) = θ_c (rows k and weights t: :meth:`_warp_rows`). (The aureole is interpolated
        in the sun's own frame instead.)
        """
        out = field.copy()
        out[: self._grid.n_in] = (1.0 - t) * field[k] + t * field[k + 1]
        return out

    def _node(self, sun_zenith_water_rad: float, n_water: float) -> tuple[int, float]:
        """The sun node below this frame's sun and the interpolation weight of the next."""
        tc_t = math.asin(1.0 / TABLE_INDEX)
        tc = math.asin(1.0 / n_water)
        th = min(max(sun_zenith_water_rad, 0.0), tc) * tc_t / tc
        zn = self._sun_zenith_rad
        i = min(max(int(np.searchsorted(zn, th)) - 1, 0), len(zn) - 2)
        return i, min(max(float((th - zn[i]) / (zn[i + 1] - zn[i])), 0.0), 1.0)

    def sky_transmittance(
        self, sky: SkyTable, sun_zenith_water_rad: float, n_water: float = TABLE_INDEX
    ) -> float:
        """The flat sea's diffuse transmittance for this sky at this sun (node-interpolated)."""
        i, f = self._node(sun_zenith_water_rad, n_water)
        return float((1.0 - f) * sky.transmittance[i] + f * sky.transmittance[i + 1])

    def _at_numpy(
        self,
        tab: FloatArray,
        ed: FloatArray,
        tau: float,
        i: int,
        f: float,
        warps: tuple[tuple[NDArray[np.intp], FloatArray], ...] | None,
    ) -> FloatArray:
        """:meth:`frame`'s field of ``tab`` with numpy (:func:`frame_kernel.at`'s reference)."""
        a = self._at_depth(tab[i], ed[i], tau)
        b = self._at_depth(tab[i + 1], ed[i + 1], tau)
        if warps is not None:
            a = self._warp(a, *warps[0])
            b = self._warp(b, *warps[1])
        return (1.0 - f) * a + f * b

    def _depth_coefs(
        self, e_down: FloatArray, tau: float
    ) -> tuple[float, float, float, float, float, float] | None:
        """Depth interpolation's plane k and factors (k, 1 − t, t, E_k, E_k+1, e).

        None past the last plane any history reached (in weakly scattering water c z = 20 is
        e^-20 of the surface light): there :meth:`_at_depth` extrapolates.
        """
        values = e_down.tolist()
        reached = next((j for j, v in enumerate(values) if v <= 0), len(values))
        p = self._planes_list[:reached]
        if tau >= p[-1]:
            return None
        ed = values[:reached]
        k = min(max(bisect.bisect_right(p, tau) - 1, 0), len(p) - 2)
        t = (tau - p[k]) / (p[k + 1] - p[k])
        e = math.exp((1 - t) * math.log(ed[k]) + t * math.log(ed[k + 1]))
        return float(k), 1 - t, t, ed[k], ed[k + 1], e

    def _at_depth(self, field: FloatArray, e_down: FloatArray, tau: float) -> FloatArray:
        """A node's field at optical depth ``tau`` (the numpy reference's depth step).

        Linear in the field normalised by E_d, E_d log-linear; past the last reached plane, the
        asymptotic extrapolation.
        """
        coefs = self._depth_coefs(e_down, tau)
        if coefs is None:
            values = e_down.tolist()
            reached = next((j for j, v in enumerate(values) if v <= 0), len(values))
            p = self._planes_list[:reached]
            ed = e_down[:reached]  # numpy scalars: the arithmetic in e_down's precision
            k_inf = math.log(ed[-2] / ed[-1]) / (p[-1] - p[-2])
            return field[reached - 1] * math.exp(-k_inf * (tau - p[-1]))
        # numpy float64 scalars (not Python floats, which numpy treats as weak): the sums below
        # in float64 whatever the field's precision (bit-identical frames).
        k, w0, w1, d0, d1, e = coefs
        k = int(k)
        w0, w1, d0, d1 = np.float64(w0), np.float64(w1), np.float64(d0), np.float64(d1)
        return (w0 * field[k] / d0 + w1 * field[k + 1] / d1) * e

    def _pad(self, g: FloatArray) -> FrameField:
        gr = self._grid
        n_in = gr.n_in
        gin = self._pad_rows(g[:n_in], gr.zenith_first, False)
        gout = self._pad_rows(g[n_in:], False, gr.nadir_last)
        tc = math.asin(1.0 / TABLE_INDEX)
        return FrameField(gin, gr.theta_in, gout, gr.theta_out, tc, math.pi / self.n_phi)

    def _pad_rows(self, rows: FloatArray, zenith: bool, nadir: bool) -> FloatArray:
        """Rows padded with a first and a last row, and mirrored first and last columns.

        At the zenith and the nadir the light has one radiance and one polarization: the ring's
        mean I, and the m = 2 harmonic of (Q, U) that a fixed polarization has in the meridian
        frame; elsewhere the end rows repeat. The mirrored columns change U's sign.
        """
        n, m = rows.shape[0], rows.shape[1]
        grid = np.empty((n + 2, m + 2, 3), dtype=rows.dtype)
        grid[1:-1, 1:-1] = rows
        grid[0, 1:-1] = poles.pole(rows[0], *self._pole_basis) if zenith else rows[0]
        grid[-1, 1:-1] = poles.pole(rows[-1], *self._pole_basis) if nadir else rows[-1]
        grid[:, 0] = grid[:, 1]
        grid[:, 0, 2] *= -1.0
        grid[:, -1] = grid[:, -2]
        grid[:, -1, 2] *= -1.0
        return grid

    @functools.cached_property
    def _pole_basis(self) -> tuple[FloatArray, FloatArray]:
        """The cos 2φ and sin 2φ of the azimuth bins' centres (:func:`poles.pole`)."""
        phi = self._grid.phi
        return np.cos(2 * phi), np.sin(2 * phi)


def remainder_of(field: FloatArray, key: WaterKey, beams: list[tuple] | None) -> FloatArray:
    """(S, P, T, n_phi, 3) ``field`` less the reflected light's bin means in the window's rows.

    The reflection of the field's own upwelling light at the surface (plane 0) plus, per sun
    node, the once-scattered beam's (``beams``: :func:`decompose.beam_terms`; None for a sky
    table, which holds all its scattered light). A wavy sea's field is returned unchanged.
    """
    out = np.array(field, dtype=np.float64)
    if key.wind_speed_mps != 0.0:
        return out
    grid = reference.Grid(planes=TABLE_PLANES)
    n_in = _n_inside(np.asarray(grid.theta_edges_deg))
    binner = _reflection_binner(n_in)
    dphi = math.pi / grid.n_phi
    planes = np.asarray(TABLE_PLANES)
    dummy = LightFieldTable.__new__(LightFieldTable)
    object.__setattr__(dummy, "theta_edges_deg", np.asarray(grid.theta_edges_deg))
    object.__setattr__(dummy, "n_phi", grid.n_phi)
    for i in range(field.shape[0]):
        # The upwelling light as the kernel will read it: node values, padded.
        nodes = decompose.conserve(field[i, 0], grid.theta_edges_deg, n_in)
        pad = LightFieldTable._pad(dummy, nodes.astype(np.float32))
        beam = None if beams is None else beams[i]
        for k, tau in enumerate(planes):
            out[i, k, :n_in] -= binner.mean(
                float(tau), pad.outside, pad.outside_cos, dphi, TABLE_INDEX, beam
            )
    # At the surface itself the light looking up inside the window is, besides the direct light,
    # only what the surface reflects: the bins' remainder there is Monte Carlo noise, and is 0.
    out[:, 0, :n_in] = 0.0
    return out


#: The remainder's rows made smooth before :func:`decompose.conserve`: the two rings next to the
#: zenith (θ < 5.7°) and the one at the nadir. With the aureole taken out the remainder is smooth,
#: and a smooth field's azimuthal harmonics above the first fall as θ^m (≲ 1 % at 5.7°), below
#: those bins' Monte Carlo noise (5–10 % at 1.5 million histories), which ``conserve`` doubles
#: at the azimuthal Nyquist mode: left in, the exact chain showed it as a ±20 % pinwheel around
#: the zenith, finer than any real structure.
REMAINDER_POLE_ROWS = (0, 1, -1)


def _n_inside(theta_edges_deg: FloatArray) -> int:
    """The number of look-zenith bins inside Snell's window (its edge is a bin edge)."""
    edges = np.radians(np.asarray(theta_edges_deg, dtype=float))
    return int(np.argmin(np.abs(edges - math.asin(1.0 / TABLE_INDEX))))


@functools.lru_cache(maxsize=4)
def _reflection_binner(n_in: int) -> decompose.ReflectionBinner:
    grid = reference.Grid(planes=TABLE_PLANES)
    return decompose.ReflectionBinner(np.asarray(grid.theta_edges_deg), grid.n_phi, n_in)


def wind_nodes(wind_speed_mps: float) -> list[tuple[float, float]]:
    """The table winds around ``wind_speed_mps`` and their linear weights (zero weights dropped)."""
    w = float(wind_speed_mps)
    nodes = WIND_NODES_MPS
    if not (math.isfinite(w) and nodes[0] <= w <= nodes[-1]):
        raise ValueError(
            f"wind_speed_mps must lie in [0, {nodes[-1]:g}] m/s, got {wind_speed_mps!r}"
        )
    i = int(np.clip(np.searchsorted(nodes, w, side="right") - 1, 0, len(nodes) - 2))
    f = (w - nodes[i]) / (nodes[i + 1] - nodes[i])
    return [(n, wt) for n, wt in ((nodes[i], 1.0 - f), (nodes[i + 1], f)) if wt > 0.0]


@functools.lru_cache(maxsize=1)
def _shipped_names() -> dict[WaterKey, str]:
    """The shipped tables' waters and their names in ``DATA_FILE``, read without their tables.

    A run needs one or two of the ten (its water at the wind nodes around its wind). Reading
    these names took 6 ms and one water's table and sky 29 ms, against 0.24 s for all ten of
    each (measured on 2026-12-07, 2-core VM): a run's start-up loads only its own.
    """
    if not DATA_FILE.exists():
        return {}
    with np.load(DATA_FILE) as d:
        return {WaterKey.from_array(d[f"{n}/key"]): n for n in (str(n) for n in d["names"])}


@functools.lru_cache(maxsize=1)
def _shipped() -> dict[WaterKey, LightFieldTable]:
    """Every shipped table (the builder, validation and tests; a run loads its own, lazily)."""
    return {key: table_for(key) for key in _shipped_names()}


@functools.lru_cache(maxsize=32)
def table_for(key: WaterKey) -> LightFieldTable:
    """The table of a water body: shipped, cached, or computed now (and cached)."""
    name = _shipped_names().get(key)
    if name is not None:
        with np.load(DATA_FILE) as d:
            return LightFieldTable.from_arrays(d, prefix=f"{name}/")
    path = store.cache_dir() / f"{key.digest()}.npz"
    if path.exists():
        with np.load(path) as d:
            return LightFieldTable.from_arrays(d)
    print(
        f"auv-twin: computing the radiative-transfer table for water a={key.a_per_m:g}, "
        f"b_w={key.b_molecular_per_m:g}, b_p={key.b_particle_per_m:g} /m, "
        f"wind {key.wind_speed_mps:g} m/s "
        f"({len(SUN_ZENITH_AIR_DEG) + 1} Monte Carlo runs of {FIRST_USE_PHOTONS} photons; "
        f"cached in {path.parent})",
        file=sys.stderr,
    )
    t = LightFieldTable.build(key, FIRST_USE_PHOTONS, seed=0, workers=1)
    store.save(path, t.arrays())
    return t
