"""The apparent-sun study trial: one frame, each compass method on it, errors against the truth."""

from __future__ import annotations

import math

from twin.campaign.apparent_sun import DEFAULTS, TRIAL, check
from twin.campaign.trials import load_trial
from twin.core.extensions import COMPASS_METHODS


def test_the_trial_is_registered_and_checks_its_parameters() -> None:
    assert load_trial("apparent_sun") is TRIAL
    assert check(DEFAULTS) == []
    bad = dict(DEFAULTS, jerlov_type="murky", depth_m=0.0, turbidity=-1.0, preset="phx")
    bad.update(auto_exposure="yes", methods=["lig", "compass9"])
    errs = check(bad)
    assert len(errs) == 6, errs
    assert any(e.startswith("jerlov_type: 'murky'; allowed: [") and "'3C'" in e for e in errs)
    assert any(e.startswith("depth_m: 0.0; allowed: a number in [0.05, 100]") for e in errs)
    assert any(e.startswith("turbidity: -1.0; allowed: a number in [0, 100]") for e in errs)
    assert any(e.startswith("preset: 'phx'; allowed: ['phx050s_p_bin4'") for e in errs)
    assert any(e.startswith("auto_exposure: 'yes'; allowed: true or false") for e in errs)
    assert any(e.startswith("methods: ['lig', 'compass9']; allowed") for e in errs)
    # The allowed methods are the registry's, whatever it holds (a plug-in's included).
    assert check(dict(DEFAULTS, methods=sorted(COMPASS_METHODS.names())[:2])) == []
    assert check(dict(DEFAULTS, methods=["pol", "pol"])) != []


def test_pol_holds_in_clear_water_and_its_apparent_sun_drifts_to_the_zenith_with_depth() -> None:
    # Jerlov I at 1 m: POL's solar vector within a degree or two (a broken refraction map or
    # sign gives tens of degrees). 3C at 20 m: multiple scattering draws POL's apparent sun
    # towards the zenith (validation/results/campaigns/compass_underwater: -13° there against
    # -0.3° at 1 m of I); the same seed is the same sun and attitude in both cells.
    p = dict(DEFAULTS, methods=["pol", "lig"])
    clear = TRIAL.run(dict(p, jerlov_type="I", depth_m=1.0), 4)
    turbid = TRIAL.run(dict(p, jerlov_type="3C", depth_m=20.0), 4)
    assert clear["sun_elevation_deg"] == turbid["sun_elevation_deg"]
    assert 20.0 <= clear["sun_elevation_deg"] <= 70.0
    pol = clear["methods"]["pol"]
    assert pol["ok"] == 1 and pol["error_deg"] < 1.0 and pol["zenith_error_deg"] < 2.0, pol
    deep = turbid["methods"]["pol"]
    assert deep["ok"] == 1 and deep["zenith_bias_deg"] < pol["zenith_bias_deg"] - 4.0, deep
    assert clear["exposure_us"] == 700.0  # the paper's sea-trial exposure unless asked
    for r in (clear, turbid):
        for m in r["methods"].values():
            assert m["ok"] == 0 or math.isclose(abs(m["zenith_bias_deg"]), m["zenith_error_deg"])


def test_the_methods_see_the_same_frame_and_a_run_is_its_seed() -> None:
    p = dict(DEFAULTS, jerlov_type="II", depth_m=5.0, methods=["pol", "lig_paper"])
    both = TRIAL.run(p, 2)
    assert TRIAL.run(p, 2) == both
    alone = TRIAL.run(dict(p, methods=["pol"]), 2)
    assert alone["methods"]["pol"] == both["methods"]["pol"]
    auto = TRIAL.run(dict(p, auto_exposure=True), 2)
    assert auto["exposure_us"] != 700.0
