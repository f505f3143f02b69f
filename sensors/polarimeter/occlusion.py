"""Which of the polarimeter's pixels the vehicle's own geometry blocks from the sky.

The rays are cast against the MuJoCo scene (``mujoco.mj_multiRay``) on a coarse grid (every
``occlusion_stride_px``-th pixel) and upsampled to the frame by nearest neighbour; a blocked pixel
keeps only the scattered light (:class:`sensors.polarimeter.render.Polarimeter`).
"""

from __future__ import annotations

from typing import TypeVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from sensors.base import WorldView
from sensors.polarimeter.spec import PolarimeterSpec
from twin.core.arrays import FloatArray

ScalarT = TypeVar("ScalarT", bound=np.generic)

DOME_CLEARANCE_M = 0.025  # models/auv/auv.xml: dome r = 3 cm centred 1.5 cm below the site


def occlusion_mask(
    world: WorldView | None,
    pspec: PolarimeterSpec,
    shape: tuple[int, int],
    pos: NDArray[np.float64],
    c_cn: NDArray[np.float64],
    rays: FloatArray,
    depth_m: float,
) -> NDArray[np.bool_]:
    """(H, W) pixels whose path to the sky is blocked by scene geometry (coarse grid, upsampled).

    Args:
        world: The simulation's view (None, or ``pspec.occlusion`` off: nothing is blocked).
        pspec: The polarimeter's spec (stride, geom groups).
        shape: The frame's (rows, columns).
        pos: The camera's position (ENU, m).
        c_cn: Its attitude C_c^n.
        rays: (H, W, 3) its rays in the camera frame.
        depth_m: Its depth (≤ 0: in air).
    """
    h, w = shape
    if world is None or not pspec.occlusion:
        return np.zeros((h, w), dtype=bool)
    k = pspec.occlusion_stride_px
    sub = np.ascontiguousarray(rays[k // 2 :: k, k // 2 :: k], dtype=np.float64)
    sh = sub.shape[:2]
    vec = sub.reshape(-1, 3) @ c_cn.T  # ENU
    nray = vec.shape[0]
    geomid = np.full(nray, -1, dtype=np.int32)
    dist = np.full(nray, -1.0, dtype=np.float64)
    groups = np.zeros(6, dtype=np.uint8)
    groups[list(pspec.occlusion_geomgroups)] = 1
    # A ray is blocked when it meets geometry before the surface (in air: anywhere above).
    up = vec[:, 2]
    if depth_m > 0:
        to_surface = np.where(up > 1e-6, depth_m / np.maximum(up, 1e-6), np.inf)
        finite = to_surface[np.isfinite(to_surface)]
        cutoff = float(min(finite.max(), 1e4)) if finite.size else 1e4
    else:  # in air: anything in the way blocks the sky
        to_surface = np.full(nray, np.inf)
        cutoff = 1e4
    # Cast from just outside the camera's own dome (the site sits inside that visual geom, which
    # would stop every ray); a 2.5 cm parallax is negligible for occluders.
    origin = np.asarray(pos, dtype=np.float64) + DOME_CLEARANCE_M * c_cn[:, 2]
    mujoco.mj_multiRay(
        world.model,
        world.data,
        origin,
        vec.reshape(-1),
        groups,
        1,
        -1,
        geomid,
        dist,
        None,
        nray,
        max(cutoff, 1e-3),
    )
    # The sea-surface plane (a visual geom at z = 0) sits exactly at to_surface: a margin
    # keeps it from blocking its own sky.
    blocked = (geomid >= 0) & (dist >= 0) & (dist < 0.999 * to_surface - 0.01)
    return upsample_nearest(blocked.reshape(sh), k, (h, w))


def upsample_nearest(coarse: NDArray[ScalarT], k: int, shape: tuple[int, int]) -> NDArray[ScalarT]:
    """A coarse grid sampled every ``k``-th pixel, back to the frame by nearest neighbour.

    Pixel (r, c) takes sample (min(r // k, rows − 1), min(c // k, cols − 1)). The columns are
    gathered first on the coarse rows, then the rows: a twelfth of the time of repeating each
    axis and padding the edge (measured at 612×512).
    """
    h, w = shape
    rows, cols = coarse.shape
    col_of = np.minimum(np.arange(w) // k, cols - 1)
    row_of = np.minimum(np.arange(h) // k, rows - 1)
    return np.take(np.take(coarse, col_of, axis=1), row_of, axis=0)
