"""SITAN: the gravity-matching filter of wang2023 §4.

SITAN (Hostetler & Andreas 1983) is an extended Kalman filter whose measurement matrix is not
the map's gradient at one point but a slope fitted over the INS's confidence region
(stochastic linearisation). The paper's fit (eqs. 36–37) over the (2L+1)² nodes around the
INS-indicated node (i, j):

    h_λ = [Σ_{n=i+1..i+L, m=j−L..j+L} Δg_M − Σ_{n=i−L..i−1, m=j−L..j+L} Δg_M] / (L(2L+1)(L+1)δ),

and h_φ alike along the other axis: the difference of the mean anomaly on the two sides
divided by the distance between their centroids, (L+1)δ. L comes from the position covariance:
L = ⌈√(max eigenvalue of P)/δ⌉, at least 1 and at most ``max_half_window``. (The paper prints
the left-minus-right difference; with its z = h(x̂) − y and x̂ = x_INS − Δx that is the same
slope with the sign carried by the state; here the state is the position and H = +∂h/∂x.)

:func:`sitan_update` takes many filters at once (vectorised over runs), for the Monte Carlo in
:mod:`twin.scoring.gravity_matching`, which holds the truth side.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from twin.core.gravity_map import GravityGrid
from twin.onboard.gravity.pcrb import riccati_update


def sitan_slope(
    grid: GravityGrid, east_m: NDArray, north_m: NDArray, half_window: NDArray
) -> NDArray[np.float64]:
    """Eqs. 36–37 at the nearest nodes of points (N,), windows of half-width L (N,): (N, 2)."""
    i, j = grid.nearest_node(east_m, north_m)
    L = np.asarray(half_window, dtype=np.int64)
    de, dn = grid.spacing_m
    rows = (j - L, j + L + 1)
    cols = (i - L, i + L + 1)
    right = grid.window_sum(*rows, i + 1, i + L + 1)
    left = grid.window_sum(*rows, i - L, i)
    up = grid.window_sum(j + 1, j + L + 1, *cols)
    down = grid.window_sum(j - L, j, *cols)
    norm = L * (2 * L + 1) * (L + 1)
    return np.stack([(right - left) / (norm * de), (up - down) / (norm * dn)], axis=-1)


def sitan_update(
    x: NDArray[np.float64],
    p: NDArray[np.float64],
    y_mgal: NDArray[np.float64],
    stored: GravityGrid,
    r_mgal2: float,
    max_half_window: int = 10,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One SITAN measurement update, for many filters at once.

    Args:
        x: (runs, 2) position estimates, East/North (m).
        p: (runs, 2, 2) their covariances (m²).
        y_mgal: (runs,) the gravimeter's anomaly readings.
        stored: The map carried on board.
        r_mgal2: Measurement variance.
        max_half_window: Largest half-width L of the slope fit (nodes).

    Returns:
        The updated (x, p).
    """
    e0, e1, n0, n1 = stored.extent_m
    # An estimate pushed off the map is held at its edge for the map look-up.
    xe = np.clip(x[:, 0], e0, e1)
    xn = np.clip(x[:, 1], n0, n1)
    sig = np.sqrt(np.linalg.eigvalsh(p)[:, -1])
    half = np.clip(np.ceil(sig / min(stored.spacing_m)), 1, max_half_window)
    h = sitan_slope(stored, xe, xn, half)
    innov = y_mgal - stored.value(xe, xn)
    ph = np.einsum("nij,nj->ni", p, h)
    s = np.einsum("ni,ni->n", h, ph) + r_mgal2
    return x + ph * (innov / s)[:, None], riccati_update(p, h, r_mgal2)


__all__ = ["sitan_slope", "sitan_update"]
