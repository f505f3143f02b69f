"""The analysis grid's block intensity and saturation mask in one compiled pass (numba).

With an analysis grid of 2×2 raw blocks (m = 2, the super-pixels: a 612×512 frame's grid),
:func:`~twin.onboard.compass.analysis_grid.block_intensity` (LIG's I, lu2025 eq. 5: 2 × (block
mean − black), the super-pixel S0 of any layout) and
:func:`~twin.onboard.compass.analysis_grid.block_saturation` (both methods' mask) are OpenCV
resizes of the window's box: a float32 copy of the raw box, ``INTER_AREA``, two numpy passes, and
for the mask a comparison, a product and a second resize. :func:`s0_and_mask` reads each block
once where it lies.

Same numbers, by exactness rather than by imitation: for an integer mosaic (uint8, uint16) and
an integer black level below 2¹⁶, every value on the way (the sum of a block's four raw values,
its quarter, the difference from the black level, twice that) is a multiple of ¼ below 2²⁰ in
magnitude, which float32 holds exactly. Each operation is then exact, in any order and whatever
OpenCV's vector and scalar code do, and a difference of equal values is +0 in both. The callers
check the mosaic and the black level (anything else takes the resizes);
``tests/onboard/compass/test_block_kernel.py`` holds the two to each other bit for bit.
"""

from __future__ import annotations

import numpy as np

from twin.core.kernel_cache import njit


@njit(cache=True)
def s0_and_mask(raw, r0, c0, rows, cols, black, sat_dn, s0_on, s0, sat):  # type: ignore[no-untyped-def]
    """2 × (block mean − black) and the saturation mask of the 2×2 blocks (r0 + i, c0 + j).

    Args: raw (H, W) uint8/uint16 (any strides); r0, c0 the first block; rows, cols how many;
    black the float32 black level (an integer); sat_dn the raw value at and above which a block
    is saturated; s0_on: fill s0. Out: s0 (rows, cols) float32 (or empty), sat (rows, cols) bool.
    """
    quarter = np.float32(0.25)
    two = np.float32(2.0)
    for i in range(rows):
        ra = 2 * (r0 + i)
        for j in range(cols):
            ca = 2 * (c0 + j)
            q0 = raw[ra, ca]
            q1 = raw[ra, ca + 1]
            q2 = raw[ra + 1, ca]
            q3 = raw[ra + 1, ca + 1]
            if s0_on:
                total = (np.float32(q0) + np.float32(q1)) + (np.float32(q2) + np.float32(q3))
                s0[i, j] = two * (total * quarter - black)
            top = max(max(q0, q1), max(q2, q3))
            sat[i, j] = np.float64(top) >= sat_dn
