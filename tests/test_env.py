"""The dm_env environment: conformance, observations are readings only, determinism."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

import scenarios
from twin.app.env import AuvEnv


def _short_scenario(seconds: float = 3.0) -> scenarios.Scenario:
    return dataclasses.replace(scenarios.load("default"), duration_s=seconds)


class SetpointEnvConformanceTest(test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return AuvEnv(_short_scenario(), control="setpoint")

    def make_action_sequence(self):
        # 40 steps of 0.1 s run past the 3 s episode, so the truncation is exercised too.
        for _ in range(40):
            yield np.array([1.5, 10.0, 45.0])


class ActuatorEnvConformanceTest(test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return AuvEnv(_short_scenario(), control="actuator")


def test_observations_are_sensor_readings_and_time_only() -> None:
    env = AuvEnv(_short_scenario())
    keys = set(env.observation_spec())
    assert keys == {
        "time_s",
        "imu/t",
        "imu/angular_rate",
        "imu/specific_force",
        "depth/t",
        "depth/depth_m",
        "depth/pressure_pa",
        "polarimeter/t",
        "polarimeter/raw",
        "polarimeter/exposure_us",
    }
    ts = env.reset()
    ts = env.step(np.array([1.5, 10.0, 0.0]))
    # A level vehicle's accelerometer reads about +g on body z (the newest of the buffered ten;
    # the standing heel of ~3.5 deg tilts it by 0.2 %).
    assert ts.observation["imu/specific_force"][-1][2] == pytest.approx(9.8, abs=0.1)
    assert ts.observation["depth/depth_m"].item() == pytest.approx(10.0, abs=0.2)
    assert ts.observation["time_s"] == pytest.approx(0.1)
    raw = ts.observation["polarimeter/raw"]
    assert raw.shape == (512, 612) and raw.dtype == np.uint16 and raw.max() > 1000


def test_episode_is_truncated_at_the_scenario_duration() -> None:
    env = AuvEnv(_short_scenario(1.0))
    env.reset()
    steps = [env.step(np.array([1.5, 10.0, 0.0])) for _ in range(10)]
    assert steps[-1].last() and steps[-1].discount == 1.0
    assert not any(s.last() for s in steps[:-1])


def test_same_seed_same_observations() -> None:
    def run() -> list[np.ndarray]:
        env = AuvEnv(_short_scenario(), seed=7)
        env.reset()
        return [
            env.step(np.array([1.5, 11.0, 30.0])).observation["imu/angular_rate"] for _ in range(20)
        ]

    a, b = run(), run()
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_bad_arguments_name_what_is_wrong() -> None:
    with pytest.raises(ValueError, match="control"):
        AuvEnv(_short_scenario(), control="joystick")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="control_period_s"):
        AuvEnv(_short_scenario(), control_period_s=0.015)
    env = AuvEnv(_short_scenario())
    env.reset()
    with pytest.raises(ValueError, match="action"):
        env.step(np.array([1.0, np.nan, 0.0]))


def test_a_policy_sees_every_imu_sample_of_the_control_period() -> None:
    # 100 Hz IMU, 0.1 s period: the observation holds the ten readings of the period, in order;
    # the 10 Hz depth gauge and the 1 Hz camera, one reading each (their latest).
    env = AuvEnv(_short_scenario())
    spec = env.observation_spec()
    assert spec["imu/angular_rate"].shape == (10, 3)
    assert spec["imu/t"].shape == (10,)
    assert spec["depth/t"].shape == ()
    assert spec["polarimeter/raw"].shape == (512, 612)
    first = env.reset().observation
    # Only the t = 0 sample exists at reset: the other nine slots are marked empty (t = -1).
    np.testing.assert_array_equal(first["imu/t"][:-1], -1.0)
    assert first["imu/t"][-1] == 0.0
    obs = env.step(np.array([1.5, 10.0, 0.0])).observation
    np.testing.assert_allclose(obs["imu/t"], np.arange(1, 11) * 0.01, atol=1e-9)
    obs2 = env.step(np.array([1.5, 10.0, 0.0])).observation
    np.testing.assert_allclose(obs2["imu/t"], np.arange(11, 21) * 0.01, atol=1e-9)
    # Distinct samples, not one repeated.
    assert len({tuple(x) for x in obs2["imu/angular_rate"]}) == 10
