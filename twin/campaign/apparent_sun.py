"""The compass methods' apparent sun from one frame, against water type, depth and exposure.

The LIG paper (hu2024) compares LIG with POL by their solar azimuth and zenith errors; this trial
asks how those errors grow with depth and turbidity in open water. One run: one frame of the
noisy PHX050S-P (``preset``: binned 4×4, 612×512, or the full 2448×2048) at ``depth_m`` in
``jerlov_type`` water (``turbidity`` scales its particles' scattering) under a flat sea, rendered
without a MuJoCo world (``Polarimeter.render_offline``: no occlusion). The sun is drawn from the
seed, elevation 20–70° and any azimuth; the camera is tilted by a roll and a pitch each drawn in
±5° at a heading drawn in ±180°; the methods get the true roll and pitch (the paper's IMU hint).
The exposure is the paper's sea-trial 700 µs, or the camera's own auto exposure
(``auto_exposure``: the PHX050S-P has one) where the paper gives none.

Then each method in ``methods`` (any registered compass method that returns a solar vector, a
plug-in's included) on the same frame. Errors are of the level-frame solar vector: the azimuth
(``error_deg``, = the heading error), the zenith angle (``zenith_error_deg``) and its sign
(``zenith_bias_deg``, negative towards the zenith: the apparent sun's drift). A method that gives
no fix has no error (its ``ok`` is 0).

Random streams: one ``numpy`` Generator from the run's seed alone, the geometry drawn first, so
the same seed is the same sun and attitude in every cell of a sweep (paired), and the methods
see the same frame.

Spec: ``scenarios/campaigns/compass_underwater.toml`` (Jerlov I, II, 1C, 3C × 1–20 m, the paper's
methods and the twin's). The LIG paper's own tank is the ``lig_tank`` trial's.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

import sensors
from sensors.polarimeter.render import OpticsConfig
from twin.campaign.trials import StudyTrial, choice_problem, names_problem, number_problem, wrap180
from twin.core.extensions import COMPASS_METHODS, WATER_BODIES
from twin.core.frames import euler_to_dcm
from twin.onboard.compass import create
from twin.onboard.compass.base import CompassContext

PRESETS = ("phx050s_p_bin4", "phx050s_p")
#: The sun's elevation range (the LIG paper's trials ran at 20–70°) and the tilts' half range.
ELEVATION_RANGE_DEG = (20.0, 70.0)
TILT_DEG = 5.0
#: The LIG paper's static-test site and day (Qingdao, 2021-07-31: hu2024 §4.2), for the
#: context's ephemeris fields only: the sun itself is the trial's.
LATITUDE_DEG, LONGITUDE_DEG = 36.175, 120.482
UTC = dt.datetime(2021, 7, 31, 4, tzinfo=dt.UTC)

DEFAULTS: dict[str, Any] = {
    "jerlov_type": "II",
    "turbidity": 1.0,
    "depth_m": 10.0,
    "preset": PRESETS[0],
    "auto_exposure": False,
    "methods": ["lig_paper", "lig", "pol_paper", "pol"],
}


def check(p: Mapping[str, Any]) -> list[str]:
    """Errors of a parameter table (each names the parameter, the value and what is allowed)."""
    errs = choice_problem(p, "jerlov_type", WATER_BODIES.names())
    errs += number_problem(p, "turbidity", 0.0, 100.0, "× the water's particle scattering")
    errs += number_problem(p, "depth_m", 0.05, 100.0, "m")
    errs += choice_problem(p, "preset", PRESETS)
    if not isinstance(p.get("auto_exposure"), bool):
        errs.append(f"auto_exposure: {p.get('auto_exposure')!r}; allowed: true or false")
    return errs + names_problem(p, "methods", COMPASS_METHODS.names())


def run(p: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """One frame, each method on it: the level-frame solar vector's azimuth and zenith errors."""
    rng = np.random.default_rng(seed)
    az = float(rng.uniform(0.0, 2.0 * math.pi))
    el = math.radians(float(rng.uniform(*ELEVATION_RANGE_DEG)))
    sun = np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])
    roll, pitch = np.radians(rng.uniform(-TILT_DEG, TILT_DEG, 2))
    yaw = float(rng.uniform(-math.pi, math.pi))
    c_b_n = euler_to_dcm(float(roll), float(pitch), yaw)
    depth = float(p["depth_m"])
    cam = sensors.create("polarimeter", str(p["preset"]), auto_exposure=bool(p["auto_exposure"]))
    cam.configure(OpticsConfig(jerlov_type=str(p["jerlov_type"]), turbidity=float(p["turbidity"])))
    raw, truth = cam.render_offline(c_b_n, depth, sun, rng)
    cal = cam.calibration()
    ctx = CompassContext(
        UTC,
        LATITUDE_DEG,
        LONGITUDE_DEG,
        roll_rad=float(roll),
        pitch_rad=float(pitch),
        depth_m=depth,
        water_index=cam.n_water,
        sun_enu=sun,
    )
    # The true sun in the level frame h (the camera's heading removed).
    s_h = euler_to_dcm(float(roll), float(pitch), 0.0) @ (c_b_n.T @ sun)
    zenith_true = math.degrees(math.acos(float(s_h[2])))
    methods: dict[str, dict[str, Any]] = {}
    for name in p["methods"]:
        fix = create(name).solve(raw, cal, ctx)
        out: dict[str, Any] = {"ok": int(fix.ok and fix.sun_h is not None)}
        if out["ok"]:
            e = np.asarray(fix.sun_h, dtype=float)
            daz = math.degrees(math.atan2(e[0], e[1]) - math.atan2(s_h[0], s_h[1]))
            dzen = math.degrees(math.acos(float(np.clip(e[2], -1.0, 1.0)))) - zenith_true
            out["error_deg"] = abs(wrap180(daz))
            out["zenith_error_deg"] = abs(dzen)
            out["zenith_bias_deg"] = dzen
        else:
            out["reason"] = str(fix.reason) if not fix.ok else "no solar vector"
        methods[name] = out
    return {
        "complete": True,
        "sun_elevation_deg": math.degrees(el),
        "exposure_us": float(truth.exposure_us),
        "methods": methods,
    }


TRIAL = StudyTrial(name="apparent_sun", run=run, defaults=DEFAULTS, check=check)
