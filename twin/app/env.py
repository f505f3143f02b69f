"""A ``dm_env.Environment`` over a scenario: observations are sensor readings only.

Actions are either autopilot setpoints (``control="setpoint"``: forward speed, depth, compass
heading; the autopilot flies them on its navigation source) or raw actuator commands
(``control="actuator"``: rudder, stern planes, propeller). Each ``step`` advances
``control_period_s`` of sim time through the stepping core
(:meth:`twin.sim.step.Simulation.step`). The episode is truncated at the scenario's duration.

Observations, buffered as dm_control's composer observables are: a sensor that samples k > 1 times
per control period (the 100 Hz IMU at a 0.1 s period: k = 10) is observed as its last k readings,
oldest first (``"<sensor>/<channel>"`` of shape (k, …), ``"<sensor>/t"`` of shape (k,)), so a
policy sees every sample, not the last of ten. A sensor with k = 1 is observed as its latest
reading (no leading axis). Slots not yet filled are zeros with t = −1. ``"time_s"`` is the sim
time. No truth: :attr:`AuvEnv.truth` is for scoring, never an input to a policy.

A task (:mod:`twin.app.tasks`: heading hold, depth hold, waypoint following, in the pattern of
dm_control's ``rl.control``) adds its goal to the observation (``"task/…"``), gives the reward
from truth, and may end the episode (``dm_env.termination``: discount 0 on failure, 1 on success).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from typing import Any, Literal

import dm_env
import numpy as np
from dm_env import specs

from scenarios.schema import Scenario
from twin.app.tasks import AuvTask
from twin.core.messages import ActuatorCommand, Reading
from twin.onboard.control.autopilot import Setpoint
from twin.sim.build import build_simulation
from twin.sim.step import Simulation
from twin.world.truth import Truth

Control = Literal["setpoint", "actuator"]


class AuvEnv(dm_env.Environment):
    """The scenario's world as a dm_env environment.

    Args:
        scenario: A validated scenario (place, water, sensors, initial state, duration).
        control: "setpoint" or "actuator" (see module docstring).
        control_period_s: Sim time per ``step`` (a multiple of the physics step).
        seed: Root seed of the first episode; each reset after the first draws the next seed, so
            episodes differ but a fresh environment with the same seed replays them exactly.
        task: The task (goal, reward, termination); None: no goal, reward from ``reward_fn``.
        reward_fn: Optional reward from (truth, observation) when there is no task; 0.0 default.
    """

    def __init__(
        self,
        scenario: Scenario,
        *,
        control: Control = "setpoint",
        control_period_s: float = 0.1,
        seed: int | None = None,
        task: AuvTask | None = None,
        reward_fn: Callable[[Truth, dict[str, np.ndarray]], float] | None = None,
    ):
        if control not in ("setpoint", "actuator"):
            raise ValueError(f"control = {control!r}: allowed 'setpoint' or 'actuator'")
        if task is not None and reward_fn is not None:
            raise ValueError("give a task or a reward_fn, not both (the task owns the reward)")
        self._scenario = scenario
        self._control = control
        self._seed0 = scenario.seed if seed is None else seed
        self._episode = 0
        self._task = task
        self._reward_fn = reward_fn
        self._world: Simulation = build_simulation(scenario, self._seed0)
        dt = self._world.physics_dt
        n = round(control_period_s / dt) if math.isfinite(control_period_s) else 0
        if n < 1 or not math.isclose(n * dt, control_period_s, rel_tol=1e-9, abs_tol=1e-12):
            raise ValueError(
                f"control_period_s = {control_period_s!r}: must be a positive multiple of the "
                f"physics step {dt} s"
            )
        self._substeps = n
        self._period = control_period_s
        # Readings per control period, per sensor: the buffer length (at least 1).
        self._k = {
            s.name: max(1, math.ceil(s.rate_hz * control_period_s - 1e-9))
            for s in self._world.suite.sensors
        }
        if task is not None:
            self._start_task(self._seed0)
        self._obs_spec = self._make_observation_spec()
        self._buffers: dict[str, deque[Reading]] = {}
        self._needs_reset = True

    # ---- specs ---------------------------------------------------------------------------
    def _make_observation_spec(self) -> dict[str, specs.Array]:
        end = float(self._scenario.duration_s)
        out: dict[str, specs.Array] = {
            "time_s": specs.BoundedArray((), np.float64, 0.0, end, name="time_s")
        }
        for sensor in self._world.suite.sensors:
            k = self._k[sensor.name]
            lead = (k,) if k > 1 else ()
            # −1: a slot not filled yet; no upper bound (a sensor's own clock may run ahead).
            out[f"{sensor.name}/t"] = specs.BoundedArray(
                lead, np.float64, -1.0, np.inf, name=f"{sensor.name}/t"
            )
            for channel, spec in sensor.channel_specs().items():
                key = f"{sensor.name}/{channel}"
                shape = lead + tuple(spec.shape)
                if isinstance(spec, specs.BoundedArray):  # the sensor's own bounds, per element
                    out[key] = specs.BoundedArray(
                        shape,
                        spec.dtype,
                        np.broadcast_to(spec.minimum, shape),
                        np.broadcast_to(spec.maximum, shape),
                        name=key,
                    )
                else:
                    out[key] = specs.Array(shape, spec.dtype, name=key)
        if self._task is not None:
            bounds = type(self._task).OBSERVATION_BOUNDS
            for key, value in self._task.get_observation(self._world).items():
                v = np.asarray(value)
                if key in bounds:
                    lo, hi = bounds[key]
                    out[key] = specs.BoundedArray(v.shape, v.dtype, lo, hi, name=key)
                else:
                    out[key] = specs.Array(v.shape, v.dtype, name=key)
        return out

    def observation_spec(self) -> dict[str, specs.Array]:
        return dict(self._obs_spec)

    def action_spec(self) -> specs.BoundedArray:
        p = self._world.plant.params
        if self._control == "setpoint":
            return specs.BoundedArray(
                (3,),
                np.float64,
                minimum=[0.0, 0.0, 0.0],
                maximum=[2.5, 200.0, 360.0],
                name="speed_mps,depth_m,heading_deg",
            )
        return specs.BoundedArray(
            (3,),
            np.float64,
            minimum=[-p.fin_max_rad, -p.fin_max_rad, 0.0],
            maximum=[p.fin_max_rad, p.fin_max_rad, p.prop_max_rpm / 60.0],
            name="rudder_rad,stern_rad,propeller_rps",
        )

    # ---- episode -------------------------------------------------------------------------
    @property
    def truth(self) -> Truth:
        """Ground truth now (for scoring and logging; not an observation)."""
        return self._world.plant.truth()

    @property
    def world(self) -> Simulation:
        return self._world

    @property
    def task(self) -> AuvTask | None:
        return self._task

    def _start_task(self, seed: int) -> None:
        assert self._task is not None
        # The task's goal stream derives from the episode's seed alone (its own SeedSequence
        # branch, so the world's streams are unchanged by having a task).
        self._task.random = np.random.default_rng(np.random.SeedSequence([seed, 0x7A5C]))
        self._task.initialize_episode(self._world)

    def reset(self) -> dm_env.TimeStep:
        seed = self._seed0 + self._episode
        if self._episode > 0:
            self._world = build_simulation(self._scenario, seed)
            if self._task is not None:
                self._start_task(seed)
        self._episode += 1
        self._needs_reset = False
        self._buffers = {s.name: deque(maxlen=self._k[s.name]) for s in self._world.suite.sensors}
        readings = self._world.suite.poll(self._world.plant)
        self._world.deliver(readings)
        self._observe(readings)
        return dm_env.restart(self._observation())

    def step(self, action: Any) -> dm_env.TimeStep:
        if self._needs_reset:
            return self.reset()
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        spec = self.action_spec()
        if a.shape != spec.shape or not np.all(np.isfinite(a)):
            raise ValueError(
                f"action {action!r}: expected {spec.shape} finite values ({spec.name})"
            )
        w = self._world
        if self._control == "setpoint":
            a = np.clip(a, spec.minimum, spec.maximum)
            sp = Setpoint(float(a[0]), float(a[1]), math.radians(float(a[2])))
            w.setpoint = sp
            cmd = w.autopilot.update(w.nav.nav_state(), sp, self._period)
        else:
            cmd = ActuatorCommand(float(a[0]), float(a[1]), float(a[2]))
        for _ in range(self._substeps):
            self._observe(w.step(cmd).readings)
        obs = self._observation()
        termination = None
        if self._task is not None:
            self._task.after_step(w)
            reward = float(self._task.get_reward(w))
            termination = self._task.get_termination(w)
        elif self._reward_fn is not None:
            reward = float(self._reward_fn(self.truth, obs))
        else:
            reward = 0.0
        if termination is not None:
            self._needs_reset = True
            if termination == 0.0:
                return dm_env.termination(reward, obs)
            return dm_env.truncation(reward, obs, discount=float(termination))
        # Half a physics step of tolerance: MuJoCo's clock is a running sum of dt that lags
        # n·dt by more than 1e-9 s in a long episode (sensors/suite.py).
        if w.plant.t >= self._scenario.duration_s - 0.5 * w.physics_dt:
            self._needs_reset = True
            return dm_env.truncation(reward, obs)
        return dm_env.transition(reward, obs)

    def _observe(self, readings: list[Reading]) -> None:
        for reading in readings:
            self._buffers[reading.sensor].append(reading)

    def _observation(self) -> dict[str, np.ndarray]:
        obs: dict[str, np.ndarray] = {"time_s": np.float64(self._world.plant.t)}
        for sensor in self._world.suite.sensors:
            k = self._k[sensor.name]
            buf = list(self._buffers[sensor.name])
            t_key = f"{sensor.name}/t"
            times = np.full(k, -1.0)
            if buf:
                times[k - len(buf) :] = [r.t for r in buf]
            obs[t_key] = times if k > 1 else np.float64(times[-1])
            for channel in sensor.channel_specs():
                key = f"{sensor.name}/{channel}"
                spec = self._obs_spec[key]
                arr = np.zeros(spec.shape, spec.dtype)
                inner = spec.shape[1:] if k > 1 else spec.shape
                for j, r in enumerate(buf):
                    v = np.asarray(r.values[channel], dtype=spec.dtype).reshape(inner)
                    if k > 1:
                        arr[k - len(buf) + j] = v
                    else:
                        arr = v.copy()
                obs[key] = arr
        if self._task is not None:
            obs.update(
                {k: np.asarray(v) for k, v in self._task.get_observation(self._world).items()}
            )
        return obs
