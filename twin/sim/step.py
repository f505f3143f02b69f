"""The stepping core: one scenario's world and vehicle computer, stepped together.

:meth:`Simulation.step` is the one place a step happens: physics under a command, the sensors
that are due, their readings delivered to every filter variant; it returns a :class:`StepResult`
(readings, compass events, the truth the sensors recorded with their readings) and hands it to the
observers in the order they were attached (the scorer first, then the recorder, which reads the
scorer's state: :func:`twin.app.run.run_scenario`), in the pattern of dm_control's
``rl/control.py``. The CLI run (:mod:`twin.app.run`), the dm_env environment (:mod:`twin.app.env`)
and offline flights (:meth:`Simulation.fly`) all step through it, so they simulate exactly the
same thing for the same scenario and seed. :mod:`twin.sim.build` builds one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

from scenarios.schema import Scenario
from sensors.suite import SensorSuite
from twin.core.messages import ActuatorCommand, Reading
from twin.onboard.control.autopilot import Autopilot, NavSource, Setpoint
from twin.onboard.control.guidance import Guidance, GuidanceStatus
from twin.onboard.gravity.matching import StoredMap
from twin.onboard.gravity.planner import PlannedPath
from twin.onboard.navigator import CompassEvent, Navigator
from twin.world.plant import Plant
from twin.world.quiet_steps import QuietSteps


@dataclass(frozen=True, slots=True)
class StepResult:
    """What one step produced.

    Attributes:
        t: Sim time after the step.
        readings: Sensor readings delivered during the step, in delivery order.
        truth: For each reading (same order), the truth its sensor recorded with it (the
            polarimeter's truth layers), or None. Truth channel: scoring and recording only.
        events: Frames the filter variants' compass methods processed, as (variant, event).
    """

    t: float
    readings: list[Reading]
    truth: list[object]
    events: list[tuple[str, CompassEvent]]


class Observer(Protocol):
    """Something that watches the simulation step (the recorder, a scorer).

    An observer may also let the simulation fly *quiet* steps (the IMU's sample and readings
    sampled before, no frame, no truth layer) in compiled blocks (:meth:`Simulation.advance`) by
    defining ``quiet_steps(sim) -> int`` (how many of the next steps its ``on_step`` would only
    take the readings of) and ``on_quiet_steps(sim, steps, readings)`` (what it does with those
    steps' readings, in delivery order). An observer without them sees every step through
    ``on_step``, as before.
    """

    def on_step(self, sim: Simulation, result: StepResult) -> None: ...


@dataclass
class Simulation:
    """Everything a run steps, built from one scenario and one seed."""

    scenario: Scenario
    seed: int
    plant: Plant
    suite: SensorSuite
    guidance: Guidance
    autopilot: Autopilot
    nav: NavSource
    navigators: dict[str, Navigator] = field(default_factory=dict)
    observers: list[Observer] = field(default_factory=list)
    # The vehicle's stored gravity map and, for a planned mission, the route it planned on it.
    stored_map: StoredMap | None = None
    route: PlannedPath | None = None
    # The last setpoint and guidance status of :meth:`control` (for the recorder and the scorer).
    setpoint: Setpoint = field(default_factory=lambda: Setpoint(0.0, 0.0, 0.0))
    status: GuidanceStatus = field(default_factory=lambda: GuidanceStatus(0, 0, False, 0.0))
    #: Fly quiet steps (the IMU's sample alone) in compiled blocks (:mod:`twin.world.quiet_steps`)
    #: where the configuration allows; False: every step through :meth:`step`, the reference
    #: the blocks equal bit for bit (``tests/sim/test_quiet_steps.py``).
    quiet_blocks: ClassVar[bool] = True
    #: End a block with the step after its quiet ones (its physics and IMU sample compiled, the
    #: rest as :meth:`step`); False: that step through :meth:`step` (the same numbers).
    closing_steps: ClassVar[bool] = True
    _quiet: QuietSteps | None = field(default=None, init=False, repr=False)

    @property
    def physics_dt(self) -> float:
        return float(self.plant.model.opt.timestep)

    @property
    def autopilot_every(self) -> int:
        """Physics steps per autopilot update."""
        return max(1, round(1.0 / (self.scenario.autopilot.rate_hz * self.physics_dt)))

    def deliver(self, readings: list[Reading]) -> list[tuple[str, CompassEvent]]:
        """Hand sensor readings (in delivery order) to every onboard filter variant.

        Returns the frames the variants' compass methods processed, as (variant, event).
        """
        # Most steps deliver the IMU's sample alone, which every variant only keeps for its next
        # batch: handed to all at once (Navigator.fan_out_imu), the same state bit for bit.
        if len(readings) == 1 and Navigator.fan_out_imu(self.navigators.values(), readings[0]):
            return []
        events = []
        for name, nav in self.navigators.items():
            for r in readings:
                event = nav.on_reading(r)
                if event is not None:
                    events.append((name, event))
        return events

    def control(self) -> ActuatorCommand:
        """The vehicle computer's command now: guidance's setpoint, then the autopilot.

        Call once per autopilot period (:attr:`autopilot_every` physics steps).
        """
        nav = self.nav.nav_state()
        self.setpoint, self.status = self.guidance.update(nav, self.plant.t)
        return self.autopilot.update(nav, self.setpoint, self.autopilot_every * self.physics_dt)

    def step(self, command: ActuatorCommand) -> StepResult:
        """Step physics under ``command``; sensors sampled, readings delivered, observers told."""
        self.plant.step(command)
        return self._after_physics(self.suite.poll_with_truth(self.plant))

    def _after_physics(self, pairs: list[tuple[Reading, object]]) -> StepResult:
        """A step's readings delivered and its result handed to the observers (its poll given)."""
        readings = [r for r, _ in pairs]
        events = self.deliver(readings) if self.navigators and readings else []
        result = StepResult(self.plant.t, readings, [x for _, x in pairs], events)
        for obs in self.observers:
            obs.on_step(self, result)
        return result

    def advance(self, command: ActuatorCommand, max_steps: int = 1) -> int:
        """Step under ``command``: the next step, or up to ``max_steps`` in a compiled block.

        Quiet steps sample the IMU alone (no other sensor due; a reading sampled before may be
        delivered in them, not a frame), every filter variant keeping the IMU's samples for its
        next batch and taking the other readings as it would, every observer only taking the
        readings (:class:`Observer`). They are flown in one compiled call
        (:class:`~twin.world.quiet_steps.QuietSteps`), the readings handed to the variants and
        the observers after it. The step after them, when it is in reach, ends the block: its
        physics and IMU sample are flown in the same call, then its other sensors sampled, its
        readings delivered and its result handed to the observers as :meth:`step` does. The
        same numbers as :meth:`step` one at a time, bit for bit. The caller keeps
        ``max_steps`` to the steps under one command. Returns the steps flown.
        """
        if max_steps > 1 and self.quiet_blocks:
            n, closing = self._fly_quiet(command, max_steps)
            if closing is not None:  # the last step's poll, given its IMU sample
                self._after_physics(self.suite.poll_with_truth(self.plant, sampled=closing))
            if n:
                return n
        self.step(command)
        return 1

    def _fly_quiet(
        self, command: ActuatorCommand, max_steps: int
    ) -> tuple[int, dict[int, dict[str, Any]] | None]:
        """A block's steps flown and their quiet readings handed on; (steps, closing sample).

        The closing sample (None: the block had no closing step) is the last step's IMU sample,
        for :meth:`advance` to poll that step with.
        """
        limit = max_steps
        for obs in self.observers:
            quiet_steps = getattr(obs, "quiet_steps", None)
            if quiet_steps is None or not hasattr(obs, "on_quiet_steps"):
                return 0, None
            limit = min(limit, quiet_steps(self))
        quiet = self._quiet
        if quiet is None or quiet.plant is not self.plant or quiet.suite is not self.suite:
            quiet = self._quiet = QuietSteps(self.plant, self.suite)
        times, k = quiet.block_times(max_steps)
        k = min(k, limit)
        navs = self.navigators.values()
        # Readings the queue delivers in these steps: each one that the observers or a filter
        # would do more with (a frame: a compass event, a truth layer) ends the quiet ones.
        for j, reading, truth in quiet.deliveries(k):
            if truth is not None or not Navigator.takes_quietly(navs, reading):
                k = j
                break
        if navs and k:
            imu = quiet.imu_name
            assert imu is not None
            k = Navigator.quiet_imu_steps(navs, imu, times[:k])
        # The step after the quiet ones, where the kernel can fly it, closes the block.
        closing = k < len(times) and self.closing_steps
        times = times[: k + 1] if closing else times[:k]
        if len(times) < 2:
            return 0, None
        sampled = None
        if closing:
            readings, samples, sampled = quiet.fly_closing(command, times)
        else:
            readings, samples = quiet.fly(command, times)
        if k:
            if navs and not Navigator.fan_out_imu_block(navs, readings, samples):
                for r in readings:
                    self.deliver([r])  # none makes a compass event (takes_quietly)
            for obs in self.observers:
                obs.on_quiet_steps(self, k, readings)  # type: ignore[attr-defined]
        return len(times), sampled

    def fly(self, until_s: float) -> None:
        """Fly the mission (guidance, autopilot, physics, sensors) up to sim time ``until_s``.

        Observers see every step; with none attached nothing is recorded (``auv-twin render``
        flies somewhere this way).
        """
        dt = self.physics_dt
        every = self.autopilot_every
        cmd = None
        k = 0
        while self.plant.t < until_s - 0.5 * dt:
            if cmd is None or k % every == 0:
                cmd = self.control()
            left = math.ceil((until_s - 0.5 * dt - self.plant.t) / dt - 1e-9)
            k += self.advance(cmd, max(1, min(every - k % every, left)))
