"""Bubbles under a breaking sea: the population, the per-frame draw, and their spots in a frame."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter.optics import bubbles as bubbles_mod
from sensors.polarimeter.optics.bubbles import A_MAX_M, BubblePopulation, hg_phase
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.tank import Tank
from twin.onboard.compass import create
from twin.onboard.compass.base import CompassContext

UTC = dt.datetime(2021, 7, 31, 4, 0, tzinfo=dt.UTC)

SUN = np.array([math.cos(math.radians(40)), 0.0, math.sin(math.radians(40))])


def _integral(f, a):
    return float(np.trapezoid(f, a))


def test_the_population_has_the_void_fraction_and_scattering_measured_under_breaking_seas():
    """Vagle & Farmer 1992, Terrill et al. 2001: void fractions ~1e-6, b of a few 1e-2 /m."""
    pop = BubblePopulation(13.0)
    a = np.geomspace(10e-6, A_MAX_M, 20001)
    n = pop.spectrum(a, np.zeros_like(a))
    void = _integral(n * (4.0 / 3.0) * math.pi * a**3, a)
    b = _integral(n * 2.0 * math.pi * a**2, a)  # geometric extinction, Q = 2
    assert 1e-6 < void < 5e-6
    assert 0.01 < b < 0.06
    # The cube law in wind, and the e-folding with depth (L = 0.4 m at and below 7.5 m/s).
    half = BubblePopulation(6.5)
    assert half.number_density_per_m3(0.0) == pytest.approx(pop.number_density_per_m3(0.0) / 8)
    ratio = half.number_density_per_m3(0.4, a_lo_m=500e-6) / half.number_density_per_m3(
        0.0, a_lo_m=500e-6
    )
    # a_ref grows by 0.8 µm over 0.4 m, which moves the a⁻⁴ tail by ~6 %.
    assert ratio == pytest.approx(math.exp(-1.0), rel=0.08)


def test_the_phase_function_is_normalised_and_forward():
    mu = np.linspace(-1.0, 1.0, 200001)
    assert _integral(2 * math.pi * hg_phase(mu), mu) == pytest.approx(1.0, rel=1e-4)
    assert _integral(2 * math.pi * mu * hg_phase(mu), mu) == pytest.approx(bubbles_mod.HG_G, 1e-3)


def _expected_count(pop: BubblePopulation, depth_m: float) -> float:
    """∫ da ∫ over the ball of radius reach·a/a_max around the camera of n(a, z), by quadrature.

    Independent of the sampler: spherical shells and polar angle on a grid, the water above the
    surface and the housing's 5 cm excluded.
    """
    a = np.geomspace(pop.a_min_m, A_MAX_M, 400)
    total = np.zeros_like(a)
    mu = np.linspace(-1.0, 1.0, 201)
    for i, ai in enumerate(a):
        rmax = pop.reach_m * ai / A_MAX_M
        if rmax <= 0.05:
            continue
        r = np.linspace(0.05, rmax, 200)
        rr, mm = np.meshgrid(r, mu, indexing="ij")
        z = depth_m - rr * mm  # mm = cos of the angle from up
        dens = np.where(z > 0, pop.spectrum(np.full_like(z, ai), np.maximum(z, 0.0)), 0.0)
        inner = np.trapezoid(dens, mu, axis=1) * 2 * math.pi
        total[i] = np.trapezoid(inner * r**2, r)
    return float(np.trapezoid(total, a))


@pytest.mark.parametrize(("wind", "depth"), [(8.5, 0.98), (12.3, 5.0)])
def test_the_draw_has_the_populations_count_and_sizes(wind, depth):
    pop = BubblePopulation(wind)
    expected = _expected_count(pop, depth)
    rng = np.random.default_rng(1)
    draws = [pop.draw(depth, rng) for _ in range(8)]
    counts = np.array([d.radii_m.size for d in draws])
    # Poisson: the mean of 8 frames within 4σ of the quadrature's count (and 2 % for its grid).
    sigma = math.sqrt(expected / len(draws))
    assert abs(counts.mean() - expected) < 4 * sigma + 0.02 * expected
    assert expected > 500  # the check has the statistics to fail
    radii = np.concatenate([d.radii_m for d in draws])
    off = np.concatenate([d.offsets_m for d in draws])
    r = np.linalg.norm(off, axis=1)
    assert np.all(r <= pop.reach_m * radii / A_MAX_M + 1e-12)
    assert np.all(r >= 0.05)
    z = np.concatenate([d.depths_m for d in draws])
    np.testing.assert_allclose(z, depth - off[:, 2])
    assert np.all(z > 0)
    # Larger bubbles are fewer but are drawn from farther: both ends are present.
    assert radii.min() < 60e-6 and radii.max() > 500e-6


def test_the_draw_is_deterministic_and_empty_where_there_are_no_bubbles():
    pop = BubblePopulation(8.5)
    a = pop.draw(0.98, np.random.default_rng(4))
    b = pop.draw(0.98, np.random.default_rng(4))
    np.testing.assert_array_equal(a.offsets_m, b.offsets_m)
    np.testing.assert_array_equal(a.radii_m, b.radii_m)
    # Calm water has no breakers; 10 m under a force-3 sea the expected count is < 1e-3.
    assert BubblePopulation(0.0).draw(0.98, np.random.default_rng(0)).radii_m.size == 0
    assert _expected_count(BubblePopulation(4.4), 10.0) < 1e-3
    assert BubblePopulation(4.4).draw(10.0, np.random.default_rng(0)).radii_m.size == 0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"wind_speed_mps": -1.0}, "wind_speed_mps"),
        ({"wind_speed_mps": math.nan}, "wind_speed_mps"),
        ({"wind_speed_mps": 5.0, "a_min_m": 1e-6}, "a_min_m"),
        ({"wind_speed_mps": 5.0, "reach_m": 0.0}, "reach_m"),
    ],
)
def test_impossible_populations_are_clear_errors(kwargs, field):
    with pytest.raises(ValueError, match=field):
        BubblePopulation(**kwargs)


def test_an_unknown_bubble_model_is_a_clear_error():
    with pytest.raises(ValueError, match=r"bubbles.*foam.*allowed"):
        OpticsConfig(bubbles="foam")


def _frame(bubbles: str, *, wind: float = 8.5, depth: float = 0.98, tank: Tank | None = None):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type="II", wind_speed_mps=wind, bubbles=bubbles))
    if tank is not None:
        cam.configure_tank(tank)
    return cam.render_offline(np.eye(3), depth, SUN, np.random.default_rng(3))


def test_bubbles_are_bright_unpolarized_points_added_to_the_frame():
    _, ideal = _frame("ideal")
    raw, real = _frame("hall_novarini")
    assert ideal.bubbles == 0
    assert real.bubbles > 1000
    d = real.stokes.astype(np.float64) - ideal.stokes.astype(np.float64)
    # Only S0 changes, and only upwards: unpolarized light added.
    np.testing.assert_array_equal(d[..., 1:], 0.0)
    assert d[..., 0].min() >= 0.0
    lit = d[..., 0] > 0
    assert 0 < lit.sum() <= real.bubbles
    # Most are faint; a few are outliers several times brighter than the water behind them.
    ratio = d[..., 0][lit] / np.maximum(ideal.stokes[..., 0][lit], 1.0)
    assert np.median(ratio) < 0.05
    assert (ratio > 1.0).sum() >= 1
    # The degree of polarization falls where a bubble lands.
    dop = np.hypot(real.stokes[..., 1], real.stokes[..., 2]) / np.maximum(real.stokes[..., 0], 1)
    dop0 = np.hypot(ideal.stokes[..., 1], ideal.stokes[..., 2]) / np.maximum(
        ideal.stokes[..., 0], 1
    )
    assert np.all(dop[lit] <= dop0[lit] + 1e-6)
    # Same seed, same frame.
    raw2, again = _frame("hall_novarini")
    np.testing.assert_array_equal(raw, raw2)
    assert again.bubbles == real.bubbles


def test_no_bubbles_in_calm_water_deep_water_or_a_tank():
    assert _frame("hall_novarini", wind=0.0)[1].bubbles == 0
    assert _frame("hall_novarini", wind=4.4, depth=10.0)[1].bubbles == 0
    tank = Tank(shape="box", length_m=0.8, width_m=0.6, water_depth_m=1.5)
    assert _frame("hall_novarini", tank=tank)[1].bubbles == 0


def test_switching_bubbles_on_leaves_the_rest_of_the_seed_alone():
    """The bubbles have their own stream: the sea and the sensor's fixed pattern do not move."""
    cam_a = sensors.create("polarimeter", "phx050s_p_bin4")
    cam_a.configure(OpticsConfig(jerlov_type="II", wind_speed_mps=8.5))
    cam_b = sensors.create("polarimeter", "phx050s_p_bin4")
    cam_b.configure(OpticsConfig(jerlov_type="II", wind_speed_mps=8.5, bubbles="hall_novarini"))
    for cam in (cam_a, cam_b):
        cam.reset(None, np.random.default_rng(11))  # type: ignore[arg-type]
    assert cam_a._waves is not None and cam_b._waves is not None
    np.testing.assert_array_equal(cam_a._waves.slopes, cam_b._waves.slopes)
    assert cam_a._dofp is not None and cam_b._dofp is not None
    np.testing.assert_array_equal(cam_a._dofp._fp.hot, cam_b._dofp._fp.hot)


@pytest.mark.parametrize("method", ["lig", "pol", "snell", "roia"])
def test_a_frame_full_of_bubbles_gives_a_finite_fix_or_says_why_not(method):
    """0.3 m under an 8.5 m/s sea (~11 000 bubbles drawn): no NaN reaches the filter."""
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    optics = OpticsConfig(
        jerlov_type="II", wind_speed_mps=8.5, bubbles="hall_novarini", flicker="caustics"
    )
    cam.configure(optics)
    raw, truth = cam.render_offline(np.eye(3), 0.3, SUN, np.random.default_rng(5))
    assert truth.bubbles > 5000
    ctx = CompassContext(UTC, 36.175, 120.482, depth_m=0.3, water_index=cam.n_water, sun_enu=SUN)
    fix = create(method).solve(raw, cam.calibration(), ctx)
    if fix.ok:
        assert np.all(np.isfinite(fix.sun_body)) and math.isfinite(fix.heading_deg)
        assert fix.covariance_body is None or np.all(np.isfinite(fix.covariance_body))
    else:
        assert fix.reason and fix.sun_body is None
