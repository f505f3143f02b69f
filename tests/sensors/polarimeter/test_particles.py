"""Marine snow: the population, the per-frame draw, and its bright points in a frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sensors
from scenarios import parse_scenario
from scenarios.loader import ScenarioError
from sensors.polarimeter.optics.bubbles import BubbleDraw, bubble_radiance
from sensors.polarimeter.optics.particles import MarineSnow
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.tank import Tank
from tests.scenario_helpers import minimal_scenario
from twin.world.assembly import optics_config

SUN = np.array([math.cos(math.radians(40)), 0.0, math.sin(math.radians(40))])


def test_the_population_is_alldredge_and_silvers_abundance_on_a_junge_spectrum():
    snow = MarineSnow()
    assert snow.number_density_per_m3() == pytest.approx(3000.0)
    # n ∝ d⁻⁴ ⇒ N(≥ d) ∝ d⁻³ − d_max⁻³ within 0.5–5 mm.
    expect = 3000.0 * (1e-3**-3 - 5e-3**-3) / (0.5e-3**-3 - 5e-3**-3)
    assert snow.number_density_per_m3(1e-3) == pytest.approx(expect)
    assert snow.number_density_per_m3(6e-3) == 0.0


def _expected_count(snow: MarineSnow) -> float:
    """∫ n(a) · (the ball of radius R(a) = reach·a/a_max, less the dome's 5 cm) da, numerically."""
    a = np.geomspace(snow.d_min_m / 2, snow.a_max_m, 20001)
    k = snow.slope - 1.0
    n = a ** (-(k + 1))
    n *= snow.number_density_per_m3() / float(np.trapezoid(n, a))
    r = snow.reach_m * a / snow.a_max_m
    vol = (4.0 / 3.0) * math.pi * (r**3 - np.minimum(r, 0.05) ** 3)
    return float(np.trapezoid(n * vol, a))


def test_the_draw_has_the_populations_count_and_sizes():
    snow = MarineSnow()
    rng = np.random.default_rng(0)
    draws = [snow.draw(10.0, rng) for _ in range(200)]  # 10 m: the balls stay under the surface
    counts = np.array([d.radii_m.size for d in draws])
    mu = _expected_count(snow)
    assert 1000 < mu < 20000  # most are faint: the threshold is a/r, not a brightness
    # Poisson: the mean of 200 counts is within 4 σ of μ.
    assert abs(counts.mean() - mu) < 4.0 * math.sqrt(mu / 200)
    radii = np.concatenate([d.radii_m for d in draws])
    assert radii.min() >= 0.25e-3 and radii.max() <= 2.5e-3
    # Each drawn point lies within its own radius's ball, outside the dome.
    r = np.linalg.norm(np.concatenate([d.offsets_m for d in draws]), axis=1)
    assert np.all(r <= snow.reach_m * radii / snow.a_max_m + 1e-12) and np.all(r >= 0.05)
    # None above the surface when the camera is shallow.
    shallow = snow.draw(0.5, np.random.default_rng(1))
    assert np.all(shallow.depths_m > 0.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"per_litre": -1.0}, "per_litre"), ({"slope": 9.0}, "slope"), ({"d_max_m": 1e-4}, "d_max_m")],
)
def test_impossible_populations_are_clear_errors(kwargs, field):
    with pytest.raises(ValueError, match=field):
        MarineSnow(**kwargs)


def test_the_albedo_scales_the_light_and_the_phase_function_is_the_points_own():
    draw = BubbleDraw(np.array([[0.0, 0.0, 1.0]]), np.array([1e-3]), np.array([2.0]))
    s = np.array([0.0, 0.0, 1.0])
    i1, _ = bubble_radiance(draw, s, 100.0, 0.2, g=0.924, albedo=1.0)
    i9, _ = bubble_radiance(draw, s, 100.0, 0.2, g=0.924, albedo=0.9)
    assert i9[0] == pytest.approx(0.9 * i1[0])
    # Looking up the beam (Θ = 0), the more forward phase function sends more light.
    ib, _ = bubble_radiance(draw, s, 100.0, 0.2)
    assert i1[0] > ib[0]


def _frame(particles: str, depth: float = 3.0, tank: Tank | None = None):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type="II", particles=particles))
    if tank is not None:
        cam.configure_tank(tank)
    return cam.render_offline(np.eye(3), depth, SUN, np.random.default_rng(3))


def test_marine_snow_adds_bright_unpolarized_points_and_leaves_the_rest_alone():
    _, ideal = _frame("ideal")
    raw, snow = _frame("marine_snow")
    assert ideal.particles == 0 and snow.particles > 100
    d = snow.stokes.astype(np.float64) - ideal.stokes.astype(np.float64)
    np.testing.assert_array_equal(d[..., 1:], 0.0)
    assert d[..., 0].min() >= 0.0
    lit = d[..., 0] > 0
    assert 0 < lit.sum() <= snow.particles
    # A few are outliers brighter than the water behind them.
    ratio = d[..., 0][lit] / np.maximum(ideal.stokes[..., 0][lit], 1.0)
    assert (ratio > 1.0).sum() >= 1
    # Same seed, same frame.
    raw2, again = _frame("marine_snow")
    np.testing.assert_array_equal(raw, raw2)
    assert again.particles == snow.particles


def test_no_marine_snow_in_a_tank_or_in_air():
    tank = Tank(shape="box", length_m=0.8, width_m=0.6, water_depth_m=1.5)
    assert _frame("marine_snow", depth=0.5, tank=tank)[1].particles == 0
    assert _frame("marine_snow", depth=-1.0)[1].particles == 0


def _scenario(optics: dict):
    return minimal_scenario(optics=optics)


def test_a_scenario_has_marine_snow_unless_it_says_ideal_or_is_a_tank():
    assert optics_config(_scenario({})).particles == "marine_snow"
    assert optics_config(_scenario({"particles": "ideal"})).particles == "ideal"
    s = _scenario({})
    assert parse_scenario(s.to_dict()) == s
    with pytest.raises(ScenarioError, match=r"optics\.particles"):
        _scenario({"particles": "plankton"})
