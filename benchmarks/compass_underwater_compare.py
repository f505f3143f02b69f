"""Before/after: LIG and POL under water, phenomenological light field vs radiative transfer.

    python benchmarks/compass_underwater_compare.py

Reads benchmarks/results/compass_underwater_phenomenological.json (the same benchmark run by the
code before the radiative-transfer light field, same cells, frames and seed) and
compass_underwater.json (now), writes compass_underwater_before_after.md.
"""

from __future__ import annotations

import json
from pathlib import Path

RESULTS = Path(__file__).parent / "results"


def main() -> None:
    before = json.loads((RESULTS / "compass_underwater_phenomenological.json").read_text())
    after = json.loads((RESULTS / "compass_underwater.json").read_text())
    key = {(r["water"], r["depth_m"]): r for r in before["rows"]}

    def f(v: float | None, ci: float | None = None) -> str:
        if v is None:
            return "—"
        return f"{v:+.1f}" + (f" ± {ci:.1f}" if ci is not None else "")

    lines = [
        "# LIG and POL under water: before and after the radiative-transfer light field",
        "",
        f"`python benchmarks/compass_underwater_compare.py`: {after['meta']['frames_per_cell']} "
        f"frames per cell, seed {after['meta']['seed']}, camera `{after['meta']['preset']}`, the "
        "same cells and random draws before and after. Zenith bias = mean signed zenith error of "
        "the solar vector ± its 95 % interval (negative = the apparent sun lies towards the "
        "zenith); azimuth = heading MAE. Before: the phenomenological model (depolarization curve, "
        "equivalent-incident-light sun); after: radiative transfer, untuned.",
        "",
        "| water | depth m | LIG zenith bias before → after | POL zenith bias before → after | "
        "LIG azimuth MAE before → after | POL azimuth MAE before → after |",
        "|---|---|---|---|---|---|",
    ]
    for r in after["rows"]:
        b = key.get((r["water"], r["depth_m"]))
        if b is None:
            continue
        cells = []
        for name in ("LIG", "POL"):
            cells.append(
                f"{f(b[name]['zen_bias'], b[name].get('zen_bias_ci'))} → "
                f"{f(r[name]['zen_bias'], r[name].get('zen_bias_ci'))}"
            )
        for name in ("LIG", "POL"):
            cells.append(f"{f(b[name]['az_mae'])[1:]} → {f(r[name]['az_mae'])[1:]}")
        lines.append(f"| {r['water']} | {r['depth_m']:g} | " + " | ".join(cells) + " |")
    lines.append("")
    (RESULTS / "compass_underwater_before_after.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
