"""Campaign throughput: runs per minute with 1 and 2 local workers and on a local Ray instance.

A campaign of N runs of the default trial cut to D seconds (no recording), run three ways into
fresh folders. Reports runs per minute, the speed-up of 2 workers over 1, and the scheduling
overhead: the campaign's wall time beyond the runs' own wall time divided among the workers.

    python benchmarks/campaign_throughput.py [--runs 8] [--duration 30]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
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
        t0 = time.perf_counter()
        counts = run_campaign(spec, d, on_message=lambda m: None, **kw)
        wall = time.perf_counter() - t0
        rows = load_campaign_results(d)
    assert counts.get("ok", 0) == len(spec.runs), counts
    workers = kw.get("workers", 1)
    busy = float(rows["wall_time_s"].sum())
    return {
        "wall_s": wall,
        "runs_per_min": len(spec.runs) / wall * 60,
        "mean_run_s": busy / len(spec.runs),
        "overhead_fraction": max(0.0, wall - busy / workers) / wall,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--duration", type=float, default=30.0)
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
        "Ray (local, 2 CPUs)": measure(spec, workers=2, use_ray=True),
    }
    base = rows["local, 1 worker"]["runs_per_min"]
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
        "| backend | wall s | runs/min | speed-up vs 1 worker | mean run s | overhead |",
        "|---|---|---|---|---|---|",
    ]
    for name, r in rows.items():
        lines.append(
            f"| {name} | {r['wall_s']:.1f} | {r['runs_per_min']:.1f} | "
            f"{r['runs_per_min'] / base:.2f}x | {r['mean_run_s']:.2f} | "
            f"{100 * r['overhead_fraction']:.0f} % |"
        )
    (RESULTS / "campaign_throughput.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
