"""Small algebra of the error-state filter's updates, written for 3-vectors as Python floats.

The updates run at 10 Hz per filter variant; numpy's per-call overhead (a few µs) would be most of
their cost, so 3-vectors are tuples of floats here and S⁻¹ has closed forms up to 3×3
(:func:`inverse_spd`; :mod:`twin.onboard.eskf_kernels` compiles the same).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
from scipy.stats import chi2

from twin.core.arrays import Float64Array as FloatArray
from twin.onboard.eskf_config import Triple


def cross3(a: Triple, b: Triple) -> Triple:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def tangent_basis(s: Triple) -> tuple[Triple, Triple]:
    """Two orthonormal vectors spanning the plane normal to the unit vector ``s``."""
    a = (1.0, 0.0, 0.0) if abs(s[0]) < 0.9 else (0.0, 1.0, 0.0)
    e1 = cross3(s, a)
    n = math.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
    e1 = (e1[0] / n, e1[1] / n, e1[2] / n)
    return e1, cross3(s, e1)


def unit3(name: str, value: Any) -> Triple:
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"Eskf.update_sun {name} = {value!r}: must be 3 finite numbers") from exc
    x, y, z = arr.tolist()
    n = math.sqrt(x * x + y * y + z * z)
    if not (math.isfinite(n) and 0.5 < n < 1.5):
        raise ValueError(
            f"Eskf.update_sun {name} = {value!r}: must be a finite unit vector (norm {n:.3g})"
        )
    return (x / n, y / n, z / n)


def inverse_spd(s: FloatArray) -> FloatArray:
    """S⁻¹ for a small symmetric positive-definite S.

    Closed form up to 3×3: np.linalg.inv's call overhead (≈ 10 µs) is several times the whole
    update's arithmetic.
    """
    m = s.shape[0]
    if m == 1:
        return 1.0 / s
    if m == 2:
        (a, b), (_, d) = s.tolist()
        det = a * d - b * b
        if det > 0.0:
            return np.array([[d, -b], [-b, a]]) / det
    elif m == 3:
        (a, b, c), (_, d, e), (_, _, f) = s.tolist()
        c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
        det = a * c00 + b * c01 + c * c02
        if det > 0.0:
            return (
                np.array(
                    [
                        [c00, c01, c02],
                        [c01, a * f - c * c, b * c - a * e],
                        [c02, b * c - a * e, a * d - b * b],
                    ]
                )
                / det
            )
    return np.linalg.inv(s)


@functools.lru_cache(maxsize=64)
def chi2_threshold(probability: float, dof: int) -> float:
    """χ²_dof⁻¹(p), the innovation gate (cached: scipy's quantile costs ~0.1 ms); ∞ for p ≥ 1."""
    return math.inf if probability >= 1.0 else float(chi2.ppf(probability, dof))


def dot3(a: Triple, b: Triple) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def given3(value: Any) -> Triple:
    x, y, z = np.asarray(value, dtype=np.float64).reshape(3).tolist()
    return (x, y, z)
