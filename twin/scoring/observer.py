"""Scoring as an observer of the stepping core: the mission, filters and fixes against truth.

Truth is sampled at the truth rate; every filter variant and every compass fix is scored.

World side (it sees truth). :class:`RunScorer` hangs off
:class:`twin.sim.step.Simulation` (``sim.observers``); the recorder reads its last samples.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twin.scoring.gravity_nav import GravityScore
from twin.scoring.mission import SETTLE_S, MissionScore, accumulate
from twin.scoring.navigation import FixScore, VariantScore
from twin.world.truth import Truth

if TYPE_CHECKING:
    from twin.core.messages import Reading
    from twin.sim.step import Simulation, StepResult


class RunScorer:
    """Mission tracking, filter variants and compass fixes scored against truth.

    Args:
        sim: The simulation (its scenario sets the truth rate).
    """

    def __init__(self, sim: Simulation):
        rate = sim.scenario.recording.truth_rate_hz
        self._every_truth = max(1, round(1.0 / (rate * sim.physics_dt)))
        self.mission = MissionScore()
        self.variants = {name: VariantScore(name) for name in sim.navigators}
        self.fixes = {name: FixScore(name) for name in sim.navigators if name != "ins"}
        self.last_truth: Truth | None = None
        self.gravity = GravityScore()
        # Set by the run loop: whether the mission is still active, and when the leg began.
        self.active = True
        self.leg_started_at = 0.0
        self._k = 0

    @property
    def last_samples(self) -> dict[str, dict[str, float]]:
        """Each variant's last truth sample, scored on its own: its estimate and errors."""
        return {name: s for name, v in self.variants.items() if (s := v.last_sample())}

    def quiet_steps(self, sim: Simulation) -> int:
        """The steps before the next truth sample: :meth:`on_step` only counts their readings."""
        return self._every_truth - self._k % self._every_truth - 1

    def on_quiet_steps(self, sim: Simulation, steps: int, readings: list[Reading]) -> None:
        """Quiet steps (no frame, no truth sample): :meth:`on_step`'s counts of their readings."""
        counts = self.mission.readings
        for r in readings:
            counts[r.sensor] = counts.get(r.sensor, 0) + 1
        self._k += steps

    def on_step(self, sim: Simulation, result: StepResult) -> None:
        counts = self.mission.readings
        for r in result.readings:
            counts[r.sensor] = counts.get(r.sensor, 0) + 1
        if result.events:
            # A fix is scored against the truth of the instant its frame was taken: that is this
            # step's state when the frame is delivered with no delay; otherwise it is not scored
            # (FixScore counts those) rather than scored against the wrong instant.
            now = sim.plant.truth()
            frames = {
                r.t: x for r, x in zip(result.readings, result.truth, strict=True) if x is not None
            }
            for name, event in result.events:
                if name in self.fixes:
                    # event.t is the frame's stamp; its truth record keeps the true instant,
                    # which a camera clock offset (sensors/polarimeter/unit/hardware.py) moves away.
                    frame = frames.get(event.t)
                    taken = getattr(frame, "t", event.t)
                    same_instant = abs(taken - now.t) < 1e-9
                    self.fixes[name].add(event, now if same_instant else None, frame)
        self._k += 1
        if self._k % self._every_truth:
            return
        truth = sim.plant.truth()
        self.last_truth = truth
        accumulate(
            self.mission,
            truth,
            sim.setpoint,
            sim.status,
            self.active,
            truth.t - self.leg_started_at >= SETTLE_S,
        )
        for name, nav in sim.navigators.items():
            self.variants[name].record(nav, truth)
        self.gravity.add(sim, truth, self)
