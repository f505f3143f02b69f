"""A run's time series as Parquet, beside the Rerun recording: data a paper can archive.

The ``.rrd`` format changes with every Rerun minor release; Parquet does not. With
``auv-twin run ... --timeseries`` (``run_scenario(timeseries=True)``) a run also writes, in
``OUT/timeseries/``:

* ``truth.parquet``: the true state at the truth rate (``t``, ``utc``, ENU position and velocity,
  roll, pitch, heading, depth, speed through water);
* ``readings_<sensor>.parquet``: every reading of each sensor as delivered (``t`` stamp,
  ``t_delivered``, one column per channel element: ``specific_force[0]`` …); channels of more
  than :data:`MAX_CHANNEL_WIDTH` numbers (the polarimeter's raw frame) are left out and named in
  the file's metadata;
* ``filters.parquet``: each filter variant's estimate and its errors against truth at the truth
  rate (long format: a ``variant`` column);
* ``compass_fixes.parquet``: every compass fix (time, variant, whether the method found the sun,
  its heading and body-frame sun vector, and its errors against truth when scored).

Each file carries the run's provenance block in its schema metadata
(:mod:`twin.record.provenance`). World side: it sees truth and readings, as the recorder does.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from twin.record.provenance import parquet_metadata

if TYPE_CHECKING:
    from twin.core.messages import Reading
    from twin.scoring.observer import RunScorer
    from twin.sim.step import Simulation, StepResult

#: A channel wider than this (an image) is not a time-series column.
MAX_CHANNEL_WIDTH = 16
FOLDER = "timeseries"


def fix_row(variant: str, event: Any) -> dict[str, Any]:
    """A compass fix as a ``compass_fixes.parquet`` row (without its errors against truth)."""
    fix = event.fix
    row: dict[str, Any] = {"t": event.t, "variant": variant, "ok": bool(fix.ok)}
    row["heading_deg"] = float(fix.heading_deg) if fix.heading_deg is not None else None
    sun = fix.sun_body if fix.sun_body is not None else (None, None, None)
    for i, axis in enumerate("xyz"):
        row[f"sun_body_{axis}"] = None if sun[i] is None else float(sun[i])
    return row


class TimeSeriesWriter:
    """An observer of the stepping core that keeps the run's series and writes them at the end.

    It reads the scorer's latest truth and samples, so it observes after the scorer.
    """

    def __init__(self, sim: Simulation, scorer: RunScorer, start_utc: dt.datetime):
        self.scorer = scorer
        self._start = start_utc
        self._truth: list[dict[str, float]] = []
        self._filters: list[dict[str, Any]] = []
        self._fixes: list[dict[str, Any]] = []
        self._readings: dict[str, list[dict[str, float]]] = {}
        self._skipped: dict[str, set[str]] = {}
        self._last_truth_t = -math.inf

    def quiet_steps(self, sim: Simulation) -> int:
        """Any number: a step without a frame or a new truth sample only adds its readings."""
        return 1 << 30

    def on_quiet_steps(self, sim: Simulation, steps: int, readings: list[Reading]) -> None:
        for reading in readings:
            self._reading(reading)

    def on_step(self, sim: Simulation, result: StepResult) -> None:
        for reading in result.readings:
            self._reading(reading)
        for name, event in result.events:
            fix = event.fix
            row = fix_row(name, event)
            fs = self.scorer.fixes.get(name)
            scored = fs is not None and fs.t and fs.t[-1] == event.t and fix.ok
            row["heading_error_deg"] = fs.heading_err[-1] if scored else None
            row["sun_error_deg"] = fs.sun_err[-1] if scored else None
            self._fixes.append(row)
        truth = self.scorer.last_truth
        if truth is None or truth.t == self._last_truth_t or truth.t != result.t:
            return
        self._last_truth_t = truth.t
        self._truth.append(
            {
                "t": truth.t,
                "east_m": float(truth.position_n[0]),
                "north_m": float(truth.position_n[1]),
                "up_m": float(truth.position_n[2]),
                "v_east_mps": float(truth.velocity_n[0]),
                "v_north_mps": float(truth.velocity_n[1]),
                "v_up_mps": float(truth.velocity_n[2]),
                "roll_deg": math.degrees(truth.roll_rad),
                "pitch_deg": math.degrees(truth.pitch_rad),
                "heading_deg": truth.heading_deg,
                "depth_m": truth.depth_m,
                "speed_through_water_mps": float(truth.speed_through_water_mps),
            }
        )
        # The scorer's sample: each filter's estimate and its errors, computed once a step.
        for name, sample in self.scorer.last_samples.items():
            self._filters.append(
                {"t": truth.t, "variant": name, **{k: float(v) for k, v in sample.items()}}
            )

    def _reading(self, reading: Any) -> None:
        row: dict[str, float] = {"t": reading.t, "t_delivered": reading.t_delivered}
        for ch, value in reading.values.items():
            a = np.asarray(value)
            if a.dtype.kind not in "biuf":
                continue
            if a.size > MAX_CHANNEL_WIDTH:
                self._skipped.setdefault(reading.sensor, set()).add(ch)
                continue
            flat = a.reshape(-1).astype(np.float64)
            if a.ndim == 0 or (a.size == 1 and a.ndim <= 1):
                row[ch] = float(flat[0])
            else:
                for i, x in enumerate(flat):
                    row[f"{ch}[{i}]"] = float(x)
        self._readings.setdefault(reading.sensor, []).append(row)

    def write(self, out: Path, block: Mapping[str, Any]) -> list[Path]:
        """Write the Parquet files (each with ``block`` in its metadata); their paths."""
        folder = Path(out) / FOLDER
        folder.mkdir(parents=True, exist_ok=True)
        start_ns = np.datetime64(self._start.replace(tzinfo=None), "ns")
        written = []

        def put(name: str, rows: list[dict[str, Any]], extra: Mapping[str, Any] = ()) -> None:
            table = (
                pa.Table.from_pylist(rows) if rows else pa.table({"t": pa.array([], pa.float64())})
            )
            if rows:
                t = np.asarray(table.column("t").to_numpy(), dtype=np.float64)
                utc = start_ns + np.rint(t * 1e9).astype("timedelta64[ns]")
                table = table.add_column(1, "utc", pa.array(utc, pa.timestamp("ns", tz="UTC")))
            meta = {**parquet_metadata(block)}
            if extra:
                meta[b"auv_twin.notes"] = json.dumps(dict(extra), default=str).encode()
            path = folder / f"{name}.parquet"
            pq.write_table(table.replace_schema_metadata(meta), path)
            written.append(path)

        put("truth", self._truth)
        put("filters", self._filters)
        put("compass_fixes", self._fixes)
        for sensor, rows in sorted(self._readings.items()):
            skipped = sorted(self._skipped.get(sensor, ()))
            put(f"readings_{sensor}", rows, {"channels_left_out": skipped} if skipped else {})
        return written
