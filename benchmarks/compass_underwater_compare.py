"""Before/after: LIG and POL under water, phenomenological light field vs radiative transfer.

    python benchmarks/compass_underwater_compare.py

Reads benchmarks/results/compass_underwater_phenomenological.json (the same benchmark run by the
code before the radiative-transfer light field, same cells, frames and seed),
compass_underwater_rt_uniform_sky.json (radiative transfer whose scattered sky light came from a
uniform unpolarized sky) and compass_underwater.json (now: the sky model's own sky), writes
compass_underwater_before_after.md.
"""

from __future__ import annotations

import json
from pathlib import Path

RESULTS = Path(__file__).parent / "results"


STAGES = (
    ("compass_underwater_phenomenological.json", "phenomenological"),
    ("compass_underwater_rt_uniform_sky.json", "RT, uniform sky"),
    ("compass_underwater.json", "RT, sky model"),
)


def main() -> None:
    runs = [
        (json.loads((RESULTS / f).read_text()), label)
        for f, label in STAGES
        if (RESULTS / f).exists()
    ]
    after = runs[-1][0]
    keys = [{(r["water"], r["depth_m"]): r for r in run["rows"]} for run, _ in runs]

    def f(v: float | None, ci: float | None = None) -> str:
        if v is None:
            return "—"
        return f"{v:+.1f}" + (f" ± {ci:.1f}" if ci is not None else "")

    arrow = " → ".join(label for _, label in runs)
    lines = [
        "# LIG and POL under water: before and after the radiative-transfer light field",
        "",
        f"`python benchmarks/compass_underwater_compare.py`: {after['meta']['frames_per_cell']} "
        f"frames per cell, seed {after['meta']['seed']}, camera `{after['meta']['preset']}`, the "
        "same cells and random draws in every stage. Zenith bias = mean signed zenith error of "
        "the solar vector ± its 95 % interval (negative = the apparent sun lies towards the "
        "zenith); azimuth = heading MAE. Stages: the phenomenological model (depolarization "
        "curve, equivalent-incident-light sun); radiative transfer with the scattered sky light "
        "of a uniform unpolarized sky; radiative transfer with the sky model's own sky (its "
        "radiance and polarization), untuned.",
        "",
        f"Each cell: {arrow}.",
        "",
        "| water | depth m | LIG zenith bias | POL zenith bias | LIG azimuth MAE | "
        "POL azimuth MAE |",
        "|---|---|---|---|---|---|",
    ]
    for r in after["rows"]:
        rows = [k.get((r["water"], r["depth_m"])) for k in keys]
        if any(x is None for x in rows):
            continue
        cells = []
        for name in ("LIG", "POL"):
            cells.append(
                " → ".join(f(x[name]["zen_bias"], x[name].get("zen_bias_ci")) for x in rows)
            )
        for name in ("LIG", "POL"):
            cells.append(" → ".join(f(x[name]["az_mae"])[1:] for x in rows))
        lines.append(f"| {r['water']} | {r['depth_m']:g} | " + " | ".join(cells) + " |")
    lines.append("")
    (RESULTS / "compass_underwater_before_after.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
