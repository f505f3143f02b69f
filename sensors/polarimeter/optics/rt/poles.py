"""Smooth rings at the zenith and the nadir of a tabulated Stokes field.

The look-direction bins next to the poles have the smallest solid angles, hence the largest Monte
Carlo noise, and converge on one point, where per-bin noise would make the field jump; a smooth
field's rings there hold only a few azimuthal harmonics (:func:`smooth`).
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.arrays import FloatArray


def pole_ring(rings: FloatArray, n_phi: int) -> FloatArray:
    """(..., n_phi, 3) rings projected on I: {1, cos φ}, Q: {1, cos 2φ}, U: {sin 2φ}."""
    phi = (np.arange(n_phi) + 0.5) * math.pi / n_phi
    out = np.empty_like(rings)
    for i, basis in enumerate(
        (
            np.stack([np.ones_like(phi), np.cos(phi)], 1),
            np.stack([np.ones_like(phi), np.cos(2 * phi)], 1),
            np.sin(2 * phi)[:, None],
        )
    ):
        proj = basis @ np.linalg.pinv(basis)
        out[..., i] = np.einsum("ij,...j->...i", proj, rings[..., i])
    np.maximum(out[..., 0], 0.0, out=out[..., 0])
    return out


def pole(ring: FloatArray, c2: FloatArray, s2: FloatArray) -> FloatArray:
    """(n_phi, 3) the zenith's (or nadir's) Stokes in each column's meridian frame.

    ``c2``, ``s2``: cos 2φ and sin 2φ at the columns' azimuths φ.
    """
    a = 2.0 * np.mean(ring[:, 1] * c2)  # Q = a cos 2φ (the ring's own m = 2 terms)
    b = 2.0 * np.mean(ring[:, 2] * s2)  # U = b sin 2φ
    out = np.empty_like(ring)
    out[:, 0] = ring[:, 0].mean()
    out[:, 1] = a * c2
    out[:, 2] = b * s2
    return out


def smooth(field: FloatArray, n_phi: int, rows: tuple[int, ...] = (0, -1)) -> FloatArray:
    """A (S, P, T, n_phi, 3) field with the rings next to the zenith and the nadir made smooth.

    Those rings are reduced to what a smooth field has there: I = mean + a cos φ gradient,
    (Q, U) the m = 2 pattern of a fixed polarization in the meridian frame (I, Q even in φ,
    U odd). Their bins have the smallest solid angles, hence the largest Monte Carlo noise,
    and converge on one point, where per-bin noise would make the field jump.
    """
    out = field.copy()
    for r in rows:
        out[..., r, :, :] = pole_ring(out[..., r, :, :], n_phi)
    return out
