"""wang2023's study on the twin's maps: PCRB-A* planned path vs the Direct and parallel paths.

The maps: ``--maps`` independent 100 × 100 km maps at 1 km drawn by their statistics
(``twin.world.gravity_random``: correlation length 5 km [assumption], scaled to the paper's 78 mGal
range), map seed m with Monte Carlo seed m + 1; the same study at correlation lengths 3, 10 and
20 km (``--sensitivity-maps`` maps each) to show how much the assumption moves the sums; and the
physical map (``twin.world.gravity.wang2023_seafloor``, a seafloor forward-modelled with
harmonica). On each map: the PCRB-A* path for Test 1 (start (58, 73) km) and Test 2 (start
(30, 58) km), both to (65, 9) km, the Direct path and the family of parallel curves (L3…L9 and
L3…L12, 5.5 km apart), SITAN along each, 1000 Monte Carlo runs, at R = 1, 2, 3, 4 mGal (Table 1's
other parameters). Table 1's Q_t is read as printed (m²/s: what the paper's own Table 2 implies,
``twin.onboard.gravity.pcrb.Q_T_READINGS``); the km²/s reading runs beside it on map 0. Writes
validation/results/gravity_path_planning.md (+ .json, + figures): the sums of RMSE beside the
paper's Tables 2–3, mean and 95 % bootstrap interval over the maps; the PCRB's sums and the INS
floor; the paper's findings judged over the maps (paths share their random numbers within a map,
so differences are paired) with lock-loss rates; the maps' measured statistics; the planner's
time.

Run: ``python validation/gravity_path_planning.py [--maps 10] [--sensitivity-maps 5]`` (about
15 min on one core).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import json
import math
import platform
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from twin.campaign.stats import bootstrap_ci
from twin.core.gravity_map import GravityGrid, OffMapError
from twin.onboard.gravity.paths import comparison_family, lateral_offset_m, resample
from twin.onboard.gravity.pcrb import Q_T_READINGS, GainsModel, floor_sum_rmse_m, information_map
from twin.onboard.gravity.planner import plan
from twin.record import provenance as pv
from twin.scoring.gravity_matching import monte_carlo
from twin.world.gravity import anomaly_grid, wang2023_seafloor
from twin.world.gravity_random import RandomFieldSpec, map_statistics, random_anomaly_grid

RESULTS = Path(__file__).resolve().parent / "results"
GOAL = (65_000.0, 9_000.0)
TESTS = {"Test 1": ((58_000.0, 73_000.0), 7), "Test 2": ((30_000.0, 58_000.0), 10)}
SIGMAS = (1.0, 2.0, 3.0, 4.0)
RUNS = 1000
#: The study's maps (module docstring) and the correlation lengths of the sensitivity rows.
MAP = RandomFieldSpec()
SENSITIVITY_LENGTHS_M = (3000.0, 10_000.0, 20_000.0)
#: Taken when the study starts: the code that ran, not the tree at the end of a long run.
PROVENANCE = pv.provenance()
#: A path's entries when it leaves the map (NaN: left out of every statistic).
OFF_MAP_KEYS = ("sum_rmse_km", "sum_bound_km", "floor_km", "length_km", "lock_lost")
#: A run has lost lock when its error at the path's end exceeds 3√tr P of the bound there.
LOCK_SIGMAS = 3.0
# wang2023 Tables 2–3: sum of RMSE (km) by R (mGal).
PAPER = {
    "Test 1": {
        "names": ["Planned", "Direct", "L3", "L4", "L5", "L6", "L7", "L8", "L9"],
        1.0: [8.1, 12.8, 21.6, 19.5, 13.8, 10.0, 9.5, 9.0, 9.6],
        2.0: [14.4, 22.8, 38.0, 34.3, 24.6, 17.7, 16.7, 15.7, 16.8],
        3.0: [20.9, 33.4, 56.0, 50.4, 36.3, 25.7, 24.0, 22.5, 24.2],
        4.0: [27.4, 44.6, 75.6, 67.1, 49.2, 34.0, 31.4, 29.3, 31.7],
    },
    "Test 2": {
        "names": ["Planned", "Direct"] + [f"L{k}" for k in range(3, 13)],
        1.0: [30.4, 66.4, 40.0, 31.3, 35.8, 41.5, 54.1, 52.5, 53.9, 49.3, 44.7, 50.0],
        2.0: [41.8, 78.5, 55.4, 43.4, 46.7, 54.3, 67.6, 64.2, 68.6, 62.8, 63.0, 67.7],
        3.0: [54.6, 93.3, 73.2, 56.6, 59.0, 68.7, 84.5, 79.4, 86.3, 80.5, 84.3, 89.0],
        4.0: [68.1, 110.0, 92.5, 70.7, 72.2, 84.7, 104.0, 97.1, 106.0, 101.0, 108.0, 112.2],
    },
}


def _paths(grid: GravityGrid, start, count: int, model: GainsModel):
    planned = plan(grid, start, GOAL, model)
    p100 = resample(planned.nodes_m)
    # The family centred on the planned path's bow: a sin(πs) bow of amplitude A has mean
    # offset 2A/π, so A = mean · π/2.
    bow = lateral_offset_m(p100, start, GOAL) * math.pi / 2
    return planned, {"Planned": p100, **comparison_family(start, GOAL, count, 5500.0, bow)}


def _bootstrap_sum(err2: np.ndarray, rng: np.random.Generator, n: int = 300):
    """95 % interval of Σ_k √(mean over runs of err²) by resampling runs."""
    runs = err2.shape[0]
    sums = np.empty(n)
    for b in range(n):
        idx = rng.integers(0, runs, runs)
        sums[b] = np.sqrt(err2[idx].mean(axis=0)).sum()
    return tuple(np.percentile(sums, [2.5, 97.5]))


def study(grid: GravityGrid, seed: int, keep_runs: bool, q: float = Q_T_READINGS["as_printed"]):
    out = {}
    for test, (start, count) in TESTS.items():
        rows = {}
        for sigma in SIGMAS:
            model = GainsModel(sigma_mgal=sigma, q_rate_m2_per_s=q)
            planned, paths = _paths(grid, start, count, model)
            res = {}
            for name, path in paths.items():
                # Common random numbers: every path sees the same draws (paired comparison).
                try:
                    mc = monte_carlo(
                        grid, grid, path, model, np.random.default_rng(seed), runs=RUNS,
                        keep_errors=keep_runs,
                    )  # fmt: skip
                except OffMapError:
                    # A parallel path the planned path's bow pushes off this map: not flown.
                    res[name] = dict.fromkeys(OFF_MAP_KEYS, math.nan)
                    continue
                entry = {
                    "sum_rmse_km": mc.sum_rmse_m / 1e3,
                    "sum_bound_km": float(mc.bound_m.sum()) / 1e3,
                    "floor_km": floor_sum_rmse_m(path, model) / 1e3,
                    "length_km": float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) / 1e3,
                    "rmse_km": (mc.rmse_m / 1e3).tolist(),
                    "bound_km": (mc.bound_m / 1e3).tolist(),
                }
                if keep_runs and mc.errors_m2 is not None:
                    lo, hi = _bootstrap_sum(mc.errors_m2, np.random.default_rng(seed + 1))
                    entry["ci_km"] = [lo / 1e3, hi / 1e3]
                    lost = mc.errors_m2[:, -1] > (LOCK_SIGMAS * mc.bound_m[-1]) ** 2
                    entry["lock_lost"] = float(lost.mean())
                res[name] = entry
            rows[f"{sigma:g}"] = {
                "paths": res,
                "planner_s": planned.seconds,
                "expanded": planned.expanded,
                "planned_nodes_m": planned.nodes_m.tolist(),
                "direct_km": math.dist(start, GOAL) / 1e3,
                "family": {k: v.tolist() for k, v in paths.items()},
            }
        out[test] = rows
    return out


def over_seeds(per_seed: list[dict]) -> dict[str, dict]:
    """The paper's "planned is best" judged over studies (maps, seeds), paired within each.

    Per test and R: how many seeds the planned path has the least sum, the planned path's sum
    minus the best other path's (mean over seeds, 95 % bootstrap CI), which path wins when the
    planned one does not, and each path's lock-loss rate (mean over seeds).
    """
    out = {}
    for test in TESTS:
        for sigma in (f"{x:g}" for x in SIGMAS):
            names = list(per_seed[0][test][sigma]["paths"])
            sums = {
                k: np.array([r[test][sigma]["paths"][k]["sum_rmse_km"] for r in per_seed])
                for k in names
            }
            others = [k for k in names if k != "Planned"]
            best_other = np.nanmin([sums[k] for k in others], axis=0)
            diff = sums["Planned"] - best_other
            lo, hi = bootstrap_ci(diff, np.mean)
            winners = [
                min((k for k in names if np.isfinite(sums[k][i])), key=lambda k, i=i: sums[k][i])
                for i in range(len(per_seed))
            ]
            lock = {
                k: float(np.nanmean([r[test][sigma]["paths"][k]["lock_lost"] for r in per_seed]))
                for k in names
            }
            out[f"{test} R={sigma}"] = {
                "seeds": len(per_seed),
                "planned_wins": winners.count("Planned"),
                "winners": {k: winners.count(k) for k in names if winners.count(k)},
                "planned_minus_best_other_km": [float(np.mean(diff)), lo, hi],
                "lock_lost": lock,
                "off_map": {k: int(np.sum(~np.isfinite(sums[k]))) for k in names},
            }
    return out


def findings(res: dict) -> dict[str, bool]:
    f = {}
    for test, rows in res.items():
        for sigma, row in rows.items():
            sums = {
                k: v["sum_rmse_km"]
                for k, v in row["paths"].items()
                if np.isfinite(v["sum_rmse_km"])
            }
            f[f"{test} R={sigma}: planned smallest"] = min(sums, key=sums.get) == "Planned"
        ranks = [
            sorted(
                (k for k in row["paths"] if np.isfinite(row["paths"][k]["sum_rmse_km"])),
                key=lambda k, r=row: r["paths"][k]["sum_rmse_km"],
            )
            for row in rows.values()
        ]
        f[f"{test}: ranking unchanged with R"] = all(r == ranks[0] for r in ranks)
    t2 = {k: v for k, v in res["Test 2"]["2"]["paths"].items() if np.isfinite(v["sum_rmse_km"])}
    f["Test 2 R=2: Direct worst"] = max(t2, key=lambda k: t2[k]["sum_rmse_km"]) == "Direct"
    return f


def timing(grid: GravityGrid) -> dict[str, float]:
    model = GainsModel()
    times = []
    for start, _ in TESTS.values():
        for _ in range(3):
            t0 = time.perf_counter()
            plan(grid, start, GOAL, model)
            times.append(time.perf_counter() - t0)
    corner = []
    for _ in range(3):
        t0 = time.perf_counter()
        p = plan(grid, (0.0, 0.0), (100_000.0, 100_000.0), model)
        corner.append(time.perf_counter() - t0)
    return {
        "tests_best_s": min(times),
        "tests_worst_s": max(times),
        "corner_to_corner_best_s": min(corner),
        "corner_expanded": p.expanded,
    }


def figures(grid: GravityGrid, res: dict) -> list[str]:
    names = []
    m = information_map(grid, 2.0)
    for test, rows in res.items():
        row = rows["2"]
        fig, ax = plt.subplots(1, 3, figsize=(17, 5))
        ext = [v / 1e3 for v in grid.extent_m]
        im = ax[0].imshow(grid.values_mgal, origin="lower", extent=ext, cmap="viridis")
        ax[0].contour(
            grid.east_m / 1e3, grid.north_m / 1e3, grid.values_mgal, 15, colors="w",
            linewidths=0.4,
        )  # fmt: skip
        fig.colorbar(im, ax=ax[0], label="anomaly (mGal)")
        ax[1].imshow(np.sqrt(m) * 1e3, origin="lower", extent=ext, cmap="magma")
        ax[1].set_title("√M (1/km) at R = 2 mGal")
        for a in ax[:2]:
            for k, p in row["family"].items():
                p = np.asarray(p) / 1e3
                style = {"Planned": ("k", 2.0), "Direct": ("0.6", 2.0)}.get(k, ("c", 0.8))
                a.plot(p[:, 0], p[:, 1], color=style[0], lw=style[1])
            a.set_xlabel("East (km)")
            a.set_ylabel("North (km)")
        ax[0].set_title(f"{test}: map, planned (black), Direct (grey), L3… (cyan)")
        for k, v in row["paths"].items():
            if "rmse_km" not in v:  # off the map
                continue
            s = np.linspace(0, v["length_km"], len(v["rmse_km"]))
            style = {"Planned": ("k", 2.0), "Direct": ("0.5", 2.0)}.get(k, (None, 0.8))
            ax[2].plot(s, v["rmse_km"], color=style[0], lw=style[1], label=k)
        ax[2].set_yscale("log")
        ax[2].set_xlabel("distance along the path (km)")
        ax[2].set_ylabel("position RMSE (km), 1000 runs")
        ax[2].legend(fontsize=7, ncol=2)
        ax[2].set_title(f"{test}: RMSE along each path, R = 2 mGal")
        fig.tight_layout()
        name = f"gravity_path_planning_{test.replace(' ', '').lower()}.png"
        fig.savefig(RESULTS / name, dpi=90)
        plt.close(fig)
        names.append(name)
    return names


def _q_section(res: dict, res_km2: dict) -> list[str]:
    """Which reading of Q_t the paper's Table 2 allows: the INS floor of each path's sum."""
    lines = [
        "## Q_t: the reading the paper's own tables imply",
        "",
        "One scalar look a step leaves the INS's variance growth Q_n = Q_t d/V in the direction",
        "it does not see, so each point's √tr P is at least √Q_n and a path's sum at least its",
        "*floor* (`floor_sum_rmse_m`), whatever the map. The least floor of each test's paths",
        "under each reading, against the least sum in the paper's R = 1 row:",
        "",
        "| test | paper's least R = 1 sum (km) | floor, Q_t in m²/s as printed (km) | "
        "floor, Q_t in km²/s (km) |",
        "|---|---|---|---|",
    ]
    verdict = []
    for test in TESTS:
        fl = float(np.nanmin([v["floor_km"] for v in res[test]["1"]["paths"].values()]))
        fk = float(np.nanmin([v["floor_km"] for v in res_km2[test]["1"]["paths"].values()]))
        least = min(PAPER[test][1.0])
        lines.append(f"| {test} | {least:g} | {fl:.2f} | {fk:.2f} |")
        if fk > least:
            verdict.append(test)
    lines += [
        "",
        (
            f"Under the km²/s reading the paper's {', '.join(verdict)} sums lie below what any "
            "path can reach: the paper ran Q_t in m²/s, as printed. That is this study's "
            "reading; the km²/s one is the variant at the end."
            if verdict
            else "Neither reading is ruled out by the floor."
        ),
        "",
    ]
    return lines


def _seeds_section(seeds: dict[str, dict]) -> list[str]:
    n = next(iter(seeds.values()))["seeds"]
    lines = [
        f"## The paper's findings over {n} independent maps (Q_t as printed)",
        "",
        "Each map has its own Monte Carlo seed, 1000 runs along every path with the same draws "
        "(paired). Planned − best other: the planned path's sum minus the least of the other "
        f"paths' on the same map, mean [95 % CI] over maps. Lock lost: the error at the path's "
        f"end above {LOCK_SIGMAS:g}√tr P of the bound there, share of runs (mean over maps).",
        "",
        "| test, R (mGal) | planned least | planned − best other (km) | winners | "
        "lock lost, planned | lock lost, most of any path |",
        "|---|---|---|---|---|---|",
    ]
    for key, v in seeds.items():
        m, lo, hi = v["planned_minus_best_other_km"]
        flown = {k: x for k, x in v["lock_lost"].items() if np.isfinite(x)}
        worst = max(flown, key=flown.get)
        win = ", ".join(f"{k} {c}" for k, c in sorted(v["winners"].items(), key=lambda x: -x[1]))
        lines.append(
            f"| {key.replace(' R=', ', ')} | {v['planned_wins']}/{v['seeds']} | "
            f"{m:+.2f} [{lo:+.2f}, {hi:+.2f}] | {win} | {100 * v['lock_lost']['Planned']:.1f} % | "
            f"{worst} {100 * v['lock_lost'][worst]:.1f} % |"
        )
    lines.append("")
    return lines


def _sums_table(test: str, rows: dict, with_ci: bool) -> list[str]:
    """One test's sums of RMSE beside the paper's, a row per R."""
    names = list(rows["1"]["paths"])
    lines = ["| R (mGal) | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for sigma, row in rows.items():
        paper = dict(zip(PAPER[test]["names"], PAPER[test][float(sigma)], strict=True))
        cells = []
        for k in names:
            v = row["paths"][k]
            ci = v.get("ci_km") if with_ci else None
            ci_txt = f" [{ci[0]:.1f}, {ci[1]:.1f}]" if ci else ""
            cells.append(f"{v['sum_rmse_km']:.1f}{ci_txt} / {paper.get(k, math.nan):g}")
        lines.append(f"| {sigma} | " + " | ".join(cells) + " |")
    return lines


def _sums_tables(res: dict, with_ci: bool) -> list[str]:
    lines = []
    for test, rows in res.items():
        title = " [95 % CI over runs]" if with_ci else ""
        lines += [f"### {test}: sum of RMSE (km), twin{title} / paper", ""]
        lines += [*_sums_table(test, rows, with_ci), ""]
    return lines


def random_map(seed: int, correlation_m: float = MAP.correlation_m) -> GravityGrid:
    """Map ``seed`` of the study's statistics (at another correlation length if given)."""
    spec = dataclasses.replace(MAP, correlation_m=correlation_m)
    return random_anomaly_grid(spec, np.random.default_rng(seed))


def over_maps(per_map: list[dict]) -> dict:
    """Each path's sum and bound per test and R: mean and 95 % bootstrap CI over the maps."""
    out: dict = {}
    for test in TESTS:
        out[test] = {}
        for sigma in (f"{x:g}" for x in SIGMAS):
            names = list(per_map[0][test][sigma]["paths"])
            row = {}
            for k in names:
                sums = [r[test][sigma]["paths"][k]["sum_rmse_km"] for r in per_map]
                bounds = [r[test][sigma]["paths"][k]["sum_bound_km"] for r in per_map]
                row[k] = {
                    "sum_rmse_km": float(np.nanmean(sums)),
                    "ci_km": list(bootstrap_ci(sums, np.mean)),
                    "sum_bound_km": float(np.nanmean(bounds)),
                    "maps": int(np.sum(np.isfinite(sums))),
                }
            out[test][sigma] = row
    return out


def statistics_over(grids: list[GravityGrid]) -> dict[str, float]:
    """The maps' measured statistics (``map_statistics``), averaged over the maps."""
    each = [map_statistics(g) for g in grids]
    return {k: float(np.mean([e[k] for e in each])) for k in each[0]}


def _maps_section(stats: dict[str, dict], n_maps: int, n_sens: int) -> list[str]:
    lines = [
        "## The maps",
        "",
        "Measured on each map (central differences at the nodes; correlation length where the "
        "autocorrelation along East and North first falls below 1/e), mean over the maps:",
        "",
        "| map | maps | range (mGal) | σ (mGal) | median gradient (mGal/km) | 90th percentile "
        "(mGal/km) | correlation length (km) |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, st in stats.items():
        n = 1 if name.startswith("seafloor") else (n_maps if "5 km" in name else n_sens)
        lines.append(
            f"| {name} | {n} | {st['range_mgal']:.1f} | {st['sigma_mgal']:.1f} | "
            f"{st['gradient_median_mgal_per_km']:.2f} | {st['gradient_p90_mgal_per_km']:.2f} | "
            f"{st['correlation_length_m'] / 1e3:.1f} |"
        )
    main_key = f"random, L = {MAP.correlation_m / 1e3:g} km"
    sea = next(v for k, v in stats.items() if k.startswith("seafloor"))
    rng_excess = 100 * (sea["range_mgal"] / MAP.range_mgal - 1)
    gentler = stats[main_key]["gradient_median_mgal_per_km"] / sea["gradient_median_mgal_per_km"]
    lines += [
        "",
        f"The paper states one statistic of its map, the range ({MAP.range_mgal:g} mGal); the "
        "random maps are scaled to it. The correlation length is an assumption "
        f"({MAP.correlation_m / 1e3:g} km; no published statistic of the paper's region was "
        "read), so the study runs at "
        + ", ".join(f"{x / 1e3:g}" for x in SENSITIVITY_LENGTHS_M)
        + f" km too (below). The physical seafloor map's range differs from the paper's by "
        f"{rng_excess:+.0f} %, and its median gradient is {gentler:.1f}× gentler than the "
        f"{main_key} maps'.",
        "",
    ]
    return lines


def _mean_sums_table(test: str, agg: dict) -> list[str]:
    """Mean sums over the maps [CI] / paper; a path off some maps says on how many it ran."""
    names = list(agg["1"])
    n_maps = max(v["maps"] for row in agg.values() for v in row.values())
    lines = ["| R (mGal) | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for sigma, row in agg.items():
        paper = dict(zip(PAPER[test]["names"], PAPER[test][float(sigma)], strict=True))
        cells = []
        for k in names:
            v = row[k]
            lo, hi = v["ci_km"]
            pk = paper.get(k, math.nan)
            few = f" ({v['maps']} maps)" if v["maps"] < n_maps else ""
            cells.append(f"{v['sum_rmse_km']:.1f} [{lo:.1f}, {hi:.1f}]{few} / {pk:g}")
        lines.append(f"| {sigma} | " + " | ".join(cells) + " |")
    return lines


def _sensitivity_section(sens: dict[str, dict]) -> list[str]:
    lines = [
        "## How much the assumed correlation length moves the study",
        "",
        "Sums of RMSE (km), mean over the maps at each length (Q_t as printed): the planned "
        "path, the Direct path, the least of the parallel paths, and how many maps the planned "
        "path had the least sum on, against the paper's.",
        "",
        "| test, R (mGal) | "
        + " | ".join(f"L = {k}" for k in sens)
        + " | paper (planned / Direct / least L) |",
        "|---|" + "---|" * (len(sens) + 1),
    ]
    for test in TESTS:
        for sigma in (f"{x:g}" for x in SIGMAS):
            cells = []
            for agg in sens.values():
                row = agg["sums"][test][sigma]
                fam = np.nanmin([v["sum_rmse_km"] for k, v in row.items() if k.startswith("L")])
                wins = agg["seeds"][f"{test} R={sigma}"]
                cells.append(
                    f"{row['Planned']['sum_rmse_km']:.1f} / {row['Direct']['sum_rmse_km']:.1f} / "
                    f"{fam:.1f} ({wins['planned_wins']}/{wins['seeds']})"
                )
            pap = dict(zip(PAPER[test]["names"], PAPER[test][float(sigma)], strict=True))
            least = min(v for k, v in pap.items() if k.startswith("L"))
            lines.append(
                f"| {test}, {sigma} | "
                + " | ".join(cells)
                + f" | {pap['Planned']:g} / {pap['Direct']:g} / {least:g} |"
            )
    lines.append("")
    return lines


def report(res, agg, res_km2, seeds, seafloor, sens, stats, tim, figs, n_maps, n_sens) -> str:
    today = dt.date.today().isoformat()
    lines = [
        "# wang2023's PCRB-A* study on the twin's gravity maps",
        "",
        f"Generated by `validation/gravity_path_planning.py` on {today} ({platform.machine()}, "
        f"Python {platform.python_version()}).",
        f"- {'; '.join(pv.describe(PROVENANCE))}",
        "",
        f"The maps: {n_maps} independent maps drawn by their statistics "
        "(`twin.world.gravity_random`: a Gaussian random field, correlation length "
        f"{MAP.correlation_m / 1e3:g} km [assumption], each scaled to the paper's "
        f"{MAP.range_mgal:g} mGal range), 100 × 100 km at 1 km, map seed m with Monte Carlo seed "
        "m + 1. Table 1's parameters: V = 5 m/s, P0 = diag(1, 1) km², Q_t = diag(0.01², 0.01²) "
        "m²/s (as printed; the next section says why), δ = 1 km, 100 points a path, 1000 "
        "Monte Carlo runs of SITAN (`twin.onboard.gravity.sitan`, vectorised over runs; paths "
        "share their random numbers). The paper's numbers are its Tables 2–3; the twin's maps "
        "are not the paper's, so the sums agree only as far as the maps' statistics do.",
        "",
        *_q_section(res, res_km2),
        *_maps_section(stats, n_maps, n_sens),
    ]
    for test in TESTS:
        lines += [
            f"## {test}: sum of RMSE (km), twin mean [95 % CI over {n_maps} maps] / paper",
            "",
            *_mean_sums_table(test, agg[test]),
            "",
            "Sum of the PCRB's √tr P along each path (km), mean over the maps:",
            "",
        ]
        names = list(agg[test]["1"])
        lines += ["| R (mGal) | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
        for sigma, row in agg[test].items():
            lines.append(
                f"| {sigma} | " + " | ".join(f"{row[k]['sum_bound_km']:.1f}" for k in names) + " |"
            )
        r2 = res[test]["2"]
        longer = 100 * (r2["paths"]["Planned"]["length_km"] / r2["direct_km"] - 1)
        lines += [
            "",
            f"On map 0: planned path {r2['paths']['Planned']['length_km']:.1f} km against the "
            f"Direct {r2['direct_km']:.1f} km (+{longer:.0f} %), planned in "
            f"{r2['planner_s']:.2f} s, {r2['expanded']} nodes expanded.",
            "",
        ]
    lines += [
        *_seeds_section(seeds),
        *_sensitivity_section(sens),
        "## Planner time (one core, map 0)",
        "",
        f"The two tests: {tim['tests_best_s']:.2f}–{tim['tests_worst_s']:.2f} s; corner to "
        f"corner of the 100 × 100 km map: {tim['corner_to_corner_best_s']:.2f} s "
        f"({tim['corner_expanded']} nodes expanded); target < 2 s.",
        "",
        *[f"![{n}]({n})" for n in figs],
        "",
        "## The physical map: the wang2023 seafloor (map seed 0, Monte Carlo seed 1)",
        "",
        "`twin.world.gravity.wang2023_seafloor()`: a seafloor with a plateau flank through "
        "Test 1's start, a sedimented plain around Test 2's, seamounts and abyssal hills, "
        "forward-modelled at the sea surface (the flown scenario's map).",
        "",
        *_sums_tables(seafloor, with_ci=False),
        "Findings on it: "
        + "; ".join(f"{k}: {'yes' if v else 'no'}" for k, v in findings(seafloor).items())
        + ".",
        "",
        "## The variant: Q_t read as km²/s (map 0)",
        "",
        "What the twin ran before; the floor above rules it out for the paper's runs.",
        "",
        *_sums_tables(res_km2, with_ci=False),
        "Findings under this reading: "
        + "; ".join(f"{k}: {'yes' if v else 'no'}" for k, v in findings(res_km2).items())
        + ".",
    ]
    return "\n".join(lines) + "\n"


def _slim(res: dict) -> dict:
    return {
        t: {s: {k: {kk: vv for kk, vv in v.items() if kk not in ("rmse_km", "bound_km")}
                for k, v in row["paths"].items()} for s, row in rows.items()}
        for t, rows in res.items()
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", type=int, default=10, help="independent maps of the main study")
    ap.add_argument(
        "--sensitivity-maps", type=int, default=5, help="maps at each other correlation length"
    )
    args = ap.parse_args()
    if args.maps < 2 or args.sensitivity_maps < 2:
        ap.error(
            f"--maps and --sensitivity-maps must be >= 2, got {args.maps}, {args.sensitivity_maps}"
        )
    RESULTS.mkdir(exist_ok=True)
    grids = [random_map(m) for m in range(args.maps)]
    per_map = []
    for m, g in enumerate(grids):
        per_map.append(study(g, seed=m + 1, keep_runs=True))
        print(f"map {m + 1} of {args.maps} done", flush=True)
    res = per_map[0]
    agg = over_maps(per_map)
    seeds = over_seeds(per_map)
    res_km2 = study(grids[0], seed=1, keep_runs=False, q=Q_T_READINGS["km2_per_s"])
    sea_grid = anomaly_grid(wang2023_seafloor(), np.random.default_rng(0))
    seafloor = study(sea_grid, seed=1, keep_runs=True)
    stats = {f"random, L = {MAP.correlation_m / 1e3:g} km": statistics_over(grids)}
    sens = {}
    for length in SENSITIVITY_LENGTHS_M:
        g_l = [random_map(m, length) for m in range(args.sensitivity_maps)]
        runs = [study(g, seed=m + 1, keep_runs=True) for m, g in enumerate(g_l)]
        sens[f"{length / 1e3:g} km"] = {"sums": over_maps(runs), "seeds": over_seeds(runs)}
        stats[f"random, L = {length / 1e3:g} km"] = statistics_over(g_l)
        print(f"correlation length {length / 1e3:g} km done", flush=True)
    sens = {
        **{k: v for k, v in sens.items() if float(k.split()[0]) < MAP.correlation_m / 1e3},
        f"{MAP.correlation_m / 1e3:g} km": {"sums": agg, "seeds": seeds},
        **{k: v for k, v in sens.items() if float(k.split()[0]) > MAP.correlation_m / 1e3},
    }
    stats = dict(sorted(stats.items(), key=lambda kv: float(kv[0].split("= ")[1].split()[0])))
    stats["seafloor (wang2023_seafloor)"] = map_statistics(sea_grid)
    tim = timing(grids[0])
    figs = figures(grids[0], res)
    (RESULTS / "gravity_path_planning.json").write_text(
        json.dumps(
            {
                "provenance": PROVENANCE,
                "map_spec": dataclasses.asdict(MAP),
                "sums_over_maps": agg,
                "sums_map0": _slim(res),
                "findings_map0": findings(res),
                "over_maps": seeds,
                "map_statistics": stats,
                "sensitivity": sens,
                "seafloor_sums": _slim(seafloor),
                "seafloor_findings": findings(seafloor),
                "km2_per_s_findings": findings(res_km2),
                "timing": tim,
            },
            indent=2,
            default=str,
        )
        + "\n"
    )
    text = report(
        res, agg, res_km2, seeds, seafloor, sens, stats, tim, figs, args.maps,
        args.sensitivity_maps,
    )  # fmt: skip
    (RESULTS / "gravity_path_planning.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
