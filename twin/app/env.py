"""A ``dm_env.Environment`` over a scenario: observations are sensor readings only.

Actions are either autopilot setpoints (``control="setpoint"``: forward speed, depth, compass
heading; the autopilot flies them on its navigation source) or raw actuator commands
(``control="actuator"``: rudder, stern planes, propeller). Each ``step`` advances
``control_period_s`` of sim time. The episode is truncated at the scenario's duration.

Observations are the latest reading of every sensor channel (``"<sensor>/<channel>"``), the sim time
at which that reading was sampled (``"<sensor>/t"``, −1 before the first one), and the sim time
(``"time_s"``). No truth: use :attr:`AuvEnv.truth` for scoring, never as an input to a policy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Literal

import dm_env
import numpy as np
from dm_env import specs

from scenarios.schema import Scenario
from twin.app.simulation import Simulation, build_simulation
from twin.core.messages import ActuatorCommand
from twin.onboard.control.autopilot import Setpoint
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
        reward_fn: Optional reward from (truth, observation); 0.0 by default (no task).
    """

    def __init__(
        self,
        scenario: Scenario,
        *,
        control: Control = "setpoint",
        control_period_s: float = 0.1,
        seed: int | None = None,
        reward_fn: Callable[[Truth, dict[str, np.ndarray]], float] | None = None,
    ):
        if control not in ("setpoint", "actuator"):
            raise ValueError(f"control = {control!r}: allowed 'setpoint' or 'actuator'")
        self._scenario = scenario
        self._control = control
        self._seed0 = scenario.seed if seed is None else seed
        self._episode = 0
        self._reward_fn = reward_fn
        self._world: Simulation = build_simulation(scenario, self._seed0)
        dt = self._world.physics_dt
        n = round(control_period_s / dt)
        if n < 1 or not math.isclose(n * dt, control_period_s, rel_tol=1e-9, abs_tol=1e-12):
            raise ValueError(
                f"control_period_s = {control_period_s!r}: must be a positive multiple of the "
                f"physics step {dt} s"
            )
        self._substeps = n
        self._period = control_period_s
        self._obs_spec = self._make_observation_spec()
        self._obs: dict[str, np.ndarray] = {}
        self._needs_reset = True

    # ---- specs ---------------------------------------------------------------------------
    def _make_observation_spec(self) -> dict[str, specs.Array]:
        out: dict[str, specs.Array] = {"time_s": specs.Array((), np.float64, name="time_s")}
        for sensor in self._world.suite.sensors:
            out[f"{sensor.name}/t"] = specs.Array((), np.float64, name=f"{sensor.name}/t")
            for channel, spec in sensor.channel_specs().items():
                key = f"{sensor.name}/{channel}"
                out[key] = specs.Array(spec.shape, spec.dtype, name=key)
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

    def reset(self) -> dm_env.TimeStep:
        if self._episode > 0:
            self._world = build_simulation(self._scenario, self._seed0 + self._episode)
        self._episode += 1
        self._needs_reset = False
        self._obs = {k: np.zeros(s.shape, s.dtype) for k, s in self._obs_spec.items()}
        for sensor in self._world.suite.sensors:
            self._obs[f"{sensor.name}/t"] = np.float64(-1.0)
        self._collect()
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
            nav = w.nav.nav_state()
            w.setpoint = sp
            cmd = w.autopilot.update(nav, sp, self._period)
        else:
            cmd = ActuatorCommand(float(a[0]), float(a[1]), float(a[2]))
        for _ in range(self._substeps):
            self._observe(w.step(cmd).readings)
        obs = self._observation()
        reward = 0.0 if self._reward_fn is None else float(self._reward_fn(self.truth, obs))
        if w.plant.t >= self._scenario.duration_s - 1e-9:
            self._needs_reset = True
            return dm_env.truncation(reward, obs)
        return dm_env.transition(reward, obs)

    def _collect(self) -> None:
        """At reset: the readings due at t = 0 (the stepping core delivers them to the filters)."""
        readings = self._world.suite.poll(self._world.plant)
        self._world.deliver(readings)
        self._observe(readings)

    def _observe(self, readings: list) -> None:
        for reading in readings:
            self._obs[f"{reading.sensor}/t"] = np.float64(reading.t)
            for channel, value in reading.values.items():
                key = f"{reading.sensor}/{channel}"
                self._obs[key] = np.asarray(value, dtype=self._obs_spec[key].dtype).reshape(
                    self._obs_spec[key].shape
                )

    def _observation(self) -> dict[str, np.ndarray]:
        self._obs["time_s"] = np.float64(self._world.plant.t)
        return {k: np.array(v, copy=True) for k, v in self._obs.items()}
