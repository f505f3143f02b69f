"""Quiet steps flown in compiled blocks are the step-by-step run, bit for bit.

:meth:`Simulation.advance` flies the steps that carry the IMU's sample alone through
:mod:`twin.world.quiet_steps` (physics, the limiter and the IMU in one compiled call); with
``quiet_blocks`` False every step goes through :meth:`Simulation.step`, the reference.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

import scenarios
from sensors.suite import SensorSuite
from twin.app.run import run_scenario
from twin.core.messages import ActuatorCommand
from twin.sim.build import build_simulation
from twin.sim.step import Simulation
from twin.world import quiet_steps


class Flown(list[int]):
    """The length of every block flown, the readings other than the IMU's that their quiet steps
    delivered, and what each closing step's poll delivered (one entry a block that had one)."""

    delivered: list[str]
    closing: list[tuple[str, ...]]


@pytest.fixture
def blocks(monkeypatch: pytest.MonkeyPatch) -> Flown:
    """Every block flown (so that no test passes with no block at all)."""
    flown = Flown()
    flown.delivered = []
    flown.closing = []
    fly, fly_closing = quiet_steps.QuietSteps.fly, quiet_steps.QuietSteps.fly_closing
    poll = SensorSuite.poll_with_truth

    def counted(self: quiet_steps.QuietSteps, command: Any, times: list[float]) -> Any:
        flown.append(len(times))
        readings, samples = fly(self, command, times)
        flown.delivered += [r.sensor for r in readings if r.sensor != "imu"]
        return readings, samples

    def counted_closing(self: quiet_steps.QuietSteps, command: Any, times: list[float]) -> Any:
        flown.append(len(times))
        readings, samples, sampled = fly_closing(self, command, times)
        flown.delivered += [r.sensor for r in readings if r.sensor != "imu"]
        flown.closing.append(())
        return readings, samples, sampled

    def polled(self: SensorSuite, world: Any, *, sampled: Any = None) -> Any:
        pairs = poll(self, world, sampled=sampled)
        if sampled is not None:
            flown.closing[-1] = tuple(r.sensor for r, _ in pairs)
        return pairs

    monkeypatch.setattr(quiet_steps.QuietSteps, "fly", counted)
    monkeypatch.setattr(quiet_steps.QuietSteps, "fly_closing", counted_closing)
    monkeypatch.setattr(SensorSuite, "poll_with_truth", polled)
    return flown


def _trial(seconds: float, **changes: Any) -> Any:
    sc = scenarios.load("sea_trial_10m")
    sc = dataclasses.replace(
        sc,
        duration_s=seconds,
        navigation=dataclasses.replace(sc.navigation, variants=("ins", "pol", "lig")),
    )
    return dataclasses.replace(sc, **changes)


def _world_state(sim: Simulation) -> tuple:
    d = sim.plant.data
    imu = sim.suite["imu"]
    errors = imu._errors  # type: ignore[attr-defined]
    return (
        d.time, d.qpos.tobytes(), d.qvel.tobytes(), d.act.tobytes(), d.ctrl.tobytes(),
        d.sensordata.tobytes(), d.qfrc_applied.tobytes(), sim.plant.limiter._last,
        imu._t_last, errors.gm.value.tobytes(), errors.rw.value.tobytes(),  # type: ignore[attr-defined]
        errors.white.value.tobytes(), tuple(sim.suite._next_step),
        [json.dumps(r.bit_generator.state, sort_keys=True) for r in sim.suite._rngs],
    )  # fmt: skip


def _filter_state(sim: Simulation) -> dict[str, tuple]:
    out = {}
    for name, nav in sim.navigators.items():
        f, ins = nav.filter, nav.filter.ins
        out[name] = (
            ins.t, ins.lat, ins.lon, ins.h, ins._v, ins._c, f.P.tobytes(), nav._t_imu,
            np.asarray(nav._rate_b).tobytes(), dict(f.counts),
            [(e.t, e.fix.ok, e.fix.heading_deg) for e in nav.events],
            [(r.t, r.t_delivered, r["angular_rate"].tobytes(), r["specific_force"].tobytes())
             for r in nav._batch.readings],
        )  # fmt: skip
    return out


def test_a_flight_in_blocks_is_the_step_by_step_flight_bit_for_bit(blocks: Flown) -> None:
    """12.4 s of the sea trial: frames and gravity updates between the blocks, the depth
    readings delivered inside them, and the clock's time step changing by an ulp at 0.64, 1.28
    … 10.24 s (a block ends before it)."""
    sc = _trial(20.0)
    fast = build_simulation(sc, 5)
    fast.fly(12.4)
    ref = build_simulation(sc, 5)
    ref.quiet_blocks = False
    ref.fly(12.4)
    assert blocks and sum(blocks) > 0.9 * 1240, "the flight took the blocks"
    assert blocks.count(10) > 100 and blocks.delivered.count("depth") > 100
    # Closing steps: the 10 Hz gravity and truth steps, the frames' among them.
    assert len(blocks.closing) > 100
    assert sum("polarimeter" in c for c in blocks.closing) >= 10
    assert _world_state(fast) == _world_state(ref)
    assert _filter_state(fast) == _filter_state(ref)


def test_blocks_without_closing_steps_are_the_same_flight(
    blocks: Flown, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Blocks that end before the step after their quiet ones (that step through
    Simulation.step) fly what the blocks with closing steps fly, bit for bit."""
    sc = _trial(20.0)
    closed = build_simulation(sc, 5)
    closed.fly(6.3)
    n = len(blocks.closing)
    assert n > 50
    monkeypatch.setattr(Simulation, "closing_steps", False)
    open_ = build_simulation(sc, 5)
    open_.fly(6.3)
    assert len(blocks.closing) == n and blocks.count(9) > 50, "no closing steps: blocks of 9"
    assert _world_state(closed) == _world_state(open_)
    assert _filter_state(closed) == _filter_state(open_)


def _outputs(out: Path) -> dict[str, Any]:
    metrics = json.loads((out / "metrics.json").read_text())
    for k in ("wall_time_s", "real_time_factor", "provenance", "versions", "recording"):
        metrics.pop(k, None)
    tables = {p.name: pd.read_parquet(p) for p in sorted((out / "timeseries").glob("*.parquet"))}
    return {"metrics": metrics, "tables": tables}


def _run_both_ways(
    tmp_path: Path,
    blocks: Flown,
    monkeypatch: pytest.MonkeyPatch,
    seconds: float,
    **outputs: bool,
) -> tuple[Path, Path]:
    """The trial run in blocks into tmp_path/fast, then step by step into tmp_path/ref."""
    sc = _trial(seconds)
    run_scenario(sc, tmp_path / "fast", camera=False, **outputs)
    n = len(blocks)
    assert n, "the run flew blocks"
    monkeypatch.setattr(Simulation, "quiet_blocks", False)
    run_scenario(sc, tmp_path / "ref", camera=False, **outputs)
    assert len(blocks) == n, "the reference flew none"
    return tmp_path / "fast", tmp_path / "ref"


def test_a_recorded_run_in_blocks_has_the_step_by_step_runs_outputs(
    tmp_path: Path, blocks: Flown, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The scorer, the recorder and the time series take the blocks' readings as their steps'."""
    dirs = _run_both_ways(tmp_path, blocks, monkeypatch, 12.0, record=True, timeseries=True)
    fast, ref = (_outputs(d) for d in dirs)
    assert fast["metrics"] == ref["metrics"]
    assert fast["metrics"]["sensor_readings"]["imu"] == 1200
    assert (
        fast["tables"].keys() == ref["tables"].keys() and "readings_imu.parquet" in fast["tables"]
    )
    for name, table in fast["tables"].items():
        pd.testing.assert_frame_equal(table, ref["tables"][name], check_exact=True)


def _mcap_messages(path: Path) -> list[tuple[str, int, bytes]]:
    from mcap.reader import make_reader

    with path.open("rb") as f:
        return [(c.topic, m.log_time, m.data) for _, c, m in make_reader(f).iter_messages()]


def test_a_ros2_log_in_blocks_has_the_step_by_step_runs_messages(
    tmp_path: Path, blocks: Flown, monkeypatch: pytest.MonkeyPatch
) -> None:
    dirs = _run_both_ways(tmp_path, blocks, monkeypatch, 3.0, record=False, mcap=True)
    fast, ref = (_mcap_messages(next(d.glob("*.mcap"))) for d in dirs)
    assert len(fast) > 300 and fast == ref


def test_a_current_or_an_observer_without_quiet_steps_flies_step_by_step(
    blocks: Flown,
) -> None:
    """What the blocks do not cover takes every step through Simulation.step."""
    sc = _trial(3.0)
    with_current = build_simulation(
        dataclasses.replace(
            sc, current=dataclasses.replace(sc.current, kind="constant", speed_mps=0.2)
        ),
        1,
    )
    with_current.fly(2.0)
    assert not blocks

    class Watcher:
        steps = 0

        def on_step(self, sim: Simulation, result: Any) -> None:
            Watcher.steps += 1

    watched = build_simulation(sc, 1)
    watched.observers.append(Watcher())
    watched.fly(2.0)
    assert not blocks and Watcher.steps == 200


def test_without_mujocos_library_beside_its_bindings_every_step_is_flown_alone(
    blocks: Flown, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(quiet_steps, "_mujoco_functions", lambda: None)
    sim = build_simulation(_trial(3.0), 1)
    sim.fly(1.0)
    assert not blocks and sim.plant.t == pytest.approx(1.0)


def _to_a_block(sims: list[Simulation]) -> None:
    """Step both simulations alike to where the next steps are quiet."""
    sims[0].fly(0.5)
    sims[1].fly(0.5)
    cmd = sims[0].control()
    sims[1].control()
    while True:
        probe = quiet_steps.QuietSteps(sims[0].plant, sims[0].suite)
        if len(probe.times(5)) >= 2:
            return
        for sim in sims:
            sim.step(cmd)


def test_a_bad_command_or_a_blown_up_state_is_named_as_step_by_step(
    blocks: Flown, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A non-finite command raises the limiter's error before anything is drawn; a blown-up
    state (an infinite velocity) raises the plant's, in a block as in a step (MuJoCo's reset
    of such a state is off in the model: it would fly on from the start in silence)."""
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to MUJOCO_LOG.TXT here
    sc = _trial(3.0)
    sims = [build_simulation(sc, 2), build_simulation(sc, 2)]
    sims[1].quiet_blocks = False
    _to_a_block(sims)
    n = len(blocks)
    bad = ActuatorCommand(rudder_rad=math.nan, stern_rad=0.0, propeller_rps=10.0)
    for sim in sims:
        with pytest.raises(ValueError, match="actuator command has a non-finite value"):
            sim.advance(bad, 5)
    # The first tried a block, which refused the command before it drew a normal or stepped.
    assert len(blocks) == n + 1 and _world_state(sims[0]) == _world_state(sims[1])
    for sim in sims:
        sim.plant.data.qvel[sim.plant._dof] = math.inf
        with pytest.raises(FloatingPointError, match="physics diverged at t = "):
            sim.advance(ActuatorCommand(0.0, 0.0, 10.0), 5)
    assert len(blocks) == n + 2 and blocks[-1] >= 2  # the first flew a block
