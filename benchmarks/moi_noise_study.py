"""liang2020's simulation study (§4.1, Figs. 8, 9, 11): MOI vs PATZ vs HT on the in-air imager.

Per sun elevation h_s ∈ {0, 10, …, 50}°, N random trials (a random solar azimuth each; the paper's
2000 by default): the ideal AoP image of the paper's hypothetical imager (Table 1: level camera at
the zenith, pinhole f = 8 mm, 3.45 µm, 2048 columns × 2448 rows, DOP_max = 1, orthographic
E-vector projection), then three cases, each solved by the three methods on the AoP image
(``twin.onboard.compass.moi.estimate_axis``):

* ideal (Fig. 8): no noise;
* Gaussian (§4.1.2, Fig. 9): zero-mean Gaussian noise on the AOPLM image with σ = 1 % of
  (max AOPLM − min AOPLM). The paper says "variance … set to 1 %(Max − Min)"; read literally in
  radians that is σ = √(0.01·π) = 10°, which contradicts its own MOI result (< 0.011° max error
  needs σ of about 2° or less), so σ = 1 % of the range (1.8°) is used;
* crosstalk (§4.1.3, Fig. 11): the same Gaussian noise plus uniform noise U(0, 2 % of the range)
  whose sign alternates between adjacent pixels (Fig. 10(a): a checkerboard of +/−, so every edge
  neighbour has the opposite sign).

Noise is added to the AoP image (AOPLM = AoP − ξ with ξ fixed per pixel, so that is the same
perturbation) and the result wrapped back to [−π/2, π/2), as a real AoP would be. The error is
the error of the SM-ASM line (mod 180°); the sun/anti-sun decision is reported separately (it is
undecidable from the AoP at h_s = 0°, where the sun and anti-sun patterns coincide).

    python benchmarks/moi_noise_study.py --trials 100     # writes benchmarks/results/

The same study as a campaign (resumable, on Ray too, one trial per run):
scenarios/campaigns/moi_noise.toml, with the trial in :mod:`twin.campaign.moi_noise`.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time
from pathlib import Path

import numpy as np

from twin.campaign.moi_noise import CASES, METHODS, add_noise, ideal_aop, imager
from twin.onboard.compass.moi import estimate_axis
from twin.onboard.polarization import stokes_from_mosaic

RESULTS = Path(__file__).resolve().parent / "results"
ELEVATIONS_DEG = (0.0, 10.0, 20.0, 30.0, 40.0, 50.0)
SEED = 20200513


def run(trials: int) -> dict:
    cal, g, sign = imager()
    rng = np.random.default_rng(SEED)
    # errs[case][method][elev] = list of |axis error| (deg); flips likewise (count)
    errs = {c: {m: {e: [] for e in ELEVATIONS_DEG} for m in METHODS} for c in CASES}
    flips = {c: {m: {e: 0 for e in ELEVATIONS_DEG} for m in METHODS} for c in CASES}
    fails = {c: {m: {e: 0 for e in ELEVATIONS_DEG} for m in METHODS} for c in CASES}
    times = {m: [] for m in METHODS}
    for elev in ELEVATIONS_DEG:
        er = math.radians(elev)
        for _ in range(trials):
            az = float(rng.uniform(0.0, 2 * math.pi))
            sun = np.array([math.cos(er) * math.sin(az), math.cos(er) * math.cos(az), math.sin(er)])
            clean = ideal_aop(cal, sun)
            for case in CASES:
                if case == "ideal":
                    aop = clean
                else:
                    aop = add_noise(clean, g.xi, sign, rng, case == "crosstalk")
                for m in METHODS:
                    t0 = time.perf_counter()
                    est = estimate_axis(m, aop, cal, sun_elevation_rad=er)
                    times[m].append(time.perf_counter() - t0)
                    if not est.ok:
                        fails[case][m][elev] += 1
                        continue
                    d = (est.axis_rad - az + math.pi / 2) % math.pi - math.pi / 2
                    errs[case][m][elev].append(abs(math.degrees(d)))
                    ds = (est.sun_azimuth_rad - az + math.pi) % (2 * math.pi) - math.pi
                    flips[case][m][elev] += int(abs(ds) > math.pi / 2)
        print(f"h_s = {elev:4.1f}° done", flush=True)
    return {"errs": errs, "flips": flips, "fails": fails, "times": times, "trials": trials}


def frame_timing(repeats: int = 5) -> dict[str, float]:
    """Best-of time per full-resolution frame: the AoP entry, and solve()'s Stokes step."""
    cal = imager()[0]
    sun = np.array([0.5, 0.6, math.sin(math.radians(30.0))])
    aop = ideal_aop(cal, sun / np.linalg.norm(sun))
    out = {}
    for m in METHODS:
        estimate_axis(m, aop, cal, sun_elevation_rad=0.5)  # warm the geometry cache
        best = math.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            estimate_axis(m, aop, cal, sun_elevation_rad=0.5)
            best = min(best, time.perf_counter() - t0)
        out[m] = best
    raw = np.random.default_rng(0).integers(0, 4096, size=(2448, 2048), dtype=np.uint16)
    for kind in ("superpixel", "interpolate"):
        best = math.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            stokes_from_mosaic(raw, method=kind)
            best = min(best, time.perf_counter() - t0)
        out[f"stokes_{kind}"] = best
    return out


def write(res: dict, timing: dict[str, float], wall_s: float) -> None:
    RESULTS.mkdir(parents=True, exist_ok=True)
    errs, flips, fails, trials = res["errs"], res["flips"], res["fails"], res["trials"]
    lines = [
        "# liang2020 simulation study: MOI vs PATZ vs HT (benchmarks/moi_noise_study.py)",
        "",
        f"Trials per sun elevation and case: **{trials}** (the paper: 2000), random solar azimuth "
        f"each, numpy Generator seed {SEED}. Full-resolution ideal AoP image of the paper's imager "
        "(2048 columns × 2448 rows, f = 8 mm, 3.45 µm, DOP_max = 1, orthographic E-vector "
        "projection). Noise: σ = 1 % of the AOPLM range (Gaussian); crosstalk adds U(0, 2 %) "
        "with a checkerboard ± sign. Errors: SM-ASM line, degrees (mean / max / variance in "
        "deg²). `flips`: sun/anti-sun decided wrong (expected ≈ half at h_s = 0°, where the AoP "
        "cannot tell them apart); `fails`: no fix.",
        "",
        f"Wall time of the study: {wall_s / 60:.1f} min on one core of the shared dev VM "
        f"({platform.processor() or platform.machine()}, OMP/BLAS threads = "
        f"{os.environ.get('OMP_NUM_THREADS', 'default')}).",
        "",
    ]
    for case in CASES:
        head = " | ".join(f"{m.upper()} mean | {m.upper()} max | {m.upper()} var" for m in METHODS)
        lines += [f"## {case}", "", f"| h_s (°) | {head} | flips (M/P/H) | fails (M/P/H) |"]
        lines.append("|---" * (3 + 3 * len(METHODS)) + "|")
        for e in ELEVATIONS_DEG:
            cells = []
            for m in METHODS:
                v = np.asarray(errs[case][m][e])
                if v.size:
                    cells += [f"{v.mean():.2e}", f"{v.max():.2e}", f"{v.var():.1e}"]
                else:
                    cells += ["–", "–", "–"]
            fl = "/".join(str(flips[case][m][e]) for m in METHODS)
            fa = "/".join(str(fails[case][m][e]) for m in METHODS)
            lines.append(f"| {e:.0f} | " + " | ".join(cells) + f" | {fl} | {fa} |")
        lines.append("")
    lines += [
        "## Time per full-resolution frame (best of 5, one thread)",
        "",
        "| step | ms |",
        "|---|---|",
    ]
    for k, v in timing.items():
        lines.append(f"| {k} | {v * 1e3:.1f} |")
    lines += [
        "",
        "`moi`/`patz`/`ht` = `estimate_axis` on a 2048×2448 AoP image including the Rayleigh "
        "sun-side check; `solve()` on a raw mosaic adds `stokes_from_mosaic` (superpixel: the "
        "methods then run on a quarter of the pixels).",
        "",
        "![max](moi_noise_study_max.png) ![mean](moi_noise_study_mean.png)",
        "",
    ]
    (RESULTS / "moi_noise_study.md").write_text("\n".join(lines))
    plot(errs)


def plot(errs: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.arange(len(ELEVATIONS_DEG))
    for stat, fn in (("max", np.max), ("mean", np.mean)):
        fig, axes = plt.subplots(1, len(CASES), figsize=(15, 4.2))
        for ax, case in zip(axes, CASES, strict=True):
            for k, m in enumerate(METHODS):
                vals = [
                    fn(errs[case][m][e]) if errs[case][m][e] else np.nan for e in ELEVATIONS_DEG
                ]
                ax.bar(x + (k - 1) * 0.27, np.maximum(vals, 1e-9), 0.27, label=m.upper())
            ax.set_yscale("log")
            ax.set_xticks(x, [f"{e:.0f}" for e in ELEVATIONS_DEG])
            ax.set_xlabel("solar elevation h_s (°)")
            ax.set_ylabel(f"{stat} error (°)")
            ax.set_title(case)
            ax.legend()
        fig.tight_layout()
        fig.savefig(RESULTS / f"moi_noise_study_{stat}.png", dpi=90)
        plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=2000, help="random trials per elevation")
    args = ap.parse_args()
    t0 = time.perf_counter()
    res = run(args.trials)
    wall = time.perf_counter() - t0
    timing = frame_timing()
    write(res, timing, wall)
    print((RESULTS / "moi_noise_study.md").read_text())


if __name__ == "__main__":
    main()
