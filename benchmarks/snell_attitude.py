"""Snell-window attitude (xin2024) and ROI-A heading (fang2024) accuracy across tilt.

The paper's experiment (xin2024 §4): a turntable tilts the camera over [−50°, 50°] in 10° steps and
at the step midpoints (±15°, ±25°, …), roll and pitch MAE 0.7544° / 0.6213°, yaw MAE 0.5303°.
Here: the noisy LUCID PHX050S-P camera (binned 4×4 by default, ``--full`` for 2448×2048) under
2 m of Jerlov II water, a fixed seed; each tilt is applied about the roll axis and, separately,
about the pitch axis, at ``--headings`` headings; the sun at 35° elevation (the paper's December
morning in Dalian: ~20–28°; see ``--sun-elevation``). ROI-A gets the true roll/pitch as its INS
hint (its paper's N100MINI) and is scored on heading only.

Writes benchmarks/results/snell_attitude.md and .json, one section per camera (a run replaces
its camera's). Run: ``python benchmarks/snell_attitude.py [--full] [--headings 3] [--tilts=…]``.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import pathlib
import time

import numpy as np

import sensors
from sensors.polarimeter.render import OpticsConfig
from twin.core.frames import euler_to_dcm
from twin.onboard.compass.base import CompassContext
from twin.onboard.compass.roia import RoiaMethod
from twin.onboard.compass.snell import SnellWindowMethod

PAPER_MAE_DEG = {"roll": 0.7544, "pitch": 0.6213, "yaw": 0.5303}
TILTS_DEG = sorted({*range(-50, 51, 10), *(s * t for t in (15, 25, 35, 45) for s in (-1, 1))})
RESULTS = pathlib.Path(__file__).resolve().parent / "results"


def sun_vec(el_deg: float, az_deg: float) -> np.ndarray:
    el, az = math.radians(el_deg), math.radians(az_deg)
    return np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])


def wrap180(x: float) -> float:
    return (x + 180.0) % 360.0 - 180.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="full resolution (2448×2048)")
    ap.add_argument("--headings", type=int, default=3, help="headings per tilt")
    ap.add_argument("--sun-elevation", type=float, default=35.0)
    ap.add_argument("--seed", type=int, default=20231228)
    ap.add_argument("--depth", type=float, default=2.0)
    ap.add_argument("--tilts", type=str, default=None, help="comma-separated subset of tilts")
    ap.add_argument("--jerlov", default="II", help="Jerlov water type")
    ap.add_argument(
        "--wind", type=float, default=0.0, help="wind at 12.5 m, m/s (frames 1 s apart)"
    )
    ap.add_argument("--stem", default="snell_attitude", help="results file name")
    args = ap.parse_args()
    tilts = [int(t) for t in args.tilts.split(",")] if args.tilts else TILTS_DEG

    preset = "phx050s_p" if args.full else "phx050s_p_bin4"
    cam = sensors.create("polarimeter", preset)
    cam.configure(OpticsConfig(jerlov_type=args.jerlov, wind_speed_mps=args.wind))
    cal = cam.calibration()
    rng = np.random.default_rng(args.seed)
    sun = sun_vec(args.sun_elevation, 150.0)
    snell, roia = SnellWindowMethod(), RoiaMethod()
    headings = [float(h) for h in np.linspace(0, 360, args.headings, endpoint=False) + 17.0]

    rows = []
    t_render = t_snell = t_roia = 0.0
    for axis in ("roll", "pitch"):
        for tilt in tilts:
            for h in headings:
                r = tilt if axis == "roll" else 0.0
                p = tilt if axis == "pitch" else 0.0
                c = euler_to_dcm(math.radians(r), math.radians(p), math.radians(-h))
                t0 = time.perf_counter()
                # Frames 1 s apart: on a wavy sea each sees the waves of its own moment.
                raw, _ = cam.render_offline(c, args.depth, sun, rng, t=float(len(rows)))
                t1 = time.perf_counter()
                ctx0 = CompassContext(
                    utc=dt.datetime(2023, 12, 28, 2),
                    latitude_deg=38.88,
                    longitude_deg=121.51,
                    depth_m=args.depth,
                    sun_enu=sun,
                )
                fs = snell.solve(raw, cal, ctx0)
                t2 = time.perf_counter()
                ctx1 = CompassContext(
                    utc=ctx0.utc,
                    latitude_deg=38.88,
                    longitude_deg=121.51,
                    roll_rad=math.radians(r),
                    pitch_rad=math.radians(p),
                    depth_m=args.depth,
                    sun_enu=sun,
                )
                fr = roia.solve(raw, cal, ctx1)
                t3 = time.perf_counter()
                t_render += t1 - t0
                t_snell += t2 - t1
                t_roia += t3 - t2
                rows.append(
                    {
                        "axis": axis,
                        "tilt_deg": tilt,
                        "heading_deg": h,
                        "snell_ok": fs.ok,
                        "snell_reason": fs.reason,
                        "roll_err": math.degrees(fs.roll_rad) - r if fs.ok else None,
                        "pitch_err": math.degrees(fs.pitch_rad) - p if fs.ok else None,
                        "yaw_err": wrap180(fs.heading_deg - h) if fs.ok else None,
                        "roia_ok": fr.ok,
                        "roia_reason": fr.reason,
                        "roia_err": wrap180(fr.heading_deg - h) if fr.ok else None,
                    }
                )
    n = len(rows)

    def mae(key: str, sel=lambda r: True) -> float:
        v = [abs(r[key]) for r in rows if r[key] is not None and sel(r)]
        return float(np.mean(v)) if v else float("nan")

    def cnt(key: str, sel=lambda r: True) -> str:
        tot = [r for r in rows if sel(r)]
        ok = [r for r in tot if r[key]]
        return f"{len(ok)}/{len(tot)}"

    head = {
        "roll": mae("roll_err"),
        "pitch": mae("pitch_err"),
        "yaw": mae("yaw_err"),
        "roia_heading": mae("roia_err"),
        "snell_fixes": cnt("snell_ok"),
        "roia_fixes": cnt("roia_ok"),
    }
    per_tilt = {}
    for t in tilts:
        sel = lambda r, t=t: r["tilt_deg"] == t  # noqa: E731
        per_tilt[t] = {
            "roll": mae("roll_err", sel),
            "pitch": mae("pitch_err", sel),
            "yaw": mae("yaw_err", sel),
            "roia": mae("roia_err", sel),
            "snell_fixes": cnt("snell_ok", sel),
            "roia_fixes": cnt("roia_ok", sel),
        }
    reasons = sorted(
        {r["roia_reason"] for r in rows if not r["roia_ok"]}
        | {r["snell_reason"] for r in rows if not r["snell_ok"]}
    )
    run = {
        "config": vars(args),
        "preset": preset,
        "size": [cal.width_px, cal.height_px],
        "tilts_deg": tilts,
        "headings_deg": headings,
        "frames": n,
        "headline": head,
        "per_tilt": per_tilt,
        "ms_per_frame": {
            "render": 1000 * t_render / n,
            "snell": 1000 * t_snell / n,
            "roia": 1000 * t_roia / n,
        },
        "no_fix_reasons": reasons,
        "rows": rows,
    }
    # One file for both resolutions: this run replaces the earlier one of the same preset.
    RESULTS.mkdir(exist_ok=True)
    jpath = RESULTS / f"{args.stem}.json"
    runs = {}
    if jpath.exists():
        try:
            runs = json.loads(jpath.read_text()).get("runs", {})
        except (ValueError, AttributeError):
            runs = {}
    runs[preset] = run
    order = sorted(runs, key=lambda k: runs[k]["size"][0])  # binned first
    jpath.write_text(json.dumps({"paper_mae_deg": PAPER_MAE_DEG, "runs": runs}, indent=1))
    text = render_md([runs[k] for k in order])
    (RESULTS / f"{args.stem}.md").write_text(text)
    print(text)


def render_md(runs: list[dict]) -> str:
    """The Markdown report of one or more runs (one per camera preset)."""
    lines = [
        "# Snell-window attitude (xin2024) and ROI-A heading (fang2024) across tilt",
        "",
        "Each tilt about the roll axis and, separately, about the pitch axis (water, wind and "
        "depth per section); "
        "ROI-A gets the true roll/pitch as its INS hint and is scored on heading only. Generated "
        "by `python benchmarks/snell_attitude.py` (binned camera) and "
        "`python benchmarks/snell_attitude.py --full --tilts=-50,-25,0,25,50` (full resolution); "
        "each run replaces the section of its camera.",
        "",
        "## Headline (MAE, degrees) and time per frame (one core)",
        "",
        "| | camera | frames | roll | pitch | yaw | fixes | ms/frame |",
        "|---|---|---|---|---|---|---|---|",
        f"| xin2024 Table 1 | | | {PAPER_MAE_DEG['roll']} | {PAPER_MAE_DEG['pitch']} | "
        f"{PAPER_MAE_DEG['yaw']} | | |",
    ]
    for run in runs:
        h, ms = run["headline"], run["ms_per_frame"]
        cam = f"`{run['preset']}` {run['size'][0]}×{run['size'][1]}"
        lines += [
            f"| snell | {cam} | {run['frames']} | {h['roll']:.3f} | {h['pitch']:.3f} | "
            f"{h['yaw']:.3f} | {h['snell_fixes']} | {ms['snell']:.0f} |",
            f"| roia heading (INS hint) | {cam} | {run['frames']} | | | {h['roia_heading']:.3f} | "
            f"{h['roia_fixes']} | {ms['roia']:.0f} |",
        ]
    for run in runs:
        c = run["config"]
        lines += [
            "",
            f"## `{run['preset']}` ({run['size'][0]}×{run['size'][1]}): per tilt "
            "(MAE over headings and both axes, degrees)",
            "",
            f"Jerlov {c.get('jerlov', 'II')} water, wind {c.get('wind', 0.0):g} m/s (frames 1 s "
            f"apart), depth {c['depth']} m, sun elevation {c['sun_elevation']}° azimuth 150°, seed "
            f"{c['seed']}, headings {', '.join(f'{x:.0f}' for x in run['headings_deg'])}°; "
            f"{run['frames']} frames. Time per frame: render {run['ms_per_frame']['render']:.0f} "
            f"ms, snell {run['ms_per_frame']['snell']:.0f} ms, roia "
            f"{run['ms_per_frame']['roia']:.0f} ms.",
            "",
            "| tilt | snell roll | snell pitch | snell yaw | snell fixes | roia heading | "
            "roia fixes |",
            "|---|---|---|---|---|---|---|",
        ]
        for t, v in run["per_tilt"].items():
            lines.append(
                f"| {int(t):+d} | {v['roll']:.3f} | {v['pitch']:.3f} | {v['yaw']:.3f} | "
                f"{v['snell_fixes']} | {v['roia']:.3f} | {v['roia_fixes']} |"
            )
        reasons = run["no_fix_reasons"]
        lines += ["", "No-fix reasons: " + ("; ".join(reasons) if reasons else "none") + "."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
