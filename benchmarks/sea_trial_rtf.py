"""Real-time factor of a sea trial with the polarimeter, the compass and the filters in the loop.

Issue #31's targets, on one core: a 10-minute sea trial with the sea trials' camera (PHX050S-P
binned 4×4, 612×512, frames at 1 Hz), three filter variants (INS, POL/INS, LIG/INS) ≥ 100× real
time without the recording and ≥ 60× with it; inside it a 612×512 frame ≤ 3 ms, each compass
method ≤ 2 ms, and the 100 Hz loop (physics, IMU, three filters, depth, scoring, scheduling)
≤ 5 ms per simulated second. (Issue #10's were 30× / 20×.)

Each row runs in a fresh interpreter pinned to one core; ``--baseline REV`` runs the same rows on
revision ``REV`` (a temporary git worktree, its own code, this script's driver), interleaved with
the current tree's, so that old and new are measured side by side under the same machine load
(the ratio is what the load cannot move). The seeded outputs of the two are compared too: every
metric of the run but its wall time and provenance, identical or listed where not.

The no-recording row says where the wall time goes: each stage is timed by a wrapper around its
entry point (≈ 1 µs a call, < 1 % of the row).

    python benchmarks/sea_trial_rtf.py [--baseline REV] [--repeats N]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
MISSION_S = 600.0

_FILTERS = "INS, covariance, depth + gravity updates (3 filters)"
# (label, module, class, method): the stages of one physics step and of one camera frame. A stage
# a revision does not have is skipped there (the driver runs on old revisions too).
STAGES: tuple[tuple[str, str, str, str], ...] = (
    ("polarimeter frame (render + sensor)", "sensors.polarimeter.render", "Polarimeter", "sample"),
    ("compass methods (POL, LIG)", "twin.onboard.compass.base", "CompassMethod", "solve"),
    ("physics (MuJoCo + hydrodynamics)", "twin.world.plant", "Plant", "step"),
    # Since issue #31 the steps with the IMU's sample alone fly in compiled blocks: their
    # physics and IMU samples are in this row, not in the two beside it.
    (
        "quiet steps in compiled blocks (physics + IMU)",
        "twin.world.quiet_steps",
        "QuietSteps",
        "fly",
    ),
    # Since this stop a block ends with the step after its quiet ones (its physics and IMU
    # sample flown with them; its other sensors, filters and scorer in their rows).
    (
        "quiet steps in compiled blocks (physics + IMU)",
        "twin.world.quiet_steps",
        "QuietSteps",
        "fly_closing",
    ),
    # One row for the filters: since issue #31 the samples go through the INS in batches, and
    # since stop 55 a batch's call makes the depth updates queued among its samples and the
    # gravity update after them (a sample or an update the batch leaves to Python still goes
    # through predict_reading or update_*, inside flush: counted twice; none does in a trial).
    *((_FILTERS, module, cls, name) for module, cls, name in (
        ("twin.onboard.eskf", "Eskf", "predict_reading"),
        ("twin.onboard.imu_batch", "ImuBatch", "flush"),
        ("twin.onboard.eskf", "Eskf", "update_depth"),
        ("twin.onboard.eskf", "Eskf", "update_gravity"),
    )),
    ("IMU model", "sensors.imu", "Imu", "sample"),
    ("scoring against truth", "twin.scoring.observer", "RunScorer", "on_step"),
)  # fmt: skip
FRAME, COMPASS = STAGES[0][0], STAGES[1][0]

# The children's one timer (this script's and sea_trial_profile.py's): wraps ``owner.name`` so
# that its wall time adds to acc[label] and its calls to calls[label] (~1 µs a call). Plain
# Python in the child's own text, so that a child runs on any revision's tree.
TIMER = r"""
def wrap_timer(owner, name, label, acc, calls):
    fn = getattr(owner, name)
    def timed(*x, _fn=fn, **k):
        t0 = time.perf_counter()
        try:
            return _fn(*x, **k)
        finally:
            acc[label] += time.perf_counter() - t0
            calls[label] += 1
    setattr(owner, name, functools.wraps(fn)(timed))
"""

# The children's common start (this script's and recording_profile.py's): pinned to one core,
# argv[1] read as JSON into ``a``, and ``sea_trial(mission_s, variants)``: sea_trial_10m's square
# flown twice (~800 s of legs), cut at the duration, so that every row is a full run. Plain
# Python that every revision since #10 runs.
CHILD_HEAD = r"""
import collections, dataclasses, functools, importlib, json, os, sys, tempfile, time
try:
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
except (AttributeError, OSError):
    pass
a = json.loads(sys.argv[1])
import scenarios
from twin.app.run import run_scenario
def sea_trial(mission_s, variants):
    sc = scenarios.load("sea_trial_10m")
    mission = dataclasses.replace(sc.mission, legs=sc.mission.legs * 2)
    return dataclasses.replace(sc, duration_s=mission_s, mission=mission,
        navigation=dataclasses.replace(sc.navigation, variants=tuple(variants)))
"""

# One row, in a fresh interpreter on one core: argv[1] = JSON {variants, record, breakdown,
# stages, mission_s}; prints one JSON line. Uses only what every revision since #10 has.
_CHILD = (
    CHILD_HEAD
    + TIMER
    + r"""
acc = collections.defaultdict(float)
calls = collections.Counter()
if a["breakdown"]:
    for label, mod, cls, name in a["stages"]:
        try:
            owner = getattr(importlib.import_module(mod), cls)
            getattr(owner, name)
        except (ImportError, AttributeError):
            continue
        wrap_timer(owner, name, label, acc, calls)
sc = sea_trial(a["mission_s"], a["variants"])
with tempfile.TemporaryDirectory() as d:
    # CPU: this process's threads and the children it waited for (the recording's compaction).
    t0, c0 = time.perf_counter(), sum(os.times()[:4])
    m = run_scenario(sc, d, camera=False, record=a["record"])
    wall, cpu = time.perf_counter() - t0, sum(os.times()[:4]) - c0
    rrd = os.path.join(d, "recording.rrd")
    size = os.path.getsize(rrd) if os.path.exists(rrd) else 0
outputs = {k: v for k, v in m.items()
           if k not in ("wall_time_s", "real_time_factor", "provenance", "versions", "recording")}
print(json.dumps({"wall_s": wall, "cpu_s": cpu, "sim_s": m["sim_time_s"], "rrd_mb": size / 1e6,
                  "frames": m["sensor_readings"].get("polarimeter", 0),
                  "stages_s": dict(acc), "outputs": outputs}, default=str))
"""
)

ROWS: tuple[tuple[tuple[str, ...], bool, bool], ...] = (
    (("ins", "pol", "lig"), False, True),
    (("ins", "pol", "lig"), True, False),
    (("ins", "lig"), True, False),
)


def _row(
    tree: Path, variants: tuple[str, ...], record: bool, breakdown: bool, mission_s: float
) -> dict[str, Any]:
    arg = {
        "variants": list(variants),
        "record": record,
        "breakdown": breakdown,
        "stages": [list(s) for s in STAGES],
        "mission_s": mission_s,
    }
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1"}
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(arg)],
        cwd=tree,
        env=env,
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _median_row(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """The run with the median wall time (its own breakdown, so that stages add up)."""
    ordered = sorted(runs, key=lambda r: r["wall_s"])
    return ordered[len(ordered) // 2]


def _differences(a: Any, b: Any, path: str = "") -> list[str]:
    """Each output that differs, as ``path (a → b)``: the size of a change is the evidence."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            out += _differences(a.get(k), b.get(k), f"{path}.{k}" if path else str(k))
        return out
    return [] if a == b else [f"{path} ({a!r} → {b!r})"]


def _loop_ms_per_s(row: dict[str, Any]) -> float:
    """Wall ms per simulated second outside the frame and the compass (the 100 Hz loop)."""
    st = row["stages_s"]
    return 1e3 * (row["wall_s"] - st.get(FRAME, 0.0) - st.get(COMPASS, 0.0)) / row["sim_s"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", metavar="REV", help="also run git revision REV, interleaved")
    ap.add_argument("--repeats", type=int, default=1, help="runs per row and tree (median)")
    ap.add_argument("--mission-s", type=float, default=MISSION_S, help="simulated seconds a row")
    ap.add_argument(
        "--name",
        default="sea_trial_rtf",
        help="the results files' stem in benchmarks/results (default: sea_trial_rtf, the file "
        "the README quotes; another name keeps a second comparison, e.g. one stop's alone)",
    )
    args = ap.parse_args()
    if not args.name or "/" in args.name or args.name.startswith("."):
        ap.error(f"--name: {args.name!r}; allowed: a file stem without '/' or a leading '.'")
    trees: dict[str, Path] = {"current": ROOT}
    tmp = tempfile.TemporaryDirectory() if args.baseline else None
    try:
        if args.baseline and tmp is not None:
            base = Path(tmp.name) / "baseline"
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(base),
                 args.baseline],
                check=True,
            )  # fmt: skip
            trees = {args.baseline: base, "current": ROOT}
        for tree in trees.values():  # numba's on-disk cache (every kernel a row runs, the
            # compass methods' on the frame at t = 0) and the light-field tables, built before
            # anything is timed
            _row(tree, ("ins", "pol", "lig"), True, False, 2.0)
        results: dict[str, list[dict[str, Any]]] = {name: [] for name in trees}
        for variants, record, breakdown in ROWS:
            runs: dict[str, list[dict[str, Any]]] = {name: [] for name in trees}
            for i in range(args.repeats):
                for name, tree in trees.items():  # interleaved: the same load for both
                    r = _row(tree, variants, record, breakdown, args.mission_s)
                    runs[name].append(r)
                    print(f"{name} {','.join(variants)} rec={record} #{i}: "
                          f"{r['wall_s']:.1f} s", file=sys.stderr)  # fmt: skip
            for name in trees:
                row = _median_row(runs[name])
                cpus = sorted(r["cpu_s"] for r in runs[name])
                row.update(variants=list(variants), recording=record,
                           walls_s=[round(r["wall_s"], 2) for r in runs[name]],
                           cpus_s=[round(r["cpu_s"], 2) for r in runs[name]],
                           cpu_median_s=cpus[len(cpus) // 2])  # fmt: skip
                results[name].append(row)
    finally:
        if args.baseline and tmp is not None:
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "remove", "--force",
                 str(Path(tmp.name) / "baseline")],
                check=False,
            )  # fmt: skip
            tmp.cleanup()
    sys.path.insert(0, str(ROOT))
    from twin.record import provenance as pv

    meta = {
        "machine": f"{platform.machine()}, Python {sys.version.split()[0]}, one core per row",
        "cpu_count": os.cpu_count(),
        "load_average_1_5_15": [round(x, 2) for x in os.getloadavg()],
        "date": time.strftime("%Y-%m-%d"),
        "repeats": args.repeats,
        "baseline": args.baseline,
        "mission_s": args.mission_s,
        "name": args.name,
        "provenance": pv.provenance(),
    }
    md = _report(results, meta)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{args.name}.md").write_text("\n".join(md) + "\n")
    slim = {k: [{x: y for x, y in r.items() if x != "outputs"} for r in v]
            for k, v in results.items()}  # fmt: skip
    (RESULTS / f"{args.name}.json").write_text(
        json.dumps({"meta": meta, "rows": slim}, indent=2, default=str) + "\n"
    )
    print("\n".join(md))
    return 0


def _cpu(row: dict[str, Any]) -> str:
    """The median CPU time and its real-time factor, or "–" for rows from before it was kept."""
    cpu = row.get("cpu_median_s")
    return "–" if cpu is None else f"{cpu:.1f} ({row['sim_s'] / cpu:.1f}x)"


def _share(secs: float, row: dict[str, Any]) -> str:
    return f"{secs:.2f} ({100 * secs / row['wall_s']:.0f} %)"


def _report(results: dict[str, list[dict[str, Any]]], meta: dict[str, Any]) -> list[str]:
    from twin.record import provenance as pv

    names = list(results)
    cmd = "python benchmarks/sea_trial_rtf.py"
    if meta["baseline"]:
        cmd += f" --baseline {meta['baseline']}"
    if meta.get("name", "sea_trial_rtf") != "sea_trial_rtf":
        cmd += f" --name {meta['name']}"
    md = [
        "# Sea trial real-time factor (issues #5, #10, #31)",
        "",
        f"`{cmd} --repeats {meta['repeats']}`. sea_trial_10m's square flown twice, cut at "
        f"{meta['mission_s']:.0f} s: physics 100 Hz, IMU 100 Hz, depth 10 Hz, polarimeter "
        f"612×512 at 1 Hz (render + compass on every frame), no chase camera. {meta['machine']}, "
        f"{meta['date']}, load average {meta['load_average_1_5_15']}; each row a fresh "
        f"interpreter, the median of {meta['repeats']} (the rows of the trees interleaved).",
        f"- {'; '.join(pv.describe(meta['provenance']))}",
        "",
        "| code | filter variants | recording | sim s | wall s | real-time factor | frames "
        "| .rrd | CPU s (its real-time factor) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for i in range(len(ROWS)):
        for name in names:
            r = results[name][i]
            md.append(
                f"| {name} | {', '.join(r['variants'])} | {'on' if r['recording'] else 'off'} | "
                f"{r['sim_s']:.0f} | {r['wall_s']:.1f} | **{r['sim_s'] / r['wall_s']:.1f}x** | "
                f"{r['frames']} | {r['rrd_mb']:.1f} MB | {_cpu(r)} |"
            )
    firsts = [results[n][0] for n in names]
    gaps = [
        abs(w - c) / w
        for n in names
        for r in results[n]
        for w, c in zip(r["walls_s"], r.get("cpus_s", r["walls_s"]), strict=True)
    ]
    reading = (
        "where the runs of a row differ, the core itself ran slower, and the CPU time differs as "
        "much"
        if max(gaps) < 0.02
        else "the gap is time the run did not have its core (or waited)"
    )
    md += [
        "",
        "CPU s: the CPU time of the run (the process's threads and the child processes it waited "
        "for, the recording's compaction; the median of the runs), which time stolen by the VM's "
        f"host and waits do not count in. Here it is within {100 * max(gaps):.1f} % of the wall "
        f"time in every run: {reading}.",
        "",
        "Targets (issue #31): three variants, no recording >= 100x; with the recording >= 60x.",
        "",
        "## Where the wall time goes (three variants, no recording)",
        "",
        "| stage | " + " | ".join(f"{n}: wall s (share)" for n in names) + " |",
        "|---|" + "---|" * len(names),
    ]
    labels = sorted(
        {k for r in firsts for k in r["stages_s"]}, key=lambda k: -firsts[-1]["stages_s"].get(k, 0)
    )
    for label in labels:
        cells = [_share(r["stages_s"].get(label, 0.0), r) for r in firsts]
        md.append(f"| {label} | " + " | ".join(cells) + " |")
    rests = [_share(r["wall_s"] - sum(r["stages_s"].values()), r) for r in firsts]
    md.append(
        "| everything else (loop, scheduling, guidance, autopilot) | " + " | ".join(rests) + " |"
    )

    def per(r: dict[str, Any], label: str, n: int) -> str:
        return f"{1e3 * r['stages_s'].get(label, 0.0) / max(n * r['frames'], 1):.1f}"

    md += [
        "",
        "## Against issue #31's per-stage targets (from the same rows)",
        "",
        "| quantity | target | " + " | ".join(names) + " |",
        "|---|---|" + "---|" * len(names),
        "| 612×512 frame, ms | ≤ 3 | " + " | ".join(per(r, FRAME, 1) for r in firsts) + " |",
        "| compass, ms per method per frame | ≤ 2 | "
        + " | ".join(per(r, COMPASS, 2) for r in firsts)
        + " |",
        "| 100 Hz loop, ms per simulated second | ≤ 5 | "
        + " | ".join(f"{_loop_ms_per_s(r):.1f}" for r in firsts)
        + " |",
    ]
    if len(names) == 2:
        md += [
            "",
            "## Same numbers",
            "",
            "Every output of the run as metrics.json has it (its rounding), but its wall time "
            "and provenance:",
            "",
        ]
        for i in range(len(ROWS)):
            a, b = results[names[0]][i], results[names[1]][i]
            diff = _differences(a["outputs"], b["outputs"])
            what = "identical" if not diff else "different in " + ", ".join(diff[:12])
            if len(diff) > 12:
                what += f" and {len(diff) - 12} more"
            md.append(
                f"- {', '.join(a['variants'])}, recording {'on' if a['recording'] else 'off'}: "
                f"the seeded outputs of {names[0]} and current are {what}."
            )
    return md


if __name__ == "__main__":
    raise SystemExit(main())
