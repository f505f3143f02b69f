"""Closed-loop responses of the autopilot and guidance on the REMUS plant."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios.schema import LegsMission, StationKeepingMission, WaypointLeg
from twin.core.messages import ActuatorCommand
from twin.onboard.control.autopilot import Autopilot, NavState, Setpoint
from twin.onboard.control.guidance import Guidance
from twin.sim.navsources import TruthNav
from twin.world.plant import Plant, PlantConfig


def _fly(plant: Plant, setpoint_fn, seconds: float, rate_hz: float = 10.0):
    ap = Autopilot(plant.hydro.rps_for_speed)
    nav = TruthNav(plant)
    dt = plant.model.opt.timestep
    every = round(1.0 / (rate_hz * dt))
    cmd = ActuatorCommand()
    log = []
    for k in range(round(seconds / dt)):
        if k % every == 0:
            ns = nav.nav_state()
            cmd = ap.update(ns, setpoint_fn(ns, plant.t), every * dt)
        plant.step(cmd)
        log.append(plant.truth())
    return log


def test_heading_depth_and_speed_steps_settle_without_large_overshoot() -> None:
    plant = Plant(PlantConfig())
    plant.reset(position_n=(0.0, 0.0, -5.0), forward_speed_mps=1.0)
    sp = Setpoint(1.5, 10.0, math.radians(90.0))
    log = _fly(plant, lambda ns, t: sp, 120.0)
    heading = np.array([tr.heading_deg for tr in log])
    depth = np.array([tr.depth_m for tr in log])
    speed = np.array([tr.speed_through_water_mps for tr in log])
    assert heading.max() < 92.0  # overshoot < 2 deg on a 90 deg step
    assert abs(heading[-1] - 90.0) < 0.5
    assert depth.max() < 10.3  # overshoot < 0.3 m on a 5 m step
    assert abs(depth[-1] - 10.0) < 0.05
    assert abs(speed[-1] - 1.5) < 0.02


def test_waypoint_following_reaches_every_waypoint() -> None:
    plant = Plant(PlantConfig())
    plant.reset(position_n=(0.0, 0.0, -10.0), forward_speed_mps=1.5)
    legs = (
        WaypointLeg(to_m=(0.0, 100.0), depth_m=10.0, speed_mps=1.5),
        WaypointLeg(to_m=(100.0, 100.0), depth_m=12.0, speed_mps=1.5),
    )
    g = Guidance(LegsMission(legs=legs, acceptance_radius_m=5.0), (0.0, 0.0))
    states = []
    log = _fly(plant, lambda ns, t: states.append(g.update(ns, t)) or states[-1][0], 200.0)
    assert states[-1][1].complete
    assert np.linalg.norm(log[-1].position_n[:2] - [100.0, 100.0]) < 15.0
    # On the straight part of the second leg the vehicle is on the line.
    late = [s for _, s in states[-300:-150]]
    assert max(abs(s.cross_track_m) for s in late) < 1.0


@pytest.mark.slow
def test_station_keeping_loiters_on_its_circle() -> None:
    plant = Plant(PlantConfig())
    plant.reset(position_n=(0.0, 0.0, -10.0), forward_speed_mps=1.0)
    m = StationKeepingMission(center_m=(0.0, 30.0), depth_m=10.0, radius_m=30.0, speed_mps=1.0)
    g = Guidance(m, (0.0, 0.0))
    log = _fly(plant, lambda ns, t: g.update(ns, t)[0], 300.0)
    r = np.array([np.hypot(tr.position_n[0], tr.position_n[1] - 30.0) for tr in log[-10000:]])
    assert np.all(np.abs(r - 30.0) < 3.0)


def _nav(e: float, n: float) -> NavState:
    return NavState(e, n, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.5)


def test_guidance_switches_at_the_wheel_over_point() -> None:
    legs = (
        WaypointLeg(to_m=(0.0, 100.0), depth_m=10.0, speed_mps=1.5),
        WaypointLeg(to_m=(100.0, 100.0), depth_m=10.0, speed_mps=1.5),
    )
    mission = LegsMission(legs=legs, acceptance_radius_m=5.0)
    # 90 deg turn, R = 20 m: wheel-over R tan(45 deg) = 20 m before the corner.
    g = Guidance(mission, (0.0, 0.0), turn_radius_m=20.0)
    assert g.update(_nav(0.0, 79.0), 0.0)[1].leg == 0
    assert g.update(_nav(0.0, 81.0), 0.1)[1].leg == 1
    # Without a turn radius it switches at the acceptance circle only.
    g = Guidance(mission, (0.0, 0.0))
    assert g.update(_nav(0.0, 94.0), 0.0)[1].leg == 0
    assert g.update(_nav(0.0, 96.0), 0.1)[1].leg == 1


def test_los_heading_points_back_to_the_path() -> None:
    legs = (WaypointLeg(to_m=(0.0, 100.0), depth_m=10.0, speed_mps=1.5),)
    g = Guidance(LegsMission(legs=legs), (0.0, 0.0), lookahead_m=8.0)
    sp, st = g.update(_nav(8.0, 50.0), 0.0)  # 8 m right (east) of a northbound path
    assert st.cross_track_m == pytest.approx(8.0)
    assert math.degrees(sp.heading_rad) == pytest.approx(-45.0)  # steer north-west, back to it
