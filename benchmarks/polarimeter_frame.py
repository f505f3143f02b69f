"""Time per polarimeter frame: the whole physics chain, then the DoFP sensor, on one core.

Issue #3's targets: a full-resolution frame (2448×2048 mosaic, every stage but waves, occlusion
on a coarse grid) in ≤ 100 ms, a 612×512 frame in ≤ 10 ms. Renders a level camera at 10 m in
Jerlov II water (sun 40° from the zenith), best of N after a warm-up frame (the per-pixel
geometry and the fast path's coarse grid are computed once per camera), and splits the time into
the optics (sky, surface, water, lens → sensor-plane Stokes) and the sensor (noise, ADC). The
optics run on the fast path (``PolarimeterSpec.fast``: a coarse grid, bilinearly upsampled, with
the exact chain near Snell's window edge and the sun); the exact chain at every pixel
(``fast=False``) is timed too, and how many pixels the fast path rendered exactly. Occlusion is
timed separately against the open-sea scene (mj_multiRay on the coarse grid).

    OMP_NUM_THREADS=1 taskset -c 1 python benchmarks/polarimeter_frame.py [--repeats N] \
        [--baseline REV [--rounds R]]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import scenarios
import sensors
from sensors.polarimeter.render import OpticsConfig, Polarimeter
from twin.record import provenance as pv
from twin.sim.build import build_simulation

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
SUN = np.array(
    [math.sin(math.radians(40)) * 0.6, math.sin(math.radians(40)) * 0.8, math.cos(math.radians(40))]
)


def _best(fn, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _exact_pixels(cam: Polarimeter) -> int:
    """Rays the fast path sent through the exact chain in the benchmark's frame, less the coarse
    grid's: the rough cells' exact pixels and (with its fine level) the fine grid's points."""
    count = []
    points = cam._render_points

    def spy(rays, *args, **kwargs):
        count.append(len(rays))
        return points(rays, *args, **kwargs)

    cam._render_points = spy  # type: ignore[method-assign]
    try:
        cam.render_stokes(None, np.zeros(3), np.eye(3), 10.0, SUN)
    finally:
        del cam._render_points
    return int(sum(count[1:]))  # the first call is the coarse grid


def time_preset(preset: str, repeats: int) -> dict[str, float | str | int]:
    cam = sensors.create("polarimeter", preset)
    assert isinstance(cam, Polarimeter)
    cam.configure(OpticsConfig())
    rng = np.random.default_rng(0)
    cam.render_offline(np.eye(3), 10.0, SUN, rng)  # warm-up: per-pixel geometry, fixed pattern
    assert cam._dofp is not None
    optics = _best(lambda: cam.render_stokes(None, np.zeros(3), np.eye(3), 10.0, SUN), repeats)
    exact = sensors.create("polarimeter", preset, fast=False)
    assert isinstance(exact, Polarimeter)
    exact.configure(OpticsConfig())
    exact.render_stokes(None, np.zeros(3), np.eye(3), 10.0, SUN)
    exact_optics = _best(
        lambda: exact.render_stokes(None, np.zeros(3), np.eye(3), 10.0, SUN), max(repeats // 2, 1)
    )
    stokes = cam.render_stokes(None, np.zeros(3), np.eye(3), 10.0, SUN)[0]
    sensor = _best(lambda: cam._dofp.render_mosaic(stokes, 700.0, rng), repeats)
    total = _best(lambda: cam.render_offline(np.eye(3), 10.0, SUN, rng), repeats)
    # Occlusion against the real scene, from the vehicle's site.
    world = build_simulation(scenarios.load("default"))
    pos, c = world.plant.site_pose("polarimeter")
    rays = cam.camera.outside(cam.n_water).directions
    occl = _best(lambda: cam._occlusion(world.plant, pos, c, rays, 10.0), repeats)
    h, w = cam.camera.shape
    return {
        "preset": preset,
        "shape": f"{w}x{h}",
        "optics_ms": optics * 1e3,
        "exact_optics_ms": exact_optics * 1e3,
        "exact_pixels": _exact_pixels(cam),
        "valid_pixels": int(cam.camera.valid.sum()),
        "sensor_ms": sensor * 1e3,
        "frame_ms": total * 1e3,
        "occlusion_ms": occl * 1e3,
        "frame_with_occlusion_ms": (total + occl) * 1e3,
    }


def _run_tree(tree: Path, repeats: int) -> list[dict]:
    """This benchmark's rows as the tree at ``tree`` times them, in a fresh interpreter.

    A baseline tree runs its own script (which writes its own results file, read back here); so
    does this tree (``--child``), so that both sides of a comparison start alike.
    """
    env = {**os.environ, "PYTHONPATH": str(tree)}
    cmd = [sys.executable, "benchmarks/polarimeter_frame.py", "--repeats", str(repeats)]
    if tree == ROOT:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "rows.json"
            subprocess.run([*cmd, "--child", str(out)], cwd=tree, env=env, check=True)
            return json.loads(out.read_text())
    subprocess.run(cmd, cwd=tree, env=env, check=True, stdout=subprocess.DEVNULL)
    return json.loads((tree / "benchmarks/results/polarimeter_frame.json").read_text())["rows"]


TIMES = (
    "optics_ms",
    "exact_optics_ms",
    "sensor_ms",
    "frame_ms",
    "occlusion_ms",
    "frame_with_occlusion_ms",
)


def _summarise(runs: list[list[dict]]) -> list[dict]:
    """Per preset, the median of each time over the rounds, with its [min, max]."""
    out = []
    for rows in zip(*runs, strict=True):
        row = dict(rows[0])
        for key in TIMES:
            vals = [r[key] for r in rows]
            row[key] = float(np.median(vals))
            row[f"{key}_range"] = [float(min(vals)), float(max(vals))]
        out.append(row)
    return out


def _cell(r: dict, key: str) -> str:
    lo_hi = r.get(f"{key}_range")
    if lo_hi is None or lo_hi[0] == lo_hi[1]:
        return f"{r[key]:.1f} ms"
    return f"{r[key]:.1f} ms [{lo_hi[0]:.1f}–{lo_hi[1]:.1f}]"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument(
        "--baseline",
        metavar="REV",
        help="also time this git revision, in the same session (a temporary worktree)",
    )
    ap.add_argument(
        "--rounds",
        type=int,
        default=1,
        help="with --baseline: rounds of baseline then this tree, each in a fresh interpreter; "
        "the table gives each time's median over the rounds and its range",
    )
    ap.add_argument("--child", metavar="JSON", help=argparse.SUPPRESS)
    args = ap.parse_args()
    presets = ("phx050s_p", "phx050s_p_bin4")
    if args.child:  # one round of this tree, for a parent that interleaves it with a baseline
        Path(args.child).write_text(json.dumps([time_preset(p, args.repeats) for p in presets]))
        return
    if args.rounds < 1:
        ap.error(f"--rounds: {args.rounds}; allowed: an integer >= 1")
    base = None
    if args.baseline:
        with tempfile.TemporaryDirectory() as tmp:
            tree = Path(tmp) / "baseline"
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(tree),
                 args.baseline],
                check=True,
            )  # fmt: skip
            try:
                base_runs, runs = [], []
                for k in range(args.rounds):
                    print(f"round {k + 1}/{args.rounds}", flush=True)
                    base_runs.append(_run_tree(tree, args.repeats))
                    runs.append(_run_tree(ROOT, args.repeats))
            finally:
                subprocess.run(
                    ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                    check=False,
                )
        base = {"rows": _summarise(base_runs)}
        rows = _summarise(runs)
    else:
        rows = [time_preset(p, args.repeats) for p in presets]
    meta = {
        "machine": platform.platform(),
        "cpu_count": os.cpu_count(),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "cpu_affinity": sorted(os.sched_getaffinity(0)),
        "load_average_1_5_15": [round(x, 2) for x in os.getloadavg()],
        "repeats": args.repeats,
        "rounds": args.rounds if args.baseline else 1,
        "date": time.strftime("%Y-%m-%d"),
        "provenance": pv.provenance(),
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "polarimeter_frame.json").write_text(
        json.dumps({"meta": meta, "rows": rows, "baseline": base}, indent=2, default=str)
    )
    how = f"best of {args.repeats}"
    if meta["rounds"] > 1:
        how += (
            f" in each of {meta['rounds']} rounds (baseline, then this tree, each in a fresh "
            "interpreter); each time is the median over the rounds [its range]"
        )
    lines = [
        "# Polarimeter frame time (one core)",
        "",
        f"`python benchmarks/polarimeter_frame.py`, {how}, {meta['date']}, "
        f"{meta['machine']}, one core (CPUs {meta['cpu_affinity']}), load average "
        f"{meta['load_average_1_5_15']} (a shared VM: runs vary by up to ±30 %). Level camera, "
        "10 m, Jerlov II, flat sea, sun 40° from the zenith.",
        f"- {'; '.join(pv.describe(meta['provenance']))}",
        "",
        "| preset | frame | optics, fast path (rays past the coarse grid: exact pixels, fine "
        "points) | optics, exact chain "
        "| sensor (noise, ADC) | whole frame | + occlusion (mj_multiRay, every 8th px) | target |",
        "|---|---|---|---|---|---|---|---|",
    ]
    labelled = [("", r) for r in rows]
    if base is not None:
        labelled = [(f" at {args.baseline}", r) for r in base["rows"]] + labelled
    for tag, r in labelled:
        target = "≤ 100 ms" if r["preset"] == "phx050s_p" else "≤ 10 ms"
        share = f"{r['exact_pixels']} for {r['valid_pixels']} px"
        lines.append(
            f"| {r['preset']}{tag} | {r['shape']} | {_cell(r, 'optics_ms')} ({share}) "
            f"| {_cell(r, 'exact_optics_ms')} | {_cell(r, 'sensor_ms')} "
            f"| {_cell(r, 'frame_ms')} | {_cell(r, 'frame_with_occlusion_ms')} | {target} |"
        )
    lines += [
        "",
        'Rows marked "at REV" are that revision\'s own benchmark, run in the same session on '
        "the same core (`--baseline REV`): old and new side by side.",
    ]
    (RESULTS / "polarimeter_frame.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
