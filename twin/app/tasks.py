"""Control tasks for the environment, in the pattern of dm_control's ``rl.control``.

A task gives an episode its goal: :meth:`~AuvTask.initialize_episode` draws it (from the task's
own Generator, seeded from the episode's seed), :meth:`~AuvTask.get_observation` shows it to the
policy (the goal only, never truth), :meth:`~AuvTask.get_reward` scores the true state against it
with dm_control's ``rewards.tolerance`` (1 inside the bounds, decaying over the margin), and
:meth:`~AuvTask.get_termination` ends an episode that failed (the vehicle broke the surface or
touched the seabed: discount 0) or succeeded (discount 1).

The "physics" argument of dm_control's interface is the :class:`~twin.sim.step.Simulation`:
rewards are computed from the world's truth, as in dm_control, while the policy's observations
stay sensor readings (:class:`twin.app.env.AuvEnv`). Actions are the environment's
(``control="setpoint"`` or ``"actuator"``), so :meth:`before_step` does nothing here.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from dm_control.rl import control
from dm_control.utils import rewards

from twin.core.frames import wrap_deg180

if TYPE_CHECKING:
    from twin.sim.step import Simulation

# The vehicle counts as surfaced above this depth (hull radius 0.095 m plus margin) and as on the
# seabed within this height of it.
_SURFACE_DEPTH_M = 0.3
_SEABED_CLEARANCE_M = 0.3


class AuvTask(control.Task):
    """Base of the AUV tasks: goal observations, tolerance rewards, failure termination."""

    def __init__(self) -> None:
        self.random = np.random.default_rng(0)

    def action_spec(self, physics: Simulation) -> None:  # the environment owns the actions
        return None

    def before_step(self, action: Any, physics: Simulation) -> None:
        return None

    def initialize_episode(self, physics: Simulation) -> None:
        """Draw the episode's goal (subclasses); ``self.random`` is already seeded."""

    def get_observation(self, physics: Simulation) -> dict[str, np.ndarray]:
        return {}

    #: (low, high) of the goal observations the task bounds (the observation spaces use them).
    OBSERVATION_BOUNDS: ClassVar[dict[str, tuple[float, float]]] = {}

    def get_reward(self, physics: Simulation) -> float:
        raise NotImplementedError

    def get_termination(self, physics: Simulation) -> float | None:
        """0.0 when the vehicle broke the surface or reached the seabed; else None (go on)."""
        truth = physics.plant.truth()
        seabed = physics.scenario.water.seabed_depth_m
        if truth.depth_m < _SURFACE_DEPTH_M:
            return 0.0
        if seabed is not None and truth.depth_m > seabed - _SEABED_CLEARANCE_M:
            return 0.0
        return None


class HeadingHold(AuvTask):
    """Hold a compass heading.

    Args:
        target_deg: The heading to hold; None draws one uniformly per episode.
        bounds_deg: Full reward within this error.
        margin_deg: The reward falls to 0.1 (gaussian) at bounds + margin.
    """

    OBSERVATION_BOUNDS: ClassVar[dict[str, tuple[float, float]]] = {
        "task/target_heading_deg": (0.0, 360.0)
    }

    def __init__(
        self, target_deg: float | None = None, bounds_deg: float = 2.0, margin_deg: float = 30.0
    ):
        super().__init__()
        if target_deg is not None and not (math.isfinite(target_deg) and 0 <= target_deg < 360):
            raise ValueError(f"target_deg = {target_deg!r}: allowed [0, 360) or None")
        self._fixed = target_deg
        self.target_deg = 0.0 if target_deg is None else target_deg
        self.bounds_deg, self.margin_deg = bounds_deg, margin_deg

    def initialize_episode(self, physics: Simulation) -> None:
        if self._fixed is None:
            self.target_deg = float(self.random.uniform(0.0, 360.0))

    def get_observation(self, physics: Simulation) -> dict[str, np.ndarray]:
        return {"task/target_heading_deg": np.float64(self.target_deg)}

    def get_reward(self, physics: Simulation) -> float:
        err = abs(float(wrap_deg180(physics.plant.truth().heading_deg - self.target_deg)))
        return float(rewards.tolerance(err, (0.0, self.bounds_deg), margin=self.margin_deg))


class DepthHold(AuvTask):
    """Hold a depth.

    The reward is dm_control's Gaussian tolerance of the depth error: 1 within ``bounds_m``,
    falling to 0.1 at bounds + margin. The margin is the episode's starting distance from the
    target (at least ``margin_m``), so the reward is 0.1 where the vehicle starts and grows as it
    closes: a policy far from the target still sees a gradient (with a fixed 2 m margin, a
    target 10 m away gave a random policy rewards below 1e-11).

    Args:
        target_m: The depth to hold; None draws one uniformly in ``draw_range_m`` per episode.
        bounds_m: Full reward within this error.
        margin_m: The least margin (m).
        draw_range_m: Where random targets are drawn.
    """

    #: Below the surface, at most the deepest ocean.
    OBSERVATION_BOUNDS: ClassVar[dict[str, tuple[float, float]]] = {
        "task/target_depth_m": (_SURFACE_DEPTH_M, 11_000.0)
    }

    def __init__(
        self,
        target_m: float | None = None,
        bounds_m: float = 0.1,
        margin_m: float = 2.0,
        draw_range_m: tuple[float, float] = (5.0, 20.0),
    ):
        super().__init__()
        if target_m is not None and not (math.isfinite(target_m) and target_m > _SURFACE_DEPTH_M):
            raise ValueError(f"target_m = {target_m!r}: allowed > {_SURFACE_DEPTH_M} m or None")
        self._fixed = target_m
        self.target_m = 10.0 if target_m is None else target_m
        self.bounds_m, self.margin_m, self.draw_range_m = bounds_m, margin_m, draw_range_m
        self.episode_margin_m = margin_m

    def initialize_episode(self, physics: Simulation) -> None:
        if self._fixed is None:
            lo, hi = self.draw_range_m
            seabed = physics.scenario.water.seabed_depth_m
            if seabed is not None:
                hi = min(hi, seabed - 2 * _SEABED_CLEARANCE_M)
            self.target_m = float(self.random.uniform(lo, max(lo, hi)))
        start = abs(physics.plant.truth().depth_m - self.target_m)
        self.episode_margin_m = max(self.margin_m, start - self.bounds_m)

    def get_observation(self, physics: Simulation) -> dict[str, np.ndarray]:
        return {"task/target_depth_m": np.float64(self.target_m)}

    def get_reward(self, physics: Simulation) -> float:
        err = abs(physics.plant.truth().depth_m - self.target_m)
        return float(rewards.tolerance(err, (0.0, self.bounds_m), margin=self.episode_margin_m))


class WaypointFollowing(AuvTask):
    """Reach waypoints in order; the episode succeeds (discount 1) at the last one.

    Args:
        waypoints_m: (East, North) points; None takes the scenario mission's waypoints.
        acceptance_m: A waypoint is reached within this horizontal distance.
        margin_m: The reward falls to 0.1 at acceptance + margin from the current waypoint.
    """

    def __init__(
        self,
        waypoints_m: tuple[tuple[float, float], ...] | None = None,
        acceptance_m: float = 5.0,
        margin_m: float = 100.0,
    ):
        super().__init__()
        if waypoints_m is not None and not waypoints_m:
            raise ValueError("waypoints_m: allowed a non-empty sequence of (East, North) or None")
        self._fixed = waypoints_m
        self.waypoints_m: tuple[tuple[float, float], ...] = waypoints_m or ()
        self.acceptance_m, self.margin_m = acceptance_m, margin_m
        self.index = 0

    def initialize_episode(self, physics: Simulation) -> None:
        if self._fixed is None:
            self.waypoints_m = tuple(physics.guidance.waypoints_en)
            if not self.waypoints_m:
                raise ValueError(
                    "WaypointFollowing: the scenario's mission has no waypoints; give waypoints_m"
                )
        self.index = 0

    def _distance(self, physics: Simulation) -> float:
        p = physics.plant.truth().position_n
        e, n = self.waypoints_m[min(self.index, len(self.waypoints_m) - 1)]
        return math.hypot(float(p[0]) - e, float(p[1]) - n)

    def after_step(self, physics: Simulation) -> None:
        while self.index < len(self.waypoints_m) and self._distance(physics) <= self.acceptance_m:
            self.index += 1

    def get_observation(self, physics: Simulation) -> dict[str, np.ndarray]:
        e, n = self.waypoints_m[min(self.index, len(self.waypoints_m) - 1)]
        return {"task/waypoint_en_m": np.array([e, n], dtype=np.float64)}

    def get_reward(self, physics: Simulation) -> float:
        if self.index >= len(self.waypoints_m):
            return 1.0
        d = self._distance(physics)
        return float(rewards.tolerance(d, (0.0, self.acceptance_m), margin=self.margin_m))

    def get_termination(self, physics: Simulation) -> float | None:
        if self.index >= len(self.waypoints_m):
            return 1.0
        return super().get_termination(physics)
