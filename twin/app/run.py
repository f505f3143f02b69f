"""The run loop: simulate a scenario, record it to Rerun, write metrics.

Outputs, in ``out_dir``:
  * ``recording.rrd``: the Rerun recording (open with ``rerun recording.rrd``).
  * ``metrics.json``: the summary. It is written as ``"status": "running"`` before the flight
    starts and rewritten at the end, so even a killed run leaves a file that says it is incomplete.

The loop is the stepping core (:class:`twin.sim.step.Simulation`) with two observers: the
scorer (:class:`twin.scoring.observer.RunScorer`) and the recorder
(:class:`twin.record.observer.RunRecorder`).

Ctrl-C or an exception stops the loop; the recording is closed (footer written) and the metrics
are written with ``"complete": false`` and the reason, before the exception propagates. If closing
the recording fails, metrics.json says so (``"recording_error"``) and the error propagates.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from scenarios.schema import Scenario
from twin.app.heap import start_up_frozen
from twin.core.ephemeris import NIGHT_ELEVATION_DEG, sun_position
from twin.record.blueprint import default_blueprint
from twin.record.mcap_log import FILE as MCAP_FILE
from twin.record.mcap_log import McapLog
from twin.record.observer import ChaseCamera, RunRecorder, log_scene
from twin.record.provenance import fingerprint, provenance
from twin.record.recorder import Recorder
from twin.record.rrd_files import compact
from twin.record.timeseries import TimeSeriesWriter
from twin.scoring.mission import format_summary, fusion_warnings, summarize
from twin.scoring.observer import RunScorer
from twin.sim.build import build_simulation
from twin.sim.step import Simulation

__all__ = ["format_summary", "prepare_output", "run_scenario"]

# Keep running this long after the last leg is done, so the recording shows the vehicle settle.
_MISSION_COMPLETE_TAIL_S = 5.0


def _write_json_atomic(path: Path, payload: dict[str, Any]) -> None:
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(payload, indent=2, sort_keys=False, default=str) + "\n")
    os.replace(tmp, path)


def prepare_output(out_dir: Path | str) -> Path:
    """Create the output folder and prove it writable, before anything is flown.

    Raises:
        OSError: With the path in the message: the folder cannot be created (a file is in the
            way, no permission, a name too long for the file system) or cannot be written.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".auv-twin-write-test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise OSError(exc.errno, f"{out}: {reason}") from None
    return out


def _versions() -> dict[str, str]:
    from importlib import metadata

    out = {"mujoco": mujoco.__version__, "numpy": np.__version__}
    for dist in ("auv-twin", "rerun-sdk"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:  # running from a source tree without install
            out[dist] = "unknown"
    return out


def _progress(total_s: float, enabled: bool):
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(
        total=round(total_s),
        unit="sim s",
        desc="sea trial",
        file=sys.stderr,
        leave=True,
        mininterval=progress_interval_s(),
    )


def progress_interval_s() -> float:
    """How often a progress bar redraws (s).

    0.1 s on a terminal; into a file or a CI log at most every 5 s, since each redraw stays there.
    """
    return 0.1 if sys.stderr.isatty() else 5.0


def run_scenario(
    scenario: Scenario,
    out_dir: Path | str,
    *,
    seed: int | None = None,
    progress: bool = False,
    camera: bool | None = None,
    on_message: Callable[[str], None] | None = None,
    record: bool = True,
    on_scored: Callable[[RunScorer], None] | None = None,
    timeseries: bool = False,
    mcap: bool = False,
    live: str | None = None,
) -> dict[str, Any]:
    """Run one sea trial and write its recording and metrics.

    Args:
        scenario: A validated scenario.
        out_dir: Output folder (created).
        seed: Root seed; defaults to the scenario's.
        progress: Show a progress bar on stderr.
        camera: Render the chase camera; ``None`` follows the scenario's recording settings.
        on_message: Called with one-line notices (e.g. "no GL context"); default: stderr.
        record: Write the Rerun recording (False: metrics only, as campaigns run by default).
        on_scored: Called with the run's scorer when the run ends (per-run time series).
        timeseries: Also write the run's time series as Parquet in ``out_dir/timeseries/``
            (:mod:`twin.record.timeseries`), also when the run stops early.
        mcap: Also write the run as ROS 2 messages in ``out_dir/run.mcap``
            (:mod:`twin.record.mcap_log`), finished also when the run stops early.
        live: Also stream the recording to a Rerun viewer at this gRPC URL while the run goes
            on (the file is unchanged); needs ``record``.

    Returns:
        The metrics dict (also written to ``out_dir/metrics.json``).
    """
    say = on_message or (lambda msg: print(msg, file=sys.stderr))
    out = prepare_output(out_dir)
    metrics_path = out / "metrics.json"
    world = build_simulation(scenario, seed)
    base = _first_metrics(scenario, world.seed, record)
    _write_json_atomic(metrics_path, base)

    # From here on, whatever stops the run (Ctrl-C during start-up included) rewrites
    # metrics.json with the reason and closes whatever was opened.
    rec: Recorder | None = None
    cam: ChaseCamera | None = None
    recorder: RunRecorder | None = None
    series: TimeSeriesWriter | None = None
    mcap_log: McapLog | None = None
    scorer = RunScorer(world)
    notes: list[str] = []
    status_text = "starting"
    error: str | None = None
    recording_error: str | None = None
    wall0 = time.perf_counter()
    bar = None
    try:
        if record:
            rec = _open_recording(out, scenario, world, base["provenance"], live)
        notes = _notes(scenario)
        for note in notes:
            say(f"note: {note}")
        if record and (scenario.recording.camera if camera is None else camera):
            cam = _open_camera(scenario, world, say)
        recorder = RunRecorder(rec, world, scorer, cam) if rec is not None else None
        series = TimeSeriesWriter(world, scorer, scenario.start_utc) if timeseries else None
        if mcap:
            mcap_log = McapLog(
                out / MCAP_FILE, world, scorer, scenario.start_utc, base["provenance"]
            )
        # The recorder and the series read what the scorer just computed: the scorer goes first.
        world.observers[:] = (
            [scorer]
            + ([recorder] if recorder is not None else [])
            + ([series] if series is not None else [])
            + ([mcap_log] if mcap_log is not None else [])
        )
        status_text = "running"
        bar = _progress(scenario.duration_s, progress)
        if rec is not None:
            log_scene(rec, world)
        with start_up_frozen():  # the full GC passes skip the start-up heap (twin/app/heap.py)
            status_text = _loop(world, scorer, recorder, bar)
    except KeyboardInterrupt:
        status_text, error = "interrupted", "KeyboardInterrupt"
        raise
    except Exception as exc:
        status_text, error = "error", f"{type(exc).__name__}: {exc}"
        raise
    finally:
        wall = time.perf_counter() - wall0
        if bar is not None:
            bar.close()
        if cam is not None:
            cam.close()
        world.observers.clear()
        if mcap_log is not None:
            mcap_log.close()
        if rec is not None:
            recording_error = _close_recording(rec, world.plant.t, status_text, error, recorder)
            if recording_error is not None and status_text in _FLYING:
                status_text = "error"
                error = f"closing the recording failed: {recording_error}"
        metrics = {
            **base,
            "complete": status_text in ("mission_complete", "duration_reached"),
            "status": status_text,
            **({"error": error} if error else {}),
            **({"recording_error": recording_error} if recording_error else {}),
            **({"notes": notes} if notes else {}),
            **summarize(world, scorer, wall),
        }
        warnings = fusion_warnings(metrics, scenario.navigation)
        if warnings:
            metrics["warnings"] = warnings
        if series is not None:
            files = series.write(out, base["provenance"])
            metrics["timeseries"] = [str(p.relative_to(out)) for p in files]
        if mcap_log is not None:
            metrics["mcap"] = {"file": MCAP_FILE, "messages": mcap_log.counts}
        _write_json_atomic(metrics_path, metrics)
        if rec is not None and recording_error is None:
            # Last, so that a Ctrl-C here leaves the metrics written and the recording whole.
            compact(out / "recording.rrd")
        if on_scored is not None:
            on_scored(scorer)
        if recording_error is not None and sys.exc_info()[0] is None:
            raise OSError(
                f"closing the recording {out / 'recording.rrd'} failed: {recording_error}"
            )
    return metrics


#: A run's status while it flies or once it ended as planned (a failure after it is an error).
_FLYING = ("mission_complete", "duration_reached", "running")


def _first_metrics(scenario: Scenario, seed: int, record: bool) -> dict[str, Any]:
    """metrics.json as the run starts: who, what and where from, before any number."""
    return {
        "scenario": scenario.name,
        "seed": seed,
        "complete": False,
        "status": "running",
        "recording": "recording.rrd" if record else None,
        "versions": _versions(),
        # Where these numbers came from: code, packages, light model, inputs, seed, machine, date.
        "provenance": provenance(fingerprint=fingerprint(scenario.to_dict()), seed=seed),
        # Every setting, defaults written out: parse_scenario(this) rebuilds the scenario.
        "scenario_config": scenario.to_dict(),
    }


def _open_recording(
    out: Path, scenario: Scenario, world: Simulation, block: dict[str, Any], live: str | None
) -> Recorder:
    rec = Recorder(
        out / "recording.rrd",
        recording_id=f"{scenario.name}-seed{world.seed}",
        start_utc=scenario.start_utc,
        compact=False,  # compacted after metrics.json is written (run_scenario)
        blueprint=default_blueprint(tuple(world.navigators), gravity=world.stored_map is not None),
        live=live,
    )
    rec.log_properties("provenance", block)
    return rec


def _open_camera(
    scenario: Scenario, world: Simulation, say: Callable[[str], None]
) -> ChaseCamera | None:
    """The chase camera, or None (with a note) where no GL context can be had."""
    cam = ChaseCamera(
        world.plant.model, scenario.recording.camera_width, scenario.recording.camera_height
    )
    if not cam.available:
        say(f"note: no GL context for the chase camera ({cam.reason}); continuing without it")
        return None
    return cam


def _close_recording(
    rec: Recorder,
    t: float,
    status_text: str,
    error: str | None,
    recorder: RunRecorder | None = None,
) -> str | None:
    """Close the recording; the failure to do so, or None.

    First the samples the run's recorder still holds, then how the run ended.
    """
    try:
        if recorder is not None:
            recorder.close()
        rec.log_text(t, f"run ended: {status_text}" + (f" ({error})" if error else ""))
        rec.close()
    except Exception as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


def _notes(scenario: Scenario) -> list[str]:
    """Conditions a user should know before reading the results (documented graceful behaviour).

    A sun below the horizon is not an error: the sky is dark, the compass methods answer "no
    solution: night" for every frame and the compass variants run as INS-only filters. The run
    says so up front, and metrics.json keeps the note.
    """
    out: list[str] = []
    compass = [v for v in scenario.navigation.variants if v != "ins"]
    if compass and scenario.sensors.polarimeter is not None:
        p = scenario.place
        end = scenario.start_utc + dt.timedelta(seconds=scenario.duration_s)
        elevations = [
            math.degrees(sun_position(t, p.latitude_deg, p.longitude_deg).elevation_rad)
            for t in (scenario.start_utc, end)
        ]
        if max(elevations) < NIGHT_ELEVATION_DEG:
            out.append(
                f"the sun is below the horizon for the whole run (elevation "
                f"{elevations[0]:.1f} to {elevations[1]:.1f} deg): the compass variants "
                f"{compass} will have no fixes ('night') and run as INS-only filters"
            )
    return out


def _loop(sim: Simulation, scorer: RunScorer, recorder: RunRecorder | None, bar) -> str:
    dt = sim.physics_dt
    n_steps = round(sim.scenario.duration_s / dt)
    every_ap = sim.autopilot_every
    every_bar = max(1, round(1.0 / dt))
    cmd = None
    complete_at: float | None = None
    k = 0
    while k < n_steps:
        if k % every_ap == 0:
            t = sim.plant.t
            prev_leg = sim.status.leg
            cmd = sim.control()
            if sim.status.leg != prev_leg:
                scorer.leg_started_at = t
            if recorder is not None:
                recorder.log_control(t, cmd, sim.setpoint)
            if sim.status.complete and complete_at is None:
                complete_at = t
                scorer.active = False
                if recorder is not None:
                    recorder.rec.log_text(t, "mission complete")
        assert cmd is not None
        # Up to the next autopilot update: quiet steps fly in compiled blocks (Simulation.advance);
        # after the mission's end, one at a time, so that the tail ends on the same step.
        most = 1 if complete_at is not None else min(every_ap - k % every_ap, n_steps - k)
        taken = sim.advance(cmd, most)
        if bar is not None and (k + taken) // every_bar > k // every_bar:
            bar.update((k + taken) // every_bar - k // every_bar)
        k += taken
        if complete_at is not None and sim.plant.t - complete_at >= _MISSION_COMPLETE_TAIL_S:
            return "mission_complete"
    return "duration_reached"
