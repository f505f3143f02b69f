"""Where a sea trial's wall time goes, stage by stage and inside the frame and the compass.

The same trial as ``sea_trial_rtf.py`` (sea_trial_10m's square flown twice, cut at 600 s; physics
and IMU at 100 Hz, depth 10 Hz, the 612×512 polarimeter at 1 Hz; INS, POL/INS and LIG/INS; no
recording), in a fresh interpreter pinned to one core, each stage timed by a wrapper around its
entry point. Stages nest (the frame holds its fast path, the fast path its compiled chain); a
wrapper costs ~1 µs a call, ~0.4 s over the 60 000 steps, which the table's "unaccounted" row
shows with the loop's own scheduling. Start-up (imports, building the simulation, the first
frame's tables and kernels) is timed apart from the flight. The 100 Hz loop's compiled and C
cores (MuJoCo's step, the wrench, IMU and filter kernels) are timed too, each row under the stage
that calls it (the filters' kernels overlap the filter rows beside them): what the loop costs
beyond them is the Python between them. Their wrappers add ~0.6 ms per simulated second.

    python benchmarks/sea_trial_profile.py [--mission-s 600]

Writes benchmarks/results/sea_trial_profile.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from sea_trial_rtf import TIMER  # noqa: E402  (the children's one timer)

# (label, parent label or "", module, class, method, per): "frame" stages are per frame, "step"
# per physics step, "method" per compass method and frame. A label may time several functions.
_MJ = "MuJoCo (mj_step2, mj_step1, mj_forwardSkip)"
_WRENCH = "the wrench and added-mass kernel"
_IMU_K = "the IMU's kernel"
_FILTER_K = "the filters' kernels (INS batches, covariance steps, updates)"
STAGES: tuple[tuple[str, str, str, str, str, str], ...] = (
    ("physics step", "", "twin.world.plant", "Plant", "step", "step"),
    ("sensors due (IMU, depth, camera …)", "", "sensors.suite", "SensorSuite",
     "poll_with_truth", "step"),
    ("IMU model", "sensors due (IMU, depth, camera …)", "sensors.imu", "Imu", "sample", "step"),
    ("polarimeter frame", "sensors due (IMU, depth, camera …)", "sensors.polarimeter.render",
     "Polarimeter", "sample", "frame"),
    ("sun (ephemeris)", "polarimeter frame", "sensors.polarimeter.render", "Polarimeter",
     "_sun_for", "frame"),
    ("light field of the frame (tables at depth and sun)", "polarimeter frame",
     "sensors.polarimeter.render", "Polarimeter", "_frame_constants", "frame"),
    ("fast path (coarse grid, exact pixels, interpolation)", "polarimeter frame",
     "sensors.polarimeter.fast_path", "FastPath", "_render_fast", "frame"),
    ("compiled chain (scattering kernel, sky, Fresnel, lens)",
     "fast path (coarse grid, exact pixels, interpolation)", "sensors.polarimeter.chain_kernel",
     "", "render_points", "frame"),
    ("vehicle's occlusion (mj_multiRay)", "polarimeter frame", "sensors.polarimeter.render",
     "Polarimeter", "_occlusion", "frame"),
    ("bubbles and marine snow", "polarimeter frame", "sensors.polarimeter.render", "Polarimeter",
     "_add_points", "frame"),
    ("sensor (exposure, noise, ADC)", "polarimeter frame", "sensors.polarimeter.unit.mosaic",
     "DoFPSensor", "render_mosaic", "frame"),
    ("readings to the filters", "", "twin.sim.step", "Simulation", "deliver", "step"),
    ("compass frames (ephemeris, method, sun update)", "readings to the filters",
     "twin.onboard.navigator", "Navigator", "_compass", "frame"),
    ("compass methods (POL, LIG)", "compass frames (ephemeris, method, sun update)",
     "twin.onboard.compass.base", "CompassMethod", "solve", "method"),
    ("IMU batches through the INS (3 filters)", "readings to the filters",
     "twin.onboard.imu_batch", "ImuBatch", "flush", "step"),
    ("depth updates (3 filters)", "readings to the filters", "twin.onboard.eskf", "Eskf",
     "update_depth", "step"),
    ("gravity updates (3 filters)", "readings to the filters", "twin.onboard.eskf", "Eskf",
     "update_gravity", "step"),
    ("scoring against truth", "", "twin.scoring.observer", "RunScorer", "on_step", "step"),
    ("guidance and autopilot", "", "twin.sim.step", "Simulation", "control", "step"),
    # The loop's compiled and C cores (the rest of each stage is the Python between them).
    (_MJ, "physics step", "mujoco", "", "mj_step2", "step"),
    (_MJ, "physics step", "mujoco", "", "mj_step1", "step"),
    (_MJ, "physics step", "mujoco", "", "mj_forwardSkip", "step"),
    (_WRENCH, "physics step", "twin.world.hydrodynamics_kernel", "", "body_wrench", "step"),
    (_IMU_K, "IMU model", "sensors.imu_kernel", "", "sample", "step"),
    (_FILTER_K, "readings to the filters", "twin.onboard.mechanization", "", "advance_samples",
     "step"),
    (_FILTER_K, "readings to the filters", "twin.onboard.eskf_kernels", "", "propagate", "step"),
    (_FILTER_K, "readings to the filters", "twin.onboard.eskf_kernels", "", "update", "step"),
)  # fmt: skip
LOOP_CORES = (_MJ, _WRENCH, _IMU_K, _FILTER_K)

_CHILD = (
    r"""
import collections, dataclasses, functools, importlib, json, os, sys, tempfile, time
t_start = time.perf_counter()
try:
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
except (AttributeError, OSError):
    pass
a = json.loads(sys.argv[1])
import scenarios
from twin.app.run import run_scenario
from twin.sim import step as step_mod
t_imported = time.perf_counter()
"""
    + TIMER
    + r"""
acc = collections.defaultdict(float)
calls = collections.Counter()
for label, _, mod, cls, name, _ in a["stages"]:
    m = importlib.import_module(mod)
    wrap_timer(getattr(m, cls) if cls else m, name, label, acc, calls)
# Rays through the exact chain (the fast path's coarse points, fine points and exact pixels).
from sensors.polarimeter import chain_kernel
rays = [0]
_points = chain_kernel.render_points
def counted_points(r, *x, _f=_points, **k):
    rays[0] += len(r)
    return _f(r, *x, **k)
chain_kernel.render_points = counted_points
first = {}
orig_step = step_mod.Simulation.step
def step(self, cmd, _orig=orig_step):
    if "t0" not in first:
        first["t0"] = time.perf_counter()
        r = _orig(self, cmd)
        first["first_step_s"] = time.perf_counter() - first["t0"]
        first["stages_after_first"] = dict(acc)
        first["calls_after_first"] = dict(calls)
        first["rays_after_first"] = rays[0]
        return r
    return _orig(self, cmd)
step_mod.Simulation.step = step
sc = scenarios.load("sea_trial_10m")
mission = dataclasses.replace(sc.mission, legs=sc.mission.legs * 2)
sc = dataclasses.replace(sc, duration_s=a["mission_s"], mission=mission,
    navigation=dataclasses.replace(sc.navigation, variants=("ins", "pol", "lig")))
with tempfile.TemporaryDirectory() as d:
    t0 = time.perf_counter()
    m = run_scenario(sc, d, camera=False, record=False)
    wall = time.perf_counter() - t0
flight = {k: v - first["stages_after_first"].get(k, 0.0) for k, v in acc.items()}
ncalls = {k: v - first["calls_after_first"].get(k, 0) for k, v in calls.items()}
print(json.dumps({"imports_s": t_imported - t_start, "run_s": wall,
                  "build_s": first["t0"] - t0, "first_step_s": first["first_step_s"],
                  "flight_s": wall - (first["t0"] - t0) - first["first_step_s"],
                  "stages_s": flight, "calls": ncalls,
                  "sim_s": m["sim_time_s"], "frames": m["sensor_readings"].get("polarimeter", 0),
                  "steps": ncalls["physics step"],
                  "chain_rays": rays[0] - first["rays_after_first"]}))
"""
)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission-s", type=float, default=600.0)
    args = ap.parse_args()
    arg = {"stages": [list(s) for s in STAGES], "mission_s": args.mission_s}
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(arg)],
        cwd=ROOT, env=env, check=True, capture_output=True, text=True,
    )  # fmt: skip
    row = json.loads(out.stdout.strip().splitlines()[-1])
    sys.path.insert(0, str(ROOT))
    from twin.record import provenance as pv

    meta = {
        "cpu_count": os.cpu_count(),
        "load_average_1_5_15": [round(x, 2) for x in os.getloadavg()],
        "date": time.strftime("%Y-%m-%d"),
        "mission_s": args.mission_s,
        "provenance": pv.provenance(),
    }
    md = _report(row, meta)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "sea_trial_profile.md").write_text("\n".join(md) + "\n")
    (RESULTS / "sea_trial_profile.json").write_text(
        json.dumps({"meta": meta, "row": row}, indent=2) + "\n"
    )
    print("\n".join(md))
    return 0


def _report(row: dict[str, Any], meta: dict[str, Any]) -> list[str]:
    from twin.record import provenance as pv

    st, calls = row["stages_s"], row["calls"]
    flight, sim_s = row["flight_s"], row["sim_s"]
    frames = max(row["frames"], 1)
    md = [
        "# Where a sea trial's wall time goes (issue #31)",
        "",
        f"`python benchmarks/sea_trial_profile.py --mission-s {meta['mission_s']:.0f}`: "
        f"sea_trial_10m's square, {sim_s:.0f} s simulated (physics and IMU 100 Hz, depth 10 Hz, "
        f"the 612×512 polarimeter at 1 Hz, {row['frames']} frames), INS + POL/INS + LIG/INS, no "
        "recording, one core, each stage timed by a wrapper round its entry point (~1 µs a "
        f"call). {meta['date']}, {meta['cpu_count']} CPUs, load average "
        f"{meta['load_average_1_5_15']}.",
        f"- {'; '.join(pv.describe(meta['provenance']))}",
        "",
        f"Start-up: imports {row['imports_s']:.2f} s, building the simulation "
        f"{row['build_s']:.2f} s, the first step (the first frame's tables and kernels, the "
        f"compass's geometry) {row['first_step_s']:.2f} s. The flight after it: "
        f"{flight:.2f} s for {sim_s:.0f} s, **{sim_s / flight:.1f}× real time**; the whole run "
        f"{row['run_s']:.2f} s ({sim_s / row['run_s']:.1f}×).",
        "",
        "| stage | wall s | share of the flight | per call | calls | ms per simulated s |",
        "|---|---|---|---|---|---|",
    ]
    children: dict[str, list[str]] = {}
    for label, parent, *_ in STAGES:
        if label not in children.setdefault(parent, []):
            children[parent].append(label)

    def per_call(label: str) -> str:
        n = max(calls.get(label, 0), 1)
        us = 1e6 * st.get(label, 0.0) / n
        return f"{us / 1e3:.2f} ms" if us >= 1000 else f"{us:.1f} µs"

    def emit(label: str, depth: int) -> None:
        s = st.get(label, 0.0)
        md.append(
            f"| {'&nbsp;&nbsp;' * 2 * depth}{label} | {s:.2f} | {100 * s / flight:.0f} % | "
            f"{per_call(label)} | {calls.get(label, 0)} | {1e3 * s / sim_s:.1f} |"
        )
        for child in children.get(label, []):
            emit(child, depth + 1)

    for top in children[""]:
        emit(top, 0)
    rest = flight - sum(st.get(label, 0.0) for label in children[""])
    md.append(
        f"| unaccounted (the loop, scheduling, step results, the wrappers) | {rest:.2f} | "
        f"{100 * rest / flight:.0f} % | | | {1e3 * rest / sim_s:.1f} |"
    )
    frame = st.get("polarimeter frame", 0.0)
    compass = st.get("compass methods (POL, LIG)", 0.0)
    loop = flight - frame - st.get("compass frames (ephemeris, method, sun update)", 0.0)
    md += [
        "",
        "## Against issue #31's per-stage targets",
        "",
        "| quantity | target | measured |",
        "|---|---|---|",
        f"| 612×512 frame, ms | ≤ 3 | {1e3 * frame / frames:.1f} |",
        f"| compass, ms per method per frame | ≤ 2 | {1e3 * compass / (2 * frames):.1f} |",
        f"| 100 Hz loop (all but the frame and the compass frames), ms per simulated s | ≤ 5 | "
        f"{1e3 * loop / sim_s:.1f} |",
        f"| whole flight, real-time factor | ≥ 100 | {sim_s / flight:.1f} |",
    ]
    cores = {label: st.get(label, 0.0) for label in LOOP_CORES}
    md += [
        "",
        f"Of the 100 Hz loop's {1e3 * loop / sim_s:.1f} ms per simulated second, its compiled and "
        f"C cores take {1e3 * sum(cores.values()) / sim_s:.1f} ("
        + ", ".join(f"{label} {1e3 * v / sim_s:.1f}" for label, v in cores.items())
        + "; each timed by the same ~1 µs wrapper, counted in). The rest is Python: the calls "
        "between them, the readings, the scheduling, scoring and guidance, one step at a time.",
    ]
    n_rays = row.get("chain_rays")
    chain = st.get("compiled chain (scattering kernel, sky, Fresnel, lens)", 0.0)
    if n_rays:
        md += [
            "",
            f"The exact chain rendered {n_rays / frames:,.0f} rays a frame (the coarse grid's "
            f"points and the rough cells' pixels) at {1e9 * chain / n_rays:.0f} ns a ray "
            "(the scattering kernel's single scattering, table light, aureole and the surface's "
            "reflection, the sky, Fresnel, the lens, in one compiled pass): "
            f"{1e3 * chain / frames:.1f} ms of the frame's {1e3 * frame / frames:.1f}.",
        ]
    return md


if __name__ == "__main__":
    raise SystemExit(main())
