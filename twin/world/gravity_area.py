"""A scenario's operating area for gravity: the world's field, the vehicle's stored map, the route.

World side. From the scenario's ``[gravity]`` table:

* :func:`gravity_field`: the true anomaly field (``twin.world.gravity``: a synthetic seafloor
  forward-modelled with harmonica, the wang2023 study's map; ``twin.world.gravity_random``: a map
  drawn by its statistics; or a grid file), the same for every
  run of the scenario (its own ``map_seed``), cached per process — a campaign worker models a
  seafloor once;
* :func:`stored_map`: what the vehicle carries — every k-th node of the field (its spacing δ is
  the stored map's resolution, whose interpolation error eq. 3's C₀β²δ⁴/4 stands for) plus an
  independent N(0, σ_m²) error per node (wang2023: σ_m, Sandwell's grid "better than 1.7 mGal"),
  drawn per run from the run's seed;
* :func:`launch_on_map`: where the scenario's place (the ENU origin) lies on the map;
* :func:`check_gravity`: what a run would reject (no map for a gravimeter, a launch point or a
  route off the map, a file that cannot be read), as ``field: message`` lines.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from scenarios.schema import Gravity, Scenario
from twin.core.gravity_map import GravityGrid, load_grid
from twin.core.mission import (
    LawnmowerMission,
    LegsMission,
    PlannedMission,
    StationKeepingMission,
    WaypointLeg,
)
from twin.world.gravity import SeafloorSpec, anomaly_grid, wang2023_seafloor
from twin.world.gravity_random import PAD_LENGTHS, RandomFieldSpec, random_anomaly_grid

#: Keep the route this far inside the map's edge: SITAN's slope window and the filter's
#: uncertainty reach a few nodes around the estimate.
EDGE_MARGIN_NODES = 3


def _spec(g: Gravity) -> SeafloorSpec:
    if g.map == "wang2023":
        return wang2023_seafloor()
    return SeafloorSpec(
        size_m=(g.size_km[0] * 1000.0, g.size_km[1] * 1000.0), spacing_m=g.spacing_m
    )


def _random_spec(g: Gravity) -> RandomFieldSpec:
    return RandomFieldSpec(
        size_m=(g.size_km[0] * 1000.0, g.size_km[1] * 1000.0),
        spacing_m=g.spacing_m,
        correlation_m=g.correlation_km * 1000.0,
        range_mgal=g.range_mgal,
    )


@functools.lru_cache(maxsize=4)
def _field_cached(g: Gravity) -> GravityGrid:
    if g.map == "file":
        grid = load_grid(g.file, variable=g.variable or None, spacing_m=g.spacing_m)
        return grid
    rng = np.random.default_rng(g.map_seed)
    if g.map == "random":
        grid = random_anomaly_grid(_random_spec(g), rng)
        return grid.with_values(grid.values_mgal, f"{grid.source} (map_seed {g.map_seed})")
    grid = anomaly_grid(_spec(g), rng)
    kind = "wang2023 map" if g.map == "wang2023" else "synthetic seafloor"
    return grid.with_values(grid.values_mgal, f"{kind} (map_seed {g.map_seed})")


def gravity_field(scenario: Scenario) -> GravityGrid | None:
    """The world's anomaly field of the scenario, or None without a map.

    Raises:
        ValueError: A file map that cannot be read (naming the file and why).
    """
    g = scenario.gravity
    if g.map == "none":
        return None
    return _field_cached(g)


def field_extent_m(g: Gravity) -> tuple[float, float, float, float] | None:
    """(east0, east1, north0, north1) of the field without building it (None: a file's)."""
    if g.map == "none" or g.map == "file":
        return None
    spec = _random_spec(g) if g.map == "random" else _spec(g)
    return (0.0, spec.size_m[0], 0.0, spec.size_m[1])


def launch_on_map(g: Gravity, extent: tuple[float, float, float, float]) -> tuple[float, float]:
    """Map coordinates (m) of the launch point (the scenario's place)."""
    e0, e1, n0, n1 = extent
    if g.launch_km is None:
        return (0.5 * (e0 + e1), 0.5 * (n0 + n1))
    return (e0 + g.launch_km[0] * 1000.0, n0 + g.launch_km[1] * 1000.0)


def field_at_stored_spacing(scenario: Scenario, field: GravityGrid) -> GravityGrid:
    """The true field at the stored map's nodes, without the map's error (the bound's map)."""
    g = scenario.gravity
    de = float(min(field.spacing_m))
    k = max(1, round(g.stored_spacing_m / de))
    e, n = field.east_m[::k], field.north_m[::k]
    if e.size < 2 or n.size < 2:
        raise ValueError(
            f"gravity.stored_spacing_m: {g.stored_spacing_m:g} leaves fewer than 2 nodes a side "
            f"of a {field.east_m[-1] - field.east_m[0]:g} m map; allowed: smaller"
        )
    return GravityGrid(e, n, field.values_mgal[::k, ::k], source=f"{field.source}, every {k}")


def stored_map(scenario: Scenario, field: GravityGrid, rng: np.random.Generator) -> GravityGrid:
    """The vehicle's map: the field at the stored spacing plus σ_m per node (module docstring)."""
    true = field_at_stored_spacing(scenario, field)
    err = scenario.gravity.map_error_mgal * rng.standard_normal(true.values_mgal.shape)
    k = max(1, round(scenario.gravity.stored_spacing_m / float(min(field.spacing_m))))
    return GravityGrid(
        true.east_m, true.north_m, true.values_mgal + err,
        source=f"stored: {field.source}, every {k} node(s)",
    )  # fmt: skip


def route_points_m(scenario: Scenario) -> list[tuple[str, tuple[float, float]]]:
    """Every horizontal place the mission sends the vehicle (ENU from the launch point).

    Heading legs are dead-reckoned at their commanded speed and duration, ignoring currents.
    """
    pts: list[tuple[str, tuple[float, float]]] = [
        ("initial.position_m", scenario.initial.position_m)
    ]
    m = scenario.mission
    here = scenario.initial.position_m
    if isinstance(m, LegsMission):
        for i, leg in enumerate(m.legs):
            if isinstance(leg, WaypointLeg):
                here = leg.to_m
            else:
                h = math.radians(leg.heading_deg)
                d = leg.speed_mps * leg.duration_s
                here = (here[0] + d * math.sin(h), here[1] + d * math.cos(h))
            pts.append((f"mission.legs[{i}]", here))
    elif isinstance(m, LawnmowerMission):
        pts += [("mission", p) for p in m.waypoints_m()]
    elif isinstance(m, PlannedMission):
        pts.append(("mission.goal_m", m.goal_m))
    elif isinstance(m, StationKeepingMission):
        c, r = m.center_m, m.radius_m
        pts += [
            ("mission.center_m", (c[0] + dx, c[1] + dy))
            for dx, dy in ((r, 0), (-r, 0), (0, r), (0, -r))
        ]
    return pts


#: The most prism evaluations (prisms × map nodes) a synthetic seafloor may cost: about a minute
#: on one 2-core machine (measured 2026-12-04: 9.6e7 evaluations, the 40 km default, in 5 s).
MAX_PRISM_EVALUATIONS = 1.2e9


def _spacing_problem(g: Gravity) -> str | None:
    """A synthetic map's spacing that leaves fewer than 3 nodes a side."""
    sx, sy = (1000.0 * v for v in g.size_km)
    if g.spacing_m > min(sx, sy) / 2:
        return (
            f"gravity.spacing_m: {g.spacing_m:g} leaves fewer than 3 nodes a side of the "
            f"{sx / 1e3:g} × {sy / 1e3:g} km map; allowed: at most {min(sx, sy) / 2:g} m"
        )
    return None


def _seafloor_size_problem(g: Gravity) -> str | None:
    """A seafloor too coarse for two nodes a side, or too fine to build in about a minute."""
    sx, sy = (1000.0 * v for v in g.size_km)
    too_coarse = _spacing_problem(g)
    if too_coarse:
        return too_coarse
    pad = _spec(g).pad_m
    nodes = (sx / g.spacing_m + 1) * (sy / g.spacing_m + 1)
    prisms = ((sx + 2 * pad) / g.spacing_m + 1) * ((sy + 2 * pad) / g.spacing_m + 1)
    if nodes * prisms <= MAX_PRISM_EVALUATIONS:
        return None
    d_min = ((sx + 2 * pad) * (sy + 2 * pad) * sx * sy / MAX_PRISM_EVALUATIONS) ** 0.25
    return (
        f"gravity.spacing_m: {g.spacing_m:g} on a {sx / 1e3:g} × {sy / 1e3:g} km seafloor is "
        f"{nodes:.3g} nodes over {prisms:.3g} prisms ({nodes * prisms:.2g} prism evaluations, "
        f"about {nodes * prisms / 2e7 / 60:.0f} min to build on 2 cores); allowed: at most "
        f"{MAX_PRISM_EVALUATIONS:.2g} evaluations: spacing_m >= {10 * math.ceil(d_min / 10):g} "
        "for this size, or a smaller size_km"
    )


#: The most nodes a random map may draw, padding included (the FFT holds ~50 bytes a node).
MAX_RANDOM_NODES = 1.6e7


def _random_size_problem(g: Gravity) -> str | None:
    """A random map too coarse for its correlation length or its size, or too big to draw."""
    sx, sy = (1000.0 * v for v in g.size_km)
    too_coarse = _spacing_problem(g)
    if too_coarse:
        return too_coarse
    if g.correlation_km * 1000.0 < g.spacing_m:
        return (
            f"gravity.correlation_km: {g.correlation_km:g} is shorter than the map's node "
            f"spacing ({g.spacing_m:g} m, spacing_m); allowed: at least {g.spacing_m / 1e3:g} km"
        )
    pad = 2 * PAD_LENGTHS * g.correlation_km * 1000.0
    nodes = ((sx + pad) / g.spacing_m + 1) * ((sy + pad) / g.spacing_m + 1)
    if nodes > MAX_RANDOM_NODES:
        return (
            f"gravity.spacing_m: {g.spacing_m:g} on a {sx / 1e3:g} × {sy / 1e3:g} km random map "
            f"(correlation_km {g.correlation_km:g}) draws {nodes:.3g} nodes; allowed: at most "
            f"{MAX_RANDOM_NODES:.2g}: a larger spacing_m or a smaller size_km"
        )
    return None


def check_gravity(scenario: Scenario) -> list[str]:
    """Every problem a run would meet with the scenario's gravity, as ``field: message`` lines."""
    g = scenario.gravity
    s = scenario.sensors
    problems: list[str] = []
    if s.gravimeter is not None and g.map == "none":
        problems.append(
            f"sensors.gravimeter: {s.gravimeter!r} measures the gravity field, but the scenario "
            'has none; set [gravity] map = "seafloor", "random", "wang2023" or "file"'
        )
    if isinstance(scenario.mission, PlannedMission) and g.map == "none":
        problems.append(
            "mission.kind: 'planned' plans on the vehicle's gravity map, but the scenario has "
            'none; set [gravity] map = "seafloor", "random", "wang2023" or "file"'
        )
    if g.map == "none":
        return problems
    if g.map == "seafloor":
        size_problem = _seafloor_size_problem(g)
        if size_problem:
            return [*problems, size_problem]
    if g.map == "random":
        size_problem = _random_size_problem(g)
        if size_problem:
            return [*problems, size_problem]
    extent = field_extent_m(g)
    spacing = g.spacing_m if g.map != "wang2023" else 1000.0
    if extent is None:
        try:
            field = gravity_field(scenario)
        except ValueError as exc:
            return [*problems, f"gravity.file: {exc}"]
        assert field is not None
        extent = field.extent_m
        spacing = float(min(field.spacing_m))
    e0, e1, n0, n1 = extent
    ratio = g.stored_spacing_m / spacing
    if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
        problems.append(
            f"gravity.stored_spacing_m: {g.stored_spacing_m:g} is not a whole multiple of the "
            f"{g.map} map's {spacing:g} m nodes (spacing_m); the stored map is every k-th node "
            "of the field"
        )
    elif min(e1 - e0, n1 - n0) < 4 * g.stored_spacing_m:
        problems.append(
            f"gravity.stored_spacing_m: {g.stored_spacing_m:g} leaves fewer than 4 stored-map "
            f"nodes a side of the {(e1 - e0) / 1e3:g} × {(n1 - n0) / 1e3:g} km map; allowed: "
            "smaller, or a larger map (size_km)"
        )
        return problems
    le, ln = launch_on_map(g, extent)
    margin = EDGE_MARGIN_NODES * max(g.stored_spacing_m, spacing)
    inside = (e0 + margin, e1 - margin, n0 + margin, n1 - margin)
    if not (inside[0] <= le <= inside[1] and inside[2] <= ln <= inside[3]):
        problems.append(
            f"gravity.launch_km: the launch point at ({(le - e0) / 1e3:g}, {(ln - n0) / 1e3:g}) km "
            f"is not on the map at least {margin / 1e3:g} km from its edge; the map spans "
            f"[0, {(e1 - e0) / 1e3:g}] × [0, {(n1 - n0) / 1e3:g}] km"
        )
        return problems
    reported: set[str] = set()
    for path, (pe, pn) in route_points_m(scenario):
        me, mn = le + pe, ln + pn
        if path in reported:
            continue
        if not (inside[0] <= me <= inside[1] and inside[2] <= mn <= inside[3]):
            problems.append(
                f"{path}: the route reaches ({(me - e0) / 1e3:.1f}, {(mn - n0) / 1e3:.1f}) km on "
                f"the gravity map, off it or within {margin / 1e3:g} km of its edge; the map spans "
                f"[0, {(e1 - e0) / 1e3:g}] × [0, {(n1 - n0) / 1e3:g}] km (gravity.launch_km "
                "places the launch point)"
            )
            reported.add(path)
    return problems


__all__ = [
    "check_gravity",
    "field_extent_m",
    "gravity_field",
    "launch_on_map",
    "route_points_m",
    "stored_map",
]
