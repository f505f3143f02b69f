"""A light-field table field at one frame's depth and sun, compiled (:meth:`LightFieldTable.frame`).

A frame reads up to five of a table's fields (the sun's, the sky's, their upwelling light at the
surface, the aureole) at its depth and sun: per field, two sun nodes each interpolated in depth,
each warped to the frame's sun inside Snell's window, then blended; about thirty numpy calls on
arrays of ~1 300 values, whose per-call cost is most of their time (0.3 ms of a frame at the sea
trial's flat sea). :func:`at` does the same element-wise operations in one compiled pass, in
float64 where numpy promotes to it, in numpy's order, so the field is numpy's bit for bit
(``tests/sensors/polarimeter/test_frame_kernel.py`` holds it to
``LightFieldTable._at_numpy``, the reference, at and between nodes). The scalars (the depth
node, its weights, the irradiance factor) stay in Python, computed as before.
"""

from __future__ import annotations

import numpy as np

from twin.core.kernel_cache import njit


@njit(cache=True, inline="always")
def _at_depth(tab, node, row, c, coefs):  # type: ignore[no-untyped-def]
    """One value of a node's field at depth: ((w₀ F[k]) / E_k + (w₁ F[k+1]) / E_k+1) · e."""
    k, w0, w1, d0, d1, e = coefs
    k = int(k)
    return (
        (w0 * np.float64(tab[node, k, row[0], row[1], c])) / d0
        + (w1 * np.float64(tab[node, k + 1, row[0], row[1], c])) / d1
    ) * e


@njit(cache=True)
def at(tab, i, coefs_a, coefs_b, k_a, t_a, k_b, t_b, f, out):  # type: ignore[no-untyped-def]
    """Sun nodes i and i + 1 of ``tab`` at depth, warped, blended: (R, P, 3) float64 into ``out``.

    Args:
        tab: (nodes, planes, R, P, 3) the table's field.
        i: The sun node below the frame's sun.
        coefs_a: Node i's depth interpolation (k, 1 − t, t, E_k, E_k+1, e)
            (``LightFieldTable._depth_coefs``).
        coefs_b: Node i + 1's.
        k_a: Node i's warp rows (``LightFieldTable._warp_rows``: the first ``len(k_a)`` rows
            are resampled at rows k and k + 1); empty: no warp.
        t_a: Their weights (of row k + 1).
        k_b: Node i + 1's warp rows.
        t_b: Their weights.
        f: The weight of node i + 1.
        out: (R, P, 3) float64, written.
    """
    n_rows, n_phi = tab.shape[2], tab.shape[3]
    n_in = k_a.shape[0]
    g = 1.0 - f
    for r in range(n_rows):
        for p in range(n_phi):
            for c in range(3):
                if r < n_in:
                    ka, kb = k_a[r], k_b[r]
                    ta, tb = t_a[r], t_b[r]
                    a = (1.0 - ta) * _at_depth(tab, i, (ka, p), c, coefs_a) + ta * _at_depth(
                        tab, i, (ka + 1, p), c, coefs_a
                    )
                    b = (1.0 - tb) * _at_depth(tab, i + 1, (kb, p), c, coefs_b) + tb * _at_depth(
                        tab, i + 1, (kb + 1, p), c, coefs_b
                    )
                else:
                    a = _at_depth(tab, i, (r, p), c, coefs_a)
                    b = _at_depth(tab, i + 1, (r, p), c, coefs_b)
                out[r, p, c] = g * a + f * b
