"""The Snell-window attitude method (xin2024) against water clarity, depth and sun elevation.

The turntable trial (:mod:`twin.campaign.snell_turntable`) runs the paper's tank; this study asks
where the method holds in open water: one frame of the noisy PHX050S-P binned 4×4 (612×512)
under a flat sea, the camera level or rolled about its x axis, at a heading drawn from the seed,
the sun at a given elevation and azimuth 150°, rendered without a MuJoCo world
(``Polarimeter.render_offline``: no occlusion), then each of the Snell-window methods on the
same frame: the paper's (``snell_paper``) and the twin's (``snell``). Errors are of the fix's
roll, pitch and heading against the frame's truth; a method that gives no fix has no error (its
``ok`` is 0) and its reason is kept.

Random streams: one ``numpy`` Generator from the run's seed alone; the heading is drawn first,
then the frame's noise (the sensor's fixed pattern and temporal noise), so the same seed is the
same heading in every cell of a sweep (paired), and the methods see the same frame.

    auv-twin campaign run scenarios/campaigns/snell_water.toml --out runs/snell_water
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
from twin.campaign.trials import StudyTrial
from twin.core.extensions import COMPASS_METHODS, WATER_BODIES
from twin.core.frames import euler_to_dcm
from twin.onboard.compass.base import CompassContext

METHODS = ("snell_paper", "snell")
SUN_AZIMUTH_DEG = 150.0
#: The paper's site and morning (xin2024 Table 1), for the context's ephemeris fields only: the
#: sun itself is the trial's.
LATITUDE_DEG, LONGITUDE_DEG = 38.88, 121.51
UTC = dt.datetime(2023, 12, 28, 2, tzinfo=dt.UTC)

DEFAULTS: dict[str, Any] = {
    "jerlov_type": "II",
    "depth_m": 1.0,
    "sun_elevation_deg": 35.0,
    "roll_deg": 0.0,
    "methods": list(METHODS),
}


def _number(p: Mapping[str, Any], key: str, lo: float, hi: float, what: str) -> list[str]:
    v = p.get(key)
    if isinstance(v, int | float) and not isinstance(v, bool) and lo <= v <= hi:
        return []
    return [f"{key}: {v!r}; allowed: a number in [{lo:g}, {hi:g}] ({what})"]


def check(p: Mapping[str, Any]) -> list[str]:
    """Errors of a parameter table (each names the parameter, the value and what is allowed)."""
    errs: list[str] = []
    if p.get("jerlov_type") not in WATER_BODIES.names():
        errs.append(f"jerlov_type: {p.get('jerlov_type')!r}; allowed: {list(WATER_BODIES.names())}")
    errs += _number(p, "depth_m", 0.05, 100.0, "m")
    errs += _number(p, "sun_elevation_deg", 5.0, 89.0, "°")
    errs += _number(p, "roll_deg", -45.0, 45.0, "° about the camera's x axis")
    m = p.get("methods")
    snells = [n for n in COMPASS_METHODS.names() if n.startswith("snell")]
    if not (isinstance(m, list) and m and all(x in snells for x in m) and len(set(m)) == len(m)):
        errs.append(f"methods: {m!r}; allowed: a non-empty list of distinct {snells}")
    return errs


def _wrap180(x: float) -> float:
    return (x + 180.0) % 360.0 - 180.0


def run(p: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """One frame, each method on it: roll, pitch and heading errors (°)."""
    rng = np.random.default_rng(seed)
    heading = float(rng.uniform(0.0, 360.0))
    roll = float(p["roll_deg"])
    depth = float(p["depth_m"])
    el, az = math.radians(float(p["sun_elevation_deg"])), math.radians(SUN_AZIMUTH_DEG)
    sun = np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type=str(p["jerlov_type"])))
    raw, _ = cam.render_offline(
        euler_to_dcm(math.radians(roll), 0.0, math.radians(-heading)), depth, sun, rng
    )
    ctx = CompassContext(
        utc=UTC, latitude_deg=LATITUDE_DEG, longitude_deg=LONGITUDE_DEG, depth_m=depth, sun_enu=sun
    )
    methods: dict[str, dict[str, Any]] = {}
    for name in p["methods"]:
        fix = COMPASS_METHODS.load(name)().solve(raw, cam.calibration(), ctx)
        out: dict[str, Any] = {"ok": int(fix.ok)}
        if fix.ok:
            out["roll_error_deg"] = abs(math.degrees(fix.roll_rad) - roll)
            out["pitch_error_deg"] = abs(math.degrees(fix.pitch_rad))
            out["error_deg"] = abs(_wrap180(fix.heading_deg - heading))
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


TRIAL = StudyTrial(name="snell_water", run=run, defaults=DEFAULTS, check=check)
