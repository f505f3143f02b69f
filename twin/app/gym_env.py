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

Options (keyword arguments of ``gym.make``):

* ``observation``: ``"full"`` (every channel, the raw 2448×2048-class mosaic included),
  ``"no_frame"`` (the camera's raw frame left out), ``"image"`` (the frame as a downsampled
  intensity image, ``uint8`` (h, w, 1): super-pixel S0 scaled to the ADC's range, area-averaged
  to ``image_height`` rows) or ``"stokes"`` (``float32`` (h, w, 3): S0 / (2 × saturation), DoP
  in [0, 1], AoP in [−π/2, π/2], from the vehicle's calibration); the image keys are
  ``<camera>/image`` and ``<camera>/stokes``.
* ``render_mode="rgb_array"``: :meth:`render` returns the chase camera's view (``uint8``
  (``render_height``, ``render_width``, 3)); without an OpenGL context (``MUJOCO_GL=egl`` or
  ``osmesa`` headless) a clear error at ``reset``.
* ``AuvTwinNormalized-v0``: the same environment with actions rescaled to [−1, 1]
  (gymnasium's ``RescaleAction``).

Spaces are bounded where the physics bounds them (the ADC's range, the pressure sensor's full
scale, the exposure range, the episode's time; an IMU has no modelled range, so its channels
are unbounded); docs/gym.md lists every key.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import cv2
import gymnasium as gym
import numpy as np
from dm_env import specs
from gymnasium import spaces

import scenarios
from scenarios.schema import Scenario
from twin.app.env import AuvEnv, Control
from twin.app.tasks import AuvTask, DepthHold, HeadingHold, WaypointFollowing
from twin.onboard.polarization import stokes_from_mosaic

#: The ``observation`` options (module docstring).
OBSERVATIONS = ("full", "no_frame", "image", "stokes")

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

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        scenario: str | Scenario = "default",
        task: str | AuvTask | None = "heading_hold",
        control: Control = "actuator",
        control_period_s: float = 0.1,
        duration_s: float | None = None,
        observation: str = "full",
        image_height: int = 64,
        render_mode: str | None = None,
        render_width: int = 320,
        render_height: int = 240,
    ):
        if observation not in OBSERVATIONS:
            raise ValueError(f"observation = {observation!r}: allowed {list(OBSERVATIONS)}")
        if not (isinstance(image_height, int) and 8 <= image_height <= 2048):
            raise ValueError(f"image_height = {image_height!r}: allowed an integer in [8, 2048]")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(
                f"render_mode = {render_mode!r}: allowed None or {self.metadata['render_modes']}"
            )
        self.render_mode = render_mode
        self._render_size = (int(render_width), int(render_height))
        self._chase: Any = None
        self._observation, self._image_h = observation, image_height
        self._last_image: tuple[float, np.ndarray] | None = None
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
        self.metadata = {**self.metadata, "render_fps": round(1.0 / control_period_s)}
        cam = next((x for x in self._env.world.suite.sensors if x.kind == "polarimeter"), None)
        self._camera = cam.name if cam is not None else None
        self._cal = cam.calibration() if cam is not None else None  # type: ignore[attr-defined]
        self.observation_space = spaces.Dict(self._spaces(self._env.observation_spec()))
        self.action_space = _box(self._env.action_spec())

    # ---- observations ---------------------------------------------------------------------
    def _spaces(self, spec: dict[str, specs.Array]) -> dict[str, spaces.Box]:
        out = {k: _box(s) for k, s in spec.items()}
        if self._camera is None or self._observation == "full":
            return out
        raw = f"{self._camera}/raw"
        del out[raw]
        if self._observation == "no_frame":
            return out
        h, w = self._image_shape()
        if self._observation == "image":
            out[f"{self._camera}/image"] = spaces.Box(0, 255, (h, w, 1), np.uint8)
        else:
            lo = np.broadcast_to(np.array([0.0, 0.0, -np.pi / 2], np.float32), (h, w, 3))
            hi = np.broadcast_to(np.array([1.0, 1.0, np.pi / 2], np.float32), (h, w, 3))
            out[f"{self._camera}/stokes"] = spaces.Box(lo, hi, (h, w, 3), np.float32)
        return out

    def _image_shape(self) -> tuple[int, int]:
        assert self._cal is not None
        sh, sw = self._cal.height_px // 2, self._cal.width_px // 2  # super-pixels
        h = min(self._image_h, sh)
        return h, max(1, round(sw * h / sh))

    def _obs(self, observation: dict[str, Any]) -> dict[str, np.ndarray]:
        obs = _obs(observation)
        if self._camera is None or self._observation == "full":
            return obs
        raw = obs.pop(f"{self._camera}/raw")
        if self._observation == "no_frame":
            return obs
        assert self._cal is not None
        key = f"{self._camera}/{self._observation}"
        stamp = float(np.asarray(obs[f"{self._camera}/t"]).reshape(-1)[-1])
        if self._last_image is not None and self._last_image[0] == stamp:
            obs[key] = self._last_image[1].copy()  # the same frame as the last step's
            return obs
        frame = raw[-1] if raw.ndim == 3 else raw  # the period's last frame
        pol = stokes_from_mosaic(
            frame,
            self._cal.layout_deg,
            black_level_dn=self._cal.black_level_dn,
            saturation_dn=self._cal.saturation_dn,
        )
        h, w = self._image_shape()
        # S0 = ½ ΣI_k of four analysers each at most the saturation: at most 2 × saturation.
        s0 = np.clip(pol.s0 / np.float32(2.0 * self._cal.saturation_dn), 0.0, 1.0)
        if self._observation == "image":
            img = cv2.resize(s0, (w, h), interpolation=cv2.INTER_AREA)
            obs[key] = np.round(img * 255).astype(np.uint8)[..., None]
        else:
            planes = [np.nan_to_num(p, nan=0.0) for p in (s0, pol.dop, pol.aop)]
            img = np.stack(
                [cv2.resize(p, (w, h), interpolation=cv2.INTER_AREA) for p in planes], -1
            )
            img[..., 1] = np.clip(img[..., 1], 0.0, 1.0)
            img[..., 2] = np.clip(img[..., 2], -np.pi / 2, np.pi / 2)
            obs[key] = img.astype(np.float32)
        self._last_image = (stamp, obs[key].copy())
        return obs

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
        self._last_image = None
        ts = self._env.reset()
        if self.render_mode == "rgb_array":
            self._open_chase()
        return self._obs(ts.observation), {"truth": self._truth()}

    # ---- rendering ------------------------------------------------------------------------
    def _open_chase(self) -> None:
        from twin.record.observer import ChaseCamera

        if self._chase is not None:
            self._chase.close()
        w, h = self._render_size
        self._chase = ChaseCamera(self._env.world.plant.model, w, h)
        if not self._chase.available:
            reason = self._chase.reason
            self._chase = None
            raise RuntimeError(
                f"render_mode='rgb_array' needs an OpenGL context ({reason}); headless, set "
                "MUJOCO_GL=egl or MUJOCO_GL=osmesa"
            )

    def render(self) -> np.ndarray | None:
        """The chase camera's view (``render_mode="rgb_array"``), else None."""
        if self.render_mode != "rgb_array":
            return None
        if self._chase is None:
            self._open_chase()
        return self._chase.render(self._env.world.plant.data)

    def close(self) -> None:
        if self._chase is not None:
            self._chase.close()
            self._chase = None
        super().close()

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict]:
        ts = self._env.step(np.asarray(action, dtype=np.float64))
        last = ts.last()
        # A last step with discount 1 before the scenario's end is the task's success.
        world = self._env.world  # half a step of tolerance on MuJoCo's running clock (env.py)
        before_end = world.plant.t < self._scenario.duration_s - 0.5 * world.physics_dt
        success = bool(last and ts.discount == 1.0 and before_end)
        terminated = bool(last and (ts.discount == 0.0 or success))
        truncated = bool(last and not terminated)
        info = {"truth": self._truth(), "success": success}
        return self._obs(ts.observation), float(ts.reward or 0.0), terminated, truncated, info


def make_normalized(**kwargs: Any) -> gym.Env:
    """:class:`AuvGymEnv` with actions rescaled to [−1, 1] (``AuvTwinNormalized-v0``)."""
    return gym.wrappers.RescaleAction(AuvGymEnv(**kwargs), -1.0, 1.0)


gym.register(id="AuvTwin-v0", entry_point="twin.app.gym_env:AuvGymEnv")
gym.register(id="AuvTwinNormalized-v0", entry_point="twin.app.gym_env:make_normalized")
