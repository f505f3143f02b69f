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
import json
import math
import os
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from twin.record.provenance import PARQUET_KEY, made_by, parquet_metadata

#: Where row files that cannot be read are set aside (their runs are run again on resume).
CORRUPT = "corrupt"


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

    skip = {"scenario_config", "versions", "sensors", "provenance"}
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


def _with_provenance(table: pa.Table, block: Mapping[str, Any] | None) -> pa.Table:
    if not block:
        return table
    meta = {**(table.schema.metadata or {}), **parquet_metadata(block)}
    return table.replace_schema_metadata(meta)


def _write_atomic(table: pa.Table, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    # The temporary name is the writer's own: two processes writing one file never share it.
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


def write_row(out: Path, row: Mapping[str, Any], block: Mapping[str, Any] | None = None) -> Path:
    """Write one run's row as ``runs/<run_id>.parquet`` (atomically), ``block`` in its metadata."""
    path = out / "runs" / f"{row['run_id']}.parquet"
    _write_atomic(_with_provenance(pa.Table.from_pylist([dict(row)]), block), path)
    return path


def write_timeseries(
    out: Path, run_id: str, columns: Mapping[str, list], block: Mapping[str, Any] | None = None
) -> Path:
    path = out / "timeseries" / f"{run_id}.parquet"
    data = {"run_id": [run_id] * len(next(iter(columns.values()), [])), **columns}
    _write_atomic(_with_provenance(pa.table(data), block), path)
    return path


def _intact(path: Path) -> bool:
    """A whole Parquet file: the magic bytes at both ends (a truncated write lacks the last)."""
    try:
        size = path.stat().st_size
        if size < 12:
            return False
        with path.open("rb") as f:
            head = f.read(4)
            f.seek(size - 4)
            return head == b"PAR1" and f.read(4) == b"PAR1"
    except OSError:
        return False


def set_aside(out: Path, path: Path, say: Callable[[str], None] | None = None) -> None:
    """Move an unreadable row file to ``DIR/corrupt/`` (its run counts as not done)."""
    dest = out / CORRUPT / path.name
    try:
        dest.parent.mkdir(exist_ok=True)
        os.replace(path, dest)
        where = f"set aside as {dest}"
    except OSError:
        where = "left in place (the folder is not writable)"
    if say is not None:
        say(f"unreadable row file {path} (not a whole Parquet file): {where}; its run counts "
            "as not done and a resume runs it again")  # fmt: skip


def finished_ids(out: Path, say: Callable[[str], None] | None = None) -> set[str]:
    """Run ids with a whole row file on disk (a re-run skips them); broken files set aside."""
    d = out / "runs"
    if not d.is_dir():
        return set()
    done = set()
    for p in d.glob("*.parquet"):
        if _intact(p):
            done.add(p.stem)
        else:
            set_aside(out, p, say)
    return done


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
        table = pq.read_table(path)
        row = table.to_pylist()[0]
        want = {"index": run.index, **{f"param.{k}": param_value(v) for k, v in run.params}}
        if all(k in row and row[k] == v for k, v in want.items()):
            continue
        stale = [k for k in row if k.startswith("param.") and k not in want]
        for k in stale:
            del row[k]
        row.update(want)
        relabelled = pa.Table.from_pylist([row]).replace_schema_metadata(table.schema.metadata)
        _write_atomic(relabelled, path)
        changed += 1
    return changed


_EMPTY = ["run_id", "index", "seed", "status", "wall_time_s", "error"]


def load_campaign_results(
    out: str | Path, *, say: Callable[[str], None] | None = None
) -> pd.DataFrame:
    """The runs of a campaign folder's experiment as one DataFrame (rows on disk, in run order).

    Reads the per-run files, so it works while a campaign runs and after a crash; a folder with
    only ``results.parquet`` (copied without its ``runs/``) is read from that. Only the rows of
    the folder's own experiment (the run ids in ``campaign.json``) are kept. What was left out is
    in ``df.attrs``: ``"ignored"`` (the number of row files of other runs) and ``"corrupt"``
    (the names of unreadable row files, set aside in ``DIR/corrupt/``); ``say`` gets one line
    for each. ``df.attrs["made_by"]`` counts the rows by the code and packages that made them
    (:func:`twin.record.provenance.made_by`, from each row file's metadata).
    """
    from twin.campaign.folder import read_record

    out = Path(out)
    record = read_record(out)
    wanted = set(record["run_ids"]) if record else None
    d = out / "runs"
    files = sorted(d.glob("*.parquet")) if d.is_dir() else []
    corrupt: list[str] = []
    made: dict[str, int] = {}
    ignored = 0
    if files:
        if wanted is not None:
            ignored = sum(1 for f in files if f.stem not in wanted)
            files = [f for f in files if f.stem in wanted]
        tables = []
        for f in files:
            try:
                if not _intact(f):
                    raise OSError("truncated")
                tables.append(pq.read_table(f))
            except (OSError, pa.ArrowException):
                corrupt.append(f.name)
                set_aside(out, f, say)
        # What made the rows, from each file's metadata as it is read: {made_by line: rows}.
        for t in tables:
            raw = (t.schema.metadata or {}).get(PARQUET_KEY)
            key = made_by(json.loads(raw) if raw else None)
            made[key] = made.get(key, 0) + 1
        df = _concat_tables(tables) if tables else pd.DataFrame(columns=_EMPTY)
    elif (out / "results.parquet").is_file():
        df = pd.read_parquet(out / "results.parquet")
        if wanted is not None and "run_id" in df.columns:
            keep = df["run_id"].isin(wanted)
            ignored = int((~keep).sum())
            df = df[keep]
        made[made_by(None)] = len(df)  # one table: the rows' own provenance is not kept
    else:
        df = pd.DataFrame(columns=_EMPTY)
    if ignored and say is not None:
        say(f"{out}: ignored {ignored} row file(s) of runs that are not this folder's experiment")
    if "index" in df.columns and len(df):
        df = df.sort_values("index", kind="stable").reset_index(drop=True)
    df.attrs["ignored"] = ignored
    df.attrs["corrupt"] = corrupt
    df.attrs["made_by"] = made
    df.attrs["record"] = record
    return df


def _concat(files: list[Path]) -> pd.DataFrame:
    return _concat_tables([pq.read_table(f) for f in files])


def _concat_tables(tables: list[pa.Table]) -> pd.DataFrame:
    # One Arrow concatenation (schemas unified: a column some rows lack is null there) and one
    # conversion: pandas' concat of 36000 one-row frames (the MOI study) takes minutes.
    tables = [t.replace_schema_metadata(None) for t in tables]
    return pa.concat_tables(tables, promote_options="permissive").to_pandas()


def load_timeseries(out: str | Path) -> pd.DataFrame:
    d = Path(out) / "timeseries"
    files = sorted(d.glob("*.parquet")) if d.is_dir() else []
    if not files:
        return pd.DataFrame(columns=["run_id"])
    return _concat(files)


def consolidate(
    out: Path, block: Mapping[str, Any] | None = None, say: Callable[[str], None] | None = None
) -> pd.DataFrame:
    """Rewrite ``results.parquet`` from the experiment's rows (all columns, union of schemas).

    Returns:
        The rows written (what :func:`load_campaign_results` gives).
    """
    df = load_campaign_results(out, say=say)
    df.attrs = {}  # what was ignored is said, not stored in the table's pandas metadata
    table = pa.Table.from_pandas(df, preserve_index=False)
    _write_atomic(_with_provenance(table, block), out / "results.parquet")
    return df


def row_provenance(path: str | Path) -> dict[str, Any] | None:
    """The provenance block of a row (or any) Parquet file written here."""
    from twin.record.provenance import read_parquet_provenance

    return read_parquet_provenance(path)


def param_value(v: Any) -> Any:
    """A swept value as a row stores it: TOML datetimes as ISO strings (one column type)."""
    import datetime as dt

    if isinstance(v, dt.datetime):
        return v.isoformat().replace("+00:00", "Z")
    if isinstance(v, dt.date | dt.time):
        return v.isoformat()
    if isinstance(v, list | dict):
        return json.dumps(v, default=str)
    return v
