"""Directions about Snell's window, shared by the compass methods.

The local-meridian basis of a direction (the reference of every E-vector here; fang2024 eq. 17's
R_i^b, first two columns), Snell's window half-angle, and the refraction of in-water look
directions to the air directions they see (lu2025 eq. 11) and back.
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.arrays import Float64Array as FloatArray


def critical_angle(water_index: float) -> float:
    """Snell's window half-angle arcsin(n_a/n_w), n_a = 1 (eq. 7's threshold)."""
    return math.asin(1.0 / water_index) if water_index > 1.0 else math.pi / 2


def meridian_basis(d: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(e_θ, e_φ) at directions d (…, 3): e_θ along increasing zenith angle, e_φ = ẑ × d / |…|.

    At the zenith (undefined meridian) x̂ and ŷ are used; (d, e_θ, e_φ) is right-handed.
    """
    rxy = np.hypot(d[..., 0], d[..., 1])
    safe = rxy > 1e-12
    cphi = np.where(safe, d[..., 0] / np.where(safe, rxy, 1.0), 1.0)
    sphi = np.where(safe, d[..., 1] / np.where(safe, rxy, 1.0), 0.0)
    z = d[..., 2]
    e_t = np.stack([z * cphi, z * sphi, -rxy], axis=-1)
    e_p = np.stack([-sphi, cphi, np.zeros_like(z)], axis=-1)
    return e_t, e_p


def refract_to_air(p_h: FloatArray, n_w: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """In-water look directions (level frame) → the air directions they see (eq. 11).

    Returns (d_air, sin r, sin i); same azimuth, sin i = n_w sin r (clipped at 1).
    """
    sin_r = np.hypot(p_h[..., 0], p_h[..., 1])
    sin_i = np.minimum(n_w * sin_r, 1.0)
    cos_i = np.sqrt(np.maximum(1.0 - sin_i * sin_i, 0.0))
    scale = np.divide(sin_i, sin_r, out=np.full_like(sin_r, n_w), where=sin_r > 1e-12)
    d = np.stack([p_h[..., 0] * scale, p_h[..., 1] * scale, cos_i], axis=-1)
    return d, sin_r, sin_i


def refract_back(s_w: FloatArray, n_w: float) -> FloatArray:
    """The air direction of a refracted (in-water) sun: same azimuth, sin θ_a = n sin θ_w."""
    rxy = math.hypot(s_w[0], s_w[1])
    if rxy < 1e-12:
        return s_w.copy()
    sa = min(n_w * rxy, 1.0)
    ca = math.copysign(math.sqrt(max(1.0 - sa * sa, 0.0)), s_w[2])
    return np.array([s_w[0] / rxy * sa, s_w[1] / rxy * sa, ca])
