"""The twin's REMUS 100 against Fossen's PythonVehicleSimulator (PVS) under identical inputs.

Fixed 15° rudder, 1525 rpm, no stern plane, ρ = 1026 kg/m³, 120 s from rest at full speed.
Measures, after the turn has settled (t > 60 s): turning diameter, yaw rate, speed and the
standing heel; plus straight-line top speed and heel.

A third column runs the twin with PVS's two deliberate differences switched to PVS's choice
(``crossflow_strips = 20``, ``prop_torque_on_hull = 0.1``): that isolates them.

PVS is not on PyPI and is not vendored here: point ``--pvs`` (or ``$PVS_PATH``) at a checkout of
github.com/cybergalactic/PythonVehicleSimulator (results below: commit c717e07). Without it the
script measures the twin alone.

    python validation/turning_vs_pvs.py --pvs ~/src/PythonVehicleSimulator
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import json
import math
import os
import platform
import sys
from pathlib import Path

import numpy as np

from twin.core.messages import ActuatorCommand
from twin.record import provenance as pv
from twin.world.plant import Plant, PlantConfig
from twin.world.vehicle import REMUS100, VehicleParams

PVS_CHOICES = dataclasses.replace(REMUS100, crossflow_strips=20, prop_torque_on_hull=0.1)

RESULTS = Path(__file__).resolve().parent / "results"
RUDDER_DEG, RPM, RHO, DURATION_S, DT = 15.0, 1525.0, 1026.0, 120.0, 0.01
ROW_KEYS = (
    "straight_speed_mps",
    "straight_heel_deg",
    "turn_diameter_m",
    "yaw_rate_deg_s",
    "turn_speed_mps",
    "turn_heel_deg",
)


def _circle(e: np.ndarray, n: np.ndarray) -> float:
    """Diameter of the least-squares circle through the points (Kåsa fit)."""
    a = np.column_stack([e, n, np.ones_like(e)])
    b = e * e + n * n
    c = np.linalg.lstsq(a, b, rcond=None)[0]
    return 2.0 * math.sqrt(c[2] + (c[0] / 2) ** 2 + (c[1] / 2) ** 2)


def twin(rudder_deg: float, vehicle: VehicleParams = REMUS100) -> dict[str, float]:
    plant = Plant(PlantConfig(water_density_kg_m3=RHO, vehicle=vehicle))
    speed0 = plant.hydro.steady_speed_mps(RPM / 60.0)
    plant.reset(forward_speed_mps=speed0)
    cmd = ActuatorCommand(math.radians(rudder_deg), 0.0, RPM / 60.0)
    e, n, r, roll, u = [], [], [], [], []
    for k in range(round(DURATION_S / DT)):
        plant.step(cmd)
        if plant.t > 60.0 and k % 10 == 0:
            tr = plant.truth()
            e.append(tr.position_n[0])
            n.append(tr.position_n[1])
            r.append(-float((quat_c(tr.quat_wxyz) @ tr.omega_b)[2]))
            roll.append(math.degrees(tr.roll_rad))
            u.append(tr.speed_through_water_mps)
    return _summary(np.array(e), np.array(n), np.array(r), np.array(roll), np.array(u))


def quat_c(q: np.ndarray) -> np.ndarray:
    from twin.core.frames import quat_to_dcm

    return quat_to_dcm(q)


def pvs(path: Path, rudder_deg: float) -> dict[str, float]:
    sys.path.insert(0, str(path / "src"))
    from python_vehicle_simulator.lib.gnc import attitudeEuler
    from python_vehicle_simulator.vehicles.remus100 import remus100

    v = remus100()
    # Start at the straight-line speed of 1525 rpm, like the twin.
    nu = np.zeros(6)
    ua = np.array([0.0, 0.0, RPM])
    eta = np.zeros(6)
    for _ in range(round(60 / DT)):
        nu, ua = v.dynamics(eta, nu, ua, np.array([0.0, 0.0, RPM]), DT)
        eta = attitudeEuler(eta, nu, DT)
    straight_heel = math.degrees(eta[3])
    straight_u = float(nu[0])
    eta = np.zeros(6)
    cmd = np.array([math.radians(rudder_deg), 0.0, RPM])
    e, n, r, roll, u = [], [], [], [], []
    for k in range(round(DURATION_S / DT)):
        nu, ua = v.dynamics(eta, nu, ua, cmd, DT)
        eta = attitudeEuler(eta, nu, DT)
        if (k + 1) * DT > 60.0 and k % 10 == 0:
            e.append(eta[1])
            n.append(eta[0])
            r.append(nu[5])
            roll.append(math.degrees(eta[3]))
            u.append(math.sqrt(nu[0] ** 2 + nu[1] ** 2 + nu[2] ** 2))
    out = _summary(np.array(e), np.array(n), np.array(r), np.array(roll), np.array(u))
    out["straight_speed_mps"] = straight_u
    out["straight_heel_deg"] = straight_heel
    return out


def _summary(e, n, r, roll, u) -> dict[str, float]:
    return {
        "turn_diameter_m": _circle(e, n),
        "yaw_rate_deg_s": math.degrees(float(np.mean(r))),
        "turn_speed_mps": float(np.mean(u)),
        "turn_heel_deg": float(np.mean(roll)),
    }


def twin_straight(vehicle: VehicleParams = REMUS100) -> dict[str, float]:
    plant = Plant(PlantConfig(water_density_kg_m3=RHO, vehicle=vehicle))
    plant.reset(forward_speed_mps=0.5)
    cmd = ActuatorCommand(0.0, 0.0, RPM / 60.0)
    for _ in range(round(60 / DT)):
        plant.step(cmd)
    tr = plant.truth()
    return {
        "straight_speed_mps": tr.speed_through_water_mps,
        "straight_heel_deg": math.degrees(tr.roll_rad),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pvs", type=Path, default=os.environ.get("PVS_PATH"))
    args = ap.parse_args()
    rows = {"twin": {**twin_straight(), **twin(RUDDER_DEG)}}
    # The twin with PVS's two modelling choices that it does not share (docs/physics.md): its
    # 21-strip cross-flow sum and a tenth of the propeller torque on the hull. What remains is the
    # rest of the model: it must then agree with PVS.
    rows["twin, PVS choices"] = {
        **twin_straight(PVS_CHOICES),
        **twin(RUDDER_DEG, PVS_CHOICES),
    }
    if args.pvs:
        rows["pvs"] = pvs(Path(args.pvs), RUDDER_DEG)
    meta = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.node()} {platform.processor() or platform.machine()}",
        "conditions": f"{RUDDER_DEG:g} deg rudder, {RPM:g} rpm, rho {RHO:g}, dt {DT}",
        "pvs_commit": "c717e07" if args.pvs else None,
        "provenance": pv.provenance(),
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "turning_vs_pvs.json").write_text(json.dumps({**meta, **rows}, indent=2) + "\n")
    lines = [
        "# REMUS 100: the twin against PythonVehicleSimulator",
        "",
        f"{meta['date']}, {meta['machine']}; {meta['conditions']}; "
        f"PVS commit {meta['pvs_commit']}. Generated by `validation/turning_vs_pvs.py`.",
        "",
        *("- " + x for x in pv.describe(meta["provenance"])),
        "",
        "| quantity | " + " | ".join(rows) + " |",
        "|---|" + "---|" * len(rows),
    ]
    for k in ROW_KEYS:
        cells = " | ".join(f"{rows[r].get(k, float('nan')):.3f}" for r in rows)
        lines.append(f"| {k} | {cells} |")
    (RESULTS / "turning_vs_pvs.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
