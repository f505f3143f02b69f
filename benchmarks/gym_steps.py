"""Gymnasium steps per second: the default sea trial under each observation option.

One environment (``AuvTwin-v0``, heading_hold, 0.1 s per step, the 612×512 polarimeter at 1 Hz),
random actions, best of three 300-step episodes after a warm-up; writes
benchmarks/results/gym_steps.md (+ .json) with provenance.

    OMP_NUM_THREADS=1 taskset -c 1 python benchmarks/gym_steps.py
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import scenarios
from twin.app.gym_env import OBSERVATIONS
from twin.record import provenance as pv

RESULTS = Path(__file__).resolve().parent / "results"
STEPS = 300


def steps_per_s(observation: str) -> tuple[float, int]:
    sc = dataclasses.replace(scenarios.load("default"), duration_s=STEPS * 0.1 + 1.0)
    env = gym.make("twin.app.gym_env:AuvTwin-v0", scenario=sc, observation=observation)
    env.action_space.seed(0)
    best = 0.0
    size = 0
    for rep in range(4):
        obs, _ = env.reset(seed=rep)
        size = sum(int(np.prod(v.shape)) for v in obs.values())
        t0 = time.perf_counter()
        for _ in range(STEPS):
            env.step(env.action_space.sample())
        rate = STEPS / (time.perf_counter() - t0)
        if rep:  # the first is the warm-up
            best = max(best, rate)
    env.close()
    return best, size


def spaces_table() -> list[str]:
    """Every observation key of the default scenario (``observation="image"`` and ``"stokes"``
    add their image keys; ``"full"`` the raw frame), and the action spaces."""
    sc = dataclasses.replace(scenarios.load("default"), duration_s=10.0)
    keys: dict[str, gym.spaces.Box] = {}
    for o in OBSERVATIONS:
        env = gym.make("twin.app.gym_env:AuvTwin-v0", scenario=sc, observation=o)
        keys.update(env.observation_space.spaces)
        env.close()
    lines = [
        "## Spaces (default scenario, generated)",
        "",
        "| key | shape | dtype | low | high |",
        "|---|---|---|---|---|",
    ]
    for k, b in sorted(keys.items()):
        lo, hi = np.min(b.low), np.max(b.high)
        lines.append(f"| `{k}` | {b.shape} | {b.dtype} | {lo:g} | {hi:g} |")
    for control in ("actuator", "setpoint"):
        env = gym.make("twin.app.gym_env:AuvTwin-v0", scenario=sc, control=control)
        a = env.action_space
        name = env.unwrapped.dm_env.action_spec().name
        lo, hi = a.low.tolist(), a.high.tolist()
        lines.append(f"\nAction, `control={control!r}`: `{name}`, low {lo}, high {hi}")
        env.close()
    return lines


def main() -> None:
    rows = {o: steps_per_s(o) for o in OBSERVATIONS}
    meta = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": platform.platform(),
        "cpu_affinity": sorted(os.sched_getaffinity(0)),
        "load_average_1_5_15": [round(x, 2) for x in os.getloadavg()],
        "provenance": pv.provenance(),
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "gym_steps.json").write_text(
        json.dumps({"meta": meta, "rows": rows}, indent=2, default=str) + "\n"
    )
    lines = [
        "# Gymnasium steps per second (default sea trial, heading_hold)",
        "",
        f"`python benchmarks/gym_steps.py`, {meta['date']}, {meta['machine']}, CPUs "
        f"{meta['cpu_affinity']}, load average {meta['load_average_1_5_15']}. One environment, "
        f"random actions, 0.1 s of simulation a step (10 physics steps; the camera renders a "
        f"frame every 10th step), best of three {STEPS}-step episodes.",
        f"- {'; '.join(pv.describe(meta['provenance']))}",
        "",
        "| observation | steps/s | simulated s per wall s | numbers per observation |",
        "|---|---|---|---|",
    ]
    for o, (rate, size) in rows.items():
        lines.append(f"| {o} | {rate:.0f} | {rate * 0.1:.1f} | {size} |")
    lines += ["", *spaces_table()]
    (RESULTS / "gym_steps.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
