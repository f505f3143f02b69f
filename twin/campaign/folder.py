"""A campaign folder holds one experiment: its record, its lock, and which rows belong to it.

``campaign.json`` records the experiment a folder holds: the fingerprint of the resolved spec,
the parts it is made of (the base scenario's content, ``[set]``, the sweep axes, the seeds, the
kept metrics and time series, the trial, the light model's version that run ids hash), the ids
of its runs, the provenance of the campaign run that wrote it (:mod:`twin.record.provenance`)
and the history of the specs run into the folder.

Running a spec into a folder that holds another experiment stops before any run
(:class:`FolderError`, naming what differs and suggesting a new ``--out``). A spec that *grows*
the folder's experiment still resumes: every run already in the folder is a run of the new spec
(same resolved scenario and seed, so the same id: more seeds, more values on an axis, an added
axis whose values include the base's own) and it keeps the same metrics, time series and trial.

While a campaign runs, it holds an exclusive lock on ``DIR/.lock`` (``fcntl.flock``): a second
campaign started into the same folder stops at once with the first one's pid. The lock dies with
its process (a SIGKILLed campaign leaves no stale lock).
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from twin.campaign.spec import CampaignSpec
from twin.record.provenance import fingerprint, provenance

RECORD = "campaign.json"
#: The parts of a spec that make it another experiment when they change (runs aside).
_KEPT = ("metrics", "timeseries", "trial")


class FolderError(RuntimeError):
    """A campaign folder that cannot take this spec (another experiment, or busy)."""


def spec_parts(spec: CampaignSpec) -> dict[str, Any]:
    """The parts of a resolved spec that its fingerprint covers (each JSON-able)."""
    from sensors.polarimeter.optics.rt.grid import MODEL_VERSION

    return {
        "base": fingerprint(spec.base.to_dict()) if spec.base is not None else None,
        "base_name": spec.base.name if spec.base is not None else None,
        "set": {k: v for k, v in spec.fixed},
        "combine": spec.combine,
        "axes": {"; ".join(a.paths): list(a.values) for a in spec.axes},
        "seeds": list(spec.seeds),
        "metrics": list(spec.metrics),
        "timeseries": list(spec.timeseries),
        "trial": spec.trial,
        "light_model": MODEL_VERSION,
    }


def spec_fingerprint(spec: CampaignSpec, parts: Mapping[str, Any] | None = None) -> str:
    """The hash of the resolved spec: its parts (``spec_parts``) and the ids of its runs."""
    parts = spec_parts(spec) if parts is None else parts
    return fingerprint({"parts": parts, "runs": [r.run_id for r in spec.runs]})


def read_record(out: Path) -> dict[str, Any] | None:
    """The folder's record, or None (no record, or one written before records had run ids)."""
    try:
        rec = json.loads((out / RECORD).read_text())
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) and isinstance(rec.get("run_ids"), list) else None


def _differences(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    out = []
    for k in sorted(set(old) | set(new)):
        if k == "base_name" or old.get(k) == new.get(k):
            continue
        if k == "base":
            out.append(
                f"base scenario content ({old.get('base_name')} {old.get(k)} -> "
                f"{new.get('base_name')} {new.get(k)})"
            )
        else:
            out.append(f"{k} ({_short(old.get(k))} -> {_short(new.get(k))})")
    return out


def _short(v: Any) -> str:
    s = json.dumps(v, default=str)
    return s if len(s) <= 80 else s[:77] + "..."


def check_spec(spec: CampaignSpec, out: Path) -> dict[str, Any] | None:
    """The folder's record if ``spec`` may run into ``out`` (None: a new folder).

    Raises:
        FolderError: The folder holds another experiment; the message names what differs.
    """
    old = read_record(out)
    if old is None:
        return None
    new_parts = spec_parts(spec)
    old_parts = old.get("parts", {})
    ids = {r.run_id for r in spec.runs}
    missing = [i for i in old["run_ids"] if i not in ids]
    kept = [k for k in _KEPT if old_parts.get(k) != new_parts.get(k)]
    if not missing and not kept:
        return old  # the same experiment, or a growth of it
    diff = _differences(old_parts, new_parts) or ["the runs' resolved scenarios"]
    why = (
        f"{len(missing)} of its {len(old['run_ids'])} runs are not runs of this spec"
        if missing
        else "this spec keeps other data (" + ", ".join(kept) + ")"
    )
    raise FolderError(
        f"{out} holds another experiment ({old.get('name')}, fingerprint "
        f"{old.get('fingerprint')}): {why}; what differs: {'; '.join(diff)}. "
        f"Run this spec into a new folder (--out {out.name}_2 or any other name); a folder "
        "may grow (more seeds, more values on an axis) but never mix experiments"
    )


def write_record(spec: CampaignSpec, out: Path, old: Mapping[str, Any] | None) -> dict[str, Any]:
    """Write ``campaign.json`` for ``spec`` (the growth history kept); the record."""
    parts = spec_parts(spec)
    fp = spec_fingerprint(spec, parts)
    prov = provenance(fingerprint=fp)
    history = list(old.get("history", [])) if old else []
    if not history or history[-1].get("fingerprint") != fp:
        history.append(
            {"fingerprint": fp, "runs": len(spec.runs), "source": spec.source,
             "commit": prov["commit"], "created_utc": prov["created_utc"]}
        )  # fmt: skip
    record = {
        "name": spec.name,
        "description": spec.description,
        "source": spec.source,
        "fingerprint": fp,
        "runs": len(spec.runs),
        "seeds": list(spec.seeds),
        "axes": {a.name: list(a.values) for a in spec.axes},
        "combine": spec.combine,
        "parts": parts,
        "provenance": prov,
        "history": history,
        "run_ids": [r.run_id for r in spec.runs],
    }
    tmp = out / f"{RECORD}.{os.getpid()}.tmp"
    tmp.write_text(json.dumps(record, indent=2, default=str) + "\n")
    os.replace(tmp, out / RECORD)
    return record


@contextlib.contextmanager
def locked(out: Path) -> Iterator[None]:
    """Hold the folder's lock for the block.

    Raises:
        FolderError: Another campaign holds it.
    """
    import fcntl

    path = out / ".lock"
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            other = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            raise FolderError(
                f"{out} is in use by another campaign (pid {other}); wait for it to finish or "
                "run into another --out"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)  # closing the descriptor releases the lock
