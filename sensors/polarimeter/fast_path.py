"""The polarimeter's fast path: smooth light on a coarse grid, the exact chain where it is not.

A frame through the exact chain at every pixel costs ~40 ms at 612×512 (~0.7 s at 2448×2048) on
one core. The fast path (``PolarimeterSpec.fast``, the default) runs the exact chain at a coarse
grid of points, upsamples it bilinearly, and renders exactly every pixel of the *rough* cells:
near Snell's window edge, around the refracted sun, where single scattering steps at the horizon,
and on the frame's border; the rough cells farther from those features it interpolates from a
grid of half the stride (the fine level, :mod:`~sensors.polarimeter.fine_grid`), and the band
inside the window's edge from a grid in (cos θ in air, azimuth) where its light is smooth (the
window grid, :mod:`~sensors.polarimeter.window_grid`; both from a stride of 8 px, where they
pay). Its static geometry is a :class:`~sensors.polarimeter.fast_plan.FastPlan`.
:class:`FastPath` is the part of the :class:`~sensors.polarimeter.render.Polarimeter` that does
it (its ``camera``, ``pspec``, ``optics``, ``n_water``, ``_column``, ``_plans``, ``_psf_sigma``,
``_psf_sigma_air`` and ``_finish``); its error against the exact chain is measured in
``tests/sensors/polarimeter/test_render_fast.py`` and ``validation/fast_path_error.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import cv2
import numpy as np
from numpy.typing import NDArray

from sensors.polarimeter import chain_kernel, pixel_kernel
from sensors.polarimeter import window_grid as window_mod
from sensors.polarimeter.fast_plan import FastPlan
from sensors.polarimeter.fine_grid import bilinear_into
from sensors.polarimeter.optics import transmission as transmission_mod
from sensors.polarimeter.optics import water as water_mod
from sensors.polarimeter.optics.sky import sky_radiance
from sensors.polarimeter.optics.sun import sun_vector as sky_vector
from sensors.polarimeter.unit import camera as camera_mod
from sensors.polarimeter.unit import port as port_mod
from twin.core.arrays import FloatArray

# The fast path's rough bands (Polarimeter._render_fast), chosen by measuring its error against the
# exact chain (tests/sensors/polarimeter/test_render_fast.py, docs/polarimeter.md).
# Inside the edge: 5 cells. 3 cells give the same worst pixel in validation/fast_path_error.py
# but break the thin limit's fast-path bounds (S0 2.4e-3, AoP 0.052°: test_light_limits.py).
_EDGE_BAND_IN_CELLS = 5.0  # coarse cells inside Snell's window edge (above the horizon in air)
# … and outside it: none. A cell that straddles the edge has a corner inside, within a cell of
# it, so the inner band keeps it rough; a cell with every corner outside lies wholly outside (the
# window is convex, and its edge bows less than 0.02 px across a cell), where the light (the
# table's outside rows, single scattering) is as smooth as anywhere. One cell (before
# 2026-12-06) cost 14 % more exact pixels (22 608 against 19 824, the 612×512 benchmark frame)
# for the same errors on every scene of validation/fast_path_error.py but two (AoP where
# DoP > 0.2, level 10 m: 0.27° → 0.29°; |Δ(S1, S2)|/S0, low sun: 0.021 → 0.023) and the thin
# limit.
_EDGE_BAND_OUT_CELLS = 0.0
_STEP_CELLS = 3.0  # the single-scattering step at the horizon (c·z): rough when this narrow
# The fine level: a rough cell is rendered exactly only within these narrower bands (counted in
# coarse cells, as above); the other rough cells are interpolated from a grid of half the stride
# (the *fine* grid), whose bilinear error falls as (fine stride / distance from the feature)²:
# ~h²/(32 x²) of S0 at x fine pixels inside the window's edge, where the Fresnel transmission
# goes as √x. Chosen by measuring the error against the exact chain, per region
# (validation/fast_path_error.py's fine-cell columns; the thin limit of test_light_limits.py set
# the edge's: 1.5 cells gave 2.8e-3 of S0 against its 1e-3 bound, 3 cells 9.0e-4).
_EDGE_EXACT_IN_CELLS = 3.0
_EDGE_EXACT_OUT_CELLS = 1.5  # (a rough cell outside the edge: one the sun's band reaches)
_SUN_EXACT_CELLS = 3.0
# The fine level pays from a coarse stride of 8 px (a fine stride of 4): at 2448×2048 a frame's
# light renders in 41 ms against 49 (136 070 rays against 190 238). At stride 4 (612×512) its
# bookkeeping costs most of what the ~5 000 rays it saves did: 0.4 ms of the fast path's 7.3 ms
# a frame in a sea trial, about 1 % of the flight (benchmarks/results/chain_cost.md), for
# slightly different frames; there the rough cells stay exact and the frames as they were.
_FINE_FROM_STRIDE = 8
_SUN_BAND_RAD = math.radians(1.0)  # around the (refracted) sun: disc + PSF …
_SUN_BAND_CELLS = 9.0  # … and the forward-peaked aureole / phase function, in cells
# The sky is evaluated at the rays inside Snell's window only when they are fewer than this
# share of the rays (below it the gather and scatter cost less than the evaluations saved).
_SKY_SUBSET_BELOW = 0.5
# The window grid (window_grid.py) gives the edge band's pixels inside the window from a coarse
# stride of 8 px: at 2448×2048 a frame's light renders in 28 ms against 34
# (benchmarks/results/polarimeter_frame.md, level at 10 m); validation/results/fast_path_error.md's
# tilted frame at 1 m takes 63 787 rays through the chain against 136 070, the grid's pixels
# within 0.2 % of S0 of the exact chain's. At stride 4 (612×512) its ~4 500 nodes cost what the
# ~12 500 pixels they replace did (7.1 against 7.0 ms a frame, measured): there the band stays
# exact.
_WINDOW_FROM_STRIDE = 8


@dataclass(frozen=True, slots=True)
class _Frame:
    """Per-frame constants of the chain (see ``Polarimeter._frame_constants``)."""

    sun: Any
    in_water: bool
    state: water_mod.ColumnState | None
    sun_look: NDArray[np.float64] | None


def _scatter_rows(flat: FloatArray, idx: NDArray[np.intp], rows: FloatArray) -> None:
    """flat[idx] = rows for (N, 3) float32 rows (one compiled loop: pixel_kernel)."""
    pixel_kernel.scatter_rows(flat, idx, np.ascontiguousarray(rows, dtype=np.float32))


class FastPath:
    """The fast path's part of the polarimeter (a mixin of ``Polarimeter``; module docstring)."""

    #: Render points under a flat sea with :mod:`~sensors.polarimeter.chain_kernel` (one
    #: compiled pass); False: the numpy chain it is tested against.
    compiled_chain: bool = True
    #: Interpolate the rough cells outside the narrow bands from the fine grid (module
    #: constants); False: every rough cell exact, the fast path before the fine level.
    fine_level: bool = True
    #: Give the edge band's pixels inside Snell's window from the (c_a, φ) grid
    #: (:mod:`~sensors.polarimeter.window_grid`); False: the exact chain there, as before it.
    window_grid: bool = True

    def _fast_plan(self, port: port_mod.PortRays) -> FastPlan | None:
        """The coarse grid for this port (cached), or None where only the exact chain applies."""
        cam = self.camera
        if (
            not self.pspec.fast
            or port.housing != "dome"
            or cam.spec.polarization_mapping != "meridional"
        ):
            return None
        stride = self.pspec.smooth_stride_px or max(8 // cam.spec.binning, 4)
        h, w = cam.shape
        if h % stride or w % stride or h < 3 * stride or w < 3 * stride:
            return None
        key = (port.n_outside, stride)
        if key not in self._plans:
            psf = self._psf_sigma if port.n_outside > 1.0 else self._psf_sigma_air
            self._plans[key] = FastPlan(cam, port, stride, psf, stride >= _FINE_FROM_STRIDE)
        return self._plans[key]

    def _render_points(
        self,
        rays: FloatArray,
        basis: FloatArray | tuple[FloatArray, NDArray[np.intp]],
        psf: FloatArray,
        c_cn: NDArray[np.float64],
        fc: _Frame,
        occluded: NDArray[np.bool_] | None = None,
        parts: Literal["total", "split", "direct"] = "total",
    ) -> tuple[FloatArray, NDArray[np.bool_], FloatArray | None]:
        """The exact chain at N rays: (sensor-plane Stokes (N, 3), sees the sky, scattered part).

        The same stages, in the same float32 arithmetic, as the whole-frame chain of
        :meth:`render_stokes`, for any set of (outside, dome) rays: the pixels the fast path
        renders exactly, and the coarse grid. ``parts``: ``"total"`` (all the light),
        ``"split"`` (the total and, third, the scattered light alone) or ``"direct"`` (the
        direct sky light only: no scattering computed).
        """
        o = self.optics
        scat = None
        if fc.in_water and parts != "direct":
            assert self._column is not None and fc.state is not None
            sun = sky_vector(fc.sun)
            k = self._column._kernel_args(fc.state, True, True)
            if k is not None and self.compiled_chain and chain_kernel.applies(o.sky, sun):
                # One compiled pass per ray: the same chain (chain_kernel's docstring).
                if not isinstance(basis, tuple):
                    basis = (basis, np.arange(len(rays)))
                return chain_kernel.render_points(
                    rays, basis, psf, c_cn, self.n_water, o.sky, sun, k,
                    self._photon_scale, occluded, parts == "split",
                )  # fmt: skip
        if isinstance(basis, tuple):
            basis = np.take(basis[0], basis[1], axis=1)
        if fc.in_water:
            assert self._column is not None and fc.state is not None
            trans = transmission_mod.surface_transmission(rays, self.n_water, rotation=c_cn)
            window_st = trans.apply(self._window_sky(trans, fc, c_cn, psf))
            if occluded is not None:
                window_st[occluded] = 0.0
            sees = trans.sees_sky
            col = self._column
            if parts == "total":
                st = col.render(rays, fc.state, window_st, rotation=c_cn)
            else:
                st = col.direct(rays, window_st, fc.state, rotation=c_cn)
                if parts == "split":
                    scat = np.asarray(col.scattered(rays, fc.state, rotation=c_cn))
                    st = st + scat  # = render(): the direct light is added onto the scattered
        else:
            sky = sky_radiance(rays, fc.sun, o.sky, rotation=c_cn, psf_sigma_rad=psf)
            sees = (rays @ c_cn[2].astype(rays.dtype)) > 0
            keep = sees if occluded is None else sees & ~occluded
            st = sky.stokes * keep[:, None]
            if parts == "split":
                scat = np.zeros_like(st)
        out = camera_mod.meridian_to_sensor_stokes(st, c_cn, basis)
        self._finish(out)
        if scat is not None:
            scat = camera_mod.meridian_to_sensor_stokes(scat, c_cn, basis)
            self._finish(scat)
        return out, sees, scat

    def _window_sky(
        self,
        trans: transmission_mod.SurfaceTransmission,
        fc: _Frame,
        c_cn: NDArray[np.float64],
        psf: FloatArray,
    ) -> FloatArray:
        """(N, 3) the sky's Stokes along each ray's sky direction, zero where it sees no sky.

        The sky model is evaluated at the rays inside Snell's window only: outside it the
        transmission factors are zero (:meth:`SurfaceTransmission.apply`), and most of the
        coarse grid's points lie there (three in four at 10 m under a level camera). Each
        sample's value does not depend on which others are evaluated with it
        (:func:`sky.sky_radiance`).
        """
        sees = trans.sees_sky
        dirs = trans.sky_directions()
        sky = self.optics.sky
        sel = np.flatnonzero(sees)
        if sel.size > _SKY_SUBSET_BELOW * sees.size:  # the gather and scatter would cost more
            return sky_radiance(dirs, fc.sun, sky, rotation=c_cn, psf_sigma_rad=psf).stokes
        # Planar (3, N) storage in and out: sky_radiance's fast layout, contiguous gathers.
        out = np.zeros((3, sees.size), dtype=dirs.dtype)
        if sel.size:
            sub = np.take(dirs.T, sel, axis=1).T
            sig = np.broadcast_to(psf, sees.shape)[sel]
            res = sky_radiance(sub, fc.sun, sky, rotation=c_cn, psf_sigma_rad=sig)
            out[:, sel] = res.stokes.T
        return out.T

    def _render_fast(
        self,
        plan: FastPlan,
        c_cn: NDArray[np.float64],
        fc: _Frame,
        valid: NDArray[np.bool_],
        occluded: NDArray[np.bool_],
    ) -> tuple[FloatArray, NDArray[np.bool_]]:
        """The frame from a coarse grid, bilinearly upsampled, and exact pixels where needed.

        1. A *cell* (the square between four coarse-grid points, one point at the centre of
           every stride × stride block of pixels, whose pixels the bilinear interpolation takes
           from those four) is *rough* when a corner point lies within ``_EDGE_BAND_IN_CELLS``
           cells inside Snell's window edge (``_EDGE_BAND_OUT_CELLS`` outside; above the
           horizon, in air: Fresnel transmission and the compressed sky are not smooth there);
           or within ``_SUN_BAND_CELLS`` cells plus ``_SUN_BAND_RAD`` of the (refracted) sun
           (the disc, the sky's aureole, the forward-peaked phase function); or near a feature
           of the scattered light narrower than a few cells (the single-scattering step at the
           horizon, sharp at shallow depth); and every cell on the frame's border is rough (the
           resize extrapolates there). This is geometry: the points' directions only.
        2. The exact chain (:meth:`_render_points`) at the points a smooth cell reads (a point
           whose cells are all rough is never read): the sensor-plane Stokes of all the light
           and of the scattered light, in photons/s. The lens's polarization mapping is applied
           at the points, so the meridian frame's singularity at the zenith is never
           interpolated, only smooth sensor-plane fields. The exact chain renders every valid
           pixel of a rough cell within the narrower bands (``_EDGE_EXACT_*``,
           ``_SUN_EXACT_CELLS``, the horizon's step, the border); the other rough cells (with
           :attr:`fine_level`) are interpolated from the fine grid, whose points the exact
           chain renders; the smooth cells from the coarse grid. From a stride of
           ``_WINDOW_FROM_STRIDE`` (with :attr:`window_grid`) the exact cells' pixels inside
           the window's edge, away from the sun, the horizon's step and the border, take their
           light from the (c_a, φ) grid of :mod:`~sensors.polarimeter.window_grid` instead.
        3. Snell's window mask: exact in the exact cells, elsewhere the nearest point's (an
           interpolated cell lies wholly on one side of the edge). Occluded pixels of
           interpolated cells lose the interpolated direct light (total − scattered at the
           points).

        The bands were chosen by measuring the error against the exact chain
        (``tests/sensors/polarimeter/test_render_fast.py``, ``docs/polarimeter.md``).
        """
        cam = self.camera
        h, w = cam.shape
        s = plan.stride
        hc, wc = h // s, w // s
        occ_any = bool(occluded.any())
        # --- rough points (geometry only) ------------------------------------------------------
        world = plan.rays64 @ c_cn.T
        cell = plan.cell_rad
        up = np.clip(world[:, 2], -1.0, 1.0)
        edge = math.acos(fc.state.window_cos) if fc.state is not None else 0.5 * math.pi
        # Signed angle from the edge in cells (> 0 outside the window / below the horizon).
        ang = (np.arccos(up) - edge) / cell
        rough = (ang > -_EDGE_BAND_IN_CELLS) & (ang < _EDGE_BAND_OUT_CELLS)
        sharp = from_sun = None
        if fc.state is not None:
            sharp = self._sharp_scattering(fc.state, up, cell)
            rough |= sharp
        if fc.sun_look is not None:
            from_sun = np.arccos(np.clip(world @ fc.sun_look, -1.0, 1.0))
            rough |= from_sun < _SUN_BAND_RAD + _SUN_BAND_CELLS * cell
        cells = plan.rough_cells(rough)
        fine = plan.fine if self.fine_level else None
        if fine is not None:
            # The rough cells outside the narrow bands: interpolated from the fine grid. A fine
            # cell's pixels read fine points up to half a cell beyond it: no fine cell may lie
            # next to the edge on either side.
            exact = (ang > -_EDGE_EXACT_IN_CELLS) & (ang < _EDGE_EXACT_OUT_CELLS)
            if sharp is not None:
                exact |= sharp
            if from_sun is not None:
                exact |= from_sun < _SUN_BAND_RAD + _SUN_EXACT_CELLS * cell
            narrow = np.zeros(plan.cell_valid.size, dtype=bool)
            narrow[plan.rough_cells(exact)] = True
            exact_cells = cells[narrow[cells]]
            fine_cells = cells[~narrow[cells]]
        else:
            exact_cells, fine_cells = cells, cells[:0]
        # --- the exact chain at the points the smooth cells read --------------------------------
        use = plan.smooth_corners(cells)
        points = plan.points[use]
        tot_c, sees_c, scat_c = self._render_points(
            plan.gather_points(use),
            (plan.basis, use),
            plan.psf[use],
            c_cn,
            fc,
            parts="split" if occ_any else "total",
        )
        # --- the coarse frame, upsampled over the image circle's bounding box -------------------
        coarse = np.zeros((hc * wc, 3), dtype=np.float32)
        _scatter_rows(coarse, points, tot_c)
        # np.zeros, not an empty frame zeroed around the box: a large frame comes zeroed from the
        # kernel's fresh pages (2448×2048: 2 ms less than writing the zeros, measured).
        st = np.zeros((h, w, 3), dtype=np.float32)
        b0, b1, a0, a1 = plan.roi
        roi = st[b0 * s : b1 * s, a0 * s : a1 * s]
        cv2.resize(coarse.reshape(hc, wc, 3)[b0:b1, a0:a1], (roi.shape[1], roi.shape[0]), dst=roi)
        cv2.copyTo(plan.zeros, plan.invalid, roi)  # OpenCV's masked copy: faster than a scatter
        flat = st.reshape(-1, 3)
        # --- the exact chain at the valid pixels of the rough cells -----------------------------
        idx = plan.pixels(exact_cells)
        banded = None
        if self.window_grid and fc.state is not None and s >= _WINDOW_FROM_STRIDE:
            # The edge band's pixels inside the window, from the (c_a, φ) grid: the exact cells
            # but those near the sun, the horizon's step or the border (window_grid.py).
            near = np.zeros(rough.shape, dtype=bool) if sharp is None else sharp.copy()
            if from_sun is not None:
                near |= from_sun < _SUN_BAND_RAD + _SUN_BAND_CELLS * cell
            special = np.zeros(plan.cell_valid.size, dtype=bool)
            special[plan.rough_cells(near)] = True  # (the border cells come with them)
            band = plan.pixels(exact_cells[~special[exact_cells]])
            banded = window_mod.band_stokes(
                plan.window_grid(self.n_water), band, plan.gather_rays(band), cam.sensor_basis,
                c_cn, self.n_water, occluded.reshape(-1)[band] if occ_any else None,
                lambda rays, basis, psf: self._render_points(
                    rays, basis, psf, window_mod.IDENTITY, fc, parts="split"
                ),
            )  # fmt: skip
            if banded is not None:
                keep = np.ones(h * w, dtype=bool)
                keep[banded[0]] = False
                idx = idx[keep[idx]]
        st_r, sees_r, _ = self._render_points(
            plan.gather_rays(idx),
            (cam.sensor_basis, idx),
            plan.psf_full[idx],
            c_cn,
            fc,
            occluded.reshape(-1)[idx] if occ_any else None,
        )
        _scatter_rows(flat, idx, st_r)
        if banded is not None:
            _scatter_rows(flat, banded[0], banded[1])
        # --- Snell's window (the sky above the horizon, in air) ---------------------------------
        win_c = np.zeros(hc * wc, dtype=np.uint8)
        win_c[points] = sees_c
        window = plan.nearest(win_c.reshape(hc, wc)).view(bool)
        win_flat = window.reshape(-1)
        win_flat[idx] = sees_r
        if banded is not None:
            win_flat[banded[0]] = True  # c_a > 0: inside the window
        # --- the fine level: the other rough cells, from the fine grid ---------------------------
        fine_direct = None
        if fine_cells.size:
            assert fine is not None
            f_idx = plan.pixels(fine_cells)
            f_pts = fine.points(fine_cells)
            tot_f, sees_f, scat_f = self._render_points(
                fine.rays[f_pts], (fine.basis, f_pts), fine.psf[f_pts], c_cn, fc,
                parts="split" if occ_any else "total",
            )  # fmt: skip
            hf, wf = fine.shape
            grid = np.zeros((hf * wf, 3), dtype=np.float32)
            grid[f_pts] = tot_f
            bilinear_into(grid, hf, wf, fine.stride, w, f_idx, flat, False)
            # A fine cell lies wholly on one side of the window's edge (the edge's cells are
            # exact): its nearest fine point's side is its pixels'.
            win_f = np.zeros(hf * wf, dtype=bool)
            win_f[f_pts] = sees_f
            win_flat[f_idx] = win_f[fine.nearest(f_idx, w)]
            if occ_any:
                assert scat_f is not None
                grid[f_pts] -= scat_f  # the direct light alone
                fine_direct = (f_idx, grid)
        window &= valid
        if occ_any:
            # Occluded pixels of interpolated cells lose their interpolated direct light (the
            # window grid's pixels are never occluded ones).
            interpolated = np.ones(h * w, dtype=bool)
            interpolated[idx] = False
            if banded is not None:
                interpolated[banded[0]] = False
            lose_mask = (occluded & window).reshape(-1) & interpolated
            if fine_direct is not None:
                assert fine is not None
                f_idx, direct_f = fine_direct
                on_fine = np.zeros(h * w, dtype=bool)
                on_fine[f_idx] = True
                lose_f = np.flatnonzero(lose_mask & on_fine)
                lose_mask &= ~on_fine
                if lose_f.size:
                    hf, wf = fine.shape
                    bilinear_into(direct_f, hf, wf, fine.stride, w, lose_f, flat, True)
                    np.maximum(flat[lose_f, 0], 0.0, out=flat[lose_f, 0])
            lose = np.flatnonzero(lose_mask)
            if lose.size:
                direct = np.zeros((hc * wc, 3), dtype=np.float32)
                assert scat_c is not None
                direct[points] = tot_c - scat_c
                flat[lose] -= plan.interpolate(direct.reshape(hc, wc, 3), lose)
                np.maximum(flat[lose, 0], 0.0, out=flat[lose, 0])
            window &= ~occluded
        return st, window

    def _sharp_scattering(
        self,
        state: water_mod.ColumnState,
        up: NDArray[np.float64],
        cell: NDArray[np.float64],
    ) -> NDArray[np.bool_]:
        """Coarse points where the scattered light is too curved to interpolate over a cell.

        Single scattering changes from a path-limited to an unlimited line of sight over
        v_z ≈ c·z at the horizon: rough within 3 c·z + 1 cell of it when c·z spans fewer than
        ``_STEP_CELLS`` cells. (The table's light is bilinear between bins of 3° and more, wider
        than a cell, and its one step, the total internal reflection at Snell's window edge, lies
        in the edge band.)
        """
        assert self._column is not None
        step = self._column.water.c_per_m * state.depth_m
        narrow = step / cell < _STEP_CELLS
        rough = np.zeros(up.shape, dtype=bool)
        if narrow.any():
            horizon = np.arcsin(up) / cell
            rough |= narrow & (np.abs(horizon) < 3.0 * step / cell + 1.0)
        return rough
