"""The LIG paper's sea trials in the twin: POL/INS falls behind LIG/INS with depth.

The paper (hu2024 §4.3) reports heading errors POL/INS 3.6° vs LIG/INS 1.6° at 10 m and 16.1° vs
2.2° at 15 m. In the twin's radiative-transfer light field (docs/polarimeter.md) the polarization
pattern's apparent sun drifts towards the zenith with depth and a filter that fuses the full
solar vector (as the paper's does) inherits it: POL/INS degrades from 10 to 15 m while LIG/INS
stays nearly flat. At 10 m the two are close — POL even ahead in the first minute and over whole
trials (benchmarks/results/sea_trials.md) — which is what transport gives, not the paper's
ranking; these tests assert what the physics gives.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest

import scenarios
from twin.app.run import run_scenario


def _variants(depth: int, duration_s: float, tmp: Path) -> dict:
    sc = scenarios.load(f"sea_trial_{depth}m")
    sc = dataclasses.replace(
        sc, duration_s=duration_s, recording=dataclasses.replace(sc.recording, camera=False)
    )
    return run_scenario(sc, tmp / f"d{depth}", camera=False)["navigation"]["variants"]


def test_the_first_minute_of_both_trials_shows_the_trend(tmp_path) -> None:
    gap = {}
    for depth in (10, 15):
        v = _variants(depth, 60.0, tmp_path)
        pol, lig = v["pol"], v["lig"]
        assert pol["compass"]["sun_updates_applied"] == pol["compass"]["fixes"] > 50  # no gate
        # POL's zenith-biased sun drags the level: its roll error is several degrees, LIG's is not.
        assert pol["roll_rmse_deg"] > 3.0 > 1.5 > lig["roll_rmse_deg"]
        gap[depth] = pol["heading_rmse_deg"] - lig["heading_rmse_deg"]
    assert gap[15] > 0  # at 15 m LIG/INS is ahead …
    assert gap[15] > gap[10]  # … and POL/INS has lost ground since 10 m


@pytest.mark.slow
def test_the_sea_trials_from_the_cli_compare_pol_and_lig(tmp_path) -> None:
    rmse = {}
    for depth in (10, 15):
        out = tmp_path / f"st{depth}"
        proc = subprocess.run(
            [sys.executable, "-m", "twin.app.cli", "run", f"sea_trial_{depth}m", "--out", str(out),
             "--quiet", "--no-camera"],
            capture_output=True, text=True, timeout=1800,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        assert "pol:" in proc.stdout and "lig:" in proc.stdout
        m = json.loads((out / "metrics.json").read_text())
        assert m["status"] == "mission_complete"
        rmse[depth] = {k: v["heading_rmse_deg"] for k, v in m["navigation"]["variants"].items()}
    # benchmarks/results/sea_trials.md, seed 0: 10 m INS 1.94°, POL 1.47°, LIG 1.67°; 15 m INS
    # 1.94°, POL 9.05°, LIG 1.76°.
    assert rmse[15]["lig"] < rmse[15]["ins"] < rmse[15]["pol"]
    assert abs(rmse[10]["pol"] - rmse[10]["lig"]) < 0.5 < rmse[15]["pol"] - rmse[15]["lig"]
    assert rmse[15]["pol"] > 3 * rmse[10]["pol"]  # POL/INS degrades with depth …
    assert rmse[15]["lig"] < 1.2 * rmse[10]["lig"]  # … LIG/INS hardly
