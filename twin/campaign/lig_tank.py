"""The LIG paper's static water-tank test (hu2024 §4.2) as a campaign trial: LIG against POL.

Stated conditions: Qingdao (36.175° N, 120.482° E), 2021-07-31, a φ3 × 1 m tank, "a box of milk
(200 mm)" mixed in to strengthen multiple scattering, the PHX050S-P + FE185C057HA-1 fixed on a
heading reference platform (level). The paper's mean absolute errors: solar azimuth POL 3.3°,
LIG 1.9°; solar zenith POL 2.9°, LIG 1.3°.

The milk, from first principles [uncertain]: "200 mm" read as one 200 mL carton (China's common
size), in 7.07 m³ (the tank filled to 1 m): a dilution of 2.83·10⁻⁵. Whole milk's fat globules
(3.8 % by volume, 3.5 µm across, relative index 1.46/1.34 — Walstra & Jenness, *Dairy Chemistry
and Physics*, 1984) scatter with van de Hulst's anomalous-diffraction efficiency Q = 2.69 at
500 nm, b = (3φ/2d)·Q = 4.4·10⁴ m⁻¹ undiluted, 1.24 m⁻¹ in the tank. The casein micelles'
smaller share is left out (an underestimate). The twin adds it as Jerlov II's particles scaled
to b_p = 1.24 m⁻¹ (their Fournier–Forand phase function, not milk's own, and Jerlov II's
absorption for tap water's).

One trial = one unit (the sourced hardware budget) over a session of 20 frames 30 s apart, at a
time between 09:00 and 15:00 local (not stated), the camera 0.5 m deep at the tank's centre (not
stated), a calm surface (no wind stated), auto exposure (the tank's exposure is not stated).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

import sensors
from sensors.polarimeter.optics.water import jerlov_water
from sensors.polarimeter.render import OpticsConfig
from sensors.polarimeter.tank import Tank
from sensors.polarimeter.unit.hardware import HardwareErrors
from twin.campaign.trials import StudyTrial, wrap180
from twin.core.ephemeris import sun_direction_enu
from twin.core.frames import euler_to_dcm
from twin.onboard.compass import create
from twin.onboard.compass.base import CompassContext

LATITUDE_DEG, LONGITUDE_DEG = 36.175, 120.482
PAPER_MAE_DEG = {("pol", "azimuth"): 3.3, ("lig", "azimuth"): 1.9, ("pol", "zenith"): 2.9,
                 ("lig", "zenith"): 1.3}  # fmt: skip
MILK_VOLUME_M3 = 200e-6
TANK_VOLUME_M3 = math.pi * 1.5**2 * 1.0
FAT_VOLUME_FRACTION = 0.038
FAT_DIAMETER_M = 3.5e-6
FAT_RELATIVE_INDEX = 1.46 / 1.34
WAVELENGTH_M = 500e-9
WATER_INDEX = 1.34
FRAMES = 20
FRAME_SPACING_S = 30.0


def milk_b_per_m(volume_m3: float = MILK_VOLUME_M3, tank_m3: float = TANK_VOLUME_M3) -> float:
    """Scattering coefficient (m⁻¹) of whole milk's fat globules diluted in the tank."""
    x = math.pi * FAT_DIAMETER_M * WATER_INDEX / WAVELENGTH_M
    rho = 2.0 * x * (FAT_RELATIVE_INDEX - 1.0)
    q = 2.0 - 4.0 / rho * math.sin(rho) + 4.0 / rho**2 * (1.0 - math.cos(rho))
    b_milk = 1.5 * FAT_VOLUME_FRACTION / FAT_DIAMETER_M * q
    return b_milk * volume_m3 / tank_m3


DEFAULTS: dict[str, Any] = {"hardware": "real", "depth_m": 0.5, "milk_ml": 200.0}


def check(p: Mapping[str, Any]) -> list[str]:
    errs = []
    if p.get("hardware") not in ("real", "ideal"):
        errs.append(f"hardware: {p.get('hardware')!r}; allowed: 'real', 'ideal'")
    d = p.get("depth_m")
    if not (isinstance(d, int | float) and not isinstance(d, bool) and 0 < d < 1.0):
        errs.append(f"depth_m: {d!r}; allowed: (0, 1) m (the tank is 1 m deep)")
    m = p.get("milk_ml")
    if not (isinstance(m, int | float) and not isinstance(m, bool) and 0 <= m <= 10_000):
        errs.append(f"milk_ml: {m!r}; allowed: [0, 10000] mL")
    return errs


def run(p: Mapping[str, Any], seed: int) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    unit_rng, frame_rng = rng.spawn(2)
    heading0 = float(rng.uniform(0.0, 360.0))
    start_local = dt.datetime(2021, 7, 31, 9, 0) + dt.timedelta(
        seconds=float(rng.uniform(0, 6 * 3600))
    )
    start_utc = start_local.replace(tzinfo=dt.UTC) - dt.timedelta(hours=8)
    b_p = milk_b_per_m(float(p["milk_ml"]) * 1e-6)
    base = jerlov_water("II")
    turbidity = b_p / base.b_particle_per_m
    cam = sensors.create("polarimeter", "phx050s_p_bin4", auto_exposure=True)
    cam.configure(OpticsConfig(jerlov_type="II", turbidity=turbidity, salinity_psu=0.0))
    errors = HardwareErrors() if p["hardware"] == "real" else HardwareErrors.ideal()
    cam.configure_hardware(errors)
    cam.configure_tank(Tank(diameter_m=3.0, water_depth_m=1.0))
    if errors.drawn:
        cam.draw_unit(unit_rng)
    cal = cam.calibration()
    depth = float(p["depth_m"])
    # The papers' LIG (eqs. 9–12, every in-window pixel) and POL beside the twin's refinements.
    methods = {name: create(name) for name in ("lig_paper", "lig", "pol_paper", "pol")}
    err: dict[str, dict[str, list[float]]] = {m: {"azimuth": [], "zenith": []} for m in methods}
    no_fix = dict.fromkeys(methods, 0)
    c = euler_to_dcm(0.0, 0.0, math.radians(-heading0))
    for k in range(FRAMES):
        utc = start_utc + dt.timedelta(seconds=k * FRAME_SPACING_S)
        sun = sun_direction_enu(utc, LATITUDE_DEG, LONGITUDE_DEG)
        raw, _ = cam.render_offline(c, depth, sun, frame_rng, t=k * FRAME_SPACING_S)
        ctx = CompassContext(
            utc, LATITUDE_DEG, LONGITUDE_DEG, depth_m=depth, water_index=cam.n_water, sun_enu=sun
        )
        true_body = c.T @ sun
        for name, method in methods.items():
            fix = method.solve(raw, cal, ctx)
            if not fix.ok or fix.heading_deg is None:
                no_fix[name] += 1
                continue
            err[name]["azimuth"].append(abs(wrap180(fix.heading_deg - heading0)))
            z_fix = math.degrees(math.acos(max(-1.0, min(1.0, float(fix.sun_body[2])))))
            err[name]["zenith"].append(abs(z_fix - math.degrees(math.acos(float(true_body[2])))))
    mean = lambda x: float(np.mean(x)) if x else math.nan  # noqa: E731
    return {
        "milk_b_per_m": b_p,
        "methods": {
            name: {
                "azimuth_mae_deg": mean(err[name]["azimuth"]),
                "zenith_mae_deg": mean(err[name]["zenith"]),
                "no_fix": no_fix[name],
            }
            for name in methods
        },
    }


TRIAL = StudyTrial(name="lig_tank", run=run, defaults=DEFAULTS, check=check)
