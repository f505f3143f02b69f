"""The gravity-aided run in the recording: the map, the route, the paths and the filters' ellipses.

Two images, north up, one pixel a stored-map node:

* ``/gravity/map``: the vehicle's stored anomaly map (viridis), with the planned route
  (``route``), the true path (``truth``, growing) and every variant's estimate with its 2σ
  position ellipse (``<variant>``, at the truth rate);
* ``/gravity/information``: wang2023's navigation-information map M = |∇h|²/R (eq. 19), where
  the planner looks for information.

The recording side sees both (truth and the vehicle's map); the onboard code logs nothing.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr

from twin.onboard.gravity.pcrb import information_map

if TYPE_CHECKING:
    from twin.core.gravity_map import GravityGrid
    from twin.record.recorder import Recorder
    from twin.sim.step import Simulation
    from twin.world.truth import Truth

MAP_ENTITY = "/gravity/map"
INFO_ENTITY = "/gravity/information"
_TRUTH_RGB = (255, 255, 255)
_ROUTE_RGB = (255, 80, 80)
_VARIANT_RGB = ((255, 200, 0), (0, 220, 255), (255, 120, 220), (120, 255, 120))


def _rgb(values: np.ndarray) -> np.ndarray:
    """Viridis of ``values`` scaled to its own range, north up (uint8 (H, W, 3))."""
    from matplotlib import colormaps

    v = np.asarray(values, dtype=np.float64)
    lo, hi = float(np.min(v)), float(np.max(v))
    x = (v - lo) / (hi - lo) if hi > lo else np.zeros_like(v)
    rgb = colormaps["viridis"](x)[..., :3]
    return (rgb[::-1] * 255).astype(np.uint8)


def to_pixels(grid: GravityGrid, en_m: np.ndarray) -> np.ndarray:
    """Map coordinates (m) → image pixels (u right = East, v down = South)."""
    p = np.asarray(en_m, dtype=np.float64).reshape(-1, 2)
    de, dn = grid.spacing_m
    u = (p[:, 0] - grid.east_m[0]) / de
    v = (grid.north_m[-1] - p[:, 1]) / dn
    return np.stack([u, v], axis=1)


def log_gravity_scene(rec: Recorder, sim: Simulation) -> None:
    """The static layers: the stored map, M, the planned route."""
    stored = sim.stored_map
    if stored is None:
        return
    grid = stored.grid
    rec.log_archetype(MAP_ENTITY, rr.Image(_rgb(grid.values_mgal)), static=True)
    info = information_map(grid, math.sqrt(stored.variance_mgal2))
    rec.log_archetype(INFO_ENTITY, rr.Image(_rgb(np.log10(info + 1e-12))), static=True)
    if sim.route is not None:
        px = to_pixels(grid, sim.route.nodes_m)
        strip = rr.LineStrips2D([px], colors=[_ROUTE_RGB], labels=["planned route"], radii=0.3)
        rec.log_archetype(f"{MAP_ENTITY}/route", strip, static=True)
        rec.log_archetype(f"{INFO_ENTITY}/route", strip, static=True)


def log_gravity_sample(rec: Recorder, sim: Simulation, truth: Truth) -> None:
    """The true position and each variant's estimate with its 2σ ellipse, now."""
    stored = sim.stored_map
    if stored is None:
        return
    grid = stored.grid
    e0, n0 = stored.launch_m
    here = np.array([[e0 + truth.position_n[0], n0 + truth.position_n[1]]])
    rec.log_archetype(
        f"{MAP_ENTITY}/truth",
        rr.Points2D(to_pixels(grid, here), colors=[_TRUTH_RGB], radii=0.4, labels=["truth"]),
        t=truth.t,
    )
    phi = np.linspace(0.0, 2 * math.pi, 49)
    for k, (name, nav) in enumerate(sim.navigators.items()):
        est = nav.estimate()
        e, n = nav.local_en(est)
        centre = np.array([e0 + e, n0 + n])
        m_n, m_e = nav.metres_per_radian
        jac = np.diag([m_e, m_n])
        p = jac @ est.covariance[[7, 6]][:, [7, 6]] @ jac  # (E, N) from (δλ, δL), m²
        w, v = np.linalg.eigh(0.5 * (p + p.T))
        axes = v * (2.0 * np.sqrt(np.maximum(w, 0.0)))
        ring = centre + (axes @ np.stack([np.cos(phi), np.sin(phi)])).T
        color = _VARIANT_RGB[k % len(_VARIANT_RGB)]
        rec.log_archetype(
            f"{MAP_ENTITY}/{name}",
            rr.LineStrips2D([to_pixels(grid, ring)], colors=[color], labels=[f"{name} 2σ"]),
            t=truth.t,
        )


__all__ = ["INFO_ENTITY", "MAP_ENTITY", "log_gravity_sample", "log_gravity_scene", "to_pixels"]
