"""Comparison paths for a planned route: the Direct path and a family of parallel curves.

wang2023 §4 compares its planned path with the straight Direct path and with "equally spaced
curves" between the same start and goal (Test 1: L3…L9; Test 2: L3…L12, "a lateral distance of
5.5 km"). Their shape is not given; the twin bows each away from the Direct path by
k·spacing·sin(π s) at fraction s of the way (fixed ends, the k-th curve k spacings off at
mid-way), a family whose members are parallel in the middle and meet at the ends as the paper's
figures show. Every path is resampled to points equally spaced along it (the paper's 100).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def resample(path_m: ArrayLike, n: int = 100) -> NDArray[np.float64]:
    """``n`` points equally spaced along a polyline (ends kept)."""
    p = np.asarray(path_m, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2:
        raise ValueError(f"path: shape {p.shape}; allowed: (K >= 2, 2)")
    if n < 2:
        raise ValueError(f"n: {n!r}; allowed: >= 2")
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]
    t = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], axis=1)


def bowed(start_m, goal_m, offset_m: float, n: int = 100) -> NDArray[np.float64]:
    """A curve from start to goal, ``offset_m`` to the left of the Direct path at mid-way."""
    a, b = np.asarray(start_m, dtype=np.float64), np.asarray(goal_m, dtype=np.float64)
    d = b - a
    left = np.array([-d[1], d[0]]) / np.linalg.norm(d)
    s = np.linspace(0.0, 1.0, 4 * n)[:, None]
    return resample(a + s * d + offset_m * np.sin(np.pi * s) * left, n)


def lateral_offset_m(path_m: ArrayLike, start_m, goal_m) -> float:
    """Mean signed distance of a path to the left of the Direct path (m)."""
    a, b = np.asarray(start_m, dtype=np.float64), np.asarray(goal_m, dtype=np.float64)
    d = (b - a) / np.linalg.norm(b - a)
    rel = np.asarray(path_m, dtype=np.float64) - a
    return float(np.mean(rel[:, 0] * -d[1] + rel[:, 1] * d[0]))


def comparison_family(
    start_m, goal_m, count: int, spacing_m: float, around_m: float = 0.0, n: int = 100
) -> dict[str, NDArray[np.float64]]:
    """The Direct path and ``count`` bowed curves, named L3, L4, … from left to right.

    The curves' mid-way offsets are ``count`` consecutive non-zero multiples of ``spacing_m``
    centred, as nearly as the integers allow, on ``around_m`` (the planned path's bow, so the
    family brackets it as the paper's figures do).
    """
    if count < 1 or not spacing_m > 0:
        raise ValueError("count >= 1 and spacing_m > 0")
    centre = round(around_m / spacing_m)
    ks: list[int] = []
    lo = hi = centre
    if centre != 0:
        ks.append(centre)
    while len(ks) < count:
        hi += 1
        if hi != 0 and len(ks) < count:
            ks.append(hi)
        lo -= 1
        if lo != 0 and len(ks) < count:
            ks.append(lo)
    ks.sort(reverse=True)  # most to the left first
    out = {"Direct": resample(np.stack([start_m, goal_m]), n)}
    for idx, k in enumerate(ks):
        out[f"L{idx + 3}"] = bowed(start_m, goal_m, k * spacing_m, n)
    return out


__all__ = ["bowed", "comparison_family", "lateral_offset_m", "resample"]
