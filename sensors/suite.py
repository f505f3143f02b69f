"""Runs a set of sensors at their own rates and delays, each with its own random stream."""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from sensors.base import Sensor, WorldView
from twin.core.messages import Reading

# The schedule is kept in physics steps, not seconds. MuJoCo's clock is a running sum of its
# time step, whose round-off grows about as t² (steps of 0.01 s: 4e-10 s off n·dt at 600 s,
# 1.2e-9 at 1500 s, 3e-7 at 16 000 s, either side): compared with k / rate within a fixed 1e-9
# in seconds (and 1e-9 in counts for the next instant), a 10 Hz gauge sampled twice in a row
# while the clock lagged by 1e-10..1e-9 s and a step late past that. The step index
# round(t / dt) is exact while the round-off stays below half a step. Tolerance, in steps, of a
# sample or delivery instant that falls on a step (k / rate in steps is a float product).
_EPS_STEPS = 1e-6


class SensorSuite:
    """Schedules sensors on the physics clock and delivers their readings after their delays.

    A sensor with rate r samples at the first physics step at or after each k / r (k = 0, 1, ...),
    so a rate that does not divide the physics rate jitters by at most one physics step (a real
    sensor's clock is not the simulator's either); its reading is delivered at the first physics
    step at or after its sampling instant plus its delay. The schedule counts physics steps
    (``world.model.opt.timestep``), so that MuJoCo's clock, a running sum, cannot move a sample
    however long the run. Each sensor draws its noise from its own
    Generator, spawned from ``seed`` in the order the sensors are given, so adding a sensor at the
    end does not change the others' noise.

    Args:
        sensors: The sensors; names must be unique.
        seed: Root seed (an int or a SeedSequence) for the sensors' random streams.
    """

    def __init__(self, sensors: Sequence[Sensor], seed: int | np.random.SeedSequence):
        names = [s.name for s in sensors]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"sensor names must be unique; repeated: {dupes}")
        self.sensors = list(sensors)
        ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        self._rngs = [np.random.default_rng(s) for s in ss.spawn(len(self.sensors))]
        self._dt = 0.0
        self._next_step = [0] * len(self.sensors)  # each sensor's next sampling step
        self._pending: list[tuple[int, float, int, Reading, object]] = []
        self._counter = itertools.count()

    def __getitem__(self, name: str) -> Sensor:
        for s in self.sensors:
            if s.name == name:
                return s
        raise KeyError(f"no sensor named {name!r}; have {[s.name for s in self.sensors]}")

    def reset(self, world: WorldView) -> None:
        """Start an episode: every sensor draws its turn-on errors; nothing pending."""
        for sensor, rng in zip(self.sensors, self._rngs, strict=True):
            sensor.reset(world, rng)
        dt = float(world.model.opt.timestep)
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"the world's physics time step is {dt!r}; allowed: a finite dt > 0")
        self._dt = dt
        n = round(world.t / dt)
        # The first instant k / rate at or after now, as a step.
        self._next_step = [
            self._step_of(math.ceil(n / self._steps_per_sample(s) - _EPS_STEPS), s)
            for s in self.sensors
        ]
        self._pending.clear()

    def _steps_per_sample(self, sensor: Sensor) -> float:
        return 1.0 / (sensor.rate_hz * self._dt)

    def _step_of(self, k: int, sensor: Sensor) -> int:
        """The first physics step at or after the sensor's k-th instant k / rate."""
        return math.ceil(k * self._steps_per_sample(sensor) - _EPS_STEPS)

    def poll(self, world: WorldView) -> list[Reading]:
        """Sample the sensors that are due now; return readings delivered by now, oldest first."""
        return [r for r, _ in self.poll_with_truth(world)]

    def poll_with_truth(
        self, world: WorldView, *, sampled: dict[int, dict[str, Any]] | None = None
    ) -> list[tuple[Reading, object]]:
        """Like :meth:`poll`, each reading paired with the truth its sensor recorded for it.

        A sensor that keeps truth of its own (the polarimeter's truth layers: true Stokes, the
        sun's pixel, masks) exposes it as ``truth`` after ``sample``; it is taken at the sampling
        instant and travels with the reading through the delay, so the scorer and the recorder
        never look it up afterwards. None for sensors without.

        ``sampled`` gives the values of sensors (by index) already sampled at this step, which
        are then not sampled again: the IMU's sample flown with the physics in a compiled block
        (:meth:`twin.world.quiet_steps.QuietSteps.fly_closing`).
        """
        t = world.t
        n = round(t / self._dt)
        next_step = self._next_step
        for i, sensor in enumerate(self.sensors):
            if next_step[i] <= n:
                if sampled is not None and i in sampled:
                    values = sampled[i]
                else:
                    values = sensor.sample(world, self._rngs[i])
                # A sensor whose clock is off the IMU's (a drawn polarimeter unit) stamps its
                # reading with its own time; delivery stays on the physics clock.
                stamp = t + getattr(sensor, "clock_offset_s", 0.0)
                reading = Reading(sensor.name, stamp, t + sensor.delay_s, values)
                truth = getattr(sensor, "truth", None)
                # Delivered at the first step at or after t + delay; in the order of t + delay.
                due = n + math.ceil(sensor.delay_s / self._dt - _EPS_STEPS)
                heapq.heappush(
                    self._pending, (due, reading.t_delivered, next(self._counter), reading, truth)
                )
                # The next instant k / rate after now (skipping any the physics clock jumped
                # over), from k rather than accumulated, so that it does not drift.
                k = math.floor(n / self._steps_per_sample(sensor) + _EPS_STEPS) + 1
                next_step[i] = self._step_of(k, sensor)
        pending = self._pending
        if not pending or pending[0][0] > n:
            return []
        out: list[tuple[Reading, object]] = []
        while pending and pending[0][0] <= n:
            _, _, _, reading, truth = heapq.heappop(pending)
            out.append((reading, truth))
        return out
