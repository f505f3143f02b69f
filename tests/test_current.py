from __future__ import annotations

import math

import numpy as np
import pytest

from twin.world.current import Current, CurrentProfilePoint


def test_constant_current_flows_toward_its_compass_direction() -> None:
    c = Current("constant", speed_mps=0.5, toward_deg=90.0)
    np.testing.assert_allclose(c.velocity_n(10.0), [0.5, 0.0, 0.0], atol=1e-12)
    c = Current("constant", speed_mps=0.5, toward_deg=180.0)
    np.testing.assert_allclose(c.velocity_n(10.0), [0.0, -0.5, 0.0], atol=1e-12)


def test_profile_interpolates_in_depth_and_holds_beyond_the_ends() -> None:
    pts = (CurrentProfilePoint(0.0, 0.4, 90.0), CurrentProfilePoint(20.0, 0.0, 90.0))
    c = Current("profile", profile=pts)
    assert c.velocity_n(10.0)[0] == pytest.approx(0.2)
    assert c.velocity_n(-1.0)[0] == pytest.approx(0.4)
    assert c.velocity_n(50.0)[0] == pytest.approx(0.0)


def test_gauss_markov_gusts_have_the_set_std_and_correlation_time() -> None:
    sigma, tau, dt = 0.05, 20.0, 0.5
    c = Current(
        "gauss_markov", speed_mps=0.2, toward_deg=0.0, sigma_mps=sigma, tau_s=tau,
        rng=np.random.default_rng(3),
    )  # fmt: skip
    xs = []
    for _ in range(200_000):
        c.step(dt)
        xs.append(c.velocity_n(0.0)[:2].copy())
    x = np.array(xs) - [0.0, 0.2]
    assert np.std(x, axis=0) == pytest.approx([sigma, sigma], rel=0.05)
    lag = round(tau / dt)
    rho = np.corrcoef(x[:-lag, 0], x[lag:, 0])[0, 1]
    assert rho == pytest.approx(math.exp(-1.0), abs=0.04)


def test_gusts_are_deterministic_per_seed() -> None:
    def run(seed: int) -> np.ndarray:
        c = Current("gauss_markov", sigma_mps=0.1, tau_s=5.0, rng=np.random.default_rng(seed))
        out = []
        for _ in range(100):
            c.step(0.1)
            out.append(c.velocity_n(0.0).copy())
        return np.array(out)

    np.testing.assert_array_equal(run(1), run(1))
    assert not np.array_equal(run(1), run(2))


def test_bad_currents_are_rejected() -> None:
    with pytest.raises(ValueError, match=r"current\.kind"):
        Current("tidal")
    with pytest.raises(ValueError, match="profile"):
        Current("profile", profile=(CurrentProfilePoint(5.0, 0.1, 0.0),))
    with pytest.raises(ValueError, match="Generator"):
        Current("gauss_markov", sigma_mps=0.1)
