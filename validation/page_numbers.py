"""The numbers of docs/validation.md: for each claim, a function that reads them from results.

Each takes the :class:`page.Results` and returns the section's lines; the claims that use them
are declared in page_claims.py.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable

from page import Results, g, md_table, pct, pick

CHECKS = "validation/results/checks.json"
CAMPAIGNS = "validation/results/campaigns"


def _one(r: Results, key: str) -> float:
    (value,) = r.measured(key)
    return value


class _Number:
    """A measured value in a template: ``{key:.2f}`` as format() has it, ``{key:pct}`` a
    percentage, ``{key:sig2}`` two significant digits (:func:`page.g`)."""

    def __init__(self, value: float) -> None:
        self.value = value

    def __format__(self, spec: str) -> str:
        if spec == "pct":
            return pct(self.value)
        if spec.startswith("sig"):
            return g(self.value, int(spec[3:] or 3))
        return format(self.value, spec)


class _Measured(dict):
    """The suite's measurements by name, for ``str.format_map`` (a missing one is an error)."""

    def __init__(self, r: Results) -> None:
        super().__init__()
        self.r = r

    def __missing__(self, key: str) -> _Number:
        return _Number(_one(self.r, key))


def measured_lines(*templates: str) -> Callable[[Results], list[str]]:
    """A claim's body: lines whose ``{key:spec}`` fields are what ``measures`` tests recorded."""

    def body(r: Results) -> list[str]:
        values = _Measured(r)
        return [t.format_map(values) for t in templates]

    return body


def _max_abs(r: Results, key: str) -> float:
    return max(abs(v) for v in r.measured(key))


# ---- the vehicle --------------------------------------------------------------------------------


def turn_full(r: Results) -> list[str]:
    d = r.json("validation/results/turning_vs_pvs.json")
    rows = []
    for label, key in (
        ("twin", "twin"),
        ("twin with PVS's two modelling choices", "twin, PVS choices"),
        ("PythonVehicleSimulator", "pvs"),
    ):
        x = d[key]
        rows.append(
            [
                label,
                f"{x['turn_diameter_m']:.1f}",
                f"{x['yaw_rate_deg_s']:.2f}",
                f"{x['turn_heel_deg']:.2f}",
                f"{x['straight_heel_deg']:.2f}",
                f"{x['straight_speed_mps']:.3f}",
            ]
        )
    return md_table(
        [
            "model",
            "diameter (m)",
            "yaw rate (°/s)",
            "heel in the turn (°)",
            "heel straight (°)",
            "speed straight (m/s)",
        ],
        rows,
    )


def plant_rtf(r: Results) -> list[str]:
    d = r.json("benchmarks/results/plant_rtf.json")
    return [
        f"- the plant alone: {d['plant']['rtf']:.0f}× real time ({d['plant']['us_per_step']:.0f} µs"
        f" a 10 ms step); a full run with sensors and recording {d['full_run']['rtf']:.0f}×"
        f" ({d['machine']})"
    ]


# ---- sensors and optics -------------------------------------------------------------------------


def snell_window(r: Results) -> list[str]:
    data = r.json(CHECKS)["measured"]
    rows = []
    for key in sorted(k for k in data if k.startswith("snell_half_angle_deg[")):
        rows.append([key.split("[", 1)[1].rstrip("]"), f"{data[key][0]:.2f}"])
    return md_table(["water (salinity S, wavelength)", "half-angle (°)"], rows)


def sky(r: Results) -> list[str]:
    return [
        "- Rayleigh sky through the MOI pinhole camera against the paper's eqs. 9–25, 6 suns and"
        f" attitudes: DoP within {g(_max_abs(r, 'sky_rayleigh_vs_moi_dop_max_abs'), 2)}, AoP "
        f"within {g(_max_abs(r, 'sky_rayleigh_vs_moi_aop_max_abs_rad'), 2)} rad",
        "- Berry's sky with δ = 0 against Rayleigh's, 4 suns: Stokes within "
        f"{g(_max_abs(r, 'sky_berry0_vs_rayleigh_max_abs'), 2)}",
    ]


def stokes(r: Results) -> list[str]:
    return [
        "- super-pixel Stokes against polanalyser's `calcStokes`: within "
        f"{g(_one(r, 'stokes_superpixel_vs_polanalyser_max_abs_dn'), 2)} DN",
        "- demosaiced (bilinear) against polanalyser's demosaicing, interior: within "
        f"{g(_max_abs(r, 'stokes_demosaiced_vs_polanalyser_max_abs_dn'), 2)} DN",
    ]


def aop_noise(r: Results) -> list[str]:
    bare = r.measured("aop_noise_vs_bare_law_rel")
    full = r.measured("aop_noise_vs_full_law_rel")
    return [
        f"- σ_AoP against 1/(2P√S0): {', '.join(f'{v:+.1%}' for v in bare)} "
        "(two fields, 128×128 super-pixels each)",
        "- against the law with read noise, quantization and diattenuation: "
        f"{', '.join(f'{v:+.1%}' for v in full)}",
    ]


def lightfield(r: Results) -> list[str]:
    rows = r.table("validation/results/lightfield_reference.md", "K_d against Jerlov")
    d = r.json("validation/results/lightfield_reference.json")
    energy = d["validation"]["energy"]
    after = r.table("validation/results/renderer_vs_reference.md", "ring by ring")
    worst = 0.0
    for row in after:
        if row["run"].startswith("2 "):
            for key, cell in row.items():
                if key.endswith("°"):
                    worst = max(worst, abs(float(cell.split("±")[0].strip().rstrip("%"))))
    fast = r.json("validation/results/fast_path_error.json")["rows"]
    return [
        *md_table(
            ["Jerlov type", "K_d reference (1/m)", "K_d Jerlov (1/m)", "ratio", "a, b from"],
            pick(rows, ["type", "K_d reference", "K_d Jerlov", "ratio", "a, b from"]),
        ),
        "",
        "- K_d outside ±10 % of Jerlov's: "
        + ", ".join(x["type"] for x in rows if abs(float(x["ratio"]) - 1.0) > 0.10)
        + " (docs/polarimeter.md gives each water's a, b and its source)",
        f"- energy closes to {g(energy['max_flux_imbalance'], 2)} "
        f"({d['photons']:,} histories a case)",
        f"- the renderer against the reference, ring by ring 2–90° from the refracted sun, five "
        f"cases at and between the table's nodes: within ±{worst:.1f} %",
        "- the fast path against the exact chain, S0 in Snell's window, "
        f"{len(fast)} scenes: {min(x['s0_window'] for x in fast):.1%}–"
        f"{max(x['s0_window'] for x in fast):.1%}",
    ]


LIG_PAPER = "LIG zenith, the paper's method"  # the sensitivity table's column


def sensitivity(r: Results) -> list[str]:
    rows = r.table("validation/results/optics_sensitivity.md", "Sensitivity")
    by_setting: dict[str, list[dict[str, str]]] = defaultdict(list)
    for row in rows:
        by_setting[row["setting"]].append(row)
    # The first setting is the sourced one; each other changes one input to an end of its range.
    base = {(x["water"], x["depth (m)"]): x for x in next(iter(by_setting.values()))}
    out = []
    for setting, cells in list(by_setting.items())[1:]:
        moves = {"POL zenith": 0.0, LIG_PAPER: 0.0, "window DoP max": 0.0}
        for x in cells:
            b = base.get((x["water"], x["depth (m)"]))
            if b is None:
                continue
            for k in moves:
                moves[k] = max(moves[k], abs(float(x[k]) - float(b[k])))
        out.append(
            [
                setting,
                f"{moves['POL zenith']:.2f}°",
                f"{moves[LIG_PAPER]:.2f}°",
                f"{moves['window DoP max']:.3f}",
            ]
        )
    return md_table(
        ["input changed", "POL zenith moves ≤", "paper's LIG zenith moves ≤", "window DoP moves ≤"],
        out,
    )


def sea_surface(r: Results) -> list[str]:
    d = r.json("validation/results/sea_surface_light.json")
    pop = d["population"]
    return [
        f"- at the surface under 13 m/s: void fraction {g(pop['void_fraction_13mps'], 2)}, "
        f"b = {pop['b_13mps_per_m']:.3f} /m (measured under breaking seas: ~1e-6 and a few "
        "1e-2 /m, Vagle & Farmer 1992; Terrill, Melville & Stramski 2001)",
        f"- bubbles drawn a frame at 0.98 m under 8.5 m/s: {d['drawn']['8.5']['0.98']:.0f}; "
        f"pixels they make ≥ 2× brighter: {d['outliers']['8.5']['0.98']:.1f} "
        f"({d['outliers']['12.3']['0.98']:.0f} under 12.3 m/s)",
        "",
        *md_table(
            ["wind (m/s)", "caustic CV / max at 0.5 m", "1.0 m", "2.6 m", "5.0 m", "10.0 m"],
            [
                [w, *(f"{cv:.2f} / {mx:.1f}" for cv, mx in d["caustics"][w].values())]
                for w in d["caustics"]
            ],
        ),
    ]


# ---- compass methods ----------------------------------------------------------------------------


def _pooled(rows: list[dict[str, str]], variant: str, **where: str) -> tuple[float, int]:
    """Run-weighted mean of a campaign's per-group means, and the number of runs."""
    total, n = 0.0, 0
    for row in rows:
        if row["variant"] != variant or any(row[f"param.{k}"] != v for k, v in where.items()):
            continue
        k = int(row["n"])
        if k:
            total += float(row["mean"]) * k
            n += k
    return (total / n if n else math.nan), n


def moi_noise(r: Results) -> list[str]:
    rows = r.csv(f"{CAMPAIGNS}/moi_noise/groups.csv")
    cases = sorted({x["param.case"] for x in rows})
    out = []
    for variant in ("moi", "patz", "ht"):
        cells = []
        for case in cases:
            sel = [x for x in rows if x["variant"] == variant and x["param.case"] == case]
            worst = max(sel, key=lambda x: float(x["mean"]))
            cells.append(
                f"{g(float(worst['mean']), 2)} [{g(float(worst['mean_lo']), 2)}, "
                f"{g(float(worst['mean_hi']), 2)}] at {float(worst['param.elevation_deg']):.0f}°"
            )
        out.append([variant.upper(), *cells])
    return md_table(["method", *(f"{c}: worst elevation's mean error (°)" for c in cases)], out)


def snell_attitude(r: Results) -> list[str]:
    yaw = r.csv(f"{CAMPAIGNS}/snell_attitude/groups.csv")
    roll = r.csv(f"{CAMPAIGNS}/snell_attitude/roll_error_deg/groups.csv")
    pitch = r.csv(f"{CAMPAIGNS}/snell_attitude/pitch_error_deg/groups.csv")
    ok = r.csv(f"{CAMPAIGNS}/snell_attitude/ok/groups.csv")  # every frame has an `ok`
    out = []
    for preset in ("phx050s_p_bin4", "phx050s_p"):
        for variant, label in (("snell_paper", "the paper's"), ("snell", "the twin's")):
            rr, n = _pooled(roll, variant, preset=preset)
            pp, _ = _pooled(pitch, variant, preset=preset)
            yy, _ = _pooled(yaw, variant, preset=preset)
            _, total = _pooled(ok, variant, preset=preset)
            out.append([preset, label, f"{rr:.1f}", f"{pp:.1f}", f"{yy:.0f}", f"{n} of {total}"])
    return [
        *md_table(
            [
                "camera",
                "method",
                "roll MAE (°)",
                "pitch MAE (°)",
                "yaw MAE (°)",
                "frames with a fix",
            ],
            out,
        ),
        "",
        "Pooled over the tilts, weighted by each cell's fixes; each cell's 95 % interval is in the"
        " report. The paper reports 0.75 / 0.62 / 0.53° in a clear-water tank (xin2024 Table 1).",
    ]


def compass_underwater(r: Results) -> list[str]:
    zen = r.csv(f"{CAMPAIGNS}/compass_underwater/zenith_bias_deg/groups.csv")
    az = r.csv(f"{CAMPAIGNS}/compass_underwater/groups.csv")
    variants = (
        ("pol_paper", "POL, paper"),
        ("pol", "POL, twin"),
        ("lig_paper", "LIG, paper"),
        ("lig", "LIG, twin"),
    )
    cells: dict[tuple[str, str], dict[str, str]] = defaultdict(dict)
    for row in zen:
        lo, hi = float(row["mean_lo"]), float(row["mean_hi"])
        cells[(row["param.jerlov_type"], row["param.depth_m"])][row["variant"]] = (
            f"{float(row['mean']):+.1f} [{lo:+.1f}, {hi:+.1f}]"
        )
    order = ["I", "IA", "IB", "II", "III", "1C", "3C"]
    keys = sorted(cells, key=lambda k: (order.index(k[0]) if k[0] in order else 99, float(k[1])))
    keys = [k for k in keys if float(k[1]) in (1.0, 5.0, 20.0)]
    rows = [
        [w, f"{float(d):g}", *(cells[(w, d)].get(v, "—") for v, _ in variants)] for w, d in keys
    ]
    az_range = []
    for v, label in variants:
        means = [float(x["mean"]) for x in az if x["variant"] == v]
        az_range.append(f"{label} {min(means):.2f}–{max(means):.2f}°")
    n = {int(x["n"]) for x in zen}
    return [
        "Zenith bias of the apparent sun (°, + towards the horizon), mean [95 % CI] over "
        f"{'/'.join(map(str, sorted(n)))} seeds a cell, at 1, 5 and 20 m (every depth in the "
        "report):",
        "",
        *md_table(["water", "depth (m)", *(label for _, label in variants)], rows),
        "",
        "- azimuth mean absolute error, range over all cells: " + "; ".join(az_range),
    ]


HW = "validation/results/hardware_experiments.md"


def hardware(r: Results) -> list[str]:
    turn = r.table(HW, "Snell-window attitude on a turntable")
    turn = [x for x in turn if x["cell"] == "budget"]
    roia = r.table(HW, "ROI-A static")
    tank = r.table(HW, "milky tank")
    sea = r.table(HW, "sea trials")
    return [
        "**Snell turntable** (xin2024 Table 1: 0.75 / 0.62 / 0.53°), the full error budget:",
        "",
        *md_table(
            ["method", "roll MAE (°)", "pitch MAE (°)", "yaw MAE (°)"],
            pick(turn, ["method", "roll MAE (°)", "pitch MAE (°)", "yaw MAE (°)"]),
        ),
        "",
        "**ROI-A heading** (fang2024 §2.2–2.3):",
        "",
        *md_table(
            ["case", "method", "twin RMSE (°)", "paper (°)", "twin ÷ paper"],
            pick(roia, ["case", "method", "twin RMSE (°)", "paper (°)", "twin ÷ paper"]),
        ),
        "",
        "**Milky tank** (hu2024 §4.2):",
        "",
        *md_table(
            ["method", "quantity", "twin MAE (°)", "paper (°)", "twin ÷ paper"],
            pick(tank, ["method", "quantity", "twin MAE (°)", "paper (°)", "twin ÷ paper"]),
        ),
        "",
        "**Sea trials, heading RMSE** (hu2024 §4.3):",
        "",
        *md_table(list(sea[0]), [list(x.values()) for x in sea]),
    ]


# ---- gravity ------------------------------------------------------------------------------------


def gravity(r: Results) -> list[str]:
    rel = "validation/results/gravity_path_planning.md"
    findings = r.table(rel, "The paper's findings over")
    length = r.table(rel, "correlation length moves")
    flown = r.table("validation/results/gravity_aided_twin.md", "planned route flown", index=2)
    flown = [x for x in flown if x["matching"] == "on" or x["filter"] == "ins"]
    plan = r.table("validation/results/gravity_aided_twin.md", "planned route flown", index=0)
    route = next(x["value"] for x in plan if x["quantity (matching on, steering on LIG/INS)"]
                 .startswith("planned route"))  # fmt: skip
    return [
        "**PCRB-A\\* on 10 drawn maps (5 km correlation length, an assumption), Q_t as printed:**",
        "",
        *md_table(
            ["test, R (mGal)", "planned least", "planned − best other (km)", "lock lost, planned"],
            pick(
                findings,
                [
                    "test, R (mGal)",
                    "planned least",
                    "planned − best other (km)",
                    "lock lost, planned",
                ],
            ),
        ),
        "",
        "**How the assumed correlation length moves it** (sums of RMSE in km: planned / Direct /"
        " least parallel path, and on how many maps the planned path was least):",
        "",
        *md_table(list(length[0]), [list(x.values()) for x in length]),
        "",
        f"**The planned route flown by the twin** ({route} km planned, navigation-grade INS):",
        "",
        *md_table(
            ["matching", "steering on", "filter", "position RMSE (m)", "RMSE ÷ PCRB"],
            pick(flown, ["matching", "steering on", "filter", "position RMSE (m)", "RMSE ÷ PCRB"]),
        ),
    ]


# ---- navigation ---------------------------------------------------------------------------------


# ---- speed --------------------------------------------------------------------------------------


def ins_rtf(r: Results) -> list[str]:
    d = r.json("benchmarks/results/ins_filter_rtf.json")
    return [
        f"- INS + 15-state filter: {d['rtf']:.0f}× real time ({d['us_per_imu_step']:.0f} µs an "
        f"IMU step); the INS alone {d['ins_alone_rtf']:.0f}× ({d['env']})"
    ]


def frame(r: Results) -> list[str]:
    d = r.json("benchmarks/results/polarimeter_frame.json")
    base = {x["shape"]: x for x in d["baseline"]["rows"]}
    rows = []
    for x in d["rows"]:
        lo, hi = x["frame_ms_range"]
        b = base.get(x["shape"])
        rows.append(
            [
                x["shape"],
                f"{x['frame_ms']:.1f} [{lo:.1f}–{hi:.1f}]",
                f"{x['frame_with_occlusion_ms']:.1f}",
                f"{b['frame_ms']:.1f}" if b else "—",
            ]
        )
    return [
        *md_table(
            ["frame", "whole frame (ms), median [range]", "with occlusion (ms)", "baseline (ms)"],
            rows,
        ),
        "",
        f"{d['meta']['rounds']} interleaved rounds on one core; targets 100 ms and 10 ms.",
    ]


def compass_timing(r: Results) -> list[str]:
    rows = r.table("benchmarks/results/compass_timing.md", "Compass methods")
    return md_table(["method", "median ms"], pick(rows, ["method", "median ms"]))


def sea_trial_rtf(r: Results) -> list[str]:
    d = r.json("benchmarks/results/sea_trial_rtf.json")
    mission = d["meta"]["mission_s"]
    rows = []
    commit = (d["meta"]["provenance"].get("commit") or "?")[:7]
    for build, runs in d["rows"].items():
        label = f"{commit} (this study's)" if build == "current" else f"{build} (baseline)"
        for x in runs:
            what = f"{len(x['variants'])} filters" + (", recording" if x["recording"] else "")
            rows.append([label, what, f"{mission / x['wall_s']:.1f}×"])
    return [
        *md_table(["build", "run", "real-time factor (median)"], rows),
        "",
        "Issue #31's targets: 100× without the recording, 60× with it.",
    ]


def sea_trial_limit(r: Results) -> list[str]:
    d = r.json("benchmarks/results/sea_trial_profile.json")
    lim = d.get("limit")
    if lim is None:
        return ["Not measured: this profile predates the limit (run the profile again)."]
    sim = lim["sim_s"]
    rows = [
        [part, f"{1e3 * p['whole_s'] / sim:.1f}", f"{1e3 * p['compiled_s'] / sim:.1f}"]
        for part, p in lim["parts"].items()
    ]
    rows.append(
        ["the flight", f"{1e3 * lim['flight_s'] / sim:.1f}", f"{1e3 * lim['compiled_s'] / sim:.1f}"]
    )
    return [
        *md_table(["part", "whole, ms per simulated s", "compiled and C work alone"], rows),
        "",
        f"Measured {lim['measured_rtf']:.1f}× real time (the profile's timers in); the compiled "
        f"and C work alone allows at most {lim['ceiling_rtf']:.0f}× "
        f"({lim['ceiling_less_dispatch_rtf']:.0f}× without numba's dispatch). Issue #31's "
        "target: 100×.",
    ]


def throughput(r: Results) -> list[str]:
    d = r.json("benchmarks/results/campaign_throughput.json")
    rows = [
        [k, f"{v['runs_per_min']:.1f}", f"{v['steady_runs_per_min']:.1f}"]
        for k, v in d.items()
        if isinstance(v, dict) and "runs_per_min" in v
    ]
    return [
        *md_table(["backend", "runs/min", "after start-up"], rows),
        "",
        f"{d['runs']} runs of a {d['duration_s']:.0f} s trial ({d['machine']}).",
    ]
