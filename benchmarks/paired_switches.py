"""Fast paths that keep their reference behind a switch, timed against it in one process (#31).

Three of issue #31's changes keep the path they replaced, behind a class switch, as the
reference a test holds them to bit for bit; a fourth, the recording's cadence, is an argument.
Their gains are a few per cent of a sea trial, less than this VM's run-to-run spread
(±10–20 %), so ``sea_trial_rtf.py``'s separate runs cannot see them; here the two paths run in
one process on one core, their rounds interleaved, so that the machine's hour affects both
alike:

* ``Simulation.closing_steps``: a block of quiet steps ends with the step after them (its
  physics and IMU sample flown in the block's compiled call, its poll given that sample), or
  that step goes through ``Simulation.step``. Two simulations of the sea trial (three filter
  variants, no observers) fly the same flight in alternating chunks of ``--chunk-s``, one with
  each setting; each chunk's wall time (perf_counter) goes to its setting's sum. Their states
  are compared at the end.
* ``ImuBatch.compiled_updates``: a filter's depth updates queued among its IMU samples and made
  with them and its gravity update in the batch's compiled call, or each by the filter's Python
  method when it comes. Timed as ``closing_steps`` is.
* ``Recorder(flush_every_s=...)``: the recording written every ``FLUSH_EVERY_S`` of simulated
  time (30 s, the default for a file alone) or every ``LIVE_FLUSH_EVERY_S`` (5 s, a live
  viewer's, the default for every recording before). Three simulations of the sea trial, each
  with the run's scorer, fly in interleaved chunks: one unrecorded, one recorded at each
  cadence (the run's recorder and its scene, no chase camera, not the run loop's control
  series: 0.08 ms per simulated second in ``recording_profile.py``); closing each recording
  (its last flush, footer and compaction) is counted to it. The two recordings' rows per entity are
  compared. Its gain is near the interleaving's own spread: the comparison runs
  ``--cadence-runs`` times, each run's change reported beside their mean.
* ``LightFieldTable.compiled``: a frame's table fields interpolated in one compiled pass each
  (``sensors/polarimeter/optics/rt/frame_kernel.py``), or with numpy. The polarimeter's light
  field of a frame (``Polarimeter._frame_constants``, at the sea trial's camera, depth and sun)
  is timed both ways, best of ``--repeats`` × 100 calls, interleaved; the fields are compared.

    OMP_NUM_THREADS=1 taskset -c 1 python benchmarks/paired_switches.py [--flight-s 300]

Writes benchmarks/results/paired_switches.{json,md}.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import sys
import tempfile
import time
import timeit
from pathlib import Path
from typing import Any

import numpy as np

import scenarios
from sensors.polarimeter.optics.rt import table as rt_table
from twin.onboard.imu_batch import ImuBatch
from twin.record import provenance as pv
from twin.record.observer import RunRecorder, log_scene
from twin.record.recorder import FLUSH_EVERY_S, LIVE_FLUSH_EVERY_S, Recorder
from twin.record.rrd_files import compact, entity_rows
from twin.scoring.observer import RunScorer
from twin.sim.build import build_simulation
from twin.sim.step import Simulation

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
WARM_S = 5.0  # flown before timing: the first frame's tables and kernels


def _scenario() -> Any:
    sc = scenarios.load("sea_trial_10m")
    mission = dataclasses.replace(sc.mission, legs=sc.mission.legs * 2)
    return dataclasses.replace(
        sc,
        duration_s=1e4,
        mission=mission,
        navigation=dataclasses.replace(sc.navigation, variants=("ins", "pol", "lig")),
    )


def _state(sim: Simulation) -> tuple:
    d = sim.plant.data
    navs = tuple(
        (n.filter.P.tobytes(), n.filter.ins._c, n.filter.ins.lat, n.filter.ins.h,
         dict(n.filter.counts), list(n.filter.rejections))
        for n in sim.navigators.values()
    )  # fmt: skip
    return d.time, d.qpos.tobytes(), d.qvel.tobytes(), navs


def flight_switch(owner: type, switch: str, flight_s: float, chunk_s: float) -> dict[str, Any]:
    """ms per simulated second of the flight with ``owner.switch`` off and on (module docstring)."""
    sc = _scenario()
    sims = {flag: build_simulation(sc) for flag in (False, True)}
    spent = {False: 0.0, True: 0.0}
    try:
        for flag, sim in sims.items():
            setattr(owner, switch, flag)
            sim.fly(WARM_S)
        t = WARM_S
        chunks = 0
        while t < WARM_S + flight_s - 1e-9:
            t = min(t + chunk_s, WARM_S + flight_s)
            order = (False, True) if chunks % 2 == 0 else (True, False)
            for flag in order:
                setattr(owner, switch, flag)
                t0 = time.perf_counter()
                sims[flag].fly(t)
                spent[flag] += time.perf_counter() - t0
            chunks += 1
    finally:
        setattr(owner, switch, True)
    return {
        "flight_s": flight_s,
        "chunk_s": chunk_s,
        "chunks": chunks,
        "without_ms_per_sim_s": 1e3 * spent[False] / flight_s,
        "with_ms_per_sim_s": 1e3 * spent[True] / flight_s,
        "same_state": _state(sims[False]) == _state(sims[True]),
    }


def recording_cadence(flight_s: float, chunk_s: float) -> dict[str, Any]:
    """ms per simulated second unrecorded and recorded at each cadence (module docstring)."""
    sc = _scenario()
    cadences = {"none": None, "live": LIVE_FLUSH_EVERY_S, "file": FLUSH_EVERY_S}
    spent = dict.fromkeys(cadences, 0.0)
    with tempfile.TemporaryDirectory() as tmp:
        sims, recs, recorders = {}, {}, {}
        for name, every in cadences.items():
            sim = sims[name] = build_simulation(sc)
            scorer = RunScorer(sim)
            sim.observers[:] = [scorer]
            if every is not None:
                rec = recs[name] = Recorder(
                    Path(tmp) / f"{name}.rrd",
                    recording_id=name,
                    start_utc=sc.start_utc,
                    flush_every_s=every,
                    variants=tuple(sim.navigators),
                    compact=False,
                )
                log_scene(rec, sim)
                recorders[name] = RunRecorder(rec, sim, scorer, None)
                sim.observers.append(recorders[name])
            sim.fly(WARM_S)
        t, chunks, names = WARM_S, 0, list(cadences)
        while t < WARM_S + flight_s - 1e-9:
            t = min(t + chunk_s, WARM_S + flight_s)
            for name in names[chunks % 3 :] + names[: chunks % 3]:  # each first in turn
                t0 = time.perf_counter()
                sims[name].fly(t)
                spent[name] += time.perf_counter() - t0
            chunks += 1
        for name, rec in recs.items():
            t0 = time.perf_counter()
            recorders[name].close()
            rec.close()
            compact(rec.path)
            spent[name] += time.perf_counter() - t0
        rows = {name: entity_rows(rec.path) for name, rec in recs.items()}
    ms = {name: 1e3 * v / flight_s for name, v in spent.items()}
    return {
        "flight_s": flight_s,
        "chunk_s": chunk_s,
        "chunks": chunks,
        "live_flush_every_s": LIVE_FLUSH_EVERY_S,
        "file_flush_every_s": FLUSH_EVERY_S,
        "unrecorded_ms_per_sim_s": ms["none"],
        "live_ms_per_sim_s": ms["live"],
        "file_ms_per_sim_s": ms["file"],
        "same_rows": rows["live"] == rows["file"] and bool(rows["file"]),
    }


def frame_fields(repeats: int) -> dict[str, Any]:
    """µs per frame of a frame's light field, the table's fields compiled or with numpy."""
    sim = build_simulation(_scenario())
    sim.fly(12.0)
    pol = next(s for s in sim.suite.sensors if type(s).__name__ == "Polarimeter")
    world = sim.plant
    pos, _ = world.site_pose(pol.site)
    depth = float(world.surface_z_m - pos[2])
    sun = pol._sun_for(world)
    sun_enu = np.asarray(sun.direction_enu, dtype=np.float64)

    def call() -> Any:
        return pol._frame_constants(sun, sun_enu, depth)

    best = {False: float("inf"), True: float("inf")}
    fields = {}
    try:
        for _ in range(repeats):
            for flag in (False, True):
                rt_table.LightFieldTable.compiled = flag
                fields[flag] = call().state.field
                best[flag] = min(best[flag], min(timeit.repeat(call, number=100, repeat=1)) / 100)
    finally:
        rt_table.LightFieldTable.compiled = True
    same = all(
        np.array_equal(np.asarray(getattr(fields[False], k)), np.asarray(getattr(fields[True], k)))
        for k in ("inside", "outside", "aureole", "up")
    )
    return {
        "depth_m": depth,
        "repeats": repeats,
        "numpy_us": 1e6 * best[False],
        "compiled_us": 1e6 * best[True],
        "same_fields": same,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flight-s", type=float, default=300.0)
    ap.add_argument("--chunk-s", type=float, default=2.0)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--cadence-runs", type=int, default=3)
    args = ap.parse_args()
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    closing = flight_switch(Simulation, "closing_steps", args.flight_s, args.chunk_s)
    updates = flight_switch(ImuBatch, "compiled_updates", args.flight_s, args.chunk_s)
    cadence_runs = [
        recording_cadence(args.flight_s, args.chunk_s) for _ in range(max(1, args.cadence_runs))
    ]
    keys = ("unrecorded_ms_per_sim_s", "live_ms_per_sim_s", "file_ms_per_sim_s")
    cadence = {
        **cadence_runs[0],
        **{k: float(np.mean([c[k] for c in cadence_runs])) for k in keys},
        "runs": cadence_runs,
        "same_rows": all(c["same_rows"] for c in cadence_runs),
    }
    fields = frame_fields(args.repeats)
    meta = {
        "machine": platform.platform(),
        "cpu_affinity": sorted(os.sched_getaffinity(0)),
        "load_average_1_5_15": [round(v, 2) for v in os.getloadavg()],
        "date": time.strftime("%Y-%m-%d"),
        "args": vars(args),
        "provenance": pv.provenance(),
    }
    c, f, r = closing, fields, cadence

    def flight_row(name: str, c: dict[str, Any]) -> str:
        return (
            f"| `{name}`: the sea trial's flight (three variants, no observers), "
            f"{c['flight_s']:g} s simulated in {c['chunks']} interleaved chunks "
            f"| {c['without_ms_per_sim_s']:.2f} ms per simulated s "
            f"| {c['with_ms_per_sim_s']:.2f} ms per simulated s "
            f"| {c['with_ms_per_sim_s'] - c['without_ms_per_sim_s']:+.2f} ms "
            f"({100 * (c['with_ms_per_sim_s'] / c['without_ms_per_sim_s'] - 1):+.1f} %) "
            f"| {'the same state, bit for bit' if c['same_state'] else 'STATES DIFFER'} |"
        )

    lines = [
        "# Fast paths against the references behind their switches, in one process (issue #31)",
        "",
        f"`python benchmarks/paired_switches.py --flight-s {args.flight_s:g} --chunk-s "
        f"{args.chunk_s:g} --repeats {args.repeats} --cadence-runs {args.cadence_runs}`, "
        f"one core, {meta['date']}, {meta['machine']}, CPUs {meta['cpu_affinity']}, load average "
        f"{meta['load_average_1_5_15']}.",
        f"- {'; '.join(pv.describe(meta['provenance']))}",
        "",
        "| switch | the reference | the fast path | change | same numbers |",
        "|---|---|---|---|---|",
        flight_row("Simulation.closing_steps", c),
        flight_row("ImuBatch.compiled_updates", updates),
        f"| `Recorder(flush_every_s=...)`: the sea trial's flight with the run's scorer, "
        f"{r['flight_s']:g} s simulated in {r['chunks']} interleaved chunks, recorded (closing "
        f"and compaction counted in); unrecorded {r['unrecorded_ms_per_sim_s']:.2f} ms per "
        f"simulated s beside them "
        f"| every {r['live_flush_every_s']:g} s: {r['live_ms_per_sim_s']:.2f} ms per simulated s "
        f"(the recording {r['live_ms_per_sim_s'] - r['unrecorded_ms_per_sim_s']:.2f}) "
        f"| every {r['file_flush_every_s']:g} s: {r['file_ms_per_sim_s']:.2f} ms per simulated s "
        f"(the recording {r['file_ms_per_sim_s'] - r['unrecorded_ms_per_sim_s']:.2f}) "
        f"| {r['file_ms_per_sim_s'] - r['live_ms_per_sim_s']:+.2f} ms "
        f"({100 * (r['file_ms_per_sim_s'] / r['live_ms_per_sim_s'] - 1):+.1f} %; the mean of "
        f"{len(r['runs'])} runs: "
        + ", ".join(
            f"{100 * (x['file_ms_per_sim_s'] / x['live_ms_per_sim_s'] - 1):+.1f} %"
            for x in r["runs"]
        )
        + ") "
        f"| {'the same rows of every entity' if r['same_rows'] else 'ROWS DIFFER'} |",
        f"| `LightFieldTable.compiled`: a frame's light field (tables at depth and sun) at "
        f"{f['depth_m']:.1f} m, best of {f['repeats']} × 100 "
        f"| {f['numpy_us']:.0f} µs a frame | {f['compiled_us']:.0f} µs a frame "
        f"| {f['compiled_us'] - f['numpy_us']:+.0f} µs "
        f"| {'the same fields, bit for bit' if f['same_fields'] else 'FIELDS DIFFER'} |",
    ]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "paired_switches.json").write_text(
        json.dumps(
            {
                "meta": meta,
                "closing_steps": closing,
                "compiled_updates": updates,
                "recording_cadence": cadence,
                "frame_fields": fields,
            },
            indent=2,
        )
        + "\n"
    )
    (RESULTS / "paired_switches.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    same = closing["same_state"] and updates["same_state"] and cadence["same_rows"]
    return 0 if same and fields["same_fields"] else 1


if __name__ == "__main__":
    sys.exit(main())
