"""The fast path's fine level: a grid of half the coarse stride that fills the rough cells.

:meth:`FastPath._render_fast` (``sensors/polarimeter/fast_path.py``) renders exactly only the
pixels near the features a grid cannot follow (Snell's window edge, the sun's disc and PSF, the
horizon's single-scattering step, the frame's border); the rest of the rough cells it
interpolates bilinearly from this finer grid, rendered through the same exact chain at its
points. Used from a coarse stride of 8 (``fast_path._FINE_FROM_STRIDE``: where it pays).
:func:`bilinear_into` is that interpolation, compiled: numpy's eleven passes over a 612×512
frame's ~12 000 interpolated pixels took 1.9 ms, more than the chain's time for the ~8 000 rays
the level saved there.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sensors.polarimeter.unit import camera as camera_mod
from twin.core.arrays import FloatArray
from twin.core.kernel_cache import njit


class FineGrid:
    """The fast path's fine level: a grid of stride f = s/2 that fills the rough cells' middles.

    Points at frame coordinates (f·j + (f − 1)/2, f·i + (f − 1)/2), the bilinear factor-f
    convention of the coarse grid. A coarse cell's pixels read the fine points of
    :attr:`cell_points` (4 × 4 of them, clipped at the frame's edges; only interior cells are
    read: the border cells stay exact).
    """

    def __init__(self, cam: camera_mod.Camera, f: int, psf: FloatArray, hc1: int, wc1: int) -> None:
        h, w = cam.shape
        self.stride = f
        self.shape = hf, wf = h // f, w // f
        jj, ii = np.meshgrid(np.arange(wf), np.arange(hf))
        rays, _ = cam.pixel_to_ray(f * jj + (f - 1) / 2.0, f * ii + (f - 1) / 2.0)
        rays = rays.reshape(-1, 3)
        self.rays = np.ascontiguousarray(rays, dtype=np.float32)
        self.basis = camera_mod.sensor_basis(rays, np.float32)
        ui = np.clip(np.rint(f * jj.reshape(-1) + (f - 1) / 2.0).astype(np.intp), 0, w - 1)
        vi = np.clip(np.rint(f * ii.reshape(-1) + (f - 1) / 2.0).astype(np.intp), 0, h - 1)
        self.psf = np.ascontiguousarray(psf[vi, ui])
        # Coarse cell (a, b) holds pixel rows 2f·a − f … 2f·a + f − 1, whose bilinear rows are
        # 2a − 2 … 2a + 1 of the fine grid (the same for columns).
        a = np.arange(hc1)[:, None] * 2 + np.arange(-2, 2)[None, :]
        b = np.arange(wc1)[:, None] * 2 + np.arange(-2, 2)[None, :]
        a, b = np.clip(a, 0, hf - 1), np.clip(b, 0, wf - 1)
        pts = a[:, None, :, None] * wf + b[None, :, None, :]  # (hc1, wc1, 4, 4)
        self.cell_points = pts.reshape(hc1 * wc1, 16).astype(np.int32)

    def points(self, cells: NDArray[np.intp]) -> NDArray[np.intp]:
        """Flat indices of the fine points the given coarse cells' pixels read."""
        mark = np.zeros(self.shape[0] * self.shape[1], dtype=bool)
        mark[self.cell_points[cells].reshape(-1)] = True
        return np.flatnonzero(mark)

    def nearest(self, idx: NDArray[np.intp], w: int) -> NDArray[np.intp]:
        """The fine point nearest each flat pixel index (a frame ``w`` pixels wide)."""
        f = self.stride
        i = np.minimum((idx // w) // f, self.shape[0] - 1)
        j = np.minimum((idx % w) // f, self.shape[1] - 1)
        return i * self.shape[1] + j


@njit(cache=True)
def bilinear_into(grid, hf, wf, f, w, idx, flat, subtract):  # type: ignore[no-untyped-def]
    """flat[idx] = (or −=) the bilinear value of the (hf·wf, 3) float32 ``grid`` at pixels ``idx``.

    The grid's point (i, j) sits at pixel (f·j + (f − 1)/2, f·i + (f − 1)/2) of a frame ``w``
    pixels wide: ``cv2.resize``'s bilinear convention, the coarse grid's
    (``FastPlan.interpolate``), clamped at the grid's edges; weights in float32 as there.
    """
    off = (f - 1) / 2.0
    for k in range(idx.shape[0]):
        p = idx[k]
        fy = (p // w - off) / f
        fx = (p % w - off) / f
        y0 = int(np.floor(fy))
        x0 = int(np.floor(fx))
        ty = np.float32(fy - y0)
        tx = np.float32(fx - x0)
        ya = min(max(y0, 0), hf - 1) * wf
        yb = min(max(y0 + 1, 0), hf - 1) * wf
        xa = min(max(x0, 0), wf - 1)
        xb = min(max(x0 + 1, 0), wf - 1)
        for c in range(3):
            top = grid[ya + xa, c] * (np.float32(1.0) - tx) + grid[ya + xb, c] * tx
            bottom = grid[yb + xa, c] * (np.float32(1.0) - tx) + grid[yb + xb, c] * tx
            v = top * (np.float32(1.0) - ty) + bottom * ty
            if subtract:
                flat[p, c] -= v
            else:
                flat[p, c] = v
