"""The array types every module annotates with, declared once.

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

__all__ = ["BoolArray", "Float64Array", "FloatArray"]
