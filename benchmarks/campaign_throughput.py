"""Campaign throughput: runs per minute with 1 and 2 workers, local pool and local Ray instance.

A campaign of N runs of the default trial cut to D seconds (no recording), run four ways into
fresh folders. Reports runs per minute, the speed-up of 2 workers over 1 for each backend, the
throughput after start-up (from the first wave of finished runs to the last: what a long
campaign sees), and the scheduling overhead: the campaign's wall time beyond the runs' own wall
time divided among the workers (process start, imports, Ray's start, scheduling, writing rows).

Issue #10's targets: 2 workers >= 1.8x the throughput of 1 for both backends; overhead < 5 % of
a 60 s trial's run time.

    python benchmarks/campaign_throughput.py [--runs 16] [--duration 60]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import tempfile
import time
from pathlib import Path

from twin.campaign.results import load_campaign_results
from twin.campaign.runner import run_campaign
from twin.campaign.spec import parse_campaign

RESULTS = Path(__file__).resolve().parent / "results"


def measure(spec, **kw) -> dict[str, float]:
    with tempfile.TemporaryDirectory() as d:
        t0 = time.time()
        counts = run_campaign(spec, d, on_message=lambda m: None, **kw)
        wall = time.time() - t0
        rows = load_campaign_results(d)
        # Each run's row file is written when the run finishes: its mtime is the finish time.
        done = sorted(p.stat().st_mtime - t0 for p in (Path(d) / "runs").glob("*.parquet"))
    assert counts.get("ok", 0) == len(spec.runs), counts
    workers = kw.get("workers", 1)
    busy = float(rows["wall_time_s"].sum())
    n = len(done)
    steady = (n - workers) / (done[-1] - done[workers - 1]) * 60 if n > workers else float("nan")
    return {
        "wall_s": wall,
        "runs_per_min": n / wall * 60,
        "steady_runs_per_min": steady,
        "first_finish_s": done[0],
        "mean_run_s": busy / n,
        "overhead_fraction": max(0.0, wall - busy / workers) / wall,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=16)
    ap.add_argument("--duration", type=float, default=60.0)
    args = ap.parse_args()
    spec = parse_campaign(
        {
            "name": "throughput",
            "base": "default",
            "seeds": args.runs,
            "metrics": ["navigation.variants.*.heading_rmse_deg"],
            "set": {"duration_s": args.duration},
        }
    )
    rows = {
        "local, 1 worker": measure(spec, workers=1),
        "local, 2 workers": measure(spec, workers=2),
        "Ray (local, 1 CPU)": measure(spec, workers=1, use_ray=True),
        "Ray (local, 2 CPUs)": measure(spec, workers=2, use_ray=True),
    }
    meta = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.machine()}, Python {platform.python_version()}, 2 cores",
        "runs": args.runs,
        "duration_s": args.duration,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "campaign_throughput.json").write_text(json.dumps({**meta, **rows}, indent=2))
    lines = [
        "# Campaign throughput (benchmarks/campaign_throughput.py)",
        "",
        f"{meta['date']}, {meta['machine']}: {args.runs} runs of the default trial cut to "
        f"{args.duration:g} s, no recording. Overhead: campaign wall time beyond the runs' own "
        "time per worker (process start, imports, scheduling, writing rows), as a fraction.",
        "",
        "| backend | wall s | runs/min | speed-up vs 1 worker (same backend) | runs/min after "
        "start-up | speed-up after start-up | first run done at s | mean run s | overhead |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in rows.items():
        one = rows["Ray (local, 1 CPU)" if name.startswith("Ray") else "local, 1 worker"]
        lines.append(
            f"| {name} | {r['wall_s']:.1f} | {r['runs_per_min']:.1f} | "
            f"{r['runs_per_min'] / one['runs_per_min']:.2f}x | {r['steady_runs_per_min']:.1f} | "
            f"{r['steady_runs_per_min'] / one['steady_runs_per_min']:.2f}x | "
            f"{r['first_finish_s']:.1f} | {r['mean_run_s']:.2f} | "
            f"{100 * r['overhead_fraction']:.1f} % |"
        )
    lines += [
        "",
        "Targets (issue #10): 2 workers >= 1.8x of 1 for both backends; overhead < 5 % of a "
        "60 s trial. Load average at the end: " + ", ".join(f"{x:.2f}" for x in os.getloadavg()),
    ]
    (RESULTS / "campaign_throughput.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
