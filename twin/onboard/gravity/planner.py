"""A* over the map grid with the PCRB as its cost (wang2023 §3).

Each node reached carries the bound P_{n|n} of the path that reached it. Expanding node n to a
neighbour n+1 at distance d_f (eq. 23): Q_n = Q_t d_f / V (eq. 25), P⁻ = P + Q_n (eq. 26), the
Riccati update with the neighbour's gradient (eq. 27), and G(n+1) = G(n) + tr P_{n+1|n+1}
(eq. 28). The heuristic (eq. 29) is H(n) = tr(Q_t) d_g / V, d_g the straight distance to the
goal; F = G + H. Open and closed lists as usual; a node is closed the first time it leaves the
open list.

Two properties the paper does not state, which follow from the construction:

* The cost-to-come depends on the path through P, so a node's best G is not a function of the
  node alone: closing it on first expansion (the paper's pseudo-code) makes the result the best
  path A* finds, not a guaranteed optimum over all paths.
* The heuristic counts the variance growth over the rest of the way, tr(Q_t) d_g / V, while G
  sums a trace at every node; its per-node share is tiny, so the search is close to Dijkstra's on
  G (admissible — it never overestimates — but weak). The benchmark records the nodes expanded.

Moves are 8-connected on the grid; ``blocked`` nodes (land, a forbidden zone) are never entered.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twin.core.gravity_map import GravityGrid
from twin.onboard.gravity.pcrb import GainsModel

_MOVES = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))


class UnreachableGoalError(ValueError):
    """No path from the start reaches the goal around the blocked nodes."""


@dataclass(frozen=True, slots=True)
class PlannedPath:
    """The planner's answer.

    Attributes:
        nodes_m: (K, 2) East/North of the nodes from start to goal (m).
        cost_m2: G at the goal: Σ tr P over the path's nodes (m²).
        expanded: Nodes taken off the open list.
        seconds: Wall time of the search.
    """

    nodes_m: NDArray[np.float64]
    cost_m2: float
    expanded: int
    seconds: float

    @property
    def length_m(self) -> float:
        return float(np.sum(np.linalg.norm(np.diff(self.nodes_m, axis=0), axis=1)))


def plan(
    grid: GravityGrid,
    start_m: tuple[float, float],
    goal_m: tuple[float, float],
    model: GainsModel,
    *,
    blocked: ArrayLike | None = None,
) -> PlannedPath:
    """The PCRB-A* path from the node nearest ``start_m`` to the node nearest ``goal_m``.

    Raises:
        OffMapError: start or goal off the map.
        UnreachableGoalError: the goal cannot be reached (or start/goal are blocked).
    """
    t0 = time.perf_counter()
    grid.require_on_map(start_m[0], start_m[1], "start")
    grid.require_on_map(goal_m[0], goal_m[1], "goal")
    ny, nx = grid.values_mgal.shape
    block = np.zeros((ny, nx), bool) if blocked is None else np.asarray(blocked, bool)
    if block.shape != (ny, nx):
        raise ValueError(f"blocked: shape {block.shape}; allowed: the map's ({ny}, {nx})")
    si, sj = (int(v) for v in grid.nearest_node(*start_m))
    gi, gj = (int(v) for v in grid.nearest_node(*goal_m))
    for name, (i, j) in (("start", (si, sj)), ("goal", (gi, gj))):
        if block[j, i]:
            raise UnreachableGoalError(f"{name}: the node at its position is blocked")
    de, dn = grid.spacing_m
    ee, nn = np.meshgrid(grid.east_m, grid.north_m)
    grad = grid.node_gradient(ee, nn)
    hx, hy = grad[..., 0].tolist(), grad[..., 1].tolist()  # Python floats: the loop is scalar
    r = model.r_mgal2
    q_rate, v = model.q_rate_m2_per_s, model.speed_mps
    h_rate = 2.0 * q_rate / v  # tr(Q_t)/V per metre to go
    blk = block.tolist()

    def update(a: float, b: float, c: float, i: int, j: int) -> tuple[float, float, float]:
        # P = [[a, b], [b, c]]; scalar measurement with H = (hx, hy).
        x, y = hx[j][i], hy[j][i]
        pa, pb = a * x + b * y, b * x + c * y
        s = x * pa + y * pb + r
        return a - pa * pa / s, b - pa * pb / s, c - pb * pb / s

    def heuristic(i: int, j: int) -> float:
        return h_rate * math.hypot((i - gi) * de, (j - gj) * dn)

    p = update(model.p0_m2, 0.0, model.p0_m2, si, sj)
    g0 = p[0] + p[2]
    best_g = {(si, sj): g0}
    state = {(si, sj): p}
    parent: dict[tuple[int, int], tuple[int, int] | None] = {(si, sj): None}
    heap = [(g0 + heuristic(si, sj), g0, si, sj)]
    closed: set[tuple[int, int]] = set()
    expanded = 0
    step = [math.hypot(di * de, dj * dn) for di, dj in _MOVES]
    while heap:
        _, g, i, j = heapq.heappop(heap)
        if (i, j) in closed or g > best_g[(i, j)]:
            continue
        closed.add((i, j))
        expanded += 1
        if (i, j) == (gi, gj):
            break
        a, b, c = state[(i, j)]
        for (di, dj), d in zip(_MOVES, step, strict=True):
            ci, cj = i + di, j + dj
            if not (0 <= ci < nx and 0 <= cj < ny) or blk[cj][ci] or (ci, cj) in closed:
                continue
            q = q_rate * d / v
            pa, pb, pc = update(a + q, b, c + q, ci, cj)
            gc = g + pa + pc
            if gc < best_g.get((ci, cj), math.inf):
                best_g[(ci, cj)] = gc
                state[(ci, cj)] = (pa, pb, pc)
                parent[(ci, cj)] = (i, j)
                heapq.heappush(heap, (gc + heuristic(ci, cj), gc, ci, cj))
    if (gi, gj) not in closed:
        raise UnreachableGoalError(
            f"goal: (E {goal_m[0]:.0f} m, N {goal_m[1]:.0f} m) cannot be reached from the start "
            "around the blocked nodes"
        )
    nodes = []
    k: tuple[int, int] | None = (gi, gj)
    while k is not None:
        nodes.append((grid.east_m[k[0]], grid.north_m[k[1]]))
        k = parent[k]
    return PlannedPath(
        np.asarray(nodes[::-1]), best_g[(gi, gj)], expanded, time.perf_counter() - t0
    )


__all__ = ["PlannedPath", "UnreachableGoalError", "plan"]
