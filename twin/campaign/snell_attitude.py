"""The window methods' attitude and heading from one frame, against water, depth, sun, tilt, sea.

The Snell-window method (xin2024) measures roll, pitch and heading from one frame; ROI-A
(fang2024) measures the heading given the INS's roll and pitch. The turntable trial
(:mod:`twin.campaign.snell_turntable`) runs the Snell paper's tank; this trial asks where the
methods hold in open water. One run: one frame of the noisy PHX050S-P (``preset``: binned 4×4,
612×512, or the full 2448×2048), the camera tilted about one axis (``tilt_axis``, ``tilt_deg``)
at a heading drawn from the seed, ``depth_m`` down in ``jerlov_type`` water under a sea of
``wind_speed_mps`` (0: flat; otherwise a Cox–Munk sea drawn from the seed), the sun at
``sun_elevation_deg`` and azimuth 150°, rendered without a MuJoCo world
(``Polarimeter.render_offline``: no occlusion). Then each method in ``methods`` on the same frame:
the Snell methods with a level hint (they measure roll and pitch themselves), ROI-A with the true
roll and pitch (its paper's N100MINI). Errors are of the fix's roll and pitch (Snell) and heading
against the frame's truth; a method that gives no fix has no error (its ``ok`` is 0).

Random streams: one ``numpy`` Generator from the run's seed alone; the heading is drawn first,
then the sea and the frame's noise, so the same seed is the same heading in every cell of a
sweep (paired), and the methods see the same frame.

Specs: ``scenarios/campaigns/snell_water.toml`` (water × depth × sun, level and rolled 10°),
``snell_attitude.toml`` (the turntable's ±50° tilts in 2 m of Jerlov II, sun 35°, both
resolutions), ``snell_waves.toml`` (the same tilts in Jerlov I under flat to force-6 seas).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

import sensors
from sensors.polarimeter.optics import water as water_mod
from sensors.polarimeter.render import OpticsConfig
from twin.campaign.trials import StudyTrial, choice_problem, names_problem, number_problem, wrap180
from twin.core.extensions import WATER_BODIES
from twin.core.frames import euler_to_dcm
from twin.onboard.compass.base import CompassContext
from twin.onboard.compass.roia import RoiaMethod, RoiaPaperMethod
from twin.onboard.compass.snell import SnellPaperMethod, SnellWindowMethod

#: The methods this trial runs (each paper's as written, and the twin's refinement).
METHODS = {
    "snell_paper": SnellPaperMethod,
    "snell": SnellWindowMethod,
    "roia_paper": RoiaPaperMethod,
    "roia": RoiaMethod,
}
PRESETS = ("phx050s_p_bin4", "phx050s_p")
SUN_AZIMUTH_DEG = 150.0
#: The Snell paper's site and morning (xin2024 Table 1), for the context's ephemeris fields only:
#: the sun itself is the trial's.
LATITUDE_DEG, LONGITUDE_DEG = 38.88, 121.51
UTC = dt.datetime(2023, 12, 28, 2, tzinfo=dt.UTC)

DEFAULTS: dict[str, Any] = {
    "jerlov_type": "II",
    "depth_m": 1.0,
    "sun_elevation_deg": 35.0,
    "tilt_axis": "roll",
    "tilt_deg": 0.0,
    "wind_speed_mps": 0.0,
    "preset": PRESETS[0],
    "methods": ["snell_paper", "snell"],
}


def check(p: Mapping[str, Any]) -> list[str]:
    """Errors of a parameter table (each names the parameter, the value and what is allowed)."""
    errs = choice_problem(p, "jerlov_type", WATER_BODIES.names())
    errs += number_problem(p, "depth_m", 0.05, 100.0, "m")
    errs += number_problem(p, "sun_elevation_deg", 5.0, 89.0, "°")
    errs += choice_problem(p, "tilt_axis", ("roll", "pitch"))
    errs += number_problem(p, "tilt_deg", -50.0, 50.0, "° about the tilt axis")
    errs += number_problem(p, "wind_speed_mps", 0.0, 30.0, "m/s at 12.5 m; 0: a flat sea")
    errs += choice_problem(p, "preset", PRESETS)
    return errs + names_problem(p, "methods", list(METHODS))


def run(p: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """One frame, each method on it: roll, pitch (Snell) and heading errors (°)."""
    rng = np.random.default_rng(seed)
    heading = float(rng.uniform(0.0, 360.0))
    tilt = float(p["tilt_deg"])
    roll, pitch = (tilt, 0.0) if p["tilt_axis"] == "roll" else (0.0, tilt)
    depth = float(p["depth_m"])
    el, az = math.radians(float(p["sun_elevation_deg"])), math.radians(SUN_AZIMUTH_DEG)
    sun = np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])
    cam = sensors.create("polarimeter", str(p["preset"]))
    cam.configure(
        OpticsConfig(jerlov_type=str(p["jerlov_type"]), wind_speed_mps=float(p["wind_speed_mps"]))
    )
    c_cn = euler_to_dcm(math.radians(roll), math.radians(pitch), math.radians(-heading))
    raw, _ = cam.render_offline(c_cn, depth, sun, rng)
    cal = cam.calibration()
    level = CompassContext(
        utc=UTC, latitude_deg=LATITUDE_DEG, longitude_deg=LONGITUDE_DEG, depth_m=depth, sun_enu=sun
    )
    hinted = CompassContext(
        utc=UTC,
        latitude_deg=LATITUDE_DEG,
        longitude_deg=LONGITUDE_DEG,
        roll_rad=math.radians(roll),
        pitch_rad=math.radians(pitch),
        depth_m=depth,
        sun_enu=sun,
    )
    methods: dict[str, dict[str, Any]] = {}
    for name in p["methods"]:
        fix = METHODS[name]().solve(raw, cal, level if name.startswith("snell") else hinted)
        out: dict[str, Any] = {"ok": int(fix.ok)}
        if fix.ok:
            if fix.roll_rad is not None and fix.pitch_rad is not None:
                out["roll_error_deg"] = abs(math.degrees(fix.roll_rad) - roll)
                out["pitch_error_deg"] = abs(math.degrees(fix.pitch_rad) - pitch)
            out["error_deg"] = abs(wrap180(fix.heading_deg - heading))
        else:
            out["reason"] = str(fix.reason)
        methods[name] = out
    w = water_mod.jerlov_water(str(p["jerlov_type"]))
    return {
        "complete": True,
        "heading_deg": heading,
        "b_per_m": w.b_per_m,
        "b_z": w.b_per_m * depth,  # the scattering optical depth down to the camera
        "methods": methods,
    }


TRIAL = StudyTrial(name="snell_attitude", run=run, defaults=DEFAULTS, check=check)
