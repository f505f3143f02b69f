"""The exact chain's kernel in vectorised passes against the scalar kernel it replaced (#31).

``sensors/polarimeter/chain_passes.py`` renders a block of rays in five passes, three of them
vectorised by LLVM. Until c227c6f the kernel was one scalar loop per ray
(``chain_kernel.chain_points`` calling ``column_kernel.scatter_pixels``). This script loads that
revision's ``chain_kernel.py`` from git (its imports are today's modules, which it shares
unchanged), renders the same rays through both in the same process, on one core, and gives the
time per ray (perf_counter, best of ``--repeats``, the two kernels' rounds interleaved) and the
largest differences of their float32 Stokes.

The rays: those the fast path sends through the exact chain in a 612×512 frame (its coarse
grid's points and its rough cells' exact pixels), in two scenes: a level camera at 10 m in
Jerlov II with the sun 40° from the zenith, and a camera tilted 20° at 3 m in Jerlov IB with the
sun 65° from the zenith.

    OMP_NUM_THREADS=1 taskset -c 1 python benchmarks/chain_passes.py [--baseline REV] [--repeats N]

Writes benchmarks/results/chain_passes.{json,md}.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import sensors
from sensors.polarimeter import chain_kernel
from sensors.polarimeter.render import OpticsConfig, Polarimeter
from twin.core.frames import euler_to_dcm
from twin.record import provenance as pv

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from polarimeter_frame import _best as best_of  # noqa: E402  (the benchmarks' one timer)

SCENES: tuple[tuple[str, str, float, float, tuple[float, float, float]], ...] = (
    # label, Jerlov type, depth (m), sun zenith (deg), camera roll, pitch, yaw (rad)
    ("level, 10 m, Jerlov II, sun 40° from the zenith", "II", 10.0, 40.0, (0.0, 0.0, 0.0)),
    ("tilted 20°, 3 m, Jerlov IB, sun 65° from the zenith", "IB", 3.0, 65.0, (0.35, 0.0, 1.0)),
)


def _sun(zenith_deg: float) -> np.ndarray:
    z = math.radians(zenith_deg)
    return np.array([math.sin(z) * 0.6, math.sin(z) * 0.8, math.cos(z)])


def _baseline_module(rev: str) -> Any:
    """The revision's ``chain_kernel`` module, loaded from git under another name."""
    src = subprocess.run(
        ["git", "-C", str(ROOT), "show", f"{rev}:sensors/polarimeter/chain_kernel.py"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    path = Path(tempfile.mkdtemp(prefix="chain_baseline_")) / "chain_kernel_baseline.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("chain_kernel_baseline", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _calls(jerlov: str, depth: float, sun_zen: float, att: tuple[float, float, float]) -> list:
    """The (args, kwargs) of the frame's calls of ``chain_kernel.render_points``."""
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    assert isinstance(cam, Polarimeter)
    cam.configure(OpticsConfig(jerlov_type=jerlov))
    calls: list = []
    shipped = chain_kernel.render_points

    def spy(*a: Any, **kw: Any) -> Any:
        calls.append((a, kw))
        return shipped(*a, **kw)

    chain_kernel.render_points = spy  # type: ignore[assignment]
    try:
        cam.render_stokes(None, np.zeros(3), euler_to_dcm(*att), depth, _sun(sun_zen))
    finally:
        chain_kernel.render_points = shipped  # type: ignore[assignment]
    return calls


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="c227c6f", help="the revision with the scalar kernel")
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds of each kernel")
    args = ap.parse_args()
    base = _baseline_module(args.baseline)
    rows = []
    for label, jerlov, depth, sun_zen, att in SCENES:
        calls = _calls(jerlov, depth, sun_zen, att)
        for (a, kw), part in zip(calls, ("coarse grid", "exact pixels"), strict=False):
            m = a[0].shape[0]
            res = {}
            best = {"baseline": math.inf, "passes": math.inf}
            for _ in range(args.rounds):
                for name, mod in (("baseline", base), ("passes", chain_kernel)):
                    res[name] = mod.render_points(*a, **kw)  # warm, and its result
                    t = best_of(
                        lambda mod=mod, a=a, kw=kw: mod.render_points(*a, **kw), args.repeats
                    )
                    best[name] = min(best[name], t)
            old, new = res["baseline"][0], res["passes"][0]
            s0 = np.maximum(old[:, 0], 1e-30)
            rows.append(
                {
                    "scene": label,
                    "rays": part,
                    "n": m,
                    "baseline_ns": 1e9 * best["baseline"] / m,
                    "passes_ns": 1e9 * best["passes"] / m,
                    "max_rel_s0": float(np.max(np.abs(new[:, 0] - old[:, 0]) / s0)),
                    "max_rel_pol": float(
                        np.max(np.hypot(new[:, 1] - old[:, 1], new[:, 2] - old[:, 2]) / s0)
                    ),
                    "values_differing": int(np.count_nonzero(new != old)),
                    "sees_equal": bool(np.array_equal(res["baseline"][1], res["passes"][1])),
                }
            )
    meta = {
        "machine": platform.platform(),
        "cpu_affinity": sorted(os.sched_getaffinity(0)),
        "load_average_1_5_15": [round(v, 2) for v in os.getloadavg()],
        "baseline": args.baseline,
        "repeats": args.repeats,
        "rounds": args.rounds,
        "date": time.strftime("%Y-%m-%d"),
        "provenance": pv.provenance(),
    }
    lines = [
        "# The exact chain's kernel: vectorised passes against the scalar loop (issue #31)",
        "",
        f"`python benchmarks/chain_passes.py --baseline {args.baseline} --repeats "
        f"{args.repeats} --rounds {args.rounds}`: the rays a 612×512 frame sends through the "
        f"exact chain, timed through `chain_kernel.render_points` (the kernel and its numpy "
        f"around it), best of {args.repeats} × {args.rounds} interleaved rounds, "
        f"{meta['date']}, {meta['machine']}, CPUs {meta['cpu_affinity']}, load average "
        f"{meta['load_average_1_5_15']}.",
        f"- {'; '.join(pv.describe(meta['provenance']))}",
        "",
        f"| scene | rays | how many | {args.baseline} (scalar), ns a ray | passes, ns a ray "
        "| speed-up | largest difference in S0 (relative) | in Q, U (of S0) "
        "| float32 values that differ |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['scene']} | {r['rays']} | {r['n']} | {r['baseline_ns']:.0f} "
            f"| {r['passes_ns']:.0f} | {r['baseline_ns'] / r['passes_ns']:.2f}x "
            f"| {r['max_rel_s0']:.1e} | {r['max_rel_pol']:.1e} "
            f"| {r['values_differing']} of {3 * r['n']} |"
        )
    same = all(r["sees_equal"] for r in rows)
    differing = sum(r["values_differing"] for r in rows)
    lines += [
        "",
        "Snell's window's mask is "
        + ("the same in every row. " if same else "NOT the same in some rows. ")
        + (
            "The float32 Stokes are the scalar kernel's bit for bit in every row: "
            if differing == 0
            else f"{differing} float32 values differ, by the amounts above: "
        )
        + "the two compute the same formulas in float64 in another order (and e^x and arccos as "
        "polynomials within 3e-13 of libm's), and round once to float32.",
    ]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "chain_passes.json").write_text(
        json.dumps({"meta": meta, "rows": rows}, indent=2, default=str) + "\n"
    )
    (RESULTS / "chain_passes.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
