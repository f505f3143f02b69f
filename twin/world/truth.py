"""Ground truth: the true state of the vehicle, for scoring and recording only.

This is the separate truth channel. Onboard code (``twin.onboard``) must never import this module;
tests/test_boundary.py checks the import graph.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class Truth:
    """The vehicle's true state at one instant (world frame ENU, body frame x right/y fwd/z up).

    Attributes:
        t: Sim time (s).
        position_n: Body-origin (CB) position in ENU (m).
        quat_wxyz: Attitude quaternion C_b^n, MuJoCo order.
        velocity_n: Body-origin velocity over ground in ENU (m/s).
        omega_b: Angular velocity relative to the (non-rotating) world, body axes (rad/s).
        roll_rad: Roll (see twin.core.frames).
        pitch_rad: Pitch.
        yaw_rad: ENU yaw (counter-clockwise from North).
        heading_deg: Compass heading, degrees clockwise from North.
        depth_m: Depth of the body origin below the surface (m).
        latitude_rad: Geodetic latitude of the body origin.
        longitude_rad: Longitude of the body origin.
        current_n: Water current at the vehicle (ENU, m/s).
        speed_through_water_mps: |ν_r| at the body origin.
        actuators: True actuator states [rudder rad, stern rad, propeller rev/s].
    """

    t: float
    position_n: np.ndarray
    quat_wxyz: np.ndarray
    velocity_n: np.ndarray
    omega_b: np.ndarray
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    heading_deg: float
    depth_m: float
    latitude_rad: float
    longitude_rad: float
    current_n: np.ndarray
    speed_through_water_mps: float
    actuators: np.ndarray
