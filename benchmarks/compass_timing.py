"""Time per full-resolution frame (2448×2048) of every registered compass method, one thread.

Renders one noise-free frame of the PHX050S-P geometry at 5 m in Jerlov II water (sun at 45°
elevation), then runs each method of ``twin.onboard.compass.available()`` best-of-N with OpenCV
and BLAS limited to one thread (set OMP/OPENBLAS/MKL_NUM_THREADS=1 before numpy loads; this
script does it). The first call of each method (cache build: rays, Jacobians) is timed apart.

Usage: python benchmarks/compass_timing.py [--repeats N]
Writes benchmarks/results/compass_timing.md.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import math  # noqa: E402
import pathlib  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

import sensors  # noqa: E402
from sensors.polarimeter.render import OpticsConfig  # noqa: E402
from twin.onboard.compass import available  # noqa: E402
from twin.onboard.compass.base import CompassContext  # noqa: E402
from twin.record import provenance as pv  # noqa: E402

RESULTS = pathlib.Path(__file__).parent / "results"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=10)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    cam = sensors.create("polarimeter", "ideal")
    cam.configure(OpticsConfig(jerlov_type="II"))
    el, az = math.radians(45.0), math.radians(120.0)
    sun = np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])
    raw, _ = cam.render_offline(np.eye(3), 5.0, sun, np.random.default_rng(0))
    cal = cam.calibration()
    ctx = CompassContext(
        dt.datetime(2021, 7, 31, 4, tzinfo=dt.UTC),
        36.175,
        120.482,
        depth_m=5.0,
        water_index=cam.n_water,
        sun_enu=sun,
    )
    rows = []
    for name, cls in sorted(available().items()):
        try:
            m = cls()
            t0 = time.perf_counter()
            fix = m.solve(raw, cal, ctx)
            first = time.perf_counter() - t0
            times = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                m.solve(raw, cal, ctx)
                times.append(time.perf_counter() - t0)
            rows.append((name, first, min(times), float(np.median(times)), fix.ok, fix.reason))
        except Exception as exc:  # a method under construction by someone else must not stop us
            rows.append((name, float("nan"), float("nan"), float("nan"), False, repr(exc)[:80]))
        print(rows[-1], flush=True)
    lines = [
        "# Compass methods: time per full-resolution frame (benchmarks/compass_timing.py)",
        "",
        f"Raw {raw.shape[1]}×{raw.shape[0]} uint16 (ideal PHX050S-P geometry, 5 m, Jerlov II), one "
        f"thread (OpenCV, BLAS), best / median of {args.repeats} after a first (cache-building) "
        f"call; {platform.processor() or platform.machine()}, shared dev VM (load varies), "
        f"{dt.date.today().isoformat()}, load average "
        f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}.",
        f"- {'; '.join(pv.describe(pv.provenance()))}",
        "",
        "| method | first call ms | best ms | median ms | ok | reason |",
        "|---|---|---|---|---|---|",
    ]
    for name, first, best, med, ok, reason in rows:
        lines.append(
            f"| {name} | {first * 1e3:.0f} | {best * 1e3:.1f} | {med * 1e3:.1f} | {ok} | {reason} |"
        )
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "compass_timing.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
