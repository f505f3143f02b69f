"""The fast path's gathers and scatters of pixel rows, compiled (issue #31).

Pure copies, so the numbers are the numpy versions' by construction: a frame's exact pixels'
rays gathered from the camera's planar storage and their Stokes scattered back into the frame,
the coarse points' likewise. numpy's fancy indexing pays per element for its generality; these
are one loop each over the pixels concerned (~20 000 of a 612×512 frame's 313 000).
"""

from __future__ import annotations

from twin.core.kernel_cache import njit


@njit(cache=True)
def gather_columns(planar, idx, out):  # type: ignore[no-untyped-def]
    """out[i] = planar[:, idx[i]] for (3, M) ``planar`` and (N, 3) ``out``."""
    for i in range(idx.shape[0]):
        j = idx[i]
        out[i, 0] = planar[0, j]
        out[i, 1] = planar[1, j]
        out[i, 2] = planar[2, j]


@njit(cache=True)
def gather_rows(rows, idx, out):  # type: ignore[no-untyped-def]
    """out[i] = rows[idx[i]] for (M, 3) ``rows`` and (N, 3) ``out``."""
    for i in range(idx.shape[0]):
        j = idx[i]
        out[i, 0] = rows[j, 0]
        out[i, 1] = rows[j, 1]
        out[i, 2] = rows[j, 2]


@njit(cache=True)
def scatter_rows(flat, idx, rows):  # type: ignore[no-untyped-def]
    """flat[idx[i]] = rows[i] for (M, 3) ``flat`` and (N, 3) ``rows``."""
    for i in range(idx.shape[0]):
        j = idx[i]
        flat[j, 0] = rows[i, 0]
        flat[j, 1] = rows[i, 1]
        flat[j, 2] = rows[i, 2]
