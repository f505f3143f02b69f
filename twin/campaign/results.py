"""Campaign results as data: one Parquet row per run, written as each run finishes.

Layout of a campaign folder:

    DIR/campaign.json        the spec's summary (name, runs, axes), written before the first run
    DIR/runs/<run_id>.parquet     one row per finished run (atomic: written, then renamed), so a
                                  campaign killed with SIGKILL keeps every finished row readable
    DIR/timeseries/<run_id>.parquet   per-run time series, when the spec asks for them
    DIR/results.parquet      all rows in one table, rewritten at the end of a run of the campaign
    DIR/recordings/<run_id>/ the kept .rrd of chosen runs

Rows: ``run_id``, ``index``, ``seed``, ``param.<path>`` per swept axis, ``status`` (ok, error,
timeout, nan, failed), ``wall_time_s``, ``error`` and every kept number of metrics.json flattened
to ``metric.<dotted.key>`` columns. :func:`load_campaign_results` reads a folder as one pandas
DataFrame; ``pd.read_parquet(DIR / "results.parquet")`` works too.
"""

from __future__ import annotations

import fnmatch
import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq


def flatten_metrics(metrics: Mapping[str, Any], patterns: Iterable[str] = ("*",)) -> dict:
    """Every number of a metrics dict as ``dotted.key: float``, kept if it matches a pattern.

    Booleans become 0/1; lists of numbers become ``key[i]``; strings and None are left out (the
    row has its own status and error columns).
    """
    out: dict[str, float] = {}

    def walk(node: Any, key: str) -> None:
        if isinstance(node, Mapping):
            for k, v in node.items():
                walk(v, f"{key}.{k}" if key else str(k))
        elif isinstance(node, bool):
            out[key] = float(node)
        elif isinstance(node, int | float):
            out[key] = float(node)
        elif isinstance(node, list | tuple) and all(
            isinstance(x, int | float) and not isinstance(x, bool) for x in node
        ):
            for i, x in enumerate(node):
                out[f"{key}[{i}]"] = float(x)

    skip = {"scenario_config", "versions", "sensors"}
    walk({k: v for k, v in metrics.items() if k not in skip}, "")
    pats = list(patterns)
    return {k: v for k, v in out.items() if any(fnmatch.fnmatchcase(k, p) for p in pats)}


def has_nan(row: Mapping[str, Any]) -> list[str]:
    """The metric columns of a row that are NaN or infinite."""
    return [
        k
        for k, v in row.items()
        if k.startswith("metric.") and isinstance(v, float) and not math.isfinite(v)
    ]


def _write_atomic(table: pa.Table, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


def write_row(out: Path, row: Mapping[str, Any]) -> Path:
    """Write one run's row as ``runs/<run_id>.parquet`` (atomically)."""
    path = out / "runs" / f"{row['run_id']}.parquet"
    _write_atomic(pa.Table.from_pylist([dict(row)]), path)
    return path


def write_timeseries(out: Path, run_id: str, columns: Mapping[str, list]) -> Path:
    path = out / "timeseries" / f"{run_id}.parquet"
    data = {"run_id": [run_id] * len(next(iter(columns.values()), [])), **columns}
    _write_atomic(pa.table(data), path)
    return path


def finished_ids(out: Path) -> set[str]:
    """Run ids with a row on disk (a re-run skips them)."""
    d = out / "runs"
    return {p.stem for p in d.glob("*.parquet")} if d.is_dir() else set()


def relabel_finished(out: Path, runs: Iterable[Any]) -> int:
    """Give finished rows the index and swept values of the spec now being run; how many changed.

    A run's identity is its resolved scenario and seed, not its place in a spec: resuming a folder
    with a spec that adds an axis (one of whose values is the base's own) reuses the runs already
    made, and their rows must then carry the new axis's column and the new order, or a report
    grouping by that axis would miss them. Each ``runs`` item is a
    :class:`~twin.campaign.spec.RunSpec`.
    """
    d = out / "runs"
    changed = 0
    for run in runs:
        path = d / f"{run.run_id}.parquet"
        if not path.exists():
            continue
        row = pq.read_table(path).to_pylist()[0]
        want = {"index": run.index, **{f"param.{k}": v for k, v in run.params}}
        if all(k in row and row[k] == v for k, v in want.items()):
            continue
        stale = [k for k in row if k.startswith("param.") and k not in want]
        for k in stale:
            del row[k]
        row.update(want)
        _write_atomic(pa.Table.from_pylist([row]), path)
        changed += 1
    return changed


def load_campaign_results(out: str | Path) -> pd.DataFrame:
    """Every run of a campaign folder as one DataFrame (rows on disk, in run order).

    Reads the per-run files, so it works while a campaign runs and after a crash.
    """
    d = Path(out) / "runs"
    files = sorted(d.glob("*.parquet")) if d.is_dir() else []
    if not files:
        return pd.DataFrame(columns=["run_id", "index", "seed", "status", "wall_time_s", "error"])
    df = _concat(files)
    return df.sort_values("index", kind="stable").reset_index(drop=True)


def _concat(files: list[Path]) -> pd.DataFrame:
    # One Arrow concatenation (schemas unified: a column some rows lack is null there) and one
    # conversion: pandas' concat of 36000 one-row frames (the MOI study) takes minutes.
    tables = [pq.read_table(f) for f in files]
    return pa.concat_tables(tables, promote_options="permissive").to_pandas()


def load_timeseries(out: str | Path) -> pd.DataFrame:
    d = Path(out) / "timeseries"
    files = sorted(d.glob("*.parquet")) if d.is_dir() else []
    if not files:
        return pd.DataFrame(columns=["run_id"])
    return _concat(files)


def consolidate(out: Path) -> Path:
    """Rewrite ``results.parquet`` from the per-run rows (all columns, union of schemas)."""
    df = load_campaign_results(out)
    path = out / "results.parquet"
    tmp = path.with_name(path.name + ".tmp")
    df.to_parquet(tmp, index=False)
    os.replace(tmp, path)
    return path
