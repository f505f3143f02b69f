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


def scalars(rrd: Path, entity: str) -> tuple[list[int], list[list[float]]]:
    """A Scalars entity's samples in the recording: (sim_time ns, values), in time order."""
    rows: list[tuple[int, list[float]]] = []
    for chunk in RrdReader(rrd).store().stream():
        if chunk.entity_path != entity or chunk.is_static:
            continue
        rb = chunk.to_record_batch()
        if "Scalars:scalars" not in rb.schema.names:
            continue
        t = rb.column(rb.schema.get_field_index("sim_time")).cast("int64").to_pylist()
        v = rb.column(rb.schema.get_field_index("Scalars:scalars")).to_pylist()
        rows.extend(zip(t, v, strict=True))
    rows.sort(key=lambda r: r[0])
    return [r[0] for r in rows], [r[1] for r in rows]
