"""Error processes: white noise, Gauss–Markov, random walk, quantization."""

from __future__ import annotations

import math

import allantools
import numpy as np
import pytest

from sensors import noise


def test_white_noise_sigma_is_density_times_root_rate() -> None:
    w = noise.WhiteNoise([1e-3, 2e-3, 3e-3], rate_hz=100.0)
    rng = np.random.default_rng(1)
    samples = np.array([w.step(rng).copy() for _ in range(20000)])
    expected = np.array([1e-3, 2e-3, 3e-3]) * 10.0
    # Relative standard error of a sample std over n = 20000 is 1/sqrt(2n) = 0.5 %.
    np.testing.assert_allclose(samples.std(axis=0), expected, rtol=0.02)
    assert np.all(np.abs(samples.mean(axis=0)) < 4 * expected / math.sqrt(20000))


def test_gauss_markov_stays_stationary_with_exact_discretisation() -> None:
    """Many chains at once: the variance stays σ² and the lag correlation is e^{−Δt/τ}."""
    sigma, tau, dt = 2.0, 5.0, 0.7
    gm = noise.GaussMarkov(sigma, tau, shape=40000)
    rng = np.random.default_rng(2)
    b0 = gm.reset(rng).copy()
    for _ in range(10):
        gm.step(rng, dt)
    b = gm.value
    assert b0.std() == pytest.approx(sigma, rel=0.02)
    assert b.std() == pytest.approx(sigma, rel=0.02)
    rho = np.corrcoef(b0, b)[0, 1]
    assert rho == pytest.approx(math.exp(-10 * dt / tau), abs=0.02)


def test_gauss_markov_two_half_steps_equal_one_step_in_distribution() -> None:
    sigma, tau = 1.0, 3.0
    rng = np.random.default_rng(3)
    a = noise.GaussMarkov(sigma, tau, shape=40000)
    a.reset(rng)
    a0 = a.value.copy()
    a.step(rng, 0.5)
    a.step(rng, 0.5)
    b = noise.GaussMarkov(sigma, tau, shape=40000)
    b.reset(rng)
    b0 = b.value.copy()
    b.step(rng, 1.0)
    assert np.corrcoef(a0, a.value)[0, 1] == pytest.approx(np.corrcoef(b0, b.value)[0, 1], abs=0.02)
    assert np.corrcoef(b0, b.value)[0, 1] == pytest.approx(math.exp(-1.0 / tau), abs=0.02)


def test_gauss_markov_limits() -> None:
    rng = np.random.default_rng(4)
    white = noise.GaussMarkov(1.5, 0.0, shape=20000)  # τ = 0: white noise of σ
    white.reset(rng)
    b0 = white.value.copy()
    white.step(rng, 0.01)
    assert abs(np.corrcoef(b0, white.value)[0, 1]) < 0.03
    assert white.value.std() == pytest.approx(1.5, rel=0.03)
    const = noise.GaussMarkov(1.5, math.inf, shape=5)  # τ = ∞: a random constant
    c0 = const.reset(rng).copy()
    const.step(rng, 100.0)
    np.testing.assert_array_equal(const.value, c0)
    with pytest.raises(ValueError, match="tau_s"):
        noise.GaussMarkov(1.0, -1.0)


def test_gauss_markov_per_row_correlation_times() -> None:
    gm = noise.GaussMarkov(np.array([[1.0], [2.0]]), np.array([[1.0], [10.0]]), shape=(2, 3))
    assert gm.sigma.shape == (2, 3)
    gm.step(np.random.default_rng(0), 1.0)
    np.testing.assert_allclose(gm._phi[:, 0], [math.exp(-1.0), math.exp(-0.1)])


def test_random_walk_variance_grows_linearly() -> None:
    k, dt, n = 0.3, 0.25, 16
    rw = noise.RandomWalk(k, shape=40000)
    rng = np.random.default_rng(5)
    rw.reset()
    for _ in range(n):
        rw.step(rng, dt)
    assert rw.value.var() == pytest.approx(k * k * n * dt, rel=0.03)


def test_quantize() -> None:
    x = np.array([0.04, 0.06, 0.149, -0.051, 1.0])
    np.testing.assert_allclose(noise.quantize(x, 0.1), [0.0, 0.1, 0.1, -0.1, 1.0])
    np.testing.assert_allclose(noise.quantize(x, 0.1, mode="floor"), [0.0, 0.0, 0.1, -0.1, 1.0])
    np.testing.assert_array_equal(noise.quantize(x, 0.0), x)
    with pytest.raises(ValueError, match="mode"):
        noise.quantize(x, 0.1, mode="ceil")


def test_gauss_markov_allan_constants() -> None:
    taus = np.linspace(0.5, 5.0, 20001)
    adev = noise.gauss_markov_adev(taus, 1.0, 1.0)
    assert adev.max() == pytest.approx(noise.GM_ADEV_PEAK_RATIO, rel=1e-6)
    assert taus[adev.argmax()] == pytest.approx(noise.GM_ADEV_PEAK_TAU_RATIO, abs=1e-3)
    # navigation.md §2.2: σ_GM ≈ 1.07 B puts the GM peak on the flicker floor 0.664 B.
    b = 3.0
    s = noise.gauss_markov_sigma_for_bias_instability(b)
    assert s == pytest.approx(1.07 * b, rel=0.01)
    assert s * noise.GM_ADEV_PEAK_RATIO == pytest.approx(0.664 * b, rel=1e-3)


def test_simulated_gauss_markov_matches_analytic_allan_deviation() -> None:
    """Fast statistical check of the discretisation against IEEE-952's curve (τ_c = 1 s)."""
    sigma, tau_c, fs, n = 1.0, 1.0, 50.0, 100_000  # 2000 s = 2000 τ_c
    gm = noise.GaussMarkov(sigma, tau_c, shape=3)
    rng = np.random.default_rng(6)
    gm.reset(rng)
    data = np.empty((n, 3))
    for k in range(n):
        data[k] = gm.step(rng, 1.0 / fs)
    taus = np.array([0.2, 1.0, 2.0, 5.0, 10.0])
    measured = np.mean(
        [allantools.oadev(data[:, i], rate=fs, data_type="freq", taus=taus)[1] for i in range(3)],
        axis=0,
    )
    np.testing.assert_allclose(measured, noise.gauss_markov_adev(taus, sigma, tau_c), rtol=0.08)


def test_same_generator_seed_gives_identical_processes() -> None:
    def run(seed: int) -> np.ndarray:
        rng = np.random.default_rng(seed)
        gm, rw, wn = noise.GaussMarkov(1.0, 2.0), noise.RandomWalk(0.5), noise.WhiteNoise(0.1, 10)
        gm.reset(rng)
        return np.array([gm.step(rng, 0.1) + rw.step(rng, 0.1) + wn.step(rng) for _ in range(50)])

    np.testing.assert_array_equal(run(11), run(11))
    assert not np.array_equal(run(11), run(12))


def test_shape_mismatch_is_an_error() -> None:
    with pytest.raises(ValueError, match="sigma"):
        noise.GaussMarkov([1.0, 2.0], 1.0, shape=3)
