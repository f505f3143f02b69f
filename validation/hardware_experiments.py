"""The seeds' hardware experiments reproduced as campaigns, beside the papers' numbers.

Each experiment is a campaign in scenarios/campaigns/ (≥ 20 seeds a cell) run through the
campaign machinery (local worker pool); this script runs what is not on disk yet, reads the
Parquet rows back and writes validation/results/hardware_experiments.md (and a figure) with each
figure as mean ± 95 % bootstrap CI beside the paper's. Nothing in the tables is typed in but the
papers' own numbers.

Run: ``python validation/hardware_experiments.py [--workers 2] [--runs DIR] [--only snell roia]``
(about 40 min on 2 cores for all four; finished runs are kept and reused).
"""

from __future__ import annotations

import argparse
import datetime as dt
import itertools
import math
import os
import pathlib
import platform
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from twin.campaign.lig_tank import PAPER_MAE_DEG as LIG_TANK_PAPER
from twin.campaign.report import bootstrap_ci
from twin.campaign.results import load_campaign_results
from twin.campaign.roia_static import CASES as ROIA_CASES
from twin.campaign.runner import run_campaign
from twin.campaign.snell_turntable import CASES, PAPER_DISTORTION_GAIN_DEG, PAPER_MAE_DEG
from twin.campaign.spec import load_campaign
from twin.record import provenance as pv

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULTS = ROOT / "validation" / "results"


def _ci_text(x: np.ndarray) -> tuple[str, float, float, float]:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return "—", math.nan, math.nan, math.nan
    lo, hi = bootstrap_ci(x, np.mean)
    m = float(np.mean(x))
    return f"{m:.2f} [{lo:.2f}, {hi:.2f}]", m, lo, hi


def snell(runs: pathlib.Path, workers: int) -> tuple[list[str], plt.Figure]:
    spec, df = _run("snell_turntable", runs, workers)
    col = "metric.methods.snell.{}_mae_deg"
    pcol = "metric.methods.snell_paper.{}_mae_deg"
    lines = [
        "## Snell-window attitude on a turntable (xin2024 §4, Table 1)",
        "",
        f"Campaign `{_rel(spec.source)}`: {len(spec.seeds)} sessions (seeds) per cell, each",
        "the mean absolute error over 16 tilted frames (±15°…±45° about each axis); cells are",
        "the full",
        "error budget under the paper's conditions and that budget with one part taken away",
        "(twin/campaign/snell_turntable.py states every assumption). Mean over sessions with its",
        "95 % bootstrap CI; the paper's mean of its 10 sessions beside it. Each cell's frames go",
        "through the method as the paper writes it (`snell_paper`) and the twin's refinement",
        "(`snell`; docs/compass_methods.md lists what differs).",
        "",
        "| cell | method | sessions | roll MAE (°) | pitch MAE (°) | yaw MAE (°) |"
        " yaw vs truth (°) | frames without a fix |",
        "|---|---|---|---|---|---|---|---|",
    ]
    fig, ax = plt.subplots(figsize=(8, 4))
    width = 0.2
    for i, case in enumerate(CASES):
        g = df[df["param.case"] == case]
        cells = []
        for j, k in enumerate(("roll", "pitch", "yaw")):
            text, m, lo, hi = _ci_text(g[col.format(k)].to_numpy(float))
            cells.append(text)
            if math.isfinite(m):
                ax.bar(j + (i - 1.5) * width, m, width, yerr=[[m - lo], [hi - m]],
                       label=case if j == 0 else None, color=f"C{i}", capsize=3)  # fmt: skip
        truth, *_ = _ci_text(g[col.format("yaw_truth")].to_numpy(float))
        nofix = int(g["metric.methods.snell.no_fix"].sum())
        if pcol.format("roll") in g:
            pcells = [_ci_text(g[pcol.format(k)].to_numpy(float))[0] for k in AXES]
            ptruth, *_ = _ci_text(g[pcol.format("yaw_truth")].to_numpy(float))
            pnofix = int(g["metric.methods.snell_paper.no_fix"].sum())
            lines.append(
                f"| {case} | the paper's | {len(g)} | {' | '.join(pcells)} | {ptruth} | {pnofix} |"
            )
        lines.append(
            f"| {case} | the twin's | {len(g)} | {' | '.join(cells)} | {truth} | {nofix} |"
        )
    lines.append(
        f"| **paper** | | 10 | {PAPER_MAE_DEG['roll']:.2f} | {PAPER_MAE_DEG['pitch']:.2f} | "
        f"{PAPER_MAE_DEG['yaw']:.2f} | — | — |"
    )
    for j, k in enumerate(("roll", "pitch", "yaw")):
        ax.hlines(PAPER_MAE_DEG[k], j - 0.45, j + 0.45, colors="k", linestyles="--",
                  label="paper" if j == 0 else None)  # fmt: skip
    ax.set_xticks(range(3), ["roll", "pitch", "yaw"])
    ax.set_ylabel("MAE (deg), mean over sessions, 95 % CI")
    ax.set_title("xin2024 turntable: twin (bars) vs paper (dashed)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    budget = df[df["param.case"] == "budget"]
    ratios = {
        k: float(np.nanmean(budget[col.format(k)].to_numpy(float))) / PAPER_MAE_DEG[k]
        for k in ("roll", "pitch", "yaw")
    }
    pratios = {
        k: float(np.nanmean(budget[pcol.format(k)].to_numpy(float))) / PAPER_MAE_DEG[k]
        for k in ("roll", "pitch", "yaw")
        if pcol.format(k) in budget
    }
    within = all(0.5 <= v <= 2 for v in ratios.values())
    verdict = (
        "within the factor of 2 the issue asks."
        if within
        else "not all within a factor of 2; the cells show which part of the budget does it."
    )
    lines += [
        "",
        "Twin ÷ paper with the full budget: "
        + ", ".join(f"{k} {v:.1f}×" for k, v in ratios.items())
        + f": {verdict}",
        "",
        "The paper's method ÷ paper with the full budget: "
        + (", ".join(f"{k} {v:.1f}×" for k, v in pratios.items()) or "not run")
        + ".",
        "",
        *_paired_methods(budget, "snell_paper", "snell", [f"{k}_mae_deg" for k in AXES]),
        "",
        "Why: the full budget carries the force 5–6 wind down to the tank as Cox–Munk slopes, "
        "which are the open sea's; a φ0.6 m tank has no fetch for its gravity waves, and the "
        "twin has no sourced slope model for one. The paper's figures lie between the flat tank "
        "(hardware_only) and the gentlest rough tank (budget_tank_wind_1): bracketed, not tuned.",
        "",
        *_snell_ablation(df, col),
    ]
    return lines, fig


def _ratio_text(r: float) -> str:
    """Twin ÷ paper as the tables print it, and whether it is within a factor of 2."""
    if not math.isfinite(r):
        return "—"
    return f"{r:.1f}×" + ("" if 0.5 <= r <= 2.0 else " (outside ×2)")


def _paired_methods(df: pd.DataFrame, paper: str, twin: str, quantities: list[str]) -> list[str]:
    """The paper's method minus the twin's refinement, per session (the same frames): CI lines."""
    out = []
    for q in quantities:
        a, b = f"metric.methods.{paper}.{q}", f"metric.methods.{twin}.{q}"
        if a not in df or b not in df:
            continue
        d = (df[a] - df[b]).dropna().to_numpy(float)
        if d.size < 2:
            continue
        lo, hi = bootstrap_ci(d, np.mean)
        verdict = (
            "the twin's refinement is better"
            if lo > 0
            else ("the paper's method is better" if hi < 0 else "not resolved")
        )
        out.append(
            f"- {q}: {paper} − {twin} per session {np.mean(d):+.2f}° [{lo:+.2f}, {hi:+.2f}]: "
            f"{verdict}."
        )
    return out


def _paired(df: pd.DataFrame, without: str, with_: str, column: str) -> np.ndarray:
    """Per seed, ``without`` minus ``with_`` (the same unit and session in both cells)."""
    a = df[df["param.case"] == without].set_index("seed")[column]
    b = df[df["param.case"] == with_].set_index("seed")[column]
    d = (a - b).dropna()
    return d.to_numpy(float)


def _snell_ablation(df: pd.DataFrame, col: str) -> list[str]:
    pairs = (
        ("distortion correction, tank under force 5–6", "no_distortion_correction", "budget"),
        (
            "distortion correction, flat tank",
            "hardware_only_no_distortion_correction",
            "hardware_only",
        ),
        ("lens compensation, tank under force 5–6", "no_lens_compensation", "budget"),
        ("lens compensation, flat tank", "hardware_only_no_lens_compensation", "hardware_only"),
    )
    lines = [
        "### The ablation: what each correction gains",
        "",
        "Per session, the MAE without the correction minus the MAE with it (the same unit, ",
        "session and waves in both cells: paired), mean with its 95 % bootstrap CI; positive = the",
        "correction helps. The paper's distortion correction gained 2.47° in roll and 1.84° in",
        "pitch in its tank under waves (§3.2) and 1.21° in yaw on its telecentric bench (§2.4).",
        "",
        "| correction | roll gain (°) | pitch gain (°) | yaw gain (°) |",
        "|---|---|---|---|",
    ]
    for label, without, with_ in pairs:
        cells = [_ci_text(_paired(df, without, with_, col.format(k)))[0] for k in AXES]
        lines.append(f"| {label} | {' | '.join(cells)} |")
    gain = " | ".join(f"{PAPER_DISTORTION_GAIN_DEG[k]:.2f}" for k in AXES)
    lines += [f"| **paper**: distortion correction | {gain} |", ""]
    helps = []
    for k in AXES:
        d = _paired(df, "no_distortion_correction", "budget", col.format(k))
        if d.size:
            lo, _hi = bootstrap_ci(d, np.mean)
            helps.append(f"{k} {'yes' if lo > 0 else '**no**'}")
    flat = {
        k: float(np.mean(_paired(df, "hardware_only_no_distortion_correction", "hardware_only", c)))
        for k, c in ((k, col.format(k)) for k in AXES)
    }
    lines += [
        "Distortion correction helps under the paper's conditions (CI above 0): "
        + ", ".join(helps)
        + " (the paper: yes for all three).",
        "",
        "On a flat tank, where the waves do not hide it, the correction gains "
        + ", ".join(
            f"{k} {flat[k]:.2f}° ({flat[k] / PAPER_DISTORTION_GAIN_DEG[k]:.2f}× the paper's)"
            for k in AXES
        )
        + ". The twin's uncorrected vehicle uses the lens's datasheet model, off the unit's lens by"
        " ISO 517's focal-length tolerance, a decentre and a measured fisheye's departure from"
        " equidistant; the paper does not say which model its uncorrected runs used, and a"
        " larger gain needs a worse one (a pinhole model cannot hold a 185° lens at all).",
        "",
    ]
    return lines


AXES = ("roll", "pitch", "yaw")


def _rel(path: str) -> str:
    p = pathlib.Path(path)
    return str(p.relative_to(ROOT)) if p.is_relative_to(ROOT) else str(p)


#: campaign name → {one line of code and packages: how many of its runs they made}
MADE_BY: dict[str, dict[str, int]] = {}


def _run(name: str, runs: pathlib.Path, workers: int):
    spec = load_campaign(ROOT / "scenarios" / "campaigns" / f"{name}.toml")
    out = runs / spec.name
    run_campaign(spec, out, workers=workers, progress=True)
    df = load_campaign_results(out)
    MADE_BY[spec.name] = dict(df.attrs.get("made_by") or {})
    return spec, df[df["status"] == "ok"]


def roia(runs: pathlib.Path, workers: int) -> list[str]:
    spec, df = _run("roia_static", runs, workers)
    lines = [
        "## ROI-A static, tank and sea (fang2024 §2.2–2.3)",
        "",
        f"Campaign `{_rel(spec.source)}`: {len(spec.seeds)} sessions per case of 30 frames",
        "each (RMSE over a session's frames, then mean over sessions with its 95 % bootstrap",
        "CI). The paper",
        "gives the tank's heading RMSE and, at sea, the solar azimuth RMSE against the Hong Kong",
        "Observatory's — with the heading known, the same error here.",
        "",
        "Each frame goes through ROI-A as the paper prints it (`roia_paper`) and the twin's",
        "refinement (`roia`; docs/compass_methods.md lists what differs).",
        "",
        "| case | method | depth (m) | sessions | twin RMSE (°) | paper (°) | twin ÷ paper |"
        " frames without a fix |",
        "|---|---|---|---|---|---|---|---|",
    ]
    col = "metric.methods.roia.heading_rmse_deg"
    for case, c in ROIA_CASES.items():
        g = df[df["param.case"] == case]
        for method, label in (("roia_paper", "the paper's"), ("roia", "the twin's")):
            mcol = f"metric.methods.{method}.heading_rmse_deg"
            if mcol not in g:
                continue
            text, m, _, _ = _ci_text(g[mcol].to_numpy(float))
            nofix = int(g[f"metric.methods.{method}.no_fix"].sum())
            lines.append(
                f"| {case} | {label} | {c.depth_m:g} | {len(g)} | {text} | "
                f"{c.paper_rmse_deg:.2f} | {m / c.paper_rmse_deg:.1f}× | {nofix} |"
            )
    lines.append("")
    for case in ROIA_CASES:
        paired = _paired_methods(
            df[df["param.case"] == case], "roia_paper", "roia", ["heading_rmse_deg"]
        )
        lines += [f"{case}: {x[2:]}" if x.startswith("- ") else x for x in paired]
    sea = [float(np.nanmean(df[df["param.case"] == k][col])) for k in ROIA_CASES if k != "tank"]
    trend = "grows" if all(b > a for a, b in itertools.pairwise(sea)) else "does not grow"
    lines += [
        "",
        f"At sea the twin's error {trend} with depth (the paper: it grows).",
        "",
        "Why the twin does not reach the paper at depth: near the surface the waves' refraction "
        "and caustics and the bubbles dominate ROI-A's zenith region; at 5–6 m of the assumed 3C "
        "water none of the budget's sources — marine snow included — moves its robust zenith "
        "statistic by degrees, and the twin has no source with a citation that would (the "
        "paper's sea sessions lasted minutes under a changing sky and sea it does not describe).",
        "",
    ]
    return lines


def lig_tank(runs: pathlib.Path, workers: int) -> list[str]:
    spec, df = _run("lig_tank", runs, workers)
    lines = [
        "## LIG vs POL in the LIG paper's milky tank (hu2024 §4.2)",
        "",
        f"Campaign `{_rel(spec.source)}`: {len(spec.seeds)} sessions of 20 frames; mean",
        "absolute error over a session, mean over sessions with its 95 % bootstrap CI. Milk's",
        "scattering from",
        f"first principles: b = {df['metric.milk_b_per_m'].iloc[0]:.2f} /m in the tank.",
        "",
        "| method | quantity | twin MAE (°) | paper (°) | twin ÷ paper |",
        "|---|---|---|---|---|",
    ]
    means = {}
    names = {
        "lig_paper": "LIG, the paper's method",
        "lig": "LIG, the twin's refinement",
        "pol_paper": "POL, as the LIG paper describes it",
        "pol": "POL, the twin's refinement",
    }
    for m in ("lig_paper", "lig", "pol_paper", "pol"):
        for q in ("azimuth", "zenith"):
            col = f"metric.methods.{m}.{q}_mae_deg"
            if col not in df:
                continue  # runs made before the paper's LIG was in the trial
            text, v, _, _ = _ci_text(df[col].to_numpy(float))
            means[m, q] = v
            paper = LIG_TANK_PAPER["lig" if m.startswith("lig") else "pol", q]
            lines.append(f"| {names[m]} | {q} | {text} | {paper:.1f} | {v / paper:.1f}× |")
    lig = "lig_paper" if ("lig_paper", "zenith") in means else "lig"
    pol = "pol_paper" if ("pol_paper", "zenith") in means else "pol"
    for q in ("azimuth", "zenith"):
        # Paired: the same session's frames through both methods.
        d = df[f"metric.methods.{pol}.{q}_mae_deg"] - df[f"metric.methods.{lig}.{q}_mae_deg"]
        d = d.dropna().to_numpy(float)
        lo, hi = bootstrap_ci(d, np.mean)
        verdict = "LIG beats POL" if lo > 0 else ("POL beats LIG" if hi < 0 else "not resolved")
        lines.append(
            f"\n{q}, {lig} against {pol}: {verdict} in the twin (POL − LIG per session "
            f"{np.mean(d):+.2f}° [{lo:+.2f}, {hi:+.2f}]; the paper: LIG beats POL)."
        )
    qs = ["azimuth_mae_deg", "zenith_mae_deg"]
    lines += ["", "The papers' methods against the twin's refinements on the same frames:", ""]
    lines += _paired_methods(df, "lig_paper", "lig", qs)
    lines += _paired_methods(df, "pol_paper", "pol", qs)
    lines += [
        "",
        "Where LIG's zenith error comes from, measured by switching one thing at a time "
        "(validation/results/lig_bias_cause.md): the twin's refinement replaces the paper's "
        "eqs. 9–12 by an exact Jacobian map and drops the rim and low-SNR pixels (the two rows "
        "above differ by that alone); under the clear sky (CIE type 12) its apparent sun leans "
        "to the horizon because the sky's gradation (horizon 3.6× its zenith) is seen through "
        "Snell's window: with no scattered light at all the lean is the same, with the "
        "gradation removed (CIE 8) it turns to a few degrees towards the zenith. Radiative "
        "transfer does not make it.",
        "",
    ]
    return lines


def sea_trials(runs: pathlib.Path, workers: int) -> list[str]:
    spec, df = _run("lig_sea_trials", runs, workers)
    paper = {(10.0, "pol"): 3.6, (10.0, "lig"): 1.6, (15.0, "pol"): 16.1, (15.0, "lig"): 2.2}
    lines = [
        "## LIG/INS vs POL/INS sea trials at 10 m and 15 m (hu2024 §4.3)",
        "",
        f"Campaign `{_rel(spec.source)}`: {len(spec.seeds)} seeds a depth, each the full",
        "450 s trial with the paper's filter set-up; heading RMSE per run, mean over runs with",
        "its 95 %",
        "bootstrap CI.",
        "",
        "| depth (m) | INS alone (°) | POL/INS, POL as the LIG paper describes it (°) "
        "| POL/INS, the twin's POL (°) | paper POL/INS | LIG/INS, the paper's LIG (°) "
        "| LIG/INS, the twin's LIG (°) | paper LIG/INS |",
        "|---|---|---|---|---|---|---|---|",
    ]
    depth_col = "param.initial.depth_m"
    rm = {}
    for depth in (10.0, 15.0):
        g = df[df[depth_col] == depth]
        cells = {}
        for v in ("ins", "pol_paper", "pol", "lig_paper", "lig"):
            key = f"metric.navigation.variants.{v}.heading_rmse_deg"
            if key not in g:
                cells[v] = "not run"
                continue
            text, m, _, _ = _ci_text(g[key].to_numpy(float))
            cells[v], rm[depth, v] = text, m
        lines.append(
            f"| {depth:g} | {cells['ins']} | {cells['pol_paper']} | {cells['pol']} | "
            f"{paper[depth, 'pol']} | "
            f"{cells['lig_paper']} | {cells['lig']} | {paper[depth, 'lig']} |"
        )

    # Paired differences: the same run's two filters; the same seed at the two depths. LIG is the
    # paper's method where the runs have it.
    lig = "lig_paper" if (10.0, "lig_paper") in rm else "lig"
    pol = "pol_paper" if (10.0, "pol_paper") in rm else "pol"

    def col(depth: float, v: str) -> pd.Series:
        g = df[df[depth_col] == depth].set_index("seed")
        return g[f"metric.navigation.variants.{v}.heading_rmse_deg"]

    def verdict(diff: pd.Series, what: str) -> str:
        d = diff.dropna().to_numpy(float)
        lo, hi = bootstrap_ci(d, np.mean)
        sign = "yes" if lo > 0 else ("no, the reverse" if hi < 0 else "not resolved")
        return f"{what}: {sign} (mean paired difference {np.mean(d):+.2f}° [{lo:+.2f}, {hi:+.2f}])"

    # Twin ÷ paper, each method as the paper runs it and as the twin refines it.
    lines += [
        "",
        "Twin ÷ paper (mean heading RMSE):",
        "",
        "| depth (m) | POL/INS, the paper's POL | POL/INS, the twin's | "
        "LIG/INS, the paper's LIG | LIG/INS, the twin's |",
        "|---|---|---|---|---|",
    ]
    far: list[str] = []
    for depth in (10.0, 15.0):
        cells = []
        for v, fam in (("pol_paper", "pol"), ("pol", "pol"), ("lig_paper", "lig"), ("lig", "lig")):
            r = rm.get((depth, v), math.nan) / paper[depth, fam]
            cells.append(_ratio_text(r))
            if math.isfinite(r) and not 0.5 <= r <= 2.0:
                far.append(f"{v} at {depth:g} m")
        lines.append(f"| {depth:g} | {' | '.join(cells)} |")
    lines += [
        "",
        "Outside a factor of 2 of the paper: " + (", ".join(far) if far else "none") + ".",
    ]
    for depth in (10.0, 15.0):
        for paper_v, twin_v in (("pol_paper", "pol"), ("lig_paper", "lig")):
            if (depth, paper_v) in rm and (depth, twin_v) in rm:
                lines.append(
                    "- "
                    + verdict(
                        col(depth, twin_v) - col(depth, paper_v),
                        f"{paper_v} beats {twin_v} at {depth:g} m",
                    )
                )
    lines += [
        "",
        "- " + verdict(col(10.0, pol) - col(10.0, lig), f"LIG/INS ({lig}) beats {pol}/INS at 10 m"),
        "- " + verdict(col(15.0, pol) - col(15.0, lig), f"LIG/INS ({lig}) beats {pol}/INS at 15 m"),
        "- " + verdict(col(15.0, pol) - col(10.0, pol), f"{pol}/INS worsens from 10 to 15 m"),
        "",
        "The paper: yes, yes, and yes (3.6° → 16.1°).",
        "",
        "Why the twin's POL/INS does not degrade 4.5× from 10 to 15 m is not established by a "
        "switch. Measured: its E-vector pattern keeps a DoP of 0.2–0.3 inside Snell's window "
        "at both depths in Jerlov II (validation/results/lightfield_reference.md), so POL's "
        "fixes barely worsen. The paper does not state its water; a more turbid one is a "
        "hypothesis, not a result.",
        "",
    ]
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--runs", default=str(ROOT / "runs" / "hardware"), help="campaign folders")
    ap.add_argument(
        "--only",
        nargs="+",
        default=["snell", "roia", "lig_tank", "sea"],
        choices=["snell", "roia", "lig_tank", "sea"],
        help="experiments to run and report (default: all)",
    )
    args = ap.parse_args()
    runs = pathlib.Path(args.runs)
    lines = [
        "# The seeds' hardware experiments, reproduced",
        "",
        f"Generated by `validation/hardware_experiments.py` on {dt.date.today()} "
        f"({platform.machine()}, {os.cpu_count()} cores, Python {sys.version.split()[0]}).",
        "",
    ]
    RESULTS.mkdir(parents=True, exist_ok=True)
    sections: list[list[str]] = []
    report_block = pv.provenance()
    if "snell" in args.only:
        sec, fig = snell(runs, args.workers)
        fig.savefig(RESULTS / "hardware_experiments_snell.png", dpi=110)
        sections.append([*sec, "![Snell turntable](hardware_experiments_snell.png)", ""])
    if "roia" in args.only:
        sections.append(roia(runs, args.workers))
    if "lig_tank" in args.only:
        sections.append(lig_tank(runs, args.workers))
    if "sea" in args.only:
        sections.append(sea_trials(runs, args.workers))
    lines += [f"- This report: {'; '.join(pv.describe(report_block))}"]
    for name, seen in MADE_BY.items():
        made = "; ".join(f"{n} runs: {k}" for k, n in seen.items()) or "no provenance"
        lines.append(f"- Campaign `{name}`, runs made by: {made}")
    lines.append("")
    path = RESULTS / "hardware_experiments.md"
    old = path.read_text() if path.exists() else ""
    text = splice(old, lines, sections, ORDER, rerun=set(MADE_BY))
    path.write_text(text)
    print(text)


#: The report's sections, in order, by the start of their headings.
ORDER = (
    "## Snell-window attitude",
    "## ROI-A static",
    "## LIG vs POL in the LIG paper's milky tank",
    "## LIG/INS vs POL/INS sea trials",
)


def splice(
    old: str,
    header: list[str],
    new: list[list[str]],
    order: tuple[str, ...],
    rerun: set[str] = frozenset(),  # type: ignore[assignment]
) -> str:
    """The report with ``new`` sections in place of theirs and the others kept from ``old``.

    A run of some experiments (``--only``) must not drop the others' sections, whose campaigns
    may be on another machine, nor their provenance: the old header's "runs made by" line of
    every campaign not in ``rerun`` is kept. Sections are keyed by the start of their ``## ``
    heading.
    """
    kept: dict[str, str] = {}
    chunks = old.split("\n## ")
    old_made = [
        ln
        for ln in chunks[0].splitlines()
        if (m := re.match(r"- Campaign `([^`]+)`, runs made by:", ln)) and m.group(1) not in rerun
    ]
    if old_made:
        at = max(i for i, ln in enumerate(header) if ln.startswith("- ")) + 1
        header = [*header[:at], *old_made, *header[at:]]
    for chunk in chunks[1:]:
        body = "## " + chunk
        key = next((k for k in order if body.startswith(k)), None)
        if key is not None:
            kept[key] = body.rstrip("\n") + "\n"
    for sec in new:
        key = next(k for k in order if sec[0].startswith(k))
        kept[key] = "\n".join(sec).rstrip("\n") + "\n"
    body = "\n".join(kept[k] for k in order if k in kept)
    return "\n".join(header) + "\n" + body


if __name__ == "__main__":
    main()
