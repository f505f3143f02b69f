"""The layout a run's recording opens with in the Rerun viewer (its stored blueprint)."""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

#: The recording's timelines and its text log's entity (the viewer's layout names them).
SIM_TIME = "sim_time"
UTC = "utc"
LOG_ENTITY = "/log"


def default_blueprint(variants: Sequence[str] = (), *, gravity: bool = False) -> rrb.Blueprint:
    """The layout a recording opens with.

    Left: the 3D world (vehicle, path travelled, mission, surface/seabed/tank) above the chase
    camera and the text log. Right: tabs: "Vehicle", a grid of time series (attitude, heading,
    depth, speed, IMU, control, every filter's heading and error), then one tab per filter variant
    with its heading error ±3σ, roll/pitch error, position error, attitude NEES and (for a compass
    variant) each fix's error against truth. The 3D view shows everything logged up to the time
    cursor, so ``/world/path`` (one segment per row) accumulates into the track; the vehicle's
    transform is always taken at the cursor.

    Args:
        variants: The run's filter variants (``[navigation] variants``), one tab each.
        gravity: Add a "Gravity map" tab (the stored map with the route, the paths and the
            filters' ellipses, and the information map M: ``twin.record.gravity``).

    Returns:
        The blueprint, to pass as ``default_blueprint`` when saving.
    """
    world = rrb.Spatial3DView(
        origin="/world",
        name="World (ENU)",
        time_ranges=rrb.VisibleTimeRange(
            SIM_TIME,
            start=rrb.TimeRangeBoundary.infinite(),
            end=rrb.TimeRangeBoundary.cursor_relative(),
        ),
        eye_controls=rrb.EyeControls3D(tracking_entity="/world/auv"),
    )
    series = rrb.Grid(
        rrb.TimeSeriesView(origin="/truth/rpy_deg", name="Attitude, truth (deg)"),
        rrb.TimeSeriesView(origin="/truth/heading_deg", name="Heading, truth (deg)"),
        rrb.TimeSeriesView(
            origin="/", contents=["/truth/depth_m", "/sensors/depth/**"], name="Depth (m)"
        ),
        rrb.TimeSeriesView(origin="/truth/speed_mps", name="Speed, truth (m/s)"),
        rrb.TimeSeriesView(origin="/sensors/imu", name="IMU"),
        rrb.TimeSeriesView(origin="/control", name="Actuator commands"),
        rrb.TimeSeriesView(
            origin="/",
            contents=["/truth/heading_deg", "/nav/heading_deg/**"],
            name="Heading: filters vs truth (deg)",
        ),
        rrb.TimeSeriesView(
            origin="/nav", contents=["/nav/*/heading_error_deg"], name="Heading error ±3σ (deg)"
        ),
        grid_columns=2,
        name="Vehicle",
    )
    per_variant = [
        rrb.Grid(
            rrb.TimeSeriesView(
                origin=f"/nav/{v}/heading_error_deg", name=f"{v}: heading error ±3σ (deg)"
            ),
            rrb.TimeSeriesView(
                origin=f"/nav/{v}/attitude_error_deg", name=f"{v}: roll/pitch error (deg)"
            ),
            rrb.TimeSeriesView(
                origin=f"/nav/{v}/position_error_m", name=f"{v}: position error (m)"
            ),
            rrb.TimeSeriesView(origin=f"/nav/{v}/nees_attitude", name=f"{v}: attitude NEES"),
            *(
                (
                    rrb.TimeSeriesView(
                        origin=f"/nav/{v}/compass_fix_error_deg",
                        name=f"{v}: compass fix error vs truth (deg)",
                    ),
                )
                if v != "ins"
                else ()
            ),
            grid_columns=2,
            name=f"Filter {v}",
        )
        for v in variants
    ]
    tabs = list(per_variant)
    if gravity:
        tabs.append(
            rrb.Horizontal(
                rrb.Spatial2DView(origin="/gravity/map", name="Stored map, route, paths, 2σ"),
                rrb.Spatial2DView(origin="/gravity/information", name="Information M (log10)"),
                name="Gravity map",
            )
        )
    right = rrb.Tabs(series, *tabs) if tabs else series
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                world,
                rrb.Horizontal(
                    rrb.Spatial2DView(origin="/camera/chase", name="Chase camera"),
                    rrb.Tabs(
                        rrb.Spatial2DView(origin="/polarimeter/intensity", name="Polarimeter S0"),
                        rrb.Spatial2DView(origin="/polarimeter/aop", name="Polarimeter AoP"),
                        rrb.Spatial2DView(origin="/polarimeter/dop", name="Polarimeter DoP"),
                        rrb.TextLogView(origin=LOG_ENTITY, name="Log"),
                    ),
                ),
                row_shares=[0.65, 0.35],
            ),
            right,
            column_shares=[0.55, 0.45],
        ),
        rrb.TimePanel(timeline=SIM_TIME),
        collapse_panels=False,
    )
