"""The statistical gravity map (twin.world.gravity_random): its stated statistics, its seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scenario_helpers import minimal_scenario

from scenarios.loader import ScenarioError
from twin.world.gravity_area import check_gravity, gravity_field
from twin.world.gravity_random import (
    RandomFieldSpec,
    gradient_median_mgal_per_m,
    map_statistics,
    random_anomaly_grid,
)


def _draw(seed: int, **kw) -> np.ndarray:
    return random_anomaly_grid(RandomFieldSpec(**kw), np.random.default_rng(seed)).values_mgal


def test_a_seed_is_one_map_and_other_seeds_are_independent_maps():
    a, a2, b = _draw(3), _draw(3), _draw(4)
    assert np.array_equal(a, a2)
    # Independent maps: 101² nodes at L = 5 km hold ~400 independent cells, so the sample
    # correlation of two independent maps is ~N(0, 0.05²).
    r = float(np.corrcoef(a.ravel(), b.ravel())[0, 1])
    assert abs(r) < 0.2


def test_each_map_has_the_stated_range_and_zero_mean():
    for seed in range(3):
        v = _draw(seed, range_mgal=50.0)
        assert v.max() - v.min() == pytest.approx(50.0, rel=1e-12)
        assert abs(v.mean()) < 1e-9


@pytest.mark.parametrize("length_m", [4000.0, 8000.0])
def test_gradients_and_correlation_length_follow_the_covariance(length_m):
    """Median |∇g| against √(2 ln 2)·√2 σ/L, the autocorrelation's 1/e lag against L."""
    spec = {"size_m": (60_000.0, 60_000.0), "spacing_m": 250.0, "correlation_m": length_m}
    ratios, lengths = [], []
    for seed in range(6):
        grid = random_anomaly_grid(RandomFieldSpec(**spec), np.random.default_rng(seed))
        st = map_statistics(grid)
        expect = gradient_median_mgal_per_m(st["sigma_mgal"], length_m) * 1e3
        ratios.append(st["gradient_median_mgal_per_km"] / expect)
        lengths.append(st["correlation_length_m"] / length_m)
    # A finite map's σ is below the field's (its mean is removed); the gradient's is not: the
    # ratio sits a little above 1, and well away from the 2× an error in s² = 2σ²/L² would give.
    assert 0.9 < np.mean(ratios) < 1.2
    assert 0.85 < np.mean(lengths) < 1.1


def test_a_longer_correlation_length_gives_gentler_gradients():
    g = [
        map_statistics(
            random_anomaly_grid(RandomFieldSpec(correlation_m=L), np.random.default_rng(0))
        )["gradient_median_mgal_per_km"]
        for L in (5000.0, 20_000.0)
    ]
    assert g[0] > 2 * g[1]


@pytest.mark.parametrize(
    ("kw", "needle"),
    [
        ({"correlation_m": 500.0}, "correlation_m"),
        ({"range_mgal": 0.0}, "range_mgal"),
        ({"spacing_m": 60_000.0}, "spacing_m"),
    ],
)
def test_impossible_specs_are_clear_errors(kw, needle):
    with pytest.raises(ValueError, match=needle):
        RandomFieldSpec(**kw)


def _scenario(**gravity) -> object:
    return minimal_scenario(
        sensors={"gravimeter": "ideal"},
        navigation={"variants": ["ins"]},
        gravity={"map": "random", **gravity},
    )


def test_a_scenario_draws_its_random_map_from_its_map_seed():
    s0 = _scenario(size_km=[30.0, 30.0], spacing_m=500.0, correlation_km=4.0, range_mgal=60.0)
    assert check_gravity(s0) == []
    f0 = gravity_field(s0)
    assert f0 is not None
    assert f0.values_mgal.shape == (61, 61)
    assert f0.values_mgal.max() - f0.values_mgal.min() == pytest.approx(60.0)
    f1 = gravity_field(_scenario(size_km=[30.0, 30.0], spacing_m=500.0, map_seed=1))
    assert f1 is not None
    assert not np.allclose(f0.values_mgal, f1.values_mgal)
    assert "map_seed 1" in f1.source


@pytest.mark.parametrize(
    ("gravity", "needle"),
    [
        ({"correlation_km": 0.2, "spacing_m": 500.0}, "gravity.correlation_km: 0.2"),
        ({"size_km": [900.0, 900.0], "spacing_m": 100.0}, "gravity.spacing_m: 100"),
    ],
)
def test_a_random_map_it_cannot_draw_is_a_one_line_error(gravity, needle):
    with pytest.raises(ScenarioError) as err:
        _scenario(**gravity)
    assert len(err.value.errors) == 1
    assert err.value.errors[0].startswith(needle)


def test_the_median_gradient_formula_is_the_rayleigh_median():
    # Rayleigh(s): P(|∇g| <= m) = 1 − exp(−m²/2s²) = 1/2 at m = s√(2 ln 2), s = √2 σ/L.
    m = gradient_median_mgal_per_m(10.0, 5000.0)
    s = math.sqrt(2.0) * 10.0 / 5000.0
    assert 1.0 - math.exp(-(m**2) / (2 * s**2)) == pytest.approx(0.5)
