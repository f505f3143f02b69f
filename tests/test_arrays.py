"""twin.core.arrays.row_norms: numpy's row norms, bit for bit."""

from __future__ import annotations

import numpy as np

from twin.core.arrays import row_norms


def test_row_norms_are_numpys_bit_for_bit():
    rng = np.random.default_rng(11)
    v = rng.standard_normal((200_000, 3)) * 10.0 ** rng.uniform(-8, 8, (200_000, 1))
    v[:5] = [[0, 0, 0], [1, 0, 0], [0, -1, 0], [3, 4, 0], [1e-300, 1e-300, 1e-300]]
    assert np.array_equal(row_norms(v), np.linalg.norm(v, axis=1))
    # A strided view (columns of a wider array) too.
    w = rng.standard_normal((1000, 5))
    assert np.array_equal(row_norms(w[:, 1:4]), np.linalg.norm(w[:, 1:4], axis=1))
