"""The CIE standard general sky (CIE S 011/E:2003, ISO 15469): the sky's radiance distribution.

Fifteen sky types, from overcast to turbid clear, each five numbers (a, b) of the gradation
φ(Z) and (c, d, e) of the scattering indicatrix f(χ); L/L_z = f(χ) φ(Z) / (f(Z_s) φ(0)).
:func:`~sensors.polarimeter.optics.sky.sky_radiance` evaluates it in blocks; the point-wise
formulas here are its oracles in the tests.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from sensors.polarimeter.optics.sun import sun_vector
from twin.core.arrays import FloatArray

#: CIE standard general sky types: type -> (a, b, c, d, e, description). CIE S 011/E:2003 Table 1
#: (as reproduced in optics.md §1.5).
CIE_SKY_TYPES: dict[int, tuple[float, float, float, float, float, str]] = {
    1: (4.0, -0.70, 0.0, -1.0, 0.00, "CIE standard overcast, steep gradation, azimuthal unif."),
    2: (4.0, -0.70, 2.0, -1.5, 0.15, "overcast, steep gradation, slight brightening towards sun"),
    3: (1.1, -0.80, 0.0, -1.0, 0.00, "overcast, moderately graded, azimuthal uniformity"),
    4: (1.1, -0.80, 2.0, -1.5, 0.15, "overcast, moderately graded, slight brightening to sun"),
    5: (0.0, -1.00, 0.0, -1.0, 0.00, "sky of uniform luminance"),
    6: (0.0, -1.00, 2.0, -1.5, 0.15, "partly cloudy, no gradation, slight brightening to sun"),
    7: (0.0, -1.00, 5.0, -2.5, 0.30, "partly cloudy, no gradation, brighter circumsolar"),
    8: (0.0, -1.00, 10.0, -3.0, 0.45, "partly cloudy, no gradation, distinct solar corona"),
    9: (-1.0, -0.55, 2.0, -1.5, 0.15, "partly cloudy, obscured sun"),
    10: (-1.0, -0.55, 5.0, -2.5, 0.30, "partly cloudy, brighter circumsolar"),
    11: (-1.0, -0.55, 10.0, -3.0, 0.45, "white-blue sky, distinct solar corona"),
    12: (-1.0, -0.32, 10.0, -3.0, 0.45, "CIE standard clear sky, low turbidity"),
    13: (-1.0, -0.32, 16.0, -3.0, 0.30, "CIE standard clear sky, polluted"),
    14: (-1.0, -0.15, 16.0, -3.0, 0.30, "cloudless turbid, broad corona"),
    15: (-1.0, -0.15, 24.0, -2.8, 0.15, "white-blue turbid, broad corona"),
}

#: Sky types whose sun is hidden: no solar disc unless ``sun_relative_radiance`` is given.
NO_DISC_TYPES = frozenset({1, 2, 3, 4, 9})


def cie_gradation(cos_z: FloatArray, a: float, b: float) -> FloatArray:
    """CIE gradation φ(Z) = 1 + a exp(b / cos Z) (CIE eq. 2); φ = 1 at and below the horizon."""
    cz = np.asarray(cos_z)
    if a == 0.0:
        return np.ones_like(cz)
    # b < 0: exp(b / cz) → 0 as cz → 0⁺; clamping cz keeps the horizon finite and exact (φ = 1).
    return 1.0 + a * np.exp(b / np.maximum(cz, 1e-30))


def cie_indicatrix(cos_chi: FloatArray, c: float, d: float, e: float) -> FloatArray:
    """CIE scattering indicatrix f(χ) = 1 + c[exp(dχ) − exp(dπ/2)] + e cos²χ (CIE eq. 3)."""
    cc = np.clip(np.asarray(cos_chi), -1.0, 1.0)
    out = 1.0 + e * cc * cc
    if c != 0.0:
        out = out + c * (np.exp(d * np.arccos(cc)) - math.exp(d * math.pi / 2))
    return out


def cie_relative_radiance(dirs: ArrayLike, sun_dir: ArrayLike, cie_type: int) -> FloatArray:
    """L/L_z of the CIE standard general sky type for ENU sky directions (CIE eq. 1).

    Directions below the horizon get φ = 1 (the horizon value); callers mask them.
    """
    if cie_type not in CIE_SKY_TYPES:
        raise ValueError(f"cie_type must be an integer 1..15, got {cie_type!r}")
    a, b, c, d, e = CIE_SKY_TYPES[cie_type][:5]
    p = np.asarray(dirs)
    s = sun_vector(sun_dir)
    norm = float(cie_indicatrix(np.float64(s[2]), c, d, e) * cie_gradation(np.float64(1.0), a, b))
    cos_chi = p @ s.astype(p.dtype)
    return cie_indicatrix(cos_chi, c, d, e) * cie_gradation(p[..., 2], a, b) / norm
