"""A finite tank around the offline camera: walls and floor occlude and shorten the water paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.tank import Tank

SUN = np.array([0.0, 0.8, 0.6])


def test_wall_and_floor_distances_are_the_geometry():
    n = 1.34
    cyl = Tank(shape="cylinder", diameter_m=3.0, water_depth_m=1.0)
    dirs = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    blocked, length = cyl.paths(dirs, 0.5, n)
    np.testing.assert_array_equal(blocked, [True, True, False, False])
    assert length[0] == pytest.approx(1.5)  # horizontal, to the wall
    assert length[1] == pytest.approx(0.5)  # straight down, to the floor
    assert math.isinf(length[2])  # straight up: out through the surface, the sky
    assert math.isinf(length[3])  # 36.9° off the zenith: inside the window, out to the sky
    off = Tank(shape="cylinder", diameter_m=3.0, camera_east_m=1.0)
    assert off.paths(np.array([[1.0, 0.0, 0.0]]), 0.5, n)[1][0] == pytest.approx(0.5)
    box = Tank(shape="box", length_m=2.0, width_m=1.0, water_depth_m=1.0)
    _, length = box.paths(np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]]), 0.5, n)
    np.testing.assert_allclose(length, [0.5, 1.0])
    # 60° off the zenith, beyond the critical angle (48.3°): up to the surface at 0.866 m from
    # the axis, totally reflected, down to the floor 1 m below in a wide tank: 1 m + 2 m of
    # path; in the φ3 m tank the wall comes first, 0.634 m further out: 1 m + 0.732 m.
    slant = np.array([[math.sin(math.radians(60)), 0.0, math.cos(math.radians(60))]])
    blocked, length = Tank(diameter_m=10.0).paths(slant, 0.5, n)
    assert not blocked[0] and length[0] == pytest.approx(1.0 + 2.0)
    blocked, length = cyl.paths(slant, 0.5, n)
    assert not blocked[0] and length[0] == pytest.approx(
        1.0 + 0.634 / math.sin(math.radians(60)), abs=1e-3
    )
    narrow = Tank(shape="box", length_m=1.0, width_m=1.0, water_depth_m=1.0)
    blocked, length = narrow.paths(slant, 0.5, n)
    assert blocked[0] and length[0] == pytest.approx(0.5 / math.sin(math.radians(60)))


def _frame(tank, depth=0.3):
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure(OpticsConfig(jerlov_type="I"))
    cam.configure_tank(tank)
    _, truth = cam.render_offline(
        np.eye(3), depth, SUN / np.linalg.norm(SUN), np.random.default_rng(0)
    )
    return truth


def test_a_wide_tank_leaves_the_window_whole_and_darkens_the_water_outside_it():
    open_sea = _frame(None)
    # φ3 m: the window's rim at 0.3 m depth is 0.34 m from the axis, far inside the walls.
    tank = _frame(Tank(shape="cylinder", diameter_m=3.0, water_depth_m=1.0))
    np.testing.assert_array_equal(tank.snell_window, open_sea.snell_window)
    inside = open_sea.snell_window
    np.testing.assert_allclose(tank.stokes[inside], open_sea.stokes[inside], rtol=1e-6)
    outside = ~inside & (open_sea.stokes[..., 0] > 0)
    # Black walls ≤ 1.5 m away in water with c ≈ 0.04 /m: a few percent of the endless column.
    ratio = tank.stokes[..., 0][outside].sum() / open_sea.stokes[..., 0][outside].sum()
    assert 0.0 < ratio < 0.2


def test_a_narrow_tank_cuts_the_window():
    full = _frame(None).snell_window.sum()
    cut = _frame(Tank(shape="box", length_m=0.8, width_m=0.4, water_depth_m=0.6)).snell_window
    # Half-width 0.2 m < 0.34 m: the window loses its North and South caps.
    assert 0.5 * full < cut.sum() < 0.95 * full


def test_bad_tanks_and_depths_are_clear_errors():
    with pytest.raises(ValueError, match=r"tank\.diameter_m"):
        Tank(diameter_m=-1.0)
    with pytest.raises(ValueError, match=r"tank\.shape"):
        Tank(shape="sphere")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="outside the tank"):
        Tank(diameter_m=1.0, camera_east_m=0.6)
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure_tank(Tank(water_depth_m=1.0))
    with pytest.raises(ValueError, match=r"tank\.water_depth_m"):
        cam.render_offline(np.eye(3), 1.5, SUN / np.linalg.norm(SUN), np.random.default_rng(0))
    with pytest.raises(TypeError, match="Tank"):
        cam.configure_tank("big")  # type: ignore[arg-type]
