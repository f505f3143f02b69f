"""Reading real .rrd files back in tests (rerun.chunk.RrdReader)."""

from __future__ import annotations

from pathlib import Path

from rerun.chunk import RrdReader

from twin.record.rrd_files import entity_rows


def entities(rrd: Path) -> dict[str, int]:
    """Entity path -> number of (non-static) rows in the recording."""
    return entity_rows(rrd)


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
