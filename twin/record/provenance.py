"""Where a number came from: the code, the packages, the inputs, the seed, the machine, the date.

Every output of the twin carries one :func:`provenance` block: ``metrics.json``, a campaign's
``campaign.json``, every Parquet file's schema metadata (key ``auv_twin.provenance``), the
campaign report's header and the Rerun recording's properties. A figure can then be traced back
to the commit, the packages and the inputs that made it.

The block:

* ``auv_twin``: the package version; ``commit`` and ``dirty`` when the package runs from a git
  checkout (None otherwise: an installed wheel has no commit);
* ``packages``: the versions of the packages whose numbers shape results (:data:`PACKAGES`);
* ``light_model``: the radiative-transfer light field's version, which run ids also hash;
* ``fingerprint``: a hash of the inputs (a scenario, or a campaign's resolved spec), and ``seed``;
* ``created_utc``: when the output was made; ``python``, ``os``, ``cpu``, ``machine``.
"""

from __future__ import annotations

import datetime as dt
import functools
import hashlib
import json
import os
import platform
import subprocess
import sys
from collections.abc import Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

#: The distributions whose versions change numbers (the Parquet metadata key of the block below).
PACKAGES = (
    "mujoco",
    "numpy",
    "scipy",
    "pvlib",
    "opencv-python-headless",
    "numba",
    "rerun-sdk",
)
#: The key under which Parquet files keep the block (JSON) in their schema metadata.
PARQUET_KEY = b"auv_twin.provenance"
_REPO = Path(__file__).resolve().parents[2]
#: Changes here do not make the tree dirty (:func:`code_version`): the benchmarks' outputs and
#: the prose (git pathspecs).
_NOT_INPUTS = (":!benchmarks/results", ":!validation/results", ":!*.md")


def fingerprint(obj: Any) -> str:
    """A 16-hex-digit hash of a JSON-able object (keys sorted; datetimes as ISO strings)."""
    blob = json.dumps(obj, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _dist_version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "not installed"


@functools.lru_cache(maxsize=1)
def code_version() -> dict[str, Any]:
    """``{"auv_twin": version, "commit": sha or None, "dirty": bool or None}``.

    The commit is read with ``git`` from the checkout the package runs from; a tree with changes
    to tracked or untracked (not ignored) files is dirty, except under ``benchmarks/results/``
    and ``validation/results/`` and in Markdown files (:data:`_NOT_INPUTS`: what the benchmarks
    and validation studies write and the prose, never what a run reads, so one benchmark's fresh
    table, or a doc edited while a study runs, does not mark a run as made from changed code).
    Cached per process: a campaign worker asks once.
    """
    out: dict[str, Any] = {"auv_twin": _dist_version("auv-twin"), "commit": None, "dirty": None}
    if not (_REPO / ".git").exists():
        return out
    env = {**os.environ, "GIT_OPTIONAL_LOCKS": "0"}  # a status must not take the index lock
    try:
        sha = subprocess.run(
            ["git", "-C", str(_REPO), "rev-parse", "HEAD"],
            capture_output=True, text=True, timeout=10, env=env, check=True,
        ).stdout.strip()  # fmt: skip
        status = subprocess.run(
            ["git", "-C", str(_REPO), "status", "--porcelain", "--", ".", *_NOT_INPUTS],
            capture_output=True, text=True, timeout=30, env=env, check=True,
        ).stdout  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return out  # no git on the machine, or not a repository after all
    out["commit"] = sha or None
    out["dirty"] = bool(status.strip())
    return out


@functools.lru_cache(maxsize=1)
def _static() -> dict[str, Any]:
    from sensors.polarimeter.optics.rt.grid import MODEL_VERSION

    return {
        **code_version(),
        "packages": {name: _dist_version(name) for name in PACKAGES},
        "light_model": MODEL_VERSION,
        "python": platform.python_version(),
        "os": f"{platform.system()} {platform.release()}",
        "cpu": _cpu_name(),
        "cpu_count": os.cpu_count(),
        "machine": platform.node(),
    }


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def provenance(*, fingerprint: str | None = None, seed: int | None = None) -> dict[str, Any]:
    """The provenance block of an output made now.

    Args:
        fingerprint: The inputs' hash (:func:`fingerprint` of a scenario or a resolved spec).
        seed: The root seed (None for an output of many seeds, such as a campaign).
    """
    return {
        **_static(),
        "fingerprint": fingerprint,
        "seed": seed,
        "created_utc": dt.datetime.now(dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }


def version_line() -> str:
    """``auv-twin 0.1.0 (commit abc123…, dirty)``: what ``auv-twin --version`` prints."""
    v = code_version()
    if v["commit"] is None:
        return f"auv-twin {v['auv_twin']} (not a git checkout)"
    return f"auv-twin {v['auv_twin']} (commit {v['commit']}{', dirty' if v['dirty'] else ''})"


def parquet_metadata(block: Mapping[str, Any]) -> dict[bytes, bytes]:
    """The block as a Parquet schema-metadata entry."""
    return {PARQUET_KEY: json.dumps(block, sort_keys=True, default=str).encode()}


def read_parquet_provenance(path: str | Path) -> dict[str, Any] | None:
    """The block a Parquet file carries, or None."""
    import pyarrow.parquet as pq

    meta = pq.read_schema(path).metadata or {}
    raw = meta.get(PARQUET_KEY)
    return json.loads(raw) if raw else None


def made_by(block: Mapping[str, Any] | None) -> str:
    """One line for the code and packages that made an output (equal lines: the same code)."""
    if block is None:
        return "no provenance (a row from before auv-twin recorded it, or from results.parquet)"
    commit = block.get("commit")
    code = (
        f"commit {commit[:12]}{' (dirty)' if block.get('dirty') else ''}" if commit else "no commit"
    )
    packages = ", ".join(f"{k} {v}" for k, v in sorted((block.get("packages") or {}).items()))
    light = f"light model {block.get('light_model')}"
    return f"auv-twin {block.get('auv_twin')}, {code}, {light}, {packages}"


def describe(block: Mapping[str, Any]) -> list[str]:
    """The block as short lines for a report's header or a summary."""
    commit = block.get("commit")
    code = f"auv-twin {block.get('auv_twin')}"
    if commit:
        code += f", commit {commit[:12]}" + (" (dirty tree)" if block.get("dirty") else "")
    else:
        code += " (no git commit: not run from a checkout)"
    pk = ", ".join(f"{k} {v}" for k, v in (block.get("packages") or {}).items())
    return [
        code,
        f"packages: {pk}",
        f"light model version {block.get('light_model')}",
        f"Python {block.get('python')} on {block.get('os')}, {block.get('cpu')} "
        f"({block.get('cpu_count')} CPUs, host {block.get('machine')})",
        f"made {block.get('created_utc')}",
    ]


if __name__ == "__main__":  # pragma: no cover - a quick look
    json.dump(provenance(), sys.stdout, indent=2)
