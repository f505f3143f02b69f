"""Running a campaign: every run in a worker process, results written as each run finishes.

The local backend is a pool of worker processes (``spawn``) that live for the whole campaign,
so each pays the ~3 s of imports once; one worker is a pool of one, never the campaign's own
process. Workers die with the campaign (SIGKILL included). The campaign holds the folder's lock
and runs only a spec of the folder's experiment (:mod:`twin.campaign.folder`). Each run is
isolated:

* a run that raises, or whose kept metrics hold NaN, is recorded with its status ("error",
  "nan") and error text, and the campaign goes on;
* a run past ``wall_time_limit_s`` is stopped inside its worker (SIGALRM) and recorded as
  "timeout";
* a worker that dies (segfault, out of memory, killed) breaks the pool: the pool is rebuilt and
  every run that was in flight is retried once, then recorded as "failed".

A re-run of the same command skips the runs that have a row on disk; a campaign killed with
SIGKILL loses at most the runs in flight. Ctrl-C stops the workers, keeps every finished row and
says how to resume. Per-run numbers depend on the run's scenario and seed only, never on the
worker count or the order runs finish in.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import functools
import multiprocessing as mp
import os
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

from twin.campaign.folder import check_spec, locked, write_record
from twin.campaign.results import (
    consolidate,
    finished_ids,
    flatten_metrics,
    has_nan,
    param_value,
    relabel_finished,
    write_row,
    write_timeseries,
)
from twin.campaign.spec import CampaignError, CampaignSpec, RunSpec
from twin.campaign.trials import SCENARIO, StudyTrial, load_trial
from twin.record.provenance import provenance


class _WallTimeExceeded(Exception):
    pass


def _on_alarm(signum: int, frame: Any) -> None:
    raise _WallTimeExceeded


def execute_run(run: RunSpec, job: dict[str, Any]) -> dict[str, Any]:
    """One run, in whichever process calls it: a result row (never raises for the run's sake)."""
    import scenarios
    from twin.app.run import run_scenario

    row: dict[str, Any] = {
        "run_id": run.run_id,
        "index": run.index,
        "seed": run.seed,
        **{f"param.{k}": param_value(v) for k, v in run.params},
        "spec_fingerprint": job.get("fingerprint", ""),
        "status": "ok",
        "error": "",
        "warnings": "",
        # Where this row was made (the worker's machine and code): the row file's metadata.
        "_provenance": provenance(fingerprint=job.get("fingerprint"), seed=run.seed),
    }
    series: dict[str, list] = {}

    def keep_series(scorer: Any) -> None:
        if not job["timeseries"]:
            return
        step = max(1, round(job["truth_rate_hz"] / job["timeseries_rate_hz"]))
        for name, vs in scorer.variants.items():
            series.setdefault("t", list(vs.t[::step]))
            series[f"{name}.heading_error_deg"] = list(vs.heading_err[::step])

    limit = float(job["wall_time_limit_s"])
    # SIGALRM works in a process's main thread only (the local pool's workers and Ray's task
    # threads are; a caller's other threads are not, and then the limit is not enforced).
    use_alarm = hasattr(signal, "SIGALRM") and threading.current_thread() is threading.main_thread()
    t0 = time.perf_counter()
    try:
        if use_alarm:
            signal.signal(signal.SIGALRM, _on_alarm)
            signal.setitimer(signal.ITIMER_REAL, limit)
        if job.get("trial", SCENARIO) != SCENARIO:
            metrics = _study(job["trial"]).run(run.scenario["params"], run.seed)
            return _finish(row, metrics, job, t0, series)
        sc = scenarios.parse_scenario(run.scenario, run.run_id)
        keep = job["keep_dir"]
        with tempfile.TemporaryDirectory(prefix="auv-twin-run-") as tmp:
            out = Path(keep) / run.run_id if keep else Path(tmp)
            metrics = run_scenario(
                sc,
                out,
                seed=run.seed,
                camera=False,
                on_message=lambda _m: None,
                record=bool(keep),
                on_scored=keep_series,
            )
        return _finish(row, metrics, job, t0, series)
    except _WallTimeExceeded:
        row["status"], row["error"] = "timeout", f"passed the wall-time limit of {limit:g} s"
    except Exception as exc:  # the run's failure is data; the campaign goes on
        row["status"], row["error"] = "error", f"{type(exc).__name__}: {exc}"
    finally:
        if use_alarm:
            signal.setitimer(signal.ITIMER_REAL, 0)
    row["wall_time_s"] = time.perf_counter() - t0
    row["_series"] = series
    return row


def _finish(
    row: dict[str, Any], metrics: Any, job: dict[str, Any], t0: float, series: dict[str, list]
) -> dict[str, Any]:
    """A finished trial's row: its kept metrics, flattened, and its status."""
    if not isinstance(metrics, dict):
        row["status"], row["error"] = "error", f"the trial returned {type(metrics).__name__}"
    else:
        flat = flatten_metrics(metrics, job["metrics"])
        row.update({f"metric.{k}": v for k, v in flat.items()})
        # The run's warnings (a compass variant that fused too few fixes): the report lists them.
        row["warnings"] = " | ".join(str(w) for w in metrics.get("warnings", []))
        if not metrics.get("complete", True):
            row["status"] = "error"
            row["error"] = str(metrics.get("error", metrics.get("status", "incomplete")))
        else:
            bad = has_nan(row)
            if bad:
                row["status"], row["error"] = "nan", f"non-finite metrics: {bad[:5]}"
    row["wall_time_s"] = time.perf_counter() - t0
    row["_series"] = series
    return row


@functools.lru_cache(maxsize=8)
def _study(name: str) -> StudyTrial:
    return load_trial(name)


def _job(spec: CampaignSpec) -> dict[str, Any]:
    return {
        "metrics": list(spec.metrics),
        "wall_time_limit_s": spec.wall_time_limit_s,
        "timeseries": list(spec.timeseries),
        "timeseries_rate_hz": spec.timeseries_rate_hz,
        "truth_rate_hz": spec.base.recording.truth_rate_hz if spec.base is not None else 0.0,
        "trial": spec.trial,
        "keep_dir": "",  # no recording; _record_worst sets it for the runs it keeps
    }


def _worker_init(parent: int | None = None, flights: bool = True) -> None:
    # Pay the imports once per worker (a flight's: ~2 s); let the parent handle Ctrl-C; die
    # with the parent.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with(parent if parent is not None else os.getppid())
    if flights:
        import twin.app.run  # noqa: F401


def _init_args(job: dict[str, Any]) -> tuple[int, bool]:
    return (os.getpid(), job.get("trial", SCENARIO) == SCENARIO)


def _die_with(parent: int) -> None:
    """End this worker when the campaign's process dies, even by SIGKILL.

    Linux: the kernel sends SIGKILL when the parent thread exits (``PR_SET_PDEATHSIG``). Also,
    everywhere: a daemon thread that sees the parent gone (re-parented) within a second.
    """
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG = 1
    if os.getppid() != parent:  # the parent died before the line above
        os._exit(1)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="die-with-parent").start()


def _store(out: Path, row: dict[str, Any], fp: str) -> None:
    series = row.pop("_series", {})
    block = row.pop("_provenance", None) or provenance(fingerprint=fp, seed=row.get("seed"))
    if series:
        write_timeseries(out, row["run_id"], series, block)
    write_row(out, row, block)


def run_campaign(
    spec: CampaignSpec,
    out: str | Path,
    *,
    workers: int = 1,
    ray_address: str | None = None,
    use_ray: bool = False,
    progress: bool = False,
    on_message: Callable[[str], None] | None = None,
) -> dict[str, int]:
    """Run every run of ``spec`` not yet on disk in ``out``; returns counts by status.

    Args:
        spec: The campaign.
        out: Its results folder (resumed when it holds rows).
        workers: Local worker processes (the local Ray instance's CPUs with ``use_ray``).
        ray_address: A Ray cluster to join (``"auto"`` or ``"host:port"``); None: local Ray.
        use_ray: Run on Ray instead of the local pool.
        progress: A progress bar (runs done, failed, runs per minute, ETA) on stderr.
        on_message: One-line notices (resume, interrupt); default stderr.

    Raises:
        KeyboardInterrupt: After stopping the workers; every finished row stays on disk.
    """
    say = on_message or (lambda m: print(m, file=sys.stderr))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with locked(out):
        old = check_spec(spec, out)  # another experiment in the folder: FolderError, no run
        counts = _run_locked(spec, out, old, workers, ray_address, use_ray, progress, say)
    return counts


def _run_locked(
    spec: CampaignSpec,
    out: Path,
    old: dict[str, Any] | None,
    workers: int,
    ray_address: str | None,
    use_ray: bool,
    progress: bool,
    say: Callable[[str], None],
) -> dict[str, int]:
    if use_ray:
        try:
            import ray  # noqa: F401
        except ImportError:
            raise CampaignError(
                ["--ray: Ray is not installed; install it with: pip install 'auv-twin[ray]'"],
                spec.source,
            ) from None
    record_ = write_record(spec, out, old)
    fp = record_["fingerprint"]
    same_layout = old is not None and old.get("fingerprint") == fp
    done = finished_ids(out, say) & {r.run_id for r in spec.runs}
    todo = [r for r in spec.runs if r.run_id not in done]
    if done:
        say(f"resuming: {len(spec.runs) - len(todo)} of {len(spec.runs)} runs already on disk")
        if not same_layout:  # a grown spec made some of them: give them this one's labels
            relabel_finished(out, [r for r in spec.runs if r.run_id in done])
    job = _job(spec)
    job["fingerprint"] = fp
    counts: dict[str, int] = {}
    bar = _bar(len(todo)) if progress else None
    t0 = time.perf_counter()

    def record(row: dict[str, Any]) -> None:
        _store(out, row, fp)
        counts[row["status"]] = counts.get(row["status"], 0) + 1
        if bar is not None:
            n_ok = counts.get("ok", 0)
            rate = sum(counts.values()) / max(time.perf_counter() - t0, 1e-9) * 60
            bar.set_postfix(
                ok=n_ok, failed=sum(counts.values()) - n_ok, per_min=f"{rate:.1f}", refresh=False
            )
            bar.update(1)

    try:
        if use_ray:
            from twin.campaign.ray_backend import run_on_ray

            run_on_ray(
                todo, job, record, address=ray_address, num_cpus=None if ray_address else workers
            )
        else:
            # One worker is a pool of one: a run that crashes its process (a segfault) is as
            # isolated as with two, never the campaign's own death.
            _run_pool(todo, job, max(1, workers), record, say)
    except KeyboardInterrupt:
        n = sum(counts.values()) + len(spec.runs) - len(todo)
        say(
            f"\ninterrupted: {n} of {len(spec.runs)} runs are on disk in {out}; "
            "run the same command again to resume"
        )
        raise
    finally:
        if bar is not None:
            bar.close()
        rows = consolidate(out, record_["provenance"], say)
    _warn_unmatched(spec, rows, say)
    if spec.keep_recordings:
        _record_worst(spec, out, job, say)
    return counts


def _warn_unmatched(spec: CampaignSpec, df: Any, say: Callable[[str], None]) -> None:
    """Say which kept-metric patterns matched no metric of any finished run (``df``: the rows)."""
    import fnmatch

    if df.empty or not (df["status"] == "ok").any():
        return
    keys = [c.removeprefix("metric.") for c in df.columns if c.startswith("metric.")]
    for pat in spec.metrics:
        if not any(fnmatch.fnmatchcase(k, pat) for k in keys):
            tops = sorted({k.split(".")[0] for k in keys})[:12]
            say(f"warning: metrics pattern {pat!r} matched no metric of any run; the runs' "
                f"metrics start with {tops}")  # fmt: skip


def _record_worst(spec: CampaignSpec, out: Path, job: dict[str, Any], say: Callable) -> None:
    """Re-fly the k worst runs with their recording kept (same scenario and seed: same run).

    Worst: the largest value of ``worst_by`` (a kept metric), by default the largest heading
    RMSE of any filter variant. Recordings land in ``recordings/<run_id>/``.
    """
    from twin.campaign.results import load_campaign_results

    df = load_campaign_results(out)
    df = df[df["status"] == "ok"]
    if spec.worst_by:
        cols = [f"metric.{spec.worst_by}"] if f"metric.{spec.worst_by}" in df.columns else []
    else:
        cols = [c for c in df.columns if c.endswith("heading_rmse_deg")]
    if df.empty or not cols:
        say(f"keep_recordings: no kept metric {spec.worst_by or '*heading_rmse_deg'} to rank by")
        return
    worst = df.assign(_score=df[cols].max(axis=1)).nlargest(spec.keep_recordings, "_score")
    by_id = {r.run_id: r for r in spec.runs}
    keep = {**job, "keep_dir": str(out / "recordings")}
    for run_id in worst["run_id"]:
        if (out / "recordings" / run_id / "recording.rrd").is_file():
            continue
        row = execute_run(by_id[run_id], keep)
        say(f"kept the recording of run {run_id} ({row['status']})")


def _run_pool(
    todo: list[RunSpec], job: dict, workers: int, record: Callable, say: Callable[[str], None]
) -> None:
    """The local pool: long-lived workers; a broken pool is rebuilt, its runs retried once.

    The runs in flight when a worker died are retried one at a time, each in a worker of its
    own (:func:`_run_alone`); a run that dies there too is recorded as "failed".

    At most ``workers`` runs are submitted at a time, so the runs a dying worker takes down with
    the pool (every submitted one) are the runs in flight, not the whole queue: a second crash
    later in a campaign costs its own in-flight runs a retry, not every run still queued.
    """
    ctx = mp.get_context("spawn")
    queue = list(todo)
    queue.reverse()  # pop() from the end: the runs go in index order
    while queue:
        pool = cf.ProcessPoolExecutor(
            max_workers=workers, mp_context=ctx, initializer=_worker_init, initargs=_init_args(job)
        )
        futures: dict[cf.Future, RunSpec] = {}
        retry: list[RunSpec] = []
        broken = False
        try:
            while (queue or futures) and not broken:
                while queue and len(futures) < workers:
                    r = queue.pop()
                    futures[pool.submit(execute_run, r, job)] = r
                finished, _ = cf.wait(futures, return_when=cf.FIRST_COMPLETED)
                for fut in finished:
                    r = futures.pop(fut)
                    try:
                        record(fut.result())
                    except BrokenProcessPool:
                        broken = True
                        retry.append(r)
            if broken:  # the other runs in flight died with the pool too
                for fut, r in futures.items():
                    try:
                        record(fut.result(timeout=0))
                    except (BrokenProcessPool, cf.TimeoutError, cf.CancelledError):
                        retry.append(r)
        except KeyboardInterrupt:
            _kill(pool)
            raise
        finally:
            if broken:
                _kill(pool)
            else:
                pool.shutdown(wait=True, cancel_futures=True)
        if retry:
            say(
                f"a worker process died: the {len(retry)} run(s) in flight are retried once, "
                "each alone in a new worker, so that only the run that kills it is marked failed"
            )
        for r in sorted(retry, key=lambda r: r.index):
            record(_run_alone(r, job, ctx))


def _run_alone(r: RunSpec, job: dict, ctx: Any) -> dict[str, Any]:
    """A run's retry in a worker of its own: a second death there is the run's own doing.

    A dying worker takes down every run in flight in its pool, and the pool cannot say whose
    run killed it; alone, a run that dies again is the culprit and the others are innocent.
    """
    pool = cf.ProcessPoolExecutor(
        max_workers=1, mp_context=ctx, initializer=_worker_init, initargs=_init_args(job)
    )
    try:
        return pool.submit(execute_run, r, job).result()
    except BrokenProcessPool:
        return _failed(r, "the worker process died twice (crash or out of memory)")
    except KeyboardInterrupt:
        _kill(pool)
        raise
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def _kill(pool: cf.ProcessPoolExecutor) -> None:
    for p in list(getattr(pool, "_processes", {}).values()):
        if p.is_alive():
            p.kill()
    pool.shutdown(wait=False, cancel_futures=True)


def _failed(r: RunSpec, why: str) -> dict[str, Any]:
    return {
        "run_id": r.run_id,
        "index": r.index,
        "seed": r.seed,
        **{f"param.{k}": param_value(v) for k, v in r.params},
        "spec_fingerprint": "",
        "status": "failed",
        "error": why,
        "warnings": "",
        "wall_time_s": float("nan"),
        "_series": {},
    }


def _bar(total: int):
    from tqdm import tqdm

    from twin.app.run import progress_interval_s

    return tqdm(
        total=total, unit="run", desc="campaign", file=sys.stderr, mininterval=progress_interval_s()
    )
