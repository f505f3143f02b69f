"""The fast path's static geometry for one camera, port and stride: its grid, cells and pixels.

Built once per (camera, port, stride) by :meth:`FastPath._fast_plan
<sensors.polarimeter.fast_path.FastPath._fast_plan>`; a frame reads it
(:meth:`FastPath._render_fast <sensors.polarimeter.fast_path.FastPath._render_fast>`).
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from sensors.polarimeter import pixel_kernel
from sensors.polarimeter import window_grid as window_mod
from sensors.polarimeter.fine_grid import FineGrid
from sensors.polarimeter.occlusion import upsample_nearest
from sensors.polarimeter.unit import camera as camera_mod
from sensors.polarimeter.unit import port as port_mod
from twin.core.arrays import FloatArray


class FastPlan:
    """The fast path's static geometry for one camera, port and stride (computed once).

    *Points*: the coarse grid, one point at the centre of every stride × stride block of pixels,
    frame coordinates (s·j + (s − 1)/2, s·i + (s − 1)/2) — exactly where ``cv2.resize`` (bilinear,
    by the integer factor s) places its source samples. *Cells*: the squares between four
    neighbouring points; a pixel's bilinear value comes from its cell's four corners. Cell (i, j),
    i = 0..H/s, holds the pixel rows s·i − s/2 .. s·i + s/2 − 1 (clipped to the frame: the half
    cells along the frame's border are extrapolated by the resize, and rendered exactly).
    ``fine``: with the fine level's grid (:class:`~sensors.polarimeter.fine_grid.FineGrid`, an
    even stride only).
    """

    def __init__(
        self,
        cam: camera_mod.Camera,
        port: port_mod.PortRays,
        stride: int,
        psf: FloatArray,
        fine: bool,
    ) -> None:
        h, w = cam.shape
        s = self.stride = stride
        hc, wc = h // s, w // s
        valid = port.valid
        # Cells with a valid pixel; the points at their corners are the ones to evaluate.
        half = s // 2
        padded = np.zeros((h + s, w + s), dtype=bool)
        padded[half : half + h, half : half + w] = valid
        self.cell_valid = padded.reshape(hc + 1, s, wc + 1, s).any(axis=(1, 3))
        need = np.zeros((hc + 1, wc + 1), dtype=bool)
        need |= self.cell_valid
        need[1:, :] |= self.cell_valid[:-1, :]
        need[:, 1:] |= need[:, :-1].copy()
        need = need[1:, 1:]
        self.points = np.flatnonzero(need)
        jj, ii = np.meshgrid(np.arange(wc), np.arange(hc))
        u_all = (s * jj + (s - 1) / 2.0).astype(np.float64)
        v_all = (s * ii + (s - 1) / 2.0).astype(np.float64)
        grid_rays, _ = cam.pixel_to_ray(u_all, v_all)  # dome: the outside rays are the lens rays
        rays = grid_rays.reshape(-1, 3)[self.points]
        self.rays64 = rays
        self.rays = np.ascontiguousarray(rays, dtype=np.float32)
        self.basis = camera_mod.sensor_basis(rays, np.float32)
        u, v = u_all.reshape(-1)[self.points], v_all.reshape(-1)[self.points]
        ui = np.clip(np.rint(u).astype(np.intp), 0, w - 1)
        vi = np.clip(np.rint(v).astype(np.intp), 0, h - 1)
        self.psf = np.ascontiguousarray(psf[vi, ui])
        self.psf_full = np.ascontiguousarray(psf.reshape(-1))
        # Angular size of a cell at each point: the largest angle to a neighbouring point.
        gap = np.zeros((hc, wc))
        dv = np.arccos(np.clip(np.sum(grid_rays[1:] * grid_rays[:-1], axis=-1), -1.0, 1.0))
        du = np.arccos(np.clip(np.sum(grid_rays[:, 1:] * grid_rays[:, :-1], axis=-1), -1.0, 1.0))
        for a, sl in ((dv, np.s_[1:]), (dv, np.s_[:-1])):
            gap[sl] = np.maximum(gap[sl], a)
        gap[:, 1:] = np.maximum(gap[:, 1:], du)
        gap[:, :-1] = np.maximum(gap[:, :-1], du)
        self.cell_rad = gap.reshape(-1)[self.points]
        border = np.zeros_like(self.cell_valid)
        border[[0, -1], :] = True
        border[:, [0, -1]] = True
        self.border = border & self.cell_valid
        # Bounding box of the valid pixels in blocks, one block wider where the frame allows:
        # there the resize's edge clamping falls on blocks without valid pixels.
        block_valid = valid.reshape(hc, s, wc, s).any(axis=(1, 3))
        rows = np.flatnonzero(block_valid.any(axis=1))
        cols = np.flatnonzero(block_valid.any(axis=0))
        if rows.size == 0:
            rows = cols = np.array([0])
        b0, b1 = max(int(rows[0]) - 1, 0), min(int(rows[-1]) + 2, hc)
        a0, a1 = max(int(cols[0]) - 1, 0), min(int(cols[-1]) + 2, wc)
        self.roi = (b0, b1, a0, a1)
        self.invalid = np.ascontiguousarray(~valid[b0 * s : b1 * s, a0 * s : a1 * s]).astype(
            np.uint8
        )
        self.zeros = np.zeros((*self.invalid.shape, 3), dtype=np.float32)
        # The valid pixels of each cell (flat indices, −1 = none), and the rays to gather from.
        hc1, wc1 = self.cell_valid.shape
        ci, cj = np.meshgrid(np.arange(hc1), np.arange(wc1), indexing="ij")
        dy, dx = np.mgrid[0:s, 0:s]
        y = (ci * s - half).reshape(-1, 1) + dy.reshape(1, -1)
        x = (cj * s - half).reshape(-1, 1) + dx.reshape(1, -1)
        inside = (y >= 0) & (y < h) & (x >= 0) & (x < w)
        table = np.where(inside, y * w + x, 0)
        table = np.where(inside & valid.reshape(-1)[table], table, -1)
        self._cell_pixels = table.astype(np.int32 if h * w < 2**31 else np.intp)
        self._rays_planar = cam.rays_planar.reshape(3, -1)
        self._shape = (h, w)
        self.fine = FineGrid(cam, s // 2, psf, hc1, wc1) if fine and s % 2 == 0 else None
        self._window_grids: dict[float, window_mod.WindowGrid] = {}

    def window_grid(self, n_water: float) -> window_mod.WindowGrid:
        """The (c_a, φ) grid of this water (built once), its columns a coarse cell apart."""
        if n_water not in self._window_grids:
            cell = float(np.median(self.cell_rad))
            self._window_grids[n_water] = window_mod.WindowGrid.for_cell(n_water, cell)
        return self._window_grids[n_water]

    def rough_cells(self, points: NDArray[np.bool_]) -> NDArray[np.intp]:
        """Flat indices of the rough cells, into the (H/s + 1, W/s + 1) cells.

        The valid cells with a corner among the flagged ``points`` (booleans over
        :attr:`points`), and the valid border cells.
        """
        hc1, wc1 = self.cell_valid.shape
        grid = np.zeros((hc1 + 1, wc1 + 1), dtype=bool)  # the points, padded by one all round
        inner = np.zeros((hc1 - 1) * (wc1 - 1), dtype=bool)
        inner[self.points] = points
        grid[1:-1, 1:-1] = inner.reshape(hc1 - 1, wc1 - 1)
        cells = grid[:-1, :-1] | grid[1:, :-1] | grid[:-1, 1:] | grid[1:, 1:]
        cells &= self.cell_valid
        cells |= self.border
        return np.flatnonzero(cells)

    def smooth_corners(self, cells: NDArray[np.intp]) -> NDArray[np.intp]:
        """Positions in :attr:`points` of the corners of the valid cells not among ``cells``.

        The points a frame's interpolation reads: every pixel of a rough cell is rendered
        exactly, so a point whose cells are all rough is never read.
        """
        hc1, wc1 = self.cell_valid.shape
        smooth = self.cell_valid.copy().reshape(-1)
        smooth[cells] = False
        smooth = smooth.reshape(hc1, wc1)
        # Point (a, b) is a corner of cells (a, b), (a + 1, b), (a, b + 1), (a + 1, b + 1).
        corner = smooth[:-1, :-1] | smooth[1:, :-1] | smooth[:-1, 1:] | smooth[1:, 1:]
        return np.flatnonzero(corner.reshape(-1)[self.points])

    def pixels(self, cells: NDArray[np.intp]) -> NDArray[np.intp]:
        """Flat indices of the valid pixels of the given cells."""
        idx = self._cell_pixels[cells].reshape(-1)
        return idx[idx >= 0].astype(np.intp)

    def nearest(self, coarse: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """``cv2.resize``'s nearest neighbour of a (H/s, W/s) grid to the frame.

        When the stride divides the frame, pixel (r, c) takes point (r // s, c // s), as OpenCV's
        nearest (⌊x · 1/s⌋, exact for these scales) does: two gathers (occlusion's
        :func:`upsample_nearest`; 58 µs against the resize's 74 at 612×512, 0.7 ms against 1.2
        at 2448×2048, measured).
        """
        h, w = self._shape
        s = self.stride
        if h % s == 0 and w % s == 0:
            return upsample_nearest(coarse, s, (h, w))
        return cv2.resize(coarse, (w, h), interpolation=cv2.INTER_NEAREST)

    def gather_points(self, use: NDArray[np.intp]) -> FloatArray:
        """(N, 3) the float32 rays of the points at positions ``use`` of :attr:`points`."""
        out = np.empty((len(use), 3), dtype=self.rays.dtype)
        pixel_kernel.gather_rows(self.rays, use, out)
        return out

    def gather_rays(self, idx: NDArray[np.intp]) -> FloatArray:
        """(N, 3) the rays of the given pixels (from planar storage)."""
        out = np.empty((len(idx), 3), dtype=self._rays_planar.dtype)
        pixel_kernel.gather_columns(self._rays_planar, idx, out)
        return out

    def interpolate(self, grid: FloatArray, idx: NDArray[np.intp]) -> FloatArray:
        """(N, 3) ``cv2.resize``'s bilinear value of a (H/s, W/s, 3) point grid at given pixels."""
        w = self._shape[1]
        s = self.stride
        hc, wc = grid.shape[:2]
        fy = ((idx // w) - (s - 1) / 2.0) / s
        fx = ((idx % w) - (s - 1) / 2.0) / s
        y0, x0 = np.floor(fy), np.floor(fx)
        ty = (fy - y0).astype(np.float32)[:, None]
        tx = (fx - x0).astype(np.float32)[:, None]
        y0 = y0.astype(np.intp)
        x0 = x0.astype(np.intp)
        ya, yb = np.clip(y0, 0, hc - 1) * wc, np.clip(y0 + 1, 0, hc - 1) * wc
        xa, xb = np.clip(x0, 0, wc - 1), np.clip(x0 + 1, 0, wc - 1)
        g = grid.reshape(-1, 3)
        top = g[ya + xa] * (1 - tx) + g[ya + xb] * tx
        bottom = g[yb + xa] * (1 - tx) + g[yb + xb] * tx
        return top * (1 - ty) + bottom * ty
