"""Gymnasium as its users expect it: rendering, observation options, bounded spaces, normalised
actions, a depth-hold reward with a gradient, vectorised environments (twin.app.gym_env)."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import scenarios
from twin.app.gym_env import AuvGymEnv


def _sea(seconds: float = 2.0) -> scenarios.Scenario:
    return dataclasses.replace(scenarios.load("default"), duration_s=seconds)


@pytest.mark.parametrize("observation", ["no_frame", "image", "stokes"])
def test_observation_options_pass_the_checker(observation: str) -> None:
    """check_env passes; what it still warns of is the IMU's unbounded channels (the IMU models
    have no measurement range), and with AuvTwinNormalized-v0 nothing about the actions."""
    env = gym.make(
        "twin.app.gym_env:AuvTwinNormalized-v0",
        scenario=_sea(),
        task="heading_hold",
        observation=observation,
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    messages = {str(w.message) for w in caught if "env_checker" in str(w.filename)}
    # (The checker also notes that it was handed a wrapped environment: the RescaleAction.)
    messages = {m for m in messages if "wrapper applied" not in m}
    assert messages and all("infinity" in m for m in messages), messages
    env = env.unwrapped
    obs, _ = env.reset(seed=1)
    assert "polarimeter/raw" not in obs
    assert env.observation_space.contains(obs)
    size = sum(int(np.prod(v.shape)) for v in obs.values())
    if observation == "image":
        img = obs["polarimeter/image"]
        assert img.dtype == np.uint8 and img.shape[-1] == 1 and img.shape[0] == 64
        assert img.max() > 0  # the sky in the window is bright
    elif observation == "stokes":
        st = obs["polarimeter/stokes"]
        assert st.shape[-1] == 3 and st.dtype == np.float32
        assert 0.0 < float(st[..., 1].max()) <= 1.0  # a polarized sky: DoP above 0
    assert size < 20_000  # against 313 421 with the raw frame


def test_spaces_are_bounded_where_the_physics_bounds_them() -> None:
    env = AuvGymEnv(scenario=_sea(), task="depth_hold", observation="full")
    sp = env.observation_space
    raw = sp["polarimeter/raw"]
    cal = env.dm_env.world.suite["polarimeter"].calibration()
    assert raw.low.min() == 0 and raw.high.max() == cal.saturation_dn
    p = sp["depth/pressure_pa"]
    assert p.low[0] == 0.0 and np.isfinite(p.high[0]) and p.high[0] > 3e5  # 30 bar class
    assert sp["time_s"].high == env.dm_env.world.scenario.duration_s
    assert np.all(np.isinf(sp["imu/angular_rate"].high))  # no modelled range: unbounded


@pytest.mark.render
def test_rgb_array_renders_the_chase_camera() -> None:
    env = gym.make(
        "twin.app.gym_env:AuvTwin-v0",
        scenario=_sea(),
        observation="no_frame",
        render_mode="rgb_array",
        render_width=160,
        render_height=120,
    )
    env.reset(seed=2)
    env.step(env.action_space.sample())
    frame = env.render()
    assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8
    assert frame.std() > 1.0  # a picture, not a blank buffer
    env.close()


def test_rgb_array_without_a_gl_context_is_a_clear_error() -> None:
    code = (
        "import gymnasium as gym, scenarios, dataclasses\n"
        "sc = dataclasses.replace(scenarios.load('default'), duration_s=1.0)\n"
        "env = gym.make('twin.app.gym_env:AuvTwin-v0', scenario=sc, observation='no_frame', "
        "render_mode='rgb_array')\n"
        "try:\n    env.reset(seed=0)\nexcept RuntimeError as e:\n    print('ERR', e)\n"
    )
    environ = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=environ
    )
    assert "ERR render_mode='rgb_array' needs an OpenGL context" in proc.stdout, proc.stderr
    assert "MUJOCO_GL=egl" in proc.stdout


def test_normalized_actions_span_minus_one_to_one() -> None:
    env = gym.make("twin.app.gym_env:AuvTwinNormalized-v0", scenario=_sea(), observation="no_frame")
    assert np.all(env.action_space.low == -1.0) and np.all(env.action_space.high == 1.0)
    env.reset(seed=0)
    inner = env.unwrapped.action_space
    # +1 on the propeller is full propeller speed on the unwrapped environment.
    rescaled = env.unwrapped  # the RescaleAction wrapper maps [−1, 1] onto [low, high]
    assert rescaled is not env
    _, _, _, _, _ = env.step(np.array([0.0, 0.0, 1.0]))
    assert inner.high[2] > 0


def test_a_random_policy_sees_a_depth_hold_gradient() -> None:
    """The reward starts at 0.1 whatever the target's distance and moves as the depth does."""
    env = AuvGymEnv(scenario=_sea(20.0), task="depth_hold", observation="no_frame")
    rewards = []
    obs, _ = env.reset(seed=4)
    env.action_space.seed(4)
    target = float(obs["task/target_depth_m"])
    start_depth = env.dm_env.truth.depth_m
    assert abs(target - start_depth) > 2.0  # beyond the old 2 m margin
    for _ in range(200):
        _, r, term, trunc, _ = env.step(env.action_space.sample())
        rewards.append(r)
        if term or trunc:
            break
    r = np.asarray(rewards)
    assert 0.05 < r[0] < 0.2  # about 0.1 at the start distance
    assert r.std() > 1e-4  # a gradient (a 2 m margin gave a maximum of 2.7e-12)


def test_make_vec_async_steps_in_parallel_processes() -> None:
    envs = gym.make_vec(
        "twin.app.gym_env:AuvTwin-v0",
        num_envs=2,
        vectorization_mode="async",
        scenario=_sea(1.0),
        task="heading_hold",
        observation="no_frame",
    )
    try:
        obs, _ = envs.reset(seed=[5, 6])
        assert obs["imu/angular_rate"].shape[0] == 2
        for _ in range(3):
            obs, reward, *_ = envs.step(envs.action_space.sample())
        assert reward.shape == (2,)
        assert not np.array_equal(obs["imu/angular_rate"][0], obs["imu/angular_rate"][1])
    finally:
        envs.close()
