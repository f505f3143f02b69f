"""The frame's bright points (bubbles, marine snow) land where projecting every point puts them.

``PointScatterers._add_points`` projects only the points within the lens's field (issue #31); the
reference below projects every drawn point and indexes the frame by (row, column). The frames,
their points and their counts must be the same, bit for bit, through a dome and a flat port.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import sensors
from sensors.polarimeter import points as points_mod
from sensors.polarimeter.render import OpticsConfig

SUN = np.array([math.cos(math.radians(40)), 0.0, math.sin(math.radians(40))])


def _add_points_reference(self, st, occluded, c_cn, depth_m, sun, kind) -> int:
    """Every drawn point projected, the frame indexed by (row, column)."""
    sources = self._point_sources(depth_m, sun, kind)  # the draw, as the method under test
    if sources is None:
        return 0
    draw, intensity, r = sources
    dirs = (draw.offsets_m / r[:, None]) @ c_cn
    u, v, ok = self.camera.project_outside(dirs, self.n_water)
    h, w = self.camera.shape
    col = np.rint(np.asarray(u)).astype(np.int64)
    row = np.rint(np.asarray(v)).astype(np.int64)
    ok = np.asarray(ok) & (col >= 0) & (col < w) & (row >= 0) & (row < h) & (intensity > 0)
    col, row, intensity, r = col[ok], row[ok], intensity[ok], r[ok]
    ok = ~occluded[row, col]
    col, row, intensity, r = col[ok], row[ok], intensity[ok], r[ok]
    omega = self._outside_solid_angle()[row, col]
    add = intensity / (r * r * omega) * self._photon_scale
    flat = st[..., 0].reshape(-1)
    np.add.at(flat, row * w + col, add.astype(np.float32))
    return int(col.size)


def _frame(housing: str, tilt_deg: float) -> tuple[np.ndarray, Any]:
    cam = sensors.create("polarimeter", "phx050s_p_bin4", housing=housing)
    cam.configure(
        OpticsConfig(
            jerlov_type="II", wind_speed_mps=14.0, bubbles="hall_novarini", particles="marine_snow"
        )
    )
    t = math.radians(tilt_deg)
    c_cn = np.array(
        [[1.0, 0.0, 0.0], [0.0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]]
    )
    return cam.render_offline(c_cn, 1.0, SUN, np.random.default_rng(5))


@pytest.mark.parametrize(("housing", "tilt_deg"), [("dome", 0.0), ("dome", 70.0), ("flat", 30.0)])
def test_points_land_where_projecting_every_point_puts_them(monkeypatch, housing, tilt_deg):
    raw, truth = _frame(housing, tilt_deg)
    assert truth.bubbles > 100 and truth.particles > 100
    monkeypatch.setattr(points_mod.PointScatterers, "_add_points", _add_points_reference)
    raw_ref, ref = _frame(housing, tilt_deg)
    assert (truth.bubbles, truth.particles) == (ref.bubbles, ref.particles)
    assert np.array_equal(truth.stokes, ref.stokes)
    assert np.array_equal(raw, raw_ref)
