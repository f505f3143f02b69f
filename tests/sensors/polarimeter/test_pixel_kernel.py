"""The fast path's compiled gathers and scatters are numpy's fancy indexing, value for value."""

from __future__ import annotations

import numpy as np

from sensors.polarimeter import pixel_kernel


def test_gathers_and_scatters_are_numpys():
    rng = np.random.default_rng(5)
    planar = rng.standard_normal((3, 5000)).astype(np.float32)
    idx = rng.choice(5000, 700, replace=False).astype(np.intp)
    out = np.empty((700, 3), np.float32)
    pixel_kernel.gather_columns(planar, idx, out)
    assert np.array_equal(out, planar[:, idx].T)
    rows = np.ascontiguousarray(planar.T)
    again = np.empty_like(out)
    pixel_kernel.gather_rows(rows, idx, again)
    assert np.array_equal(again, rows[idx])
    flat = rng.standard_normal((5000, 3)).astype(np.float32)
    want = flat.copy()
    want[idx] = out
    pixel_kernel.scatter_rows(flat, idx, out)
    assert np.array_equal(flat, want)
