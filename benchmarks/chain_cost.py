"""What a ray through the exact chain costs, part by part, and what the fine level saves where.

Two measurements behind issue #31's frame budget (benchmarks/results/sea_trial_profile.md gives
the rays a sea-trial frame sends through the chain and their total cost):

1. **Per ray, by part.** The 612×512 frame of ``tests/sensors/polarimeter/test_render_fast.py``'s
   "level 10 m" scene: the rays the fast path sends through the compiled chain (the coarse
   grid's points and the rough cells' exact pixels), split into those inside Snell's window and
   outside it, each timed best-of-N through :func:`chain_kernel.render_points`; then the window's
   rays again with one part of the scattered light switched off at a time (the surface's
   reflection of the upwelling light, single scattering, the sun's aureole, the table's light):
   the difference is that part's cost. Timings only: no number of the product changes.
2. **The fine level in a sea trial** (``FastPath.fine_level``, used from a coarse stride of 8):
   sea_trial_10m's frames at 612×512 (stride 4), the fast path's time per frame with the level
   forced on and off, interleaved runs in fresh interpreters on one core; and the 2448×2048
   frame of ``validation/fast_path_error.py``, the light's time with and without it.

    python benchmarks/chain_cost.py [--repeats 20] [--trial-s 150] [--rounds 3]

Writes benchmarks/results/chain_cost.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from polarimeter_frame import _best as best_of  # noqa: E402  (the benchmarks' one timer)

# scatter_pixels's arguments after ``out`` (column_kernel.scatter_pixels), to switch parts off.
_K_NAMES = (
    "single", "cz", "c", "sx", "sy", "sz", "e_sun", "beam_q", "r0x", "r0y", "r0z", "luts",
    "has_field", "f_in", "t_in", "f_out", "t_out", "cos_c_frame", "cos_c_table", "dphi", "cphi",
    "sphi", "agrid", "apsi", "dom", "up", "n_water",
)  # fmt: skip

# One fast-path time per frame of a sea trial, the fine level forced on or off (argv[1]).
_TRIAL = r"""
import dataclasses, json, os, sys, tempfile, time
try:
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
except (AttributeError, OSError):
    pass
import scenarios
from twin.app.run import run_scenario
from sensors.polarimeter import fast_path
fast_path._FINE_FROM_STRIDE = 4 if sys.argv[1] == "on" else 10**9
acc = [0.0, 0]
orig = fast_path.FastPath._render_fast
def timed(self, *a, _f=orig, **k):
    t0 = time.perf_counter()
    try:
        return _f(self, *a, **k)
    finally:
        acc[0] += time.perf_counter() - t0
        acc[1] += 1
fast_path.FastPath._render_fast = timed
sc = scenarios.load("sea_trial_10m")
sc = dataclasses.replace(sc, duration_s=float(sys.argv[2]),
    navigation=dataclasses.replace(sc.navigation, variants=("ins",)))
with tempfile.TemporaryDirectory() as d:
    run_scenario(sc, d, camera=False, record=False)
print(json.dumps({"ms": 1e3 * acc[0] / acc[1], "frames": acc[1]}))
"""


def _scenes() -> Any:
    """tests/sensors/polarimeter/test_render_fast.py (its scenes and camera pairs)."""
    import importlib

    # The package first: tests/sensors would otherwise shadow the project's sensors package.
    importlib.import_module("sensors.polarimeter.render")
    sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "tests" / "sensors" / "polarimeter")]
    return importlib.import_module("test_render_fast")


def _best(f: Any, repeats: int) -> float:
    """The best of ``repeats`` timed calls after a first (warm-up) one."""
    f()
    return best_of(f, repeats)


def per_ray(repeats: int) -> dict[str, Any]:
    """Part 1: ns per ray through the compiled chain, by region and by part (module docstring)."""
    from sensors.polarimeter import chain_kernel

    t = _scenes()
    _, c, depth, sun, optics = t.SCENES[0]
    fast, _ = t._pair("phx050s_p_bin4", **optics)
    calls: list[tuple[Any, ...]] = []
    orig = chain_kernel.render_points

    def keep(rays, basis, psf, c_cn, *rest):  # type: ignore[no-untyped-def]
        calls.append((rays.copy(), (basis[0], basis[1].copy()), psf.copy(), c_cn, rest))
        return orig(rays, basis, psf, c_cn, *rest)

    chain_kernel.render_points = keep  # type: ignore[assignment]
    try:
        fast.render_stokes(None, np.zeros(3), c, depth, sun)
    finally:
        chain_kernel.render_points = orig  # type: ignore[assignment]
    cos_edge = math.sqrt(1.0 - 1.0 / fast.n_water**2)
    rows, window = [], []
    for name, (rays, basis, psf, c_cn, rest) in zip(
        ("coarse grid", "exact pixels"), calls, strict=True
    ):
        inside = (rays.astype(np.float64) @ np.asarray(c_cn).T)[:, 2] > cos_edge
        for where, sel in (("inside the window", inside), ("outside", ~inside)):
            idx = np.flatnonzero(sel)
            if idx.size == 0:
                continue
            args = (np.ascontiguousarray(rays[idx]), (basis[0], basis[1][idx]), psf[idx], c_cn)
            s = _best(lambda a=args, r=rest: orig(*a, *r), repeats)
            rows.append(
                {"rays": name, "where": where, "n": int(idx.size), "ns": 1e9 * s / idx.size}
            )
            if name == "exact pixels" and where == "inside the window":
                window = [args, rest]
    parts = []
    if window:
        args, rest = window
        n = len(args[0])
        k = rest[3]

        def cost(**off: Any) -> float:
            kk = list(k)
            for key, value in off.items():
                kk[_K_NAMES.index(key)] = value
            r = (*rest[:3], tuple(kk), *rest[4:])
            return 1e9 * _best(lambda: orig(*args, *r), repeats) / n

        up = k[_K_NAMES.index("up")]
        base = cost()
        switched = {
            "the surface's reflection of the upwelling light": cost(up=up[:1]),
            "single scattering": cost(single=False),
            "the sun's aureole": cost(apsi=k[_K_NAMES.index("apsi")][:1]),
            "the table's light (its lookup, the aureole and the reflection)": cost(has_field=False),
            "all scattered light": cost(has_field=False, single=False),
        }
        parts = [{"part": "all of it", "ns": base, "saves_ns": 0.0}] + [
            {"part": p, "ns": v, "saves_ns": base - v} for p, v in switched.items()
        ]
    return {"rows": rows, "parts": parts}


def fine_level(trial_s: float, rounds: int, repeats: int) -> dict[str, Any]:
    """Part 2: the fine level's effect at 612×512 in a sea trial and at 2448×2048."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    trial: dict[str, list[float]] = {"on": [], "off": []}
    frames = 0
    for _ in range(rounds):
        for mode in ("off", "on"):
            out = subprocess.run(
                [sys.executable, "-c", _TRIAL, mode, str(trial_s)],
                cwd=ROOT, env=env, check=True, capture_output=True, text=True,
            )  # fmt: skip
            r = json.loads(out.stdout.strip().splitlines()[-1])
            trial[mode].append(r["ms"])
            frames = r["frames"]
    from twin.core.frames import euler_to_dcm

    t = _scenes()
    fast, _ = t._pair("phx050s_p")
    c, sun = euler_to_dcm(0.35, -0.17, 0.4), t._sun(30, 60)
    full: dict[str, float] = {}
    for on in (False, True):
        fast.fine_level = on
        full["on" if on else "off"] = 1e3 * _best(
            lambda: fast.render_stokes(None, np.zeros(3), c, 1.0, sun), max(repeats // 4, 3)
        )
    return {"trial_ms": trial, "trial_frames": frames, "trial_s": trial_s, "full_ms": full}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--trial-s", type=float, default=150.0)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    sys.path.insert(0, str(ROOT))
    from twin.record import provenance as pv

    ray = per_ray(args.repeats)
    fine = fine_level(args.trial_s, args.rounds, args.repeats)
    meta = {
        "date": time.strftime("%Y-%m-%d"),
        "cpu_count": os.cpu_count(),
        "load_average_1_5_15": [round(x, 2) for x in os.getloadavg()],
        "args": vars(args),
        "provenance": pv.provenance(),
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "chain_cost.json").write_text(
        json.dumps({"meta": meta, "per_ray": ray, "fine_level": fine}, indent=2) + "\n"
    )
    md = _report(meta, ray, fine)
    (RESULTS / "chain_cost.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0


def _report(meta: dict[str, Any], ray: dict[str, Any], fine: dict[str, Any]) -> list[str]:
    from twin.record import provenance as pv

    a = meta["args"]
    md = [
        "# The exact chain's cost per ray, and the fine level's (issue #31)",
        "",
        f"`python benchmarks/chain_cost.py --repeats {a['repeats']} --trial-s "
        f"{a['trial_s']:g} --rounds {a['rounds']}`, one core, {meta['date']}, "
        f"{meta['cpu_count']} CPUs, load average {meta['load_average_1_5_15']}.",
        f"- {'; '.join(pv.describe(meta['provenance']))}",
        "",
        "## A ray through the compiled chain (612×512, level camera at 10 m, best of "
        f"{a['repeats']})",
        "",
        "| rays | where | rays in the frame | ns a ray |",
        "|---|---|---|---|",
        *(f"| {r['rays']} | {r['where']} | {r['n']} | {r['ns']:.0f} |" for r in ray["rows"]),
        "",
        "The exact pixels inside Snell's window, with one part of the scattered light off:",
        "",
        "| switched off | ns a ray | that part's cost, ns |",
        "|---|---|---|",
        *(f"| {p['part']} | {p['ns']:.0f} | {p['saves_ns']:.0f} |" for p in ray["parts"]),
        "",
        "## The fine level",
        "",
    ]
    tr = fine["trial_ms"]
    md += [
        f"sea_trial_10m at 612×512 (coarse stride 4), {fine['trial_frames']} frames of "
        f"{fine['trial_s']:g} s, the fast path's time a frame (interleaved fresh interpreters):",
        "",
        "| fine level | runs, ms a frame | median |",
        "|---|---|---|",
        *(
            f"| {mode} | {', '.join(f'{x:.2f}' for x in tr[mode])} | "
            f"{float(np.median(tr[mode])):.2f} |"
            for mode in ("off", "on")
        ),
        "",
        f"2448×2048 (stride 8; validation/fast_path_error.py's tilted 1 m frame), the light: "
        f"{fine['full_ms']['off']:.1f} ms without the level, {fine['full_ms']['on']:.1f} ms "
        "with it (best of several).",
    ]
    return md


if __name__ == "__main__":
    raise SystemExit(main())
