"""A small WorldView over the real AUV model, for sensor tests (no mocks)."""

from __future__ import annotations

import copy
import datetime as dt
import math
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
import pytest

from sensors.base import Sensor
from twin.core import earth
from twin.core.frames import euler_to_quat

SCENE = Path(__file__).resolve().parents[2] / "models" / "auv" / "scene_open_sea.xml"
T0_UTC = dt.datetime(2021, 7, 31, 2, 0, tzinfo=dt.UTC)


class MjWorld:
    """Implements sensors.base.WorldView over a MuJoCo model whose state the test prescribes.

    :meth:`place` sets the vehicle's pose and velocity and computes the sensors by inverse dynamics
    for a prescribed acceleration (default zero: the vehicle is held on its path, as a neutrally
    buoyant, trimmed AUV is), so the accelerometer reads specific force and not free fall.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        latitude_deg: float = 45.0,
        longitude_deg: float = 120.0,
        water_density_kg_m3: float = 1025.0,
        atmospheric_pressure_pa: float = 101325.0,
    ):
        self._model = copy.copy(model)  # opt.gravity is per world
        self._data = mujoco.MjData(self._model)
        self._lat = math.radians(latitude_deg)
        self._lon = math.radians(longitude_deg)
        self._g = earth.normal_gravity(self._lat)
        self._model.opt.gravity[:] = (0.0, 0.0, -self._g)
        self._rho = water_density_kg_m3
        self._p_atm = atmospheric_pressure_pa
        self._adr: dict[str, tuple[int, int]] = {}
        self.place()

    # --- WorldView ---------------------------------------------------------------------------
    @property
    def t(self) -> float:
        return float(self._data.time)

    @property
    def utc(self) -> dt.datetime:
        return T0_UTC + dt.timedelta(seconds=self.t)

    @property
    def model(self) -> mujoco.MjModel:
        return self._model

    @property
    def data(self) -> mujoco.MjData:
        return self._data

    @property
    def latitude_rad(self) -> float:
        return self._lat

    @property
    def longitude_rad(self) -> float:
        return self._lon

    @property
    def gravity_mps2(self) -> float:
        return self._g

    @property
    def water_density_kg_m3(self) -> float:
        return self._rho

    @property
    def atmospheric_pressure_pa(self) -> float:
        return self._p_atm

    @property
    def surface_z_m(self) -> float:
        return 0.0

    def mj_sensor(self, name: str) -> np.ndarray:
        if name not in self._adr:
            s = self._model.sensor(name)  # KeyError for an unknown name
            self._adr[name] = (int(s.adr[0]), int(s.dim[0]))
        adr, dim = self._adr[name]
        return self._data.sensordata[adr : adr + dim]

    def site_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        site = self._data.site(name)
        return site.xpos, site.xmat.reshape(3, 3)

    # --- test controls -----------------------------------------------------------------------
    def place(
        self,
        pos: tuple[float, float, float] = (0.0, 0.0, -10.0),
        rpy: tuple[float, float, float] = (0.0, 0.0, 0.0),
        vel_world: tuple[float, float, float] = (0.0, 0.0, 0.0),
        omega_body: tuple[float, float, float] = (0.0, 0.0, 0.0),
        acc_world: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> MjWorld:
        """Put the body origin at ``pos`` with attitude (roll, pitch, yaw) in radians.

        ``vel_world`` is the body origin's velocity in n, ``omega_body`` the angular velocity in
        body axes (MuJoCo's free-joint convention), ``acc_world`` the prescribed linear
        acceleration of the body origin in n; the angular acceleration is zero.
        """
        m, d = self._model, self._data
        d.qpos[0:3] = pos
        d.qpos[3:7] = euler_to_quat(*rpy)
        d.qvel[0:3] = vel_world
        d.qvel[3:6] = omega_body
        mujoco.mj_forward(m, d)
        d.qacc[:] = 0.0
        d.qacc[0:3] = acc_world
        mujoco.mj_inverse(m, d)  # recomputes the acceleration-stage sensors for this qacc
        return self

    def set_time(self, t: float) -> None:
        """Set the sim clock without moving anything (sensors only look at the state)."""
        self._data.time = t


def collect(
    sensor: Sensor, world: MjWorld, rng: np.random.Generator, n: int
) -> dict[str, np.ndarray]:
    """Sample ``n`` times at the sensor's rate on the (static) world: channel -> (n, dim) array."""
    period = 1.0 / sensor.rate_hz
    t0 = world.t
    rows: dict[str, list[np.ndarray]] = {c: [] for c in sensor.channel_specs()}
    for k in range(n):
        world.set_time(t0 + k * period)
        for c, v in sensor.sample(world, rng).items():
            rows[c].append(v)
    return {c: np.array(v) for c, v in rows.items()}


@pytest.fixture(scope="session")
def auv_model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(SCENE))


@pytest.fixture
def world(auv_model: mujoco.MjModel) -> MjWorld:
    """The AUV level at 10 m, at rest, heading north, at 45° N."""
    return MjWorld(auv_model)


@pytest.fixture
def make_world(auv_model: mujoco.MjModel) -> Callable[..., MjWorld]:
    """Factory: ``make_world(latitude_deg=..., water_density_kg_m3=...)``."""
    return lambda **kw: MjWorld(auv_model, **kw)


@pytest.fixture(name="collect")
def collect_fixture() -> Callable[..., np.ndarray]:
    """:func:`collect`, for the test modules (conftest is not importable as a module)."""
    return collect
