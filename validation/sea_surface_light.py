"""Bubbles and caustics under a wind sea: how many, how bright, how much flicker.

Measures the two near-surface error sources of issue 12's part 5 and part 1 on their own
(``sensors.polarimeter.optics.bubbles``, ``sensors.polarimeter.optics.caustics``) and in a frame,
beside what
the literature measured, and writes validation/results/sea_surface_light.md (+ .json). Every
number comes from a run here; the literature's are quoted with their source.

* The Hall–Novarini population: void fraction and scattering coefficient at the surface.
* Bubbles drawn per frame (mean of 10 frames) by depth and wind, and in a rendered frame
  (PHX050S-P binned 4×, level, sun 40° from the zenith, Jerlov II) the pixels they make at least
  twice as bright as the water behind them.
* The caustic field's irradiance contrast (coefficient of variation of F over the 4.8 m tile,
  mean of 5 sea draws) and its brightest spot, by depth and wind.
* The flicker a frame's pixels carry: the 1st and 99th percentile of S0 with caustics over S0
  with a uniform beam, by depth at 8.5 m/s (mean of 3 seeds).

Run: ``python validation/sea_surface_light.py`` (about 3 min on 2 cores).
"""

from __future__ import annotations

import datetime as dt
import json
import math
import platform
from pathlib import Path

import numpy as np

import sensors
from sensors.polarimeter.optics.bubbles import A_MAX_M, BubblePopulation
from sensors.polarimeter.optics.caustics import CausticField
from sensors.polarimeter.optics.surface import water_index
from sensors.polarimeter.optics.waves import WaveSurface, WindSea
from sensors.polarimeter.render import OpticsConfig
from twin.record import provenance as pv

RESULTS = Path(__file__).resolve().parent / "results"
SUN = np.array([math.sin(math.radians(40)), 0.0, math.cos(math.radians(40))])
WINDS = (4.4, 8.5, 12.3)  # Beaufort 3, 5, 6 (WMO mid-range; scenarios.loader.BEAUFORT_MPS)
N_WATER = water_index(35.0, 15.0, 500.0)


def population() -> dict[str, float]:
    pop = BubblePopulation(13.0)
    a = np.geomspace(10e-6, A_MAX_M, 20001)
    n = pop.spectrum(a, np.zeros_like(a))
    small = a < 50e-6
    return {
        "void_fraction_13mps": float(np.trapezoid(n * 4 / 3 * math.pi * a**3, a)),
        "b_13mps_per_m": float(np.trapezoid(n * 2 * math.pi * a**2, a)),
        "b_13mps_below_50um_per_m": float(np.trapezoid((n * 2 * math.pi * a**2)[small], a[small])),
    }


def drawn(depths: tuple[float, ...]) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    for u in WINDS:
        pop = BubblePopulation(u)
        rng = np.random.default_rng(0)
        out[f"{u}"] = {
            f"{z}": float(np.mean([pop.draw(z, rng).radii_m.size for _ in range(10)]))
            for z in depths
        }
    return out


def _frame(wind: float, depth: float, seed: int, bubbles: str, flicker: str):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(
        OpticsConfig(jerlov_type="II", wind_speed_mps=wind, bubbles=bubbles, flicker=flicker)
    )
    return cam.render_offline(np.eye(3), depth, SUN, np.random.default_rng(seed))[1]


def outliers(depths: tuple[float, ...]) -> dict[str, dict[str, float]]:
    """Pixels a frame's bubbles make ≥ 2× brighter, mean of 3 seeds."""
    out: dict[str, dict[str, float]] = {}
    for u in (8.5, 12.3):
        row = {}
        for z in depths:
            counts = []
            for seed in range(3):
                base = _frame(u, z, seed, "ideal", "ideal").stokes[..., 0]
                real = _frame(u, z, seed, "hall_novarini", "ideal").stokes[..., 0]
                counts.append(int(np.sum(real >= 2.0 * np.maximum(base, 1e-30))))
            row[f"{z}"] = float(np.mean(counts))
        out[f"{u}"] = row
    return out


def pixel_flicker(depths: tuple[float, ...]) -> dict[str, list[float]]:
    out = {}
    for z in depths:
        lo, hi = [], []
        for seed in range(3):
            a = _frame(8.5, z, seed, "ideal", "ideal").stokes[..., 0]
            b = _frame(8.5, z, seed, "ideal", "caustics").stokes[..., 0]
            m = a > 0
            p1, p99 = np.percentile(b[m] / a[m], [1, 99])
            lo.append(p1), hi.append(p99)
        out[f"{z}"] = [float(np.mean(lo)), float(np.mean(hi))]
    return out


def main() -> None:
    bubble_depths = (0.3, 0.98, 2.0, 5.0, 10.0)
    caustic_depths = (0.5, 1.0, 2.6, 5.0, 10.0)
    res = {
        "population": population(),
        "drawn": drawn(bubble_depths),
        "outliers": outliers((0.3, 0.98, 2.0)),
        "caustics": {},
        "flicker": pixel_flicker((0.5, 2.0, 10.0)),
        "provenance": pv.provenance(),
    }
    # A field per depth, tabulated at that depth exactly (levels=2: the surface and it).
    contrast: dict[str, dict[str, list[float]]] = {}
    for u in WINDS:
        row = {}
        for z in caustic_depths:
            cv, mx = [], []
            for seed in range(5):
                waves = WaveSurface(WindSea(wind_speed_mps=u), np.random.default_rng(seed))
                cf = CausticField(waves, SUN, N_WATER, z, levels=2)
                f = cf.fields[-1]
                cv.append(float(f.std()))
                mx.append(float(f.max()))
            row[f"{z}"] = [float(np.mean(cv)), float(np.mean(mx))]
        contrast[f"{u}"] = row
    res["caustics"] = contrast
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "sea_surface_light.json").write_text(json.dumps(res, indent=2) + "\n")
    (RESULTS / "sea_surface_light.md").write_text(report(res, bubble_depths, caustic_depths))
    print((RESULTS / "sea_surface_light.md").read_text())


def report(res: dict, bubble_depths: tuple[float, ...], caustic_depths: tuple[float, ...]) -> str:
    p = res["population"]
    today = dt.date.today().isoformat()
    lines = [
        "# Bubbles and caustics under a wind sea",
        "",
        f"Generated by `validation/sea_surface_light.py` on {today} ({platform.machine()}, "
        f"Python {platform.python_version()}).",
        "",
        *("- " + x for x in pv.describe(res["provenance"])),
        "",
        "## The bubble population (Hall–Novarini, `sensors.polarimeter.optics.bubbles`)",
        "",
        f"At the surface under 13 m/s: void fraction {p['void_fraction_13mps']:.2g}, "
        f"scattering coefficient b = {p['b_13mps_per_m']:.3g} /m (geometric, Q = 2), of which "
        f"{p['b_13mps_below_50um_per_m']:.3g} /m from bubbles under 50 µm (the haze not drawn). "
        "Measured under breaking seas: void fractions of order 1e-6 near the surface (Vagle & "
        "Farmer 1992) and bubble b of a few 1e-2 /m (Terrill, Melville & Stramski 2001).",
        "",
        "Bubbles drawn per frame (the bright enough ones: radius ≥ 50 µm within "
        "4 m · a / 1 mm of the camera), mean of 10 frames:",
        "",
        "| wind (m/s) | " + " | ".join(f"{z} m" for z in bubble_depths) + " |",
        "|---|" + "---|" * len(bubble_depths),
    ]
    for u, row in res["drawn"].items():
        lines.append(f"| {u} | " + " | ".join(f"{row[f'{z}']:.0f}" for z in bubble_depths) + " |")
    lines += [
        "",
        "Pixels a frame's bubbles make at least twice as bright as the water behind them "
        "(PHX050S-P binned 4×, 612 × 512, level, sun 40° from the zenith, Jerlov II; mean of "
        "3 seeds):",
        "",
        "| wind (m/s) | " + " | ".join(f"{z} m" for z in res["outliers"]["8.5"]) + " |",
        "|---|" + "---|" * len(res["outliers"]["8.5"]),
    ]
    for u, row in res["outliers"].items():
        lines.append(f"| {u} | " + " | ".join(f"{v:.1f}" for v in row.values()) + " |")
    lines += [
        "",
        "## Caustics (`sensors.polarimeter.optics.caustics`)",
        "",
        "The refracted sun beam's irradiance relative to a flat sea's, F, over the 4.8 m tile: "
        "its coefficient of variation and its brightest cell (7.5 cm), mean of 5 sea draws. "
        "Beside it: near the surface the fluctuations are of the order of the mean (Snyder & "
        "Dera 1970); enhancements up to 40× the mean at 1 m are possible and the strongest "
        "fluctuations lie at 0.5–10 m (Hieronymi 2011); the CV above 2 m is on average four "
        "times that at 25 m (Hieronymi & Macke 2010). F is the direct beam's alone (a "
        "measured E_d carries the diffuse light too, which lowers its CV), and rays below the "
        "surface are straight (no beam blur), so deep values are upper bounds.",
        "",
        "| wind (m/s) | " + " | ".join(f"{z} m: CV / max" for z in caustic_depths) + " |",
        "|---|" + "---|" * len(caustic_depths),
    ]
    for u, row in res["caustics"].items():
        cells = [f"{row[f'{z}'][0]:.2f} / {row[f'{z}'][1]:.1f}" for z in caustic_depths]
        lines.append(f"| {u} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "The flicker in a frame's pixels at 8.5 m/s: S0 with caustics over S0 with a uniform "
        "beam, 1st and 99th percentile over the frame (mean of 3 seeds). Only the sun-lit "
        "single-scattered light flickers, and a pixel's ray averages F over metres of path:",
        "",
        "| depth (m) | 1 % | 99 % |",
        "|---|---|---|",
    ]
    for z, (lo, hi) in res["flicker"].items():
        lines.append(f"| {z} | {lo:.3f} | {hi:.3f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
