"""Real-time factor of the plant: physics + hydrodynamics + IMU + depth gauge (+ autopilot).

Runs a 10-minute mission (the lawnmower survey, cut to 600 s) on one core and reports the
real-time factor; also the full run loop with the Rerun recording (no camera) for comparison.
Target (issue #2): >= 100x real time for the plant on one core.

    python benchmarks/plant_rtf.py            # prints a table and writes benchmarks/results/
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import scenarios
from twin.app.run import run_scenario
from twin.core.messages import ActuatorCommand
from twin.record import provenance as pv
from twin.sim.build import build_simulation

RESULTS = Path(__file__).resolve().parent / "results"
MISSION_S = 600.0


def plant_only(repeats: int = 3) -> dict[str, float]:
    sc = dataclasses.replace(scenarios.load("lawnmower_10m"), duration_s=MISSION_S)
    best = float("inf")
    for _ in range(repeats):
        w = build_simulation(sc)
        dt = w.physics_dt
        every = round(1.0 / (sc.autopilot.rate_hz * dt))
        cmd = ActuatorCommand()
        n = 0
        t0 = time.perf_counter()
        for k in range(round(MISSION_S / dt)):
            if k % every == 0:
                nav = w.nav.nav_state()
                sp, _ = w.guidance.update(nav, w.plant.t)
                cmd = w.autopilot.update(nav, sp, every * dt)
            w.plant.step(cmd)
            n += len(w.suite.poll(w.plant))
        best = min(best, time.perf_counter() - t0)
    return {
        "sim_s": MISSION_S,
        "wall_s": best,
        "rtf": MISSION_S / best,
        "readings": n,
        "us_per_step": best / round(MISSION_S / dt) * 1e6,
    }


def full_run() -> dict[str, float]:
    sc = dataclasses.replace(scenarios.load("lawnmower_10m"), duration_s=MISSION_S)
    with tempfile.TemporaryDirectory() as d:
        m = run_scenario(sc, d, camera=False)
        size = (Path(d) / "recording.rrd").stat().st_size
    return {
        "sim_s": m["sim_time_s"],
        "wall_s": m["wall_time_s"],
        "rtf": m["real_time_factor"],
        "rrd_mb": size / 1e6,
    }


def main() -> int:
    try:  # one core, as the target says
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    plant = plant_only()
    full = full_run()
    env = f"{platform.processor() or platform.machine()}, Python {sys.version.split()[0]}, 1 core"
    prov = pv.provenance()
    md = [
        "# Plant real-time factor (issue #2 benchmark)",
        "",
        f"10-minute mission (lawnmower_10m cut to {MISSION_S:.0f} s), physics step 10 ms,",
        f"IMU 100 Hz, depth gauge 10 Hz, autopilot 10 Hz. Machine: {env}. Best of 3 for the plant.",
        "",
        "| what | sim s | wall s | real-time factor |",
        "|---|---|---|---|",
        f"| plant: physics + hydrodynamics + IMU + depth + autopilot | {plant['sim_s']:.0f} | "
        f"{plant['wall_s']:.2f} | **{plant['rtf']:.0f}x** ({plant['us_per_step']:.0f} µs/step) |",
        f"| full run loop with Rerun recording, no camera | {full['sim_s']:.0f} | "
        f"{full['wall_s']:.2f} | {full['rtf']:.0f}x (recording {full['rrd_mb']:.1f} MB) |",
        "",
        "Target: >= 100x real time for the plant on one core.",
        "",
        *("- " + x for x in pv.describe(prov)),
    ]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "plant_rtf.md").write_text("\n".join(md) + "\n")
    (RESULTS / "plant_rtf.json").write_text(
        json.dumps({"plant": plant, "full_run": full, "machine": env, "provenance": prov}, indent=2)
        + "\n"
    )
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
