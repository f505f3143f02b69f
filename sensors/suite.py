"""Runs a set of sensors at their own rates and delays, each with its own random stream."""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Sequence

import numpy as np

from sensors.base import Sensor, WorldView
from twin.core.messages import Reading

# Tolerance when comparing a sample instant with the physics clock: sample times are k / rate and
# the physics clock is n * dt; both carry float round-off.
_EPS_S = 1e-9


class SensorSuite:
    """Schedules sensors on the physics clock and delivers their readings after their delays.

    A sensor with rate r samples at the first physics step at or after each k / r (k = 0, 1, ...),
    so a rate that does not divide the physics rate jitters by at most one physics step (a real
    sensor's clock is not the simulator's either). Each sensor draws its noise from its own
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
        self._next_t = [0.0] * len(self.sensors)
        self._pending: list[tuple[float, int, Reading, object]] = []
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
        self._next_t = [math.ceil(world.t * s.rate_hz - _EPS_S) / s.rate_hz for s in self.sensors]
        self._pending.clear()

    def poll(self, world: WorldView) -> list[Reading]:
        """Sample the sensors that are due now; return readings delivered by now, oldest first."""
        return [r for r, _ in self.poll_with_truth(world)]

    def poll_with_truth(self, world: WorldView) -> list[tuple[Reading, object]]:
        """Like :meth:`poll`, each reading paired with the truth its sensor recorded for it.

        A sensor that keeps truth of its own (the polarimeter's truth layers: true Stokes, the
        sun's pixel, masks) exposes it as ``truth`` after ``sample``; it is taken at the sampling
        instant and travels with the reading through the delay, so the scorer and the recorder
        never look it up afterwards. None for sensors without.
        """
        t = world.t
        next_t = self._next_t
        for i, sensor in enumerate(self.sensors):
            if next_t[i] <= t + _EPS_S:
                values = sensor.sample(world, self._rngs[i])
                # A sensor whose clock is off the IMU's (a drawn polarimeter unit) stamps its
                # reading with its own time; delivery stays on the physics clock.
                stamp = t + getattr(sensor, "clock_offset_s", 0.0)
                reading = Reading(sensor.name, stamp, t + sensor.delay_s, values)
                truth = getattr(sensor, "truth", None)
                heapq.heappush(
                    self._pending, (reading.t_delivered, next(self._counter), reading, truth)
                )
                # Next instant k / rate after now (skipping any the physics clock jumped over),
                # computed from k rather than accumulated, so it does not drift.
                rate = sensor.rate_hz
                next_t[i] = (math.floor(t * rate + _EPS_S) + 1) / rate
        pending = self._pending
        if not pending or pending[0][0] > t + _EPS_S:
            return []
        out: list[tuple[Reading, object]] = []
        while pending and pending[0][0] <= t + _EPS_S:
            _, _, reading, truth = heapq.heappop(pending)
            out.append((reading, truth))
        return out
