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
    """Eqs. 36–37 at the nearest nodes of points (N,), windows of half-width L (N,): (N, 2).

    Away from the map's edge this is the paper's expression. A window the edge cuts is the same
    fit over the nodes present: each side's mean over its own nodes, divided by the distance
    between the two sides' centroids (the paper's normaliser L(2L+1)(L+1)δ counts nodes that are
    not there, which read as 0 mGal). A side with no node left (the point on the edge) is the
    centre column or row itself, a one-sided difference. Exact on a plane at any window, on the
    edge and off it (tests/onboard/test_gravity_nav.py).
    """
    i, j = grid.nearest_node(east_m, north_m)
    L = np.asarray(half_window, dtype=np.int64)
    ny, nx = grid.values_mgal.shape
    de, dn = grid.spacing_m
    e_slope = _side_difference(grid, i, j, L, nx, ny, along_east=True) / de
    n_slope = _side_difference(grid, j, i, L, ny, nx, along_east=False) / dn
    return np.stack([e_slope, n_slope], axis=-1)


def _side_difference(
    grid: GravityGrid,
    k: NDArray,
    m: NDArray,
    L: NDArray,
    n_along: int,
    n_across: int,
    *,
    along_east: bool,
) -> NDArray[np.float64]:
    """(Mean of the + side − mean of the − side) / centroid distance in nodes, along one axis.

    ``k`` indexes the axis the slope is along (``n_along`` nodes), ``m`` the other.
    """
    a0 = np.clip(m - L, 0, n_across)
    a1 = np.clip(m + L + 1, 0, n_across)
    plus0 = k + 1
    plus1 = np.minimum(k + L + 1, n_along)
    edge = plus1 <= plus0  # on the + edge: the centre line stands in
    plus0 = np.where(edge, k, plus0)
    plus1 = np.where(edge, k + 1, plus1)
    minus0 = np.maximum(k - L, 0)
    minus1 = k.copy()
    edge = minus1 <= minus0
    minus0 = np.where(edge, k, minus0)
    minus1 = np.where(edge, k + 1, minus1)

    def mean(b0: NDArray, b1: NDArray) -> NDArray[np.float64]:
        if along_east:
            total = grid.window_sum(a0, a1, b0, b1)
        else:
            total = grid.window_sum(b0, b1, a0, a1)
        return total / ((b1 - b0) * (a1 - a0))

    # Centroid of nodes b0..b1−1, relative to k: (b0 + b1 − 1)/2 − k.
    dist = 0.5 * ((plus0 + plus1) - (minus0 + minus1))
    return (mean(plus0, plus1) - mean(minus0, minus1)) / dist


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
