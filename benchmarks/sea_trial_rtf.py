"""Real-time factor of a sea trial with the polarimeter, the compass and the filters in the loop.

Issue #10's targets, on one core: a 10-minute sea trial with the sea trials' camera (PHX050S-P
binned 4×4, 612×512, frames at 1 Hz), three filter variants (INS, POL/INS, LIG/INS) and no
recording ≥ 30× real time; with the Rerun recording ≥ 20×. (Issue #5's was ≥ 10× with two
variants and the recording.) The no-recording row also says where the wall time goes: each stage
is timed by a wrapper around its entry point (≈ 1 µs a call, < 1 % of the row).

    python benchmarks/sea_trial_rtf.py
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import json
import os
import platform
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import scenarios
import sensors.imu
import sensors.polarimeter.render
import twin.onboard.eskf
import twin.scoring.observer
import twin.world.plant
from twin.app.run import run_scenario
from twin.onboard.compass.base import CompassMethod

RESULTS = Path(__file__).resolve().parent / "results"
MISSION_S = 600.0

# (label, class, method): the stages of one physics step and of one camera frame.
STAGES: tuple[tuple[str, Any, str], ...] = (
    ("polarimeter frame (render + sensor)", sensors.polarimeter.render.Polarimeter, "sample"),
    ("compass methods (POL, LIG)", CompassMethod, "solve"),
    ("physics (MuJoCo + hydrodynamics)", twin.world.plant.Plant, "step"),
    ("INS + covariance (3 filters, 100 Hz)", twin.onboard.eskf.Eskf, "predict_reading"),
    ("depth + gravity updates (3 filters)", twin.onboard.eskf.Eskf, "update_depth"),
    ("depth + gravity updates (3 filters)", twin.onboard.eskf.Eskf, "update_gravity"),
    ("IMU model", sensors.imu.Imu, "sample"),
    ("scoring against truth", twin.scoring.observer.RunScorer, "on_step"),
)


@contextmanager
def stage_timers() -> Iterator[dict[str, float]]:
    """Accumulate the wall time spent in each of :data:`STAGES` while the block runs."""
    acc: dict[str, float] = collections.defaultdict(float)
    saved = []
    for label, cls, name in STAGES:
        fn = getattr(cls, name)
        saved.append((cls, name, fn))

        def timed(*a: Any, _fn: Callable[..., Any] = fn, _label: str = label, **k: Any) -> Any:
            t0 = time.perf_counter()
            try:
                return _fn(*a, **k)
            finally:
                acc[_label] += time.perf_counter() - t0

        setattr(cls, name, functools.wraps(fn)(timed))
    try:
        yield acc
    finally:
        for cls, name, fn in saved:
            setattr(cls, name, fn)


def run(variants: tuple[str, ...], record: bool, breakdown: bool = False) -> dict[str, Any]:
    sc = scenarios.load("sea_trial_10m")
    # The square twice (~800 s of legs), cut at 10 minutes: the run ends by duration, not by
    # the mission, so every row is a full 600 s.
    mission = dataclasses.replace(sc.mission, legs=sc.mission.legs * 2)  # type: ignore[attr-defined]
    sc = dataclasses.replace(
        sc,
        duration_s=MISSION_S,
        mission=mission,
        navigation=dataclasses.replace(sc.navigation, variants=variants),
    )
    with tempfile.TemporaryDirectory() as d:
        ctx = stage_timers() if breakdown else _no_timers()
        with ctx as acc:
            t0 = time.perf_counter()
            m = run_scenario(sc, d, camera=False, record=record)
            wall = time.perf_counter() - t0
        rrd = Path(d) / "recording.rrd"
        size = rrd.stat().st_size if rrd.exists() else 0
    row: dict[str, Any] = {
        "variants": list(variants),
        "recording": record,
        "sim_s": m["sim_time_s"],
        "wall_s": round(wall, 2),
        "rtf": round(m["sim_time_s"] / wall, 1),
        "rrd_mb": round(size / 1e6, 1),
        "frames": m["sensor_readings"].get("polarimeter", 0),
    }
    if breakdown:
        row["stages_s"] = {k: round(v, 2) for k, v in acc.items()}
    return row


@contextmanager
def _no_timers() -> Iterator[dict[str, float]]:
    yield {}


def main() -> int:
    try:  # one core, as the target says
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    three = ("ins", "pol", "lig")
    rows = [run(three, record=False, breakdown=True), run(three, record=True)]
    rows.append(run(("ins", "lig"), record=True))
    env = f"{platform.processor() or platform.machine()}, Python {sys.version.split()[0]}, 1 core"
    md = [
        "# Sea trial real-time factor (issues #5 and #10)",
        "",
        f"`python benchmarks/sea_trial_rtf.py`. sea_trial_10m's square flown twice, cut at "
        f"{MISSION_S:.0f} s: physics 100 Hz, IMU 100 Hz, depth 10 Hz, polarimeter 612×512 at 1 Hz "
        "(render + compass on every frame), no chase camera. Machine: "
        f"{env}, {time.strftime('%Y-%m-%d')}, load average {os.getloadavg()[0]:.2f}.",
        "",
        "| filter variants | recording | sim s | wall s | real-time factor | frames | .rrd |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        md.append(
            f"| {', '.join(r['variants'])} | {'on' if r['recording'] else 'off'} | "
            f"{r['sim_s']:.0f} | {r['wall_s']:.1f} | **{r['rtf']:.1f}x** | {r['frames']} | "
            f"{r['rrd_mb']:.1f} MB |"
        )
    md += [
        "",
        "Targets (issue #10): three variants, no recording >= 30x; with the recording >= 20x.",
        "",
        "## Where the wall time goes (three variants, no recording)",
        "",
        "| stage | wall s | share |",
        "|---|---|---|",
    ]
    first = rows[0]
    for label, secs in sorted(first["stages_s"].items(), key=lambda kv: -kv[1]):
        md.append(f"| {label} | {secs:.1f} | {100 * secs / first['wall_s']:.0f} % |")
    rest = first["wall_s"] - sum(first["stages_s"].values())
    md.append(
        f"| everything else (loop, sensor scheduling, guidance, autopilot) | {rest:.1f} | "
        f"{100 * rest / first['wall_s']:.0f} % |"
    )
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "sea_trial_rtf.md").write_text("\n".join(md) + "\n")
    (RESULTS / "sea_trial_rtf.json").write_text(
        json.dumps({"rows": rows, "machine": env}, indent=2) + "\n"
    )
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
