"""A WorldView over a small real MuJoCo scene: the vehicle 3 m down, optionally a pier above."""

from __future__ import annotations

import datetime as dt
import math

import mujoco
import numpy as np

_XML = """
<mujoco>
  <worldbody>
    <geom name="sea_surface" type="plane" size="0 0 0.05" pos="0 0 0" group="0"/>
    {extra}
    <body name="auv" pos="0 0 -3">
      <freejoint/>
      <geom type="ellipsoid" size="0.095 0.8 0.095" mass="30"/>
      <site name="polarimeter" pos="0 0.35 0.1"/>
    </body>
  </worldbody>
</mujoco>
"""

#: A pier covering the whole sky above the camera.
WIDE_PIER = '<geom name="pier" type="box" size="20 20 0.3" pos="0 0 -1" group="0"/>'
#: A narrow pier half across Snell's window.
NARROW_PIER = '<geom name="pier" type="box" size="0.6 20 0.3" pos="0.5 0 -1" group="0"/>'


class SceneWorld:
    """The plant's WorldView protocol over a real MuJoCo scene, without the vehicle dynamics."""

    def __init__(self, extra_xml: str = "") -> None:
        self.model = mujoco.MjModel.from_xml_string(_XML.format(extra=extra_xml))
        self.data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, self.data)
        self.t = 0.0
        self.utc = dt.datetime(2021, 9, 3, 3, 0, tzinfo=dt.UTC)
        self.latitude_rad = math.radians(37.54)
        self.longitude_rad = math.radians(122.06)
        self.gravity_mps2 = 9.8
        self.water_density_kg_m3 = 1025.0
        self.atmospheric_pressure_pa = 101325.0
        self.surface_z_m = 0.0

    def mj_sensor(self, name: str) -> np.ndarray:
        return self.data.sensor(name).data

    def site_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        s = self.data.site(name)
        return s.xpos.copy(), s.xmat.reshape(3, 3).copy()
