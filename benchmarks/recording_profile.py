"""Where a recorded sea trial's recording time goes (issue #31's recorded target, ≥ 60×).

The trial of ``sea_trial_rtf.py``'s recorded row (sea_trial_10m's square flown twice, cut at
600 s, INS + POL/INS + LIG/INS, the 612×512 polarimeter at 1 Hz, the Rerun recording on, no
chase camera), in a fresh interpreter pinned to one core, with each part of the recording timed
by a wrapper round its entry point (~1 µs a call): what the recorder does as an observer of the
steps (the polarimeter's three pictures a frame and their parts, the readings' series, the
filters' samples, truth), the control series the run loop logs, the writes (flushes: set off
from inside those rows, so counted in them too) and closing the file (its footer, then the
compaction, a child process). Rerun's own threads work inside a write, which waits for them;
what they do between writes is not in these rows (the paired comparison in
``paired_switches.py`` measures the recording whole, against the same flight unrecorded).

The median of ``--repeats`` fresh interpreters, each after an untimed one that fills numba's
cache.

    python benchmarks/recording_profile.py [--mission-s 600] [--repeats 3]

Writes benchmarks/results/recording_profile.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from sea_trial_rtf import CHILD_HEAD, TIMER  # noqa: E402  (the children's start and timer)

_OBSERVER = "the recorder as an observer of the steps (all it does in the flight)"
_PICTURES = "the polarimeter's three pictures a frame"
_WRITES = "writes (flushes), set off from the rows above"
# (label, parent label or "", module, class or "", function): a label may time several.
STAGES: tuple[tuple[str, str, str, str, str], ...] = (
    (_OBSERVER, "", "twin.record.observer", "RunRecorder", "on_step"),
    (_OBSERVER, "", "twin.record.observer", "RunRecorder", "on_quiet_steps"),
    (_PICTURES, _OBSERVER, "twin.record.observer", "", "_log_polarimeter"),
    ("their Stokes inversion (S0–S2, AoP, DoP)", _PICTURES, "twin.record.observer", "",
     "stokes_from_mosaic"),
    ("their intensity scale and colour maps", _PICTURES, "twin.record.images", "",
     "intensity_u8"),
    ("their intensity scale and colour maps", _PICTURES, "twin.record.images", "", "aop_rgb"),
    ("their intensity scale and colour maps", _PICTURES, "twin.record.images", "", "dop_rgb"),
    ("their JPEG encoding", _PICTURES, "twin.record.recorder", "Recorder", "log_image"),
    ("the readings' series (IMU, depth, camera exposure …)", _OBSERVER, "twin.record.recorder",
     "Recorder", "log_reading"),
    ("the filters' samples (/nav, every 50 truth samples)", _OBSERVER, "twin.record.observer",
     "RunRecorder", "log_nav"),
    ("truth samples", _OBSERVER, "twin.record.observer", "", "log_truth"),
    ("compass events", _OBSERVER, "twin.record.observer", "", "log_compass_event"),
    ("the control series (the run loop's)", "", "twin.record.observer", "RunRecorder",
     "log_control"),
    (_WRITES, "", "twin.record.recorder", "Recorder", "flush"),
    ("closing the file (last write, footer)", "", "twin.record.recorder", "Recorder", "close"),
    ("compaction (rerun rrd optimize, a child process)", "", "twin.app.run", "", "compact"),
)  # fmt: skip

_CHILD = (
    CHILD_HEAD
    + TIMER
    + r"""
acc, calls = collections.defaultdict(float), collections.Counter()
for label, _, mod, cls, name in a["stages"]:
    m = importlib.import_module(mod)
    wrap_timer(getattr(m, cls) if cls else m, name, label, acc, calls)
sc = sea_trial(a["mission_s"], ("ins", "pol", "lig"))
with tempfile.TemporaryDirectory() as d:
    t0 = time.perf_counter()
    m = run_scenario(sc, d, camera=False, record=True)
    wall = time.perf_counter() - t0
    rrd_mb = os.path.getsize(os.path.join(d, "recording.rrd")) / 1e6
print(json.dumps({"wall_s": wall, "sim_s": m["sim_time_s"], "rrd_mb": rrd_mb,
                  "frames": m["sensor_readings"].get("polarimeter", 0),
                  "stages_s": dict(acc), "calls": dict(calls)}))
"""
)


def _child(arg: dict[str, Any], env: dict[str, str]) -> dict[str, Any]:
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(arg)],
        cwd=ROOT, env=env, capture_output=True, text=True,
    )  # fmt: skip
    if out.returncode != 0:
        sys.exit(f"the timed run failed:\n{out.stderr[-4000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission-s", type=float, default=600.0)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    stages = [list(s) for s in STAGES]
    _child({"stages": [], "mission_s": 2.0}, env)  # numba's cache filled, nothing wrapped
    runs = []
    for i in range(max(1, args.repeats)):
        runs.append(_child({"stages": stages, "mission_s": args.mission_s}, env))
        print(f"run {i}: {runs[-1]['wall_s']:.1f} s", flush=True)
    sys.path.insert(0, str(ROOT))
    from twin.record import provenance as pv

    meta = {
        "cpu_count": os.cpu_count(),
        "load_average_1_5_15": [round(x, 2) for x in os.getloadavg()],
        "date": time.strftime("%Y-%m-%d"),
        "args": vars(args),
        "provenance": pv.provenance(),
    }
    md = _report(runs, meta)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "recording_profile.md").write_text("\n".join(md) + "\n")
    (RESULTS / "recording_profile.json").write_text(
        json.dumps({"meta": meta, "runs": runs}, indent=2) + "\n"
    )
    print("\n".join(md))
    return 0


def _report(runs: list[dict[str, Any]], meta: dict[str, Any]) -> list[str]:
    from twin.record import provenance as pv

    def med(f: Any) -> float:
        return float(statistics.median(f(r) for r in runs))

    sim_s = runs[0]["sim_s"]
    wall = med(lambda r: r["wall_s"])
    a = meta["args"]
    md = [
        "# Where a recorded sea trial's recording time goes (issue #31)",
        "",
        f"`python benchmarks/recording_profile.py --mission-s {a['mission_s']:g} --repeats "
        f"{a['repeats']}`: sea_trial_10m's square, {sim_s:.0f} s simulated, INS + POL/INS + "
        f"LIG/INS, the 612×512 polarimeter at 1 Hz ({runs[0]['frames']} frames, each logged "
        f"as three pictures), the recording on ({runs[0]['rrd_mb']:.1f} MB), no chase camera; "
        "one core, each part timed by a wrapper round its entry point (~1 µs a call), the median "
        f"of {len(runs)} fresh interpreters. {meta['date']}, {meta['cpu_count']} CPUs, load "
        f"average {meta['load_average_1_5_15']}.",
        f"- {'; '.join(pv.describe(meta['provenance']))}",
        "",
        f"The whole run (start-up in it): {wall:.2f} s, {sim_s / wall:.1f}× real time.",
        "",
        "| part | wall s | per call | calls | ms per simulated s | of the run |",
        "|---|---|---|---|---|---|",
    ]
    children: dict[str, list[str]] = {}
    for label, parent, *_ in STAGES:
        if label not in children.setdefault(parent, []):
            children[parent].append(label)

    def emit(label: str, depth: int) -> None:
        s = med(lambda r: r["stages_s"].get(label, 0.0))
        n = int(med(lambda r: r["calls"].get(label, 0)))
        us = 1e6 * s / max(n, 1)
        per = f"{us / 1e3:.2f} ms" if us >= 1000 else f"{us:.1f} µs"
        md.append(
            f"| {'&nbsp;&nbsp;' * 2 * depth}{label} | {s:.2f} | {per} | {n} | "
            f"{1e3 * s / sim_s:.2f} | {100 * s / wall:.0f} % |"
        )
        for child in children.get(label, []):
            emit(child, depth + 1)

    for top in children[""]:
        emit(top, 0)
    tops = [lab for lab in children[""] if lab != _WRITES]  # the writes are inside the others
    total = med(lambda r: sum(r["stages_s"].get(lab, 0.0) for lab in tops))
    pictures = med(
        lambda r: r["stages_s"].get(_PICTURES, 0.0) / max(r["calls"].get(_PICTURES, 0), 1)
    )
    md += [
        "",
        f"All the recording's timed parts (the writes counted once, inside the rows that set "
        f"them off): {total:.2f} s, **{1e3 * total / sim_s:.2f} ms per simulated s**; the "
        f"pictures {1e3 * pictures:.2f} ms a frame. Not in these rows: what Rerun's "
        "threads do between writes.",
    ]
    return md


if __name__ == "__main__":
    sys.exit(main())
