"""A finite tank around the camera: walls and floor that end its view of the water and the sky.

World side, for offline rendering (:meth:`sensors.polarimeter.render.Polarimeter.render_offline`,
which has no MuJoCo scene; in a run the tank scene's geometry occludes through ray casts). The
seeds' tank trials were run in small tanks with an open top: the LIG paper's φ3 × 1 m tank
(hu2024 §4.2), the ROI-A paper's 300 L tank (fang2024 §2.2), the Snell-window paper's tank lined
with black cloth whose rim the camera sees beyond 97.5° (xin2024 §3.2). Open sea and tank differ
for the camera in two ways this module models:

* A ray that meets a wall or the floor before the surface sees no sky (occluded).
* A ray that does not leave through the surface — blocked, or totally reflected by the surface
  back down — ends on a wall or the floor after a path of length L, not in the endless column of
  the open sea: the renderer's path radiance is scaled by 1 − exp(−c L), the fraction a path of L
  builds up of the infinite path's radiance when the source function is uniform along it (exact
  for a homogeneous, uniformly lit column; the totally reflected path is lit like the open sea's).

The walls themselves are black (``wall_reflectance = 0``: the black cloth of xin2024; a painted
tank wall reflects a few percent, which is ignored [uncertain]). The rim above the water is not
modelled: the tanks were filled to near the rim.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

TankShape = Literal["cylinder", "box"]


@dataclass(frozen=True, slots=True)
class Tank:
    """A tank's geometry and where the camera sits in it.

    Attributes:
        shape: ``"cylinder"`` (``diameter_m``) or ``"box"`` (``length_m`` East × ``width_m``
            North).
        diameter_m: Inner diameter of a cylinder.
        length_m: Inner East–West size of a box.
        width_m: Inner North–South size of a box.
        water_depth_m: Surface to floor.
        camera_east_m: Camera offset East of the tank's centre.
        camera_north_m: Camera offset North of the tank's centre.
    """

    shape: TankShape = "cylinder"
    diameter_m: float = 3.0
    length_m: float = 1.0
    width_m: float = 1.0
    water_depth_m: float = 1.0
    camera_east_m: float = 0.0
    camera_north_m: float = 0.0

    def __post_init__(self) -> None:
        if self.shape not in ("cylinder", "box"):
            raise ValueError(f"tank.shape: {self.shape!r}; allowed: 'cylinder', 'box'")
        for name in ("diameter_m", "length_m", "width_m", "water_depth_m"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and 0.0 < v <= 1000.0):
                raise ValueError(f"tank.{name}: {v!r}; allowed: (0, 1000] m")
        for name in ("camera_east_m", "camera_north_m"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v)):
                raise ValueError(f"tank.{name}: {v!r}; allowed: a finite offset in m")
        if not self._inside(self.camera_east_m, self.camera_north_m):
            raise ValueError(
                f"tank.camera_east_m/camera_north_m: ({self.camera_east_m!r}, "
                f"{self.camera_north_m!r}) is outside the tank"
            )

    def _inside(self, e: float, n: float) -> bool:
        if self.shape == "cylinder":
            return math.hypot(e, n) < self.diameter_m / 2
        return abs(e) < self.length_m / 2 and abs(n) < self.width_m / 2

    def check_depth(self, depth_m: float) -> None:
        """Raise ValueError unless a camera at ``depth_m`` is in the tank's water."""
        if not 0.0 < depth_m < self.water_depth_m:
            raise ValueError(
                f"depth_m: {depth_m!r} is not in the tank's water; allowed (0, "
                f"{self.water_depth_m:g}) m (tank.water_depth_m)"
            )

    def paths(
        self, dirs_enu: NDArray[np.floating], depth_m: float, n_water: float
    ) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
        """(blocked, L) for rays from the camera along ENU directions.

        ``blocked``: the ray meets a wall or the floor before the surface (it sees no sky).
        ``L``: the length of its path through the water until it ends on a wall or the floor —
        for a ray that meets the surface beyond the critical angle, after its total internal
        reflection; ``inf`` where the path leaves the water through the surface (the sky).
        """
        d = np.asarray(dirs_enu, dtype=np.float64).reshape(-1, 3)
        p0 = np.zeros_like(d)
        p0[:, 0], p0[:, 1], p0[:, 2] = self.camera_east_m, self.camera_north_m, -depth_m
        t_block = self._to_wall_or_floor(p0, d)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_surface = np.where(d[:, 2] > 0, depth_m / d[:, 2], np.inf)
        blocked = t_block < t_surface
        length = np.where(blocked, t_block, np.inf)
        # Beyond the critical angle the surface is a mirror: the path goes on down to a wall.
        cos_c = math.sqrt(max(1.0 - 1.0 / (n_water * n_water), 0.0))
        tir = ~blocked & (d[:, 2] > 0) & (d[:, 2] < cos_c)
        if tir.any():
            at = p0[tir] + t_surface[tir, None] * d[tir]
            at[:, 2] = 0.0
            down = d[tir] * np.array([1.0, 1.0, -1.0])
            length[tir] = t_surface[tir] + self._to_wall_or_floor(at, down)
        shape = np.shape(dirs_enu)[:-1]
        return blocked.reshape(shape), length.reshape(shape)

    def _to_wall_or_floor(
        self, p: NDArray[np.float64], d: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Distance from points p inside the tank along d to a wall or the floor (rows)."""
        dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
        e0, n0 = p[:, 0], p[:, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.shape == "cylinder":
                # |p + t d_xy| = R: t = (−p·d + √((p·d)² + |d|²(R² − |p|²))) / |d|².
                a = dx * dx + dy * dy
                b = e0 * dx + n0 * dy
                c = (self.diameter_m / 2) ** 2 - e0 * e0 - n0 * n0
                t_wall = np.where(a > 1e-18, (-b + np.sqrt(b * b + a * c)) / a, np.inf)
            else:
                hx, hy = self.length_m / 2, self.width_m / 2
                tx = np.where(dx > 0, (hx - e0) / dx, (-hx - e0) / dx)
                ty = np.where(dy > 0, (hy - n0) / dy, (-hy - n0) / dy)
                t_wall = np.minimum(np.where(dx != 0, tx, np.inf), np.where(dy != 0, ty, np.inf))
            t_floor = np.where(dz < 0, (self.water_depth_m + p[:, 2]) / -dz, np.inf)
        return np.minimum(t_wall, t_floor)


__all__ = ["Tank"]
