"""Real-time factor of the onboard navigation alone: strapdown INS + 15-state ESKF.

A 10-minute run at the seed IMU's rate (the lig2024 preset: 100 Hz), the vehicle level and
moving straight north at 1.5 m/s (ideal IMU arrays precomputed, so only the navigation code is
timed), with gravity-vector and solar-vector updates at 10 Hz and depth at 10 Hz.
Target: >= 200x real time on one core.

    python benchmarks/ins_filter_rtf.py      # prints a table and writes benchmarks/results/
"""

from __future__ import annotations

import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from twin.core import earth
from twin.core.frames import euler_to_dcm
from twin.onboard.eskf import Eskf, EskfConfig
from twin.onboard.ins import NavState, StrapdownIns
from twin.record import provenance as pv

RESULTS = Path(__file__).resolve().parent / "results"
MISSION_S = 600.0
RATE_HZ = 100.0  # sensors.imu IMU_PRESETS["lig2024"].rate_hz
LAT = math.radians(36.175)


def run_once(config: EskfConfig | None = None, *, ins_only: bool = False) -> dict[str, float]:
    """One timed mission; ``ins_only`` times the bare StrapdownIns steps (no filter)."""
    n = round(MISSION_S * RATE_HZ)
    dt = 1.0 / RATE_HZ
    c = euler_to_dcm(0.0, 0.0, 0.0)  # heading north
    v = np.array([0.0, 1.5, 0.0])
    # Level, straight and steady: the ideal IMU reads Earth + transport rate and -g (+ Coriolis).
    w_in = earth.earth_rate_enu(LAT) + earth.transport_rate_enu(LAT, -10.0, v)
    f_n = np.array([0.0, 0.0, earth.normal_gravity(LAT, -10.0)]) + np.cross(
        2 * earth.earth_rate_enu(LAT) + earth.transport_rate_enu(LAT, -10.0, v), v
    )
    w_b, f_b = c.T @ w_in, c.T @ f_n
    rng = np.random.default_rng(0)
    gyro = w_b + 4.4e-4 * rng.standard_normal((n, 3))
    accel = f_b + 4.4e-3 * rng.standard_normal((n, 3))
    sun_n = np.array([0.5, -0.3, 0.81])
    sun_n /= np.linalg.norm(sun_n)
    sun_b = c.T @ sun_n
    nav = Eskf(config or EskfConfig(), NavState(0.0, LAT, 2.1, -10.0, v, c))
    every = round(RATE_HZ / 10.0)
    if ins_only:
        ins = StrapdownIns(NavState(0.0, LAT, 2.1, -10.0, v, c))
        t0 = time.perf_counter()
        for k in range(n):
            ins.step(dt, gyro[k], accel[k])
        wall = time.perf_counter() - t0
        return {"wall_s": wall, "us_per_imu_step": wall / n * 1e6, "rtf": MISSION_S / wall}
    t0 = time.perf_counter()
    for k in range(n):
        nav.predict_imu(dt, gyro[k], accel[k])
        if (k + 1) % every == 0:
            nav.update_gravity()
            nav.update_sun(sun_body=sun_b, sun_enu=sun_n)
            nav.update_depth(10.0)
    wall = time.perf_counter() - t0
    e = nav.estimate()
    return {
        "sim_s": MISSION_S,
        "wall_s": wall,
        "rtf": MISSION_S / wall,
        "us_per_imu_step": wall / n * 1e6,
        "updates": float(sum(v for k, v in nav.counts.items() if k != "not_static")),
        "rejections": float(len(nav.rejections)),
        "heading_deg_end": e.heading_deg,
        "heading_sigma_deg_end": e.heading_sigma_deg,
        "_P": e.covariance,
    }


def main() -> int:
    try:  # one core, as the target says
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    runs = [run_once() for _ in range(5)]
    best = min(runs, key=lambda r: r["wall_s"])
    ins_alone = min((run_once(ins_only=True) for _ in range(3)), key=lambda r: r["wall_s"])
    # The covariance step: what propagating P every 0.1 s (the default, and the 10 Hz update
    # rate anyway) costs in accuracy against every 0.01 s (every IMU sample).
    fine = run_once(EskfConfig(cov_step_s=0.01))
    p, pf = best.pop("_P"), fine.pop("_P")
    for r in runs:
        r.pop("_P", None)
    sig, sig_f = np.sqrt(np.diag(p)), np.sqrt(np.diag(pf))
    rel = np.abs(sig / sig_f - 1.0)
    cov_err = float(rel.max())
    names = [f"{a}_{x}" for a in ("phi", "dv") for x in "ENU"] + ["dlat", "dlon", "dh"]
    names += [f"{a}_{x}" for a in ("bg", "ba") for x in "xyz"]
    cov_err_state = names[int(rel.argmax())]
    cov_err_att = float(rel[0:3].max())
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    env = (
        f"{platform.processor() or platform.machine()}, Python {sys.version.split()[0]}, 1 core "
        f"of {os.cpu_count()} (shared; 1-min load average {load:.1f} at the end)"
    )
    prov = pv.provenance()
    md = [
        "# INS + ESKF real-time factor",
        "",
        f"Environment: {env}. Best of 5. Target: >= 200x.",
        "",
        "| what | sim s | wall s | RTF | µs per IMU step | updates applied | rejected |",
        "|---|---|---|---|---|---|---|",
        f"| INS + ESKF | {best['sim_s']:.0f} | {best['wall_s']:.2f} | {best['rtf']:.0f}x | "
        f"{best['us_per_imu_step']:.1f} | {best['updates']:.0f} | {best['rejections']:.0f} |",
        f"| INS alone | {MISSION_S:.0f} | {ins_alone['wall_s']:.2f} | {ins_alone['rtf']:.0f}x | "
        f"{ins_alone['us_per_imu_step']:.1f} | | |",
        "",
        "100 Hz IMU steps (INS + lazy covariance propagation every 0.1 s), gravity + sun + depth",
        "updates at 10 Hz each (the run loop's sun rate is 1 Hz: this is the heavier case),",
        "paper-default EskfConfig. Before the float/in-place rewrite: 154 µs per step, 65x",
        "(INS alone 33 µs) as first recorded; ≈ 100 µs, 100x re-measured with this harness at",
        "load ≈ 1 next to the rewrite's 37 µs, 270x. Timings on this shared 2-core machine move",
        "by ±30 % with the other jobs' load (at load 2-3 the rewrite measured 160-200x).",
        "",
        f"Covariance step 0.1 s vs 0.01 s (each IMU sample): largest relative difference of any "
        f"state's σ after {MISSION_S:.0f} s: {cov_err:.1e} ({cov_err_state}); attitude "
        f"{cov_err_att:.1e}. The run loop's 10 Hz updates propagate every 0.1 s anyway.",
        "",
        *("- " + x for x in pv.describe(prov)),
        "",
    ]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "ins_filter_rtf.md").write_text("\n".join(md))
    (RESULTS / "ins_filter_rtf.json").write_text(
        json.dumps(
            {
                "env": env,
                "provenance": prov,
                **best,
                "ins_alone_us_per_imu_step": ins_alone["us_per_imu_step"],
                "ins_alone_rtf": ins_alone["rtf"],
                "cov_step_0p1_vs_0p01_max_rel_sigma_diff": cov_err,
                "cov_step_0p1_vs_0p01_max_rel_sigma_state": cov_err_state,
                "cov_step_0p1_vs_0p01_attitude_rel_sigma_diff": cov_err_att,
            },
            indent=2,
        )
    )
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
