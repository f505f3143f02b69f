"""The ROI-A paper's static experiments (fang2024 §2.2–2.3) as a campaign trial.

* ``tank``: a 300 L tank at 36.0018° N, 120.1229° E on 2023-10-17, 11:00–11:30 local (UTC+8),
  clear sky, the lens 0.3123 m under the surface, level, a heading every 20 s; the paper's
  heading RMSE 0.30°.
* ``sea_0.98`` / ``sea_4.89`` / ``sea_5.94``: from a vessel off Qingdao (35.7711° N,
  120.0973° E) on 2024-01-24, clear and sunny, the camera at 0.98, 4.89 and 5.94 m "despite
  continuous changes in attitude angles", roll and pitch from its N100MINI INS; the paper's solar
  azimuth RMSE 1.10°, 2.03°, 3.04° (against the Hong Kong Observatory's azimuth; with the true
  heading known that is the heading error here).

One trial = one unit (the sourced hardware budget of ``sensors.polarimeter.unit.hardware``, the
IMX264MZR camera with the 185° lens, auto exposure) over one session of 30 frames 20 s apart;
the metric is the RMSE over the session's frames.

What the paper does not state, and what the twin assumes [uncertain]:

* The tank: a 300 L box 0.8 × 0.6 × 0.625 m, the camera at its centre; tap water (Jerlov I); no
  wind on the water (none is stated).
* The sea: coastal water off Qingdao in winter, Jerlov 3C; wind force 3 (a gentle breeze on a
  clear winter day); the session at 10:00–12:00 local (the time is not given).
* The vessel's motion: roll and pitch each a random 3° (1σ) per frame, the INS's roll/pitch hint
  off by 0.1° (1σ), the N100MINI's stated dynamic accuracy class [uncertain].
* The camera is binned 4×4 for speed; ROI-A reads the zenith region, which binning keeps.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

import sensors
from scenarios.ranges import BEAUFORT_MPS
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.tank import Tank
from sensors.polarimeter.unit.hardware import HardwareErrors
from twin.campaign.trials import StudyTrial, wrap180
from twin.core.ephemeris import sun_direction_enu
from twin.core.frames import euler_to_dcm
from twin.onboard.compass.base import CompassContext
from twin.onboard.compass.roia import RoiaMethod, RoiaPaperMethod


@dataclass(frozen=True, slots=True)
class Case:
    """One experiment: where, when (local, UTC+8), how deep, in what water, and the paper's RMSE."""

    latitude_deg: float
    longitude_deg: float
    start_local: dt.datetime
    depth_m: float
    jerlov_type: str
    wind_beaufort: int
    in_tank: bool
    paper_rmse_deg: float


_TANK_DAY = dt.datetime(2023, 10, 17, 11, 0)
_SEA_DAY = dt.datetime(2024, 1, 24, 10, 0)
CASES: dict[str, Case] = {
    "tank": Case(36.0018, 120.1229, _TANK_DAY, 0.3123, "I", 0, True, 0.30),
    "sea_0.98": Case(35.7711, 120.0973, _SEA_DAY, 0.98, "3C", 3, False, 1.10),
    "sea_4.89": Case(35.7711, 120.0973, _SEA_DAY, 4.89, "3C", 3, False, 2.03),
    "sea_5.94": Case(35.7711, 120.0973, _SEA_DAY, 5.94, "3C", 3, False, 3.04),
}
FRAMES = 30
FRAME_SPACING_S = 20.0
SESSION_SPREAD_S = {"tank": 0.0, "sea": 2 * 3600.0}  # the sea session's start: 10:00–12:00
ROLL_PITCH_SIGMA_DEG = 3.0
HINT_SIGMA_DEG = 0.1

DEFAULTS: dict[str, Any] = {"case": "tank", "hardware": "real"}


def check(p: Mapping[str, Any]) -> list[str]:
    errs = []
    if p.get("case") not in CASES:
        errs.append(f"case: {p.get('case')!r}; allowed: {', '.join(map(repr, CASES))}")
    if p.get("hardware") not in ("real", "ideal"):
        errs.append(f"hardware: {p.get('hardware')!r}; allowed: 'real', 'ideal'")
    return errs


def run(p: Mapping[str, Any], seed: int) -> dict[str, Any]:
    case = CASES[p["case"]]
    lat, lon, depth, in_tank = case.latitude_deg, case.longitude_deg, case.depth_m, case.in_tank
    rng = np.random.default_rng(seed)
    unit_rng, frame_rng, motion_rng = rng.spawn(3)
    heading0 = float(rng.uniform(0.0, 360.0))
    spread = SESSION_SPREAD_S["tank" if in_tank else "sea"]
    start_utc = case.start_local.replace(tzinfo=dt.UTC) - dt.timedelta(hours=8)
    start_utc += dt.timedelta(seconds=float(rng.uniform(0.0, spread)))
    cam = sensors.create("polarimeter", "imx264mzr", binning=4)
    wind = BEAUFORT_MPS[case.wind_beaufort]
    # The sea's bubbles, marine snow (neither in the tank: Polarimeter._bubbles, _particles)
    # and caustics; one budget for every case.
    cam.configure(
        OpticsConfig(
            jerlov_type=case.jerlov_type,
            wind_speed_mps=wind,
            bubbles="hall_novarini",
            flicker="caustics",
            particles="marine_snow",
        )
    )
    errors = HardwareErrors() if p["hardware"] == "real" else HardwareErrors.ideal()
    cam.configure_hardware(errors)
    if in_tank:
        cam.configure_tank(Tank(shape="box", length_m=0.8, width_m=0.6, water_depth_m=0.625))
    if errors.drawn:
        cam.draw_unit(unit_rng)
    cal = cam.calibration()
    # The paper's method (``roia_paper``) beside the twin's refinement, on the same frames.
    methods = {"roia": RoiaMethod(), "roia_paper": RoiaPaperMethod()}
    errs: dict[str, list[float]] = {name: [] for name in methods}
    no_fix = dict.fromkeys(methods, 0)
    for k in range(FRAMES):
        utc = start_utc + dt.timedelta(seconds=k * FRAME_SPACING_S)
        sun = sun_direction_enu(utc, lat, lon)
        if in_tank:
            roll = pitch = 0.0
        else:
            roll, pitch = motion_rng.normal(0.0, ROLL_PITCH_SIGMA_DEG, 2)
        hint_r, hint_p = np.array([roll, pitch]) + motion_rng.normal(0.0, HINT_SIGMA_DEG, 2)
        c = euler_to_dcm(math.radians(roll), math.radians(pitch), math.radians(-heading0))
        raw, _ = cam.render_offline(c, depth, sun, frame_rng, t=k * FRAME_SPACING_S)
        ctx = CompassContext(
            utc, lat, lon, roll_rad=math.radians(hint_r), pitch_rad=math.radians(hint_p),
            depth_m=depth, water_index=cam.n_water, sun_enu=sun,
        )  # fmt: skip
        for name, method in methods.items():
            fix = method.solve(raw, cal, ctx)
            if not fix.ok or fix.heading_deg is None:
                no_fix[name] += 1
                continue
            errs[name].append(wrap180(fix.heading_deg - heading0))
    out = {}
    for name in methods:
        e = np.asarray(errs[name])
        out[name] = {
            "heading_rmse_deg": float(np.sqrt(np.mean(e * e))) if e.size else math.nan,
            "heading_mean_deg": float(np.mean(e)) if e.size else math.nan,
            "no_fix": no_fix[name],
        }
    return {
        "methods": out,
        "depth_m": depth,
    }


TRIAL = StudyTrial(name="roia_static", run=run, defaults=DEFAULTS, check=check)
