"""Control tasks (dm_control rl.control pattern) and the Gymnasium adapter, on the real plant."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import scenarios
from twin.app.env import AuvEnv
from twin.app.gym_env import AuvGymEnv
from twin.app.tasks import DepthHold, HeadingHold, WaypointFollowing


def _tank(seconds: float = 4.0) -> scenarios.Scenario:
    return dataclasses.replace(scenarios.load("tank"), duration_s=seconds)


def _short_default(seconds: float = 4.0) -> scenarios.Scenario:
    return dataclasses.replace(scenarios.load("default"), duration_s=seconds)


def test_heading_hold_rewards_the_true_heading_against_the_goal() -> None:
    sc = _short_default()
    env = AuvEnv(sc, control="setpoint", task=HeadingHold(target_deg=0.0))
    ts = env.reset()
    assert ts.observation["task/target_heading_deg"] == 0.0
    on_goal = [env.step(np.array([1.5, 10.0, 0.0])).reward for _ in range(5)]
    env2 = AuvEnv(sc, control="setpoint", task=HeadingHold(target_deg=90.0))
    env2.reset()
    off_goal = [env2.step(np.array([1.5, 10.0, 0.0])).reward for _ in range(5)]
    assert min(on_goal) > 0.99  # starts on heading North: inside the 2 deg bounds
    assert max(off_goal) < 0.01  # 90 deg off, far past the 30 deg margin


def test_random_goals_derive_from_the_episode_seed() -> None:
    sc = _short_default()
    a = AuvEnv(sc, task=HeadingHold(), seed=5)
    b = AuvEnv(sc, task=HeadingHold(), seed=5)
    c = AuvEnv(sc, task=HeadingHold(), seed=6)
    goals = [e.reset().observation["task/target_heading_deg"] for e in (a, b, c)]
    assert goals[0] == goals[1] != goals[2]
    # A task does not change the world's random streams.
    plain = AuvEnv(sc, seed=5)
    np.testing.assert_array_equal(
        plain.reset().observation["imu/angular_rate"],
        AuvEnv(sc, task=HeadingHold(), seed=5).reset().observation["imu/angular_rate"],
    )


def test_depth_hold_terminates_with_discount_zero_when_the_vehicle_surfaces() -> None:
    sc = dataclasses.replace(
        scenarios.load("default"),
        duration_s=60.0,
        initial=dataclasses.replace(scenarios.load("default").initial, depth_m=0.8),
    )
    env = AuvEnv(sc, control="actuator", task=DepthHold(target_m=10.0))
    env.reset()
    # Full stern planes down at full speed: the nose pitches up and the vehicle breaks surface.
    for _ in range(600):
        ts = env.step(np.array([0.0, math.radians(15.0), 1525.0 / 60.0]))
        if ts.last():
            break
    assert ts.last() and ts.discount == 0.0
    assert env.truth.depth_m < 0.3
    assert ts.reward < 0.1


def test_waypoint_following_succeeds_with_discount_one() -> None:
    sc = _short_default(60.0)
    env = AuvEnv(sc, control="setpoint", task=WaypointFollowing(((0.0, 30.0),), acceptance_m=5.0))
    env.reset()
    rewards = []
    for _ in range(600):
        ts = env.step(np.array([1.5, 10.0, 0.0]))
        rewards.append(ts.reward)
        if ts.last():
            break
    assert ts.last() and ts.discount == 1.0
    assert env.truth.position_n[1] > 25.0  # it really got there
    assert rewards[-1] == 1.0 and rewards[0] < rewards[-1]  # the reward rose on the way


def test_gymnasium_make_passes_the_env_checker() -> None:
    env = gym.make(
        "twin.app.gym_env:AuvTwin-v0", scenario=_tank(), task="depth_hold", duration_s=2.0
    )
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    assert "truth" in info
    total, steps = 0.0, 0
    while True:
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        total += reward
        steps += 1
        if terminated or truncated:
            break
    assert truncated and not terminated and steps == 20  # 2 s at 0.1 s
    assert 0.0 <= total <= steps


def test_gymnasium_same_seed_same_episode() -> None:
    def roll(seed: int) -> list[np.ndarray]:
        env = AuvGymEnv(scenario=_tank(), task="heading_hold", duration_s=1.0)
        obs, _ = env.reset(seed=seed)
        out = [obs["imu/angular_rate"]]
        for _ in range(5):
            obs, *_ = env.step(np.array([0.05, 0.0, 10.0]))
            out.append(obs["imu/angular_rate"])
        return out

    for x, y in zip(roll(11), roll(11), strict=True):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(roll(11)[-1], roll(12)[-1])


def test_bad_task_arguments_name_what_is_wrong() -> None:
    with pytest.raises(ValueError, match="target_deg"):
        HeadingHold(target_deg=400.0)
    with pytest.raises(ValueError, match="target_m"):
        DepthHold(target_m=-1.0)
    with pytest.raises(ValueError, match="waypoints_m"):
        WaypointFollowing(())
    with pytest.raises(ValueError, match="task"):
        AuvGymEnv(scenario=_tank(), task="backflip")
