"""Caustics: the refracted sun beam focused by the waves, and the flicker it gives a frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter.optics import waves as waves_mod
from sensors.polarimeter.optics.caustics import CausticField
from sensors.polarimeter.render import OpticsConfig

N_WATER = 1.34
SUN = np.array([math.cos(math.radians(40)), 0.0, math.sin(math.radians(40))])


class _Sinusoid:
    """A slope field with one sinusoid along East: the lens whose focus geometry is known.

    Stands in for :class:`~sensors.polarimeter.optics.waves.WaveSurface` (the field uses only
    ``sea``
    and ``slopes_at``); amplitude 0 is a flat sea.
    """

    def __init__(self, amplitude: float, cycles: int) -> None:
        self.sea = waves_mod.WindSea(wind_speed_mps=5.0)
        self.k = 2 * math.pi * cycles / (self.sea.grid_size * self.sea.cell_m)
        self.amplitude = amplitude

    def slopes_at(self, east_m, north_m):
        e = np.asarray(east_m, dtype=np.float64)
        return np.stack([self.amplitude * np.sin(self.k * e), np.zeros_like(e)], axis=-1)


def test_a_flat_sea_has_a_uniform_beam():
    cf = CausticField(_Sinusoid(0.0, 4), SUN, N_WATER, 10.0)
    np.testing.assert_allclose(cf.fields, 1.0, atol=1e-12)
    look = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, 0.0, -1.0]])
    np.testing.assert_allclose(cf.ray_factor(look, (0.3, 0.7), 3.0, SUN, 0.2), 1.0, atol=1e-12)


def test_a_sinusoidal_sea_focuses_as_geometric_optics_says():
    """Zenith sun: a facet of slope s bends the beam by α − asin(sin α/n), α = atan s.

    Above the first caustic the irradiance at the landing point is 1/(dq/dx) of the flat sea's,
    q(x) = x + z tan(bend(x)); the field's cloud-in-cell, averaged over each cell, must follow.
    """
    sea = _Sinusoid(0.1, 8)
    z = 1.5
    cf = CausticField(sea, np.array([0.0, 0.0, 1.0]), N_WATER, 3.0, levels=3, oversample=16)
    x = np.linspace(0.0, sea.sea.grid_size * sea.sea.cell_m, 200001)[:-1]
    alpha = np.arctan(sea.amplitude * np.sin(sea.k * x))
    q = x + z * np.tan(alpha - np.arcsin(np.sin(alpha) / N_WATER))
    assert np.all(np.diff(q) > 0)  # above the first caustic: no folds
    # Flux per cell: the share of entry points landing in each cell (Fresnel weights vary < 1 %
    # at these tilts), relative to the mean.
    g, h = sea.sea.grid_size, sea.sea.cell_m
    cells = np.floor(np.mod(q, g * h) / h).astype(int)
    expected = np.bincount(cells, minlength=g) / (x.size / g)
    got = cf.fields[1].mean(axis=1)  # along North the field is uniform
    np.testing.assert_allclose(cf.fields[1], got[:, None] * np.ones((1, g)), atol=1e-9)
    assert np.ptp(expected) > 0.5  # the lens focuses measurably at this depth (0.74)
    # Measured 0.020 at worst: cloud-in-cell shares a point's flux with the neighbouring cell.
    np.testing.assert_allclose(got, expected, atol=0.04)
    assert got.mean() == pytest.approx(1.0, abs=1e-12)


def test_a_wind_sea_flickers_more_with_depth_and_keeps_its_mean():
    sea = waves_mod.WindSea(wind_speed_mps=8.5)
    waves = waves_mod.WaveSurface(sea, np.random.default_rng(2))
    cf = CausticField(waves, SUN, N_WATER, 10.0, levels=11)
    cv = cf.fields.reshape(cf.fields.shape[0], -1).std(axis=1)
    means = cf.fields.reshape(cf.fields.shape[0], -1).mean(axis=1)
    np.testing.assert_allclose(means, 1.0, atol=1e-12)
    # At the surface only the facets' Fresnel transmittance varies (a few per cent).
    assert cv[0] < 0.05
    # Within the first metres the focused net grows to order-one contrast.
    assert cv[3] > 0.5
    assert np.all(cf.fields >= 0)
    # Same sea, same field.
    again = CausticField(
        waves_mod.WaveSurface(sea, np.random.default_rng(2)), SUN, N_WATER, 10.0, levels=11
    )
    np.testing.assert_array_equal(again.fields, cf.fields)


def test_impossible_fields_are_clear_errors():
    with pytest.raises(ValueError, match="max_depth_m"):
        CausticField(_Sinusoid(0.1, 4), SUN, N_WATER, -1.0)
    with pytest.raises(ValueError, match="levels"):
        CausticField(_Sinusoid(0.1, 4), SUN, N_WATER, 5.0, levels=1)
    with pytest.raises(ValueError, match=r"flicker.*allowed"):
        OpticsConfig(flicker="strobe")


def _frame(flicker: str, wind: float = 8.5, depth: float = 2.0):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type="II", wind_speed_mps=wind, flicker=flicker))
    return cam.render_offline(np.eye(3), depth, SUN, np.random.default_rng(3))[1]


def test_the_frame_flickers_around_the_uniform_beams_light():
    ideal, real = _frame("ideal"), _frame("caustics")
    m = ideal.stokes[..., 0] > 0
    ratio = real.stokes[..., 0][m] / ideal.stokes[..., 0][m]
    lo, hi = np.percentile(ratio, [1, 99])
    # Measured ±4–7 % at 2 m under 8.5 m/s: visible, and far from swamping the frame.
    assert hi - lo > 0.04
    assert 0.7 < lo and hi < 1.3
    assert abs(float(np.mean(ratio)) - 1.0) < 0.03
    assert np.all(np.isfinite(real.stokes))
    again = _frame("caustics")
    np.testing.assert_array_equal(again.stokes, real.stokes)


def test_calm_water_does_not_flicker():
    np.testing.assert_array_equal(_frame("caustics", wind=0.0).stokes, _frame("ideal", 0.0).stokes)
