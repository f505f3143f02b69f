"""The seeds' hardware experiments as study trials: their conditions, checks and determinism.

The full campaigns (20 seeds a cell) are benchmarks (validation/hardware_experiments.py); here
one session of the cells that need no first-use radiative-transfer table (clear water, a flat
tank) runs, to show the trial works end to end and is deterministic.
"""

from __future__ import annotations

import math

import pytest

from twin.campaign import lig_tank, roia_static, snell_turntable
from twin.campaign.spec import load_campaign
from twin.campaign.trials import load_trial


def test_the_tank_wind_chain():
    # Force 5 (9.35 m/s at 10 m over grass, z0 = 3 cm) is 5.64 m/s at 1 m, i.e. the friction
    # velocity of a 7.32 m/s wind at 12.5 m over water (z0 = 0.2 mm).
    u1 = 9.35 * math.log(1 / 0.03) / math.log(10 / 0.03)
    assert u1 == pytest.approx(5.64, abs=0.01)
    assert snell_turntable.tank_wind_mps(5) == pytest.approx(
        u1 * math.log(12.5 / 2e-4) / math.log(1 / 2e-4)
    )
    assert snell_turntable.tank_wind_mps(6) == pytest.approx(9.63, abs=0.01)
    assert snell_turntable.tank_wind_mps(5) < snell_turntable.tank_wind_mps(5.5) < 9.63


def test_milk_scattering_from_anomalous_diffraction():
    # van de Hulst's Q(ρ) tends to 2 for large phase shifts; 200 mL in φ3 × 1 m: 1.25 /m.
    assert lig_tank.milk_b_per_m() == pytest.approx(1.247, abs=0.005)
    assert lig_tank.milk_b_per_m(0.0) == 0.0
    assert lig_tank.milk_b_per_m(400e-6) == pytest.approx(2 * lig_tank.milk_b_per_m())


@pytest.mark.parametrize(
    ("trial", "params", "field"),
    [
        ("snell_turntable", {"case": "sunny"}, "case"),
        ("snell_turntable", {"wind_beaufort": 13}, "wind_beaufort"),
        ("snell_turntable", {"depth_m": 0.5, "tank_water_depth_m": 0.4}, "depth_m"),
        ("snell_turntable", {"tank_wind_mps": -3.0}, "tank_wind_mps"),
        ("snell_turntable", {"distortion_correction": "off"}, "distortion_correction"),
        ("roia_static", {"case": "lake"}, "case"),
        ("roia_static", {"hardware": "perfect"}, "hardware"),
        ("lig_tank", {"depth_m": 1.5}, "depth_m"),
        ("lig_tank", {"milk_ml": -1.0}, "milk_ml"),
    ],
)
def test_bad_parameters_name_the_field(trial, params, field):
    t = load_trial(trial)
    errs = t.check({**t.defaults, **params})
    assert errs and any(e.startswith(f"{field}:") for e in errs), errs


def test_the_campaign_specs_resolve():
    for name, runs in (("snell_turntable", 200), ("roia_static", 80), ("lig_tank", 20)):
        spec = load_campaign(f"scenarios/campaigns/{name}.toml")
        assert len(spec.runs) == runs and len(spec.seeds) >= 20
    assert len(load_campaign("scenarios/campaigns/lig_sea_trials.toml").runs) == 40


def test_a_turntable_session_on_a_flat_tank_is_accurate_and_deterministic():
    p = {**snell_turntable.DEFAULTS, "case": "hardware_only"}
    a = snell_turntable.run(p, 3)
    assert a == snell_turntable.run(p, 3)
    s = a["methods"]["snell"]
    assert s["no_fix"] == 0
    # A real unit on flat water: a few tenths of a degree (the campaign: 0.3° / 0.3° / 0.1°).
    assert 0.0 < s["roll_mae_deg"] < 1.0 and 0.0 < s["pitch_mae_deg"] < 1.0
    assert 0.0 < s["yaw_mae_deg"] < 1.0
    assert 20.0 < a["sun_elevation_deg"] < 27.0  # a December morning in Dalian
    assert a["tank_wind_mps"] == 0.0 and a["boresight_deg"] > 0.0
    # The paper's method on the same frames: its own numbers, not a copy of the twin's.
    q = a["methods"]["snell_paper"]
    assert q["no_fix"] == 0 and 0.0 < q["roll_mae_deg"] < 5.0
    assert q["roll_mae_deg"] != s["roll_mae_deg"]


def test_a_roia_tank_session_runs(monkeypatch):
    monkeypatch.setattr(roia_static, "FRAMES", 4)
    out = roia_static.run({"case": "tank", "hardware": "real"}, 0)["methods"]
    m, q = out["roia"], out["roia_paper"]
    assert m["no_fix"] == 0 and 0.0 < m["heading_rmse_deg"] < 3.0
    assert q["no_fix"] == 0 and 0.0 < q["heading_rmse_deg"] < 3.0


def test_a_partial_report_keeps_the_other_sections_and_their_provenance():
    import importlib.util
    import pathlib

    path = pathlib.Path(__file__).parents[2] / "validation" / "hardware_experiments.py"
    spec = importlib.util.spec_from_file_location("hardware_experiments", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    old = "\n".join(
        [
            "# R",
            "",
            "- This report: old",
            "- Campaign `snell_turntable`, runs made by: 200 runs: commit aaa",
            "- Campaign `lig_sea_trials`, runs made by: 40 runs: commit bbb",
            "",
            "## Snell-window attitude x",
            "old snell",
            "## LIG/INS vs POL/INS sea trials y",
            "old sea",
        ]
    )
    header = [
        "# R",
        "",
        "- This report: new",
        "- Campaign `lig_sea_trials`, runs made by: 40 runs: commit ccc",
        "",
    ]
    text = mod.splice(
        old,
        header,
        [["## LIG/INS vs POL/INS sea trials y", "new sea"]],
        mod.ORDER,
        rerun={"lig_sea_trials"},
    )
    assert "old snell" in text and "new sea" in text and "old sea" not in text
    assert "snell_turntable`, runs made by: 200 runs: commit aaa" in text
    assert "commit ccc" in text and "commit bbb" not in text
    assert text.index("commit aaa") < text.index("## Snell")
