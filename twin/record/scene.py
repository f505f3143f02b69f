"""The run's static scene in the Rerun recording: the hull, the mission, the sea and the tank.

Entities (all static): ``/world`` (view coordinates), ``/world/auv/hull``, ``/world/auv`` (axes),
``/world/auv/nose``, ``/world/mission/waypoints`` and ``route``, ``/world/surface`` and
``/world/seabed`` (grids), ``/world/tank``. :class:`twin.record.recorder.Recorder` logs it once
per run.
"""

from __future__ import annotations

import math

import numpy as np
import rerun as rr

from twin.core.arrays import Float64Array as FloatArray

TRUTH_COLOR = (255, 200, 40)
WAYPOINT_COLOR = (220, 40, 220)
SURFACE_COLOR = (90, 170, 230)
SEABED_COLOR = (150, 120, 80)
TANK_COLOR = (170, 170, 170)


def log_static_scene(
    rec: rr.RecordingStream,
    *,
    waypoints_n: np.ndarray | None,
    vehicle_half_sizes: tuple[float, float, float],
    surface_z: float = 0.0,
    seabed_z: float | None = None,
    tank_half_sizes: tuple[float, float, float] | None = None,
) -> None:
    """Log what does not change during the run (all static) to ``rec``.

    Args:
        rec: The recording stream.
        waypoints_n: Mission waypoints in n (ENU, metres), shape (N, 3) or (N, 2) (then at the
            surface); ``None`` for none.
        vehicle_half_sizes: Hull ellipsoid half sizes in body axes (x right, y forward, z up).
        surface_z: World z of the sea surface (m).
        seabed_z: World z of the seabed (m); ``None`` draws none.
        tank_half_sizes: Half sizes of a test tank (m). The tank is centred on the world origin
            in x and y, with its top at ``surface_z``; ``None`` for open water.
    """
    rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    half = np.asarray(vehicle_half_sizes, dtype=np.float64)
    rec.log(
        "/world/auv/hull",
        rr.Ellipsoids3D(
            half_sizes=[half], colors=[TRUTH_COLOR], fill_mode=rr.components.FillMode.Solid
        ),
        static=True,
    )
    rec.log("/world/auv", rr.TransformAxes3D(axis_length=float(half.max()) * 0.6), static=True)
    rec.log(
        "/world/auv/nose",
        rr.Arrows3D(vectors=[[0.0, 1.3 * half[1], 0.0]], colors=[(255, 60, 60)]),
        static=True,
    )

    extent_pts: list[FloatArray] = [np.zeros((1, 2))]
    if waypoints_n is not None and len(waypoints_n) > 0:
        wps = np.asarray(waypoints_n, dtype=np.float64)
        if wps.ndim != 2 or wps.shape[1] not in (2, 3):
            raise ValueError(f"waypoints_n has shape {wps.shape}: expected (N, 3) or (N, 2)")
        if wps.shape[1] == 2:
            wps = np.column_stack([wps, np.full(len(wps), surface_z)])
        rec.log(
            "/world/mission/waypoints",
            rr.Points3D(
                wps,
                radii=rr.Radius.ui_points(5.0),
                colors=[WAYPOINT_COLOR],
                labels=[f"WP{i}" for i in range(len(wps))],
            ),
            static=True,
        )
        rec.log(
            "/world/mission/route",
            rr.LineStrips3D([wps], radii=rr.Radius.ui_points(1.0), colors=[(*WAYPOINT_COLOR, 160)]),
            static=True,
        )
        extent_pts.append(wps[:, :2])

    if tank_half_sizes is not None:
        th = np.asarray(tank_half_sizes, dtype=np.float64)
        rec.log(
            "/world/tank",
            rr.Boxes3D(
                half_sizes=[th],
                centers=[[0.0, 0.0, surface_z - th[2]]],
                colors=[TANK_COLOR],
                fill_mode=rr.components.FillMode.MajorWireframe,
            ),
            static=True,
        )
        lo, hi = -th[:2], th[:2]
    else:
        pts = np.concatenate(extent_pts)
        # Open water: frame the mission with a margin, at least 50 m across.
        pad = max(10.0, 0.1 * float(np.ptp(pts, axis=0).max()))
        lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
        centre, span = (lo + hi) / 2, np.maximum(hi - lo, 50.0)
        lo, hi = centre - span / 2, centre + span / 2

    rec.log("/world/surface", _grid(lo, hi, surface_z, SURFACE_COLOR), static=True)
    if seabed_z is not None:
        rec.log("/world/seabed", _grid(lo, hi, seabed_z, SEABED_COLOR), static=True)


def _grid(lo: FloatArray, hi: FloatArray, z: float, color: tuple[int, int, int]) -> rr.LineStrips3D:
    """A rectangular grid of lines at height z covering [lo, hi] in x and y (about 10 cells)."""
    span = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    raw = max(span / 10.0, 1e-3)
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1.0, 2.0, 5.0, 10.0) if m * mag >= raw)
    xs = np.arange(math.ceil(lo[0] / step), math.floor(hi[0] / step) + 1) * step
    ys = np.arange(math.ceil(lo[1] / step), math.floor(hi[1] / step) + 1) * step
    strips = [[[x, lo[1], z], [x, hi[1], z]] for x in xs]
    strips += [[[lo[0], y, z], [hi[0], y, z]] for y in ys]
    return rr.LineStrips3D(strips, radii=rr.Radius.ui_points(0.5), colors=[(*color, 128)])
