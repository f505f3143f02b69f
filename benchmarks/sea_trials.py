"""The LIG paper's sea trials in the twin: POL/INS vs LIG/INS heading error at 10 m and 15 m.

Runs scenarios/sea_trial_10m.toml and sea_trial_15m.toml (Weihai, 2021-09-03, the paper's IMU,
PHX050S-P at 700 µs binned to 612×512, compass at 1 Hz, five paired filter variants: INS,
POL/INS and LIG/INS, each with the paper's method and with the twin's) in three
filter set-ups: the paper's (full solar vector, every fix fused: no gate), the twin's default
(full vector, NIS gate p = 0.999) and the robust one (azimuth only, gated). Writes
benchmarks/results/sea_trials.{md,json}.

    python benchmarks/sea_trials.py [--seeds 0 1 2] [--workers 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from scipy import stats

import scenarios
from twin.app.run import run_scenario

RESULTS = Path(__file__).resolve().parent / "results"
PAPER = {10: {"pol": 3.6, "lig": 1.6}, 15: {"pol": 16.1, "lig": 2.2}}


SETUPS = {
    "paper: vector, no gate": {"gate_probability": 1.0, "sun_measurement": "vector"},
    "default: vector, gated": {"gate_probability": 0.999, "sun_measurement": "vector"},
    "robust: azimuth, gated": {"gate_probability": 0.999, "sun_measurement": "azimuth"},
}


def _trial(args: tuple[int, str, int]) -> dict:
    return trial(*args)


def trial(depth: int, setup: str, seed: int) -> dict:
    sc = scenarios.load(f"sea_trial_{depth}m")
    sc = dataclasses.replace(
        sc,
        navigation=dataclasses.replace(sc.navigation, **SETUPS[setup]),
        recording=dataclasses.replace(sc.recording, camera=False),
    )
    with tempfile.TemporaryDirectory() as d:
        m = run_scenario(sc, d, seed=seed, camera=False)
    out = {"depth_m": depth, "setup": setup, "seed": seed, "rtf": m["real_time_factor"]}
    for name, v in m["navigation"]["variants"].items():
        comp = v.get("compass") or {}
        out[name] = {
            "heading_rmse_deg": v["heading_rmse_deg"],
            "heading_mae_deg": v["heading_mae_deg"],
            "heading_max_deg": v["heading_max_deg"],
            "roll_pitch_rmse_deg": [v["roll_rmse_deg"], v["pitch_rmse_deg"]],
            "nees": v["nees_attitude_mean"],
            "sun_applied": comp.get("sun_updates_applied"),
            "sun_rejected": comp.get("sun_updates_rejected"),
        }
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--workers", type=int, default=1, help="runs in parallel (processes)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    jobs = [(d, u, s) for u in SETUPS for d in (10, 15) for s in args.seeds]
    with ProcessPoolExecutor(max(args.workers, 1)) as ex:
        rows = list(ex.map(_trial, jobs))
    lines = [
        "# LIG paper sea trials in the twin (benchmarks/sea_trials.py)",
        "",
        f"Seeds {args.seeds}; heading RMSE over the whole run, degrees, mean over the seeds ± its "
        "95 % interval (MAE in brackets); "
        "roll/pitch RMSE; sun updates applied/rejected by the NIS gate. Run time "
        f"{time.perf_counter() - t0:.0f} s, {time.strftime('%Y-%m-%d')}.",
        "",
        "| filter set-up | depth | INS only | POL/INS, the LIG paper's POL | POL/INS, the twin's "
        "POL | LIG/INS, the paper's LIG | LIG/INS, the twin's LIG | paper POL/INS | "
        "paper LIG/INS |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for u in SETUPS:
        for d in (10, 15):
            sel = [r for r in rows if r["depth_m"] == d and r["setup"] == u]

            def cell(name: str, sel=sel) -> str:
                vals = [r[name]["heading_rmse_deg"] for r in sel]
                rm = statistics.mean(vals)
                # Student-t 95 % interval of the mean over the seeds.
                ci = (
                    float(stats.t.ppf(0.975, len(vals) - 1))
                    * statistics.stdev(vals)
                    / len(vals) ** 0.5
                    if len(vals) > 1
                    else None
                )
                mae = statistics.mean(r[name]["heading_mae_deg"] for r in sel)
                rp = [
                    statistics.mean(r[name]["roll_pitch_rmse_deg"][i] for r in sel) for i in (0, 1)
                ]
                s = f"{rm:.2f}" + (f" ± {ci:.2f}" if ci is not None else "")
                s += f" ({mae:.2f}); r/p {rp[0]:.2f}/{rp[1]:.2f}"
                if sel[0][name]["sun_applied"] is not None:
                    ap_ = sum(r[name]["sun_applied"] for r in sel)
                    rj = sum(r[name]["sun_rejected"] for r in sel)
                    s += f"; sun {ap_}/{rj}"
                return s

            lines.append(
                f"| {u} | {d} m | {cell('ins')} | {cell('pol_paper')} | {cell('pol')} | "
                f"{cell('lig_paper')} | "
                f"{cell('lig')} | "
                f"{PAPER[d]['pol']} | {PAPER[d]['lig']} |"
            )
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "sea_trials.md").write_text("\n".join(lines) + "\n")
    (RESULTS / "sea_trials.json").write_text(json.dumps(rows, indent=2) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
