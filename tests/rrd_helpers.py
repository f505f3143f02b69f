"""Reading real .rrd files back in tests (rerun.chunk.RrdReader)."""

from __future__ import annotations

from pathlib import Path

from rerun.chunk import RrdReader


def entities(rrd: Path) -> dict[str, int]:
    """Entity path -> number of (non-static) rows in the recording."""
    rows: dict[str, int] = {}
    for line in RrdReader(rrd).store().summary().splitlines():
        parts = line.split()
        if not parts or "static=True" in line:
            continue
        n = next((int(p.split("=")[1]) for p in parts if p.startswith("rows=")), 0)
        rows[parts[0]] = rows.get(parts[0], 0) + n
    return rows
