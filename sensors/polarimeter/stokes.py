"""Linear Stokes vectors with explicit 3-D reference axes (the chain's one polarization convention).

Arrays broadcast over leading axes: ``stokes`` is (..., 3) = (I, Q, U); directions and reference
vectors are (..., 3) unit vectors. ``d`` is the direction the light travels (from the source
towards the camera). The E-vector at angle ψ from ``ref`` is ``cos ψ · ref + sin ψ · (d × ref)``.
"""

from __future__ import annotations

import numpy as np

from twin.core.arrays import FloatArray


def _unit(v: FloatArray) -> FloatArray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def reference_angle(d: FloatArray, ref_from: FloatArray, ref_to: FloatArray) -> FloatArray:
    """Angle χ from ``ref_from`` to ``ref_to`` about ``d`` (radians, right-handed about d).

    Both references must be perpendicular to ``d``.
    """
    cross = np.cross(ref_from, ref_to)
    return np.arctan2(np.sum(cross * d, axis=-1), np.sum(ref_from * ref_to, axis=-1))


def rotate_reference(
    stokes: FloatArray, d: FloatArray, ref_from: FloatArray, ref_to: FloatArray
) -> FloatArray:
    """Re-express Stokes vectors relative to a new reference axis (same light, new frame).

    An E-vector at ψ from ``ref_from`` is at ψ − χ from ``ref_to`` (χ from :func:`reference_angle`),
    so (Q, U) rotate by −2χ.
    """
    chi = reference_angle(d, ref_from, ref_to)
    c, s = np.cos(2 * chi), np.sin(2 * chi)
    out = np.array(stokes, dtype=np.result_type(stokes, np.float32), copy=True)
    q, u = stokes[..., 1], stokes[..., 2]
    out[..., 1] = c * q + s * u
    out[..., 2] = -s * q + c * u
    return out


def from_evector(
    intensity: FloatArray, dop: FloatArray, e_vec: FloatArray, d: FloatArray, ref: FloatArray
) -> FloatArray:
    """Stokes (I, Q, U) of light with degree of polarization ``dop`` and E-vector ``e_vec``.

    ``e_vec`` need not be normalised or exactly perpendicular to ``d``: its component along ``d``
    is removed. Where it is zero (an unpolarized point) the result has Q = U = 0.
    """
    e = e_vec - np.sum(e_vec * d, axis=-1, keepdims=True) * d
    psi = np.arctan2(np.sum(e * np.cross(d, ref), axis=-1), np.sum(e * ref, axis=-1))
    ip = intensity * dop
    return np.stack([intensity, ip * np.cos(2 * psi), ip * np.sin(2 * psi)], axis=-1)


def to_aop_dop(stokes: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(AoP in [-π/2, π/2) from the reference axis, DoP in [0, 1]) of Stokes vectors.

    Where I == 0 the DoP is 0 (a dark pixel carries no polarization), never NaN.
    """
    i, q, u = stokes[..., 0], stokes[..., 1], stokes[..., 2]
    aop = 0.5 * np.arctan2(u, q)
    aop = np.where(aop >= np.pi / 2, aop - np.pi, aop)
    lin = np.hypot(q, u)
    dop = np.divide(lin, i, out=np.zeros_like(lin), where=i > 0)
    return aop, np.clip(dop, 0.0, 1.0)


def to_evector(stokes: FloatArray, d: FloatArray, ref: FloatArray) -> FloatArray:
    """Unit E-vector direction(s) of Stokes vectors given their reference (mod sign)."""
    aop, _ = to_aop_dop(stokes)
    c, s = np.cos(aop)[..., None], np.sin(aop)[..., None]
    return _unit(c * ref + s * np.cross(d, ref))


def meridian_reference(d: FloatArray, up: FloatArray | None = None) -> FloatArray:
    """The local-meridian reference axis for light travelling along ``d``.

    The unit vector perpendicular to ``d`` in the vertical plane containing ``d`` (the plane of
    incidence on a flat horizontal surface), pointing towards ``up`` (default ENU +z). For a ray
    along the vertical the meridian is undefined; the world +y (North) axis is used there.
    """
    up_v = np.array([0.0, 0.0, 1.0]) if up is None else np.asarray(up, dtype=float)
    r = up_v - np.sum(up_v * d, axis=-1, keepdims=True) * d
    n = np.linalg.norm(r, axis=-1, keepdims=True)
    fallback = np.broadcast_to(np.array([0.0, 1.0, 0.0]), r.shape)
    return np.where(n > 1e-9, r / np.where(n > 1e-9, n, 1.0), fallback)
