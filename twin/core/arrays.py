"""The array types every module annotates with, declared once, and one helper on them.

``FloatArray`` is any floating dtype (the renderer keeps float32 frames); ``Float64Array`` is
float64 where a module's arithmetic needs it (the filter, the INS, the calibration). Both sides of
the world/onboard boundary import them from here.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.floating]
Float64Array = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def row_norms(v: FloatArray) -> FloatArray:
    """The Euclidean norm of each row of an (N, 3) array: ``np.linalg.norm(v, axis=1)``'s numbers.

    √((x² + y²) + z²), the order numpy's reduction over the short axis adds in (bit for bit,
    ``tests/test_arrays.py``), at a sixth of its time (~3 ns a row against ~19: the reduction's
    per-row overhead dominates three elements).
    """
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    return np.sqrt(x * x + y * y + z * z)


__all__ = ["BoolArray", "Float64Array", "FloatArray", "row_norms"]
