"""A Gymnasium adapter over :class:`twin.app.env.AuvEnv` for RL users.

    import gymnasium as gym
    env = gym.make("twin.app.gym_env:AuvTwin-v0", scenario="default", task="heading_hold")
    obs, info = env.reset(seed=3)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Spaces come from the dm_env specs: a ``Dict`` of ``Box`` per observation key (sensor readings,
buffered as in :class:`~twin.app.env.AuvEnv`, and the task's goal), a ``Box`` action space
(setpoints or actuator commands). ``reset(seed=s)`` builds the episode from seed ``s`` (same seed,
same episode); without a seed the next episode seed follows the previous one. ``terminated`` is a
dm_env termination (discount 0: the vehicle failed) or a task success (discount 1, reported in
``info["success"]``); ``truncated`` is the scenario's duration reached. ``info["truth"]`` carries
the true state (a dict of :class:`~twin.world.truth.Truth`'s fields) for analysis, never for
the policy.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from dm_env import specs
from gymnasium import spaces

import scenarios
from scenarios.schema import Scenario
from twin.app.env import AuvEnv, Control
from twin.app.tasks import AuvTask, DepthHold, HeadingHold, WaypointFollowing

TASKS: dict[str, type[AuvTask]] = {
    "heading_hold": HeadingHold,
    "depth_hold": DepthHold,
    "waypoint_following": WaypointFollowing,
}


def _box(spec: specs.Array) -> spaces.Box:
    dtype = np.dtype(spec.dtype)
    if isinstance(spec, specs.BoundedArray):
        return spaces.Box(
            np.broadcast_to(spec.minimum, spec.shape).astype(dtype),
            np.broadcast_to(spec.maximum, spec.shape).astype(dtype),
            shape=spec.shape,
            dtype=dtype,
        )
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        return spaces.Box(info.min, info.max, shape=spec.shape, dtype=dtype)
    return spaces.Box(-np.inf, np.inf, shape=spec.shape, dtype=dtype)


def _obs(observation: dict[str, Any]) -> dict[str, np.ndarray]:
    return {k: np.asarray(v) for k, v in observation.items()}


class AuvGymEnv(gym.Env):
    """Gymnasium view of a scenario.

    Args:
        scenario: A shipped scenario name, a ``.toml`` path or a :class:`Scenario`.
        task: None, a task name (``heading_hold``, ``depth_hold``, ``waypoint_following``) or a
            task object.
        control: ``"setpoint"`` or ``"actuator"``.
        control_period_s: Sim time per step.
        duration_s: Override the scenario's duration (episode length), or None.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}

    def __init__(
        self,
        scenario: str | Scenario = "default",
        task: str | AuvTask | None = "heading_hold",
        control: Control = "actuator",
        control_period_s: float = 0.1,
        duration_s: float | None = None,
    ):
        sc = scenarios.load(scenario) if isinstance(scenario, str) else scenario
        if duration_s is not None:
            sc = scenarios.parse_scenario({**sc.to_dict(), "duration_s": duration_s}, sc.name)
        if isinstance(task, str):
            if task not in TASKS:
                raise ValueError(f"task = {task!r}: allowed {sorted(TASKS)} or None")
            task = TASKS[task]()
        self._scenario, self._task, self._control = sc, task, control
        self._period = control_period_s
        self._next_seed = sc.seed
        self._env = self._make(self._next_seed)
        self.observation_space = spaces.Dict(
            {k: _box(s) for k, s in self._env.observation_spec().items()}
        )
        self.action_space = _box(self._env.action_spec())

    def _make(self, seed: int) -> AuvEnv:
        return AuvEnv(
            self._scenario,
            control=self._control,
            control_period_s=self._period,
            seed=seed,
            task=self._task,
        )

    @property
    def dm_env(self) -> AuvEnv:
        return self._env

    def _truth(self) -> dict[str, Any]:
        """The true state as a plain dict (Truth's fields), for analysis only."""
        return dataclasses.asdict(self._env.truth)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        super().reset(seed=seed)
        if seed is not None:
            if seed < 0:
                raise ValueError(f"seed = {seed}: must be >= 0")
            self._next_seed = seed
        self._env = self._make(self._next_seed)
        self._next_seed += 1
        ts = self._env.reset()
        return _obs(ts.observation), {"truth": self._truth()}

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict]:
        ts = self._env.step(np.asarray(action, dtype=np.float64))
        last = ts.last()
        # A last step with discount 1 before the scenario's end is the task's success.
        before_end = self._env.world.plant.t < self._scenario.duration_s - 1e-9
        success = bool(last and ts.discount == 1.0 and before_end)
        terminated = bool(last and (ts.discount == 0.0 or success))
        truncated = bool(last and not terminated)
        info = {"truth": self._truth(), "success": success}
        return _obs(ts.observation), float(ts.reward or 0.0), terminated, truncated, info


gym.register(id="AuvTwin-v0", entry_point="twin.app.gym_env:AuvGymEnv")
