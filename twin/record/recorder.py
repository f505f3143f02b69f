"""The run's Rerun recorder: truth, sensor readings and control series into one ``.rrd`` file.

A simulator that must run at >= 100x real time cannot afford ``rr.log`` per 100 Hz sample (about
40-60 us each on the dev machine, plus one chunk per row). The recorder appends samples to plain
Python lists instead (about 1.5 us per call) and, every ``flush_every_s`` of *sim* time, turns each
list into numpy columns and writes them with ``rr.send_columns``: one chunk per entity per flush.
JPEG images and image-space points are buffered the same way: ``rr.log`` of an
``EncodedImage`` costs 0.3–0.7 ms (a column of them ~0.06 ms an image, measured with Rerun 0.41),
three images a polarimeter frame. Raw images and text are rare and go straight to ``rr.log``.

Timelines: ``sim_time`` (duration, integer nanoseconds of sim time) and ``utc`` (timestamp,
``start_utc + sim_time``). The wall-clock ``log_time`` timeline is disabled and no recording
properties are sent, so the same inputs give the same recording (same chunks, same values; the bytes
differ because chunk ids are random).

Entity paths::

    /world                      ViewCoordinates RIGHT_HAND_Z_UP (static)
    /world/auv                  Transform3D per truth sample (translation, quaternion xyzw);
                                TransformAxes3D (static)
    /world/auv/hull             Ellipsoids3D, body axes x right, y forward, z up (static)
    /world/auv/nose             Arrows3D along body +y: which end is forward (static)
    /world/path                 LineStrips3D, one 2-point segment per path_period_s of sim time
    /world/mission/waypoints    Points3D (static)
    /world/mission/route        LineStrips3D through the waypoints (static)
    /world/surface, /world/seabed   grids of LineStrips3D (static)
    /world/tank                 Boxes3D wireframe (static)
    /truth/rpy_deg              Scalars (roll, pitch, yaw)
    /truth/heading_deg, /truth/depth_m, /truth/speed_mps      Scalars
    /truth/velocity_n           Scalars (east, north, up)
    /sensors/<sensor>/<channel> Scalars, one series per vector component
    <any entity>                Scalars via log_scalars (convention: /control/..., /autopilot/...)
    /camera/chase (etc.)        EncodedImage (JPEG) or Image via log_image
    /log                        TextLog

Crash behaviour, and how to read or repair a cut recording: :mod:`twin.record.rrd_files`.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import cv2
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from twin.core.arrays import Float64Array as FloatArray
from twin.core.frames import wxyz_to_xyzw
from twin.core.messages import Reading
from twin.record import scene
from twin.record.blueprint import LOG_ENTITY, SIM_TIME, UTC, default_blueprint
from twin.record.rrd_files import compact

# A reading channel with more elements than this is a frame or a matrix, not a time series: it is
# skipped (and listed in ``Recorder.skipped_channels``); log images with ``log_image``.
MAX_SERIES_WIDTH = 16

#: Sim-time span buffered before the columns are written, for a file alone: a killed process
#: (a crash the run cannot catch) loses at most this much of the recording, ~1 s of wall time
#: at the sea trial's speed. Each flush costs ~10 ms whatever it holds (one chunk per entity,
#: ~45 entities) and leaves its chunks for the compaction to merge: 30 s rather than 5 s took the
#: sea trial's recording from 6.7 to 4.4 ms per simulated second (issue #31;
#: benchmarks/paired_switches.py times both in one process).
FLUSH_EVERY_S = 30.0
#: The same with a live viewer: it sees the run at most this far behind.
LIVE_FLUSH_EVERY_S = 5.0

_NS_PER_S = 1_000_000_000
_EPOCH = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
_XYZ = ("x", "y", "z")
_XYZ_COLORS = ((230, 60, 60), (60, 200, 60), (70, 110, 240))
_PATH_COLOR = (255, 140, 0)

# Column layout of one buffered truth row: t, position (3), quaternion wxyz (4), velocity (3),
# roll/pitch/yaw (3), heading, depth.
_T = 0
_POS = slice(1, 4)
_QUAT = slice(4, 8)
_VEL = slice(8, 11)
_RPY = slice(11, 14)
_HDG = 14
_DEPTH = 15
_TRUTH_WIDTH = 16


def utc_ns(t: dt.datetime) -> int:
    """Nanoseconds since 1970 of an aware datetime, exactly (float seconds resolve ~0.2 µs)."""
    return (t - _EPOCH) // dt.timedelta(microseconds=1) * 1000


def _default_names(width: int, label: str) -> list[str]:
    if width == 1:
        return [label]
    if width <= 3:
        return list(_XYZ[:width])
    return [f"[{i}]" for i in range(width)]


class _Series:
    """Samples of one Scalars entity since the last flush.

    ``rows`` holds ``ndarray.tolist()`` results (a float, a flat list or nested lists, all of one
    ``shape``); ``flush`` reshapes them to (N, width).
    """

    __slots__ = ("rows", "shape", "t", "width")

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.shape = shape
        self.width = math.prod(shape)
        self.t: list[float] = []
        self.rows: list[object] = []


class Recorder:
    """Writes one run to an ``.rrd`` file, buffering high-rate samples into columns.

    Usage (the run loop)::

        rec = Recorder(path, recording_id=run_id, start_utc=scenario.start_utc)
        try:
            rec.log_static_scene(waypoints_n=wps, vehicle_half_sizes=(0.095, 0.8, 0.095))
            for ...:
                rec.log_truth(t, position_n=..., quat_wxyz=..., ...)
                for r in readings:
                    rec.log_reading(r)
        finally:
            rec.close()

    Args:
        path: The ``.rrd`` file to write (parent folders are created).
        application_id: Rerun application id (groups recordings in the viewer).
        recording_id: Unique id of this recording (the run id).
        start_utc: UTC instant of sim time 0 (timezone-aware).
        flush_every_s: Sim-time span buffered before the columns are written; a killed process
            loses at most this much. ``None``: :data:`FLUSH_EVERY_S` for a file alone,
            :data:`LIVE_FLUSH_EVERY_S` with ``live``.
        blueprint: The layout to store with the file; ``None`` stores
            :func:`~twin.record.blueprint.default_blueprint`.
        path_period_s: Sim-time spacing of the path-travelled segments in ``/world/path``.
        jpeg_quality: JPEG quality for :meth:`log_image`; ``None`` stores raw pixels.
        live: Also stream to a Rerun viewer or server at this gRPC URL (e.g.
            ``rerun+http://127.0.0.1:9876/proxy``, :func:`spawn_viewer`'s), as the run goes on.

    Raises:
        ValueError: If ``start_utc`` is naive or a period is not positive.
    """

    def __init__(
        self,
        path: Path | str,
        *,
        application_id: str = "auv_twin",
        recording_id: str,
        start_utc: dt.datetime,
        flush_every_s: float | None = None,
        blueprint: rrb.Blueprint | None = None,
        variants: Sequence[str] = (),
        path_period_s: float = 0.5,
        jpeg_quality: int | None = 80,
        compact: bool = True,
        live: str | None = None,
    ) -> None:
        if start_utc.tzinfo is None or start_utc.utcoffset() is None:
            raise ValueError(f"start_utc = {start_utc!r}: must be timezone-aware (UTC)")
        if flush_every_s is None:
            flush_every_s = FLUSH_EVERY_S if live is None else LIVE_FLUSH_EVERY_S
        if not (flush_every_s > 0 and math.isfinite(flush_every_s)):
            raise ValueError(f"flush_every_s = {flush_every_s!r}: must be a finite number > 0")
        if not (path_period_s > 0 and math.isfinite(path_period_s)):
            raise ValueError(f"path_period_s = {path_period_s!r}: must be a finite number > 0")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # Exact integer nanoseconds: float seconds since 1970 only resolve ~0.2 us.
        self._start_ns = utc_ns(start_utc)
        self._flush_every_s = float(flush_every_s)
        self._path_period_s = float(path_period_s)
        self._jpeg_quality = jpeg_quality
        self._compact = compact

        # The default batcher flushes every 200 ms of *wall* time, so chunk boundaries (and so
        # store.summary()) would depend on machine speed. Flushing only on our sim-time schedule
        # (and on the 2 MiB size limit, also deterministic) makes the same run give the same chunks.
        self._rec = rr.RecordingStream(
            application_id,
            recording_id=recording_id,
            send_properties=False,
            batcher_config=rr.ChunkBatcherConfig(flush_tick=dt.timedelta(days=365)),
        )
        self._rec.set_log_time_enabled(False)
        bp = blueprint if blueprint is not None else default_blueprint(variants)
        if live is None:
            self._rec.save(self.path, default_blueprint=bp)
        else:
            # The file and a live viewer get the same stream (the file is what it would be
            # alone: tests/test_live_view.py).
            self._rec.set_sinks(rr.FileSink(self.path), rr.GrpcSink(live), default_blueprint=bp)

        self._truth: list[tuple[float, ...]] = []
        self._series: dict[str, _Series] = {}
        # entity -> (times, JPEG bytes) and entity -> rows (t, (N, 2) points, radius, colour,
        # label) since the last flush.
        self._images: dict[str, tuple[list[float], list[bytes]]] = {}
        self._points2d: dict[
            str, list[tuple[float, FloatArray, float, tuple[int, int, int], str | None]]
        ] = {}
        # sensor -> channel -> its series, or None when the channel is skipped (too wide). Two
        # string-keyed lookups are cheaper than building and hashing a (sensor, channel) tuple.
        self._reading_series: dict[str, dict[str, _Series | None]] = {}
        self.skipped_channels: set[str] = set()
        self._next_flush_t = math.inf
        self._path_last_point: FloatArray | None = None
        self._path_last_bin: int | None = None
        self._path_tail: tuple[float, FloatArray] | None = None
        self._truth_names_logged = False
        self._closed = False

    # ------------------------------------------------------------------ context manager

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    @property
    def flush_every_s(self) -> float:
        """The sim-time span buffered before the columns are written (the constructor's)."""
        return self._flush_every_s

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has run."""
        return self._closed

    def log_properties(self, name: str, values: Mapping[str, Any]) -> None:
        """Recording properties (``/__properties/<name>``) from a nested mapping.

        Keys are flattened to dotted names; every value is logged as text (None as "").
        """
        flat: dict[str, str] = {}

        def walk(node: Any, key: str) -> None:
            if isinstance(node, Mapping):
                for k, v in node.items():
                    walk(v, f"{key}.{k}" if key else str(k))
            else:
                flat[key] = "" if node is None else str(node)

        walk(values, "")
        self._rec.send_property(name, rr.AnyValues(**flat))

    # ------------------------------------------------------------------ static scene

    def log_static_scene(self, **scene_args: Any) -> None:
        """Log what does not change during the run: :func:`twin.record.scene.log_static_scene`.

        Args:
            **scene_args: Its keywords (waypoints, the hull's and a tank's half sizes, the
                surface's and the seabed's heights).
        """
        scene.log_static_scene(self._rec, **scene_args)

    # ------------------------------------------------------------------ buffered streams

    def log_truth(
        self,
        t: float,
        *,
        position_n: np.ndarray,
        quat_wxyz: np.ndarray,
        velocity_n: np.ndarray,
        rpy_deg: np.ndarray,
        heading_deg: float,
        depth_m: float,
    ) -> None:
        """Buffer one ground-truth sample.

        Args:
            t: Sim time (s).
            position_n: Position in n (ENU, m), shape (3,).
            quat_wxyz: Attitude C_b^n as a quaternion (w, x, y, z), shape (4,).
            velocity_n: Velocity in n (m/s), shape (3,).
            rpy_deg: Roll, pitch, yaw (deg; yaw CCW from North, see ``twin.core.frames``).
            heading_deg: Compass heading (deg, CW from North).
            depth_m: Depth below the surface (m, positive down).
        """
        # One flat tuple per sample: tolist() and a tuple display cost about half of writing the
        # slices of a preallocated numpy row (measured); the columns are built once per flush.
        try:
            row = (
                t,
                *position_n.tolist(),
                *quat_wxyz.tolist(),
                *velocity_n.tolist(),
                *rpy_deg.tolist(),
                heading_deg,
                depth_m,
            )
        except AttributeError:  # lists or tuples rather than ndarrays: the slow path
            vectors = (position_n, quat_wxyz, velocity_n, rpy_deg)
            row = (
                t,
                *np.concatenate([np.ravel(v) for v in vectors]).tolist(),
                heading_deg,
                depth_m,
            )
        self._truth.append(row)
        if t >= self._next_flush_t:
            self.flush()
        elif self._next_flush_t == math.inf:
            self._next_flush_t = t + self._flush_every_s

    def log_reading(self, reading: Reading) -> None:
        """Buffer one sensor reading: each channel to ``/sensors/<sensor>/<channel>``.

        Samples are stamped with ``reading.t`` (the sampling instant), not the delivery time, so
        they line up with truth. Channels wider than ``MAX_SERIES_WIDTH`` elements (frames) are
        skipped and listed in :attr:`skipped_channels`.

        Args:
            reading: The reading.

        Raises:
            ValueError: If a channel changes its number of elements during the run.
        """
        # The hot path of a run (hundreds of calls per sim second): no numpy calls but tolist(),
        # no per-sample allocation beyond the row itself; the flush check is inlined.
        t = reading.t
        channels = self._reading_series.get(reading.sensor)
        if channels is None:
            channels = self._reading_series[reading.sensor] = {}
        for channel, value in reading.values.items():
            try:
                series = channels[channel]
            except KeyError:
                series = channels[channel] = self._new_reading_series(
                    reading.sensor, channel, value
                )
            if series is None:
                continue
            try:
                shape, row = value.shape, value.tolist()
            except AttributeError:  # a Python number or list rather than an ndarray
                arr = np.asarray(value, dtype=np.float64)
                shape, row = arr.shape, arr.tolist()
            if shape != series.shape:
                raise ValueError(
                    f"/sensors/{reading.sensor}/{channel}: shape {shape} at t={t}, "
                    f"{series.shape} before; a channel's shape must not change"
                )
            series.t.append(t)
            series.rows.append(row)
        if t >= self._next_flush_t:
            self.flush()
        elif self._next_flush_t == math.inf:
            self._next_flush_t = t + self._flush_every_s

    def log_scalars(
        self,
        entity: str,
        t: float,
        values: np.ndarray | float,
        names: Sequence[str] | None = None,
    ) -> None:
        """Buffer one sample of a generic series (actuator commands, setpoints, errors).

        Args:
            entity: Entity path, e.g. ``"/control/rudder_rad"``.
            t: Sim time (s).
            values: A scalar or a 1-D vector (one line per element).
            names: Series names, used the first time the entity is seen (defaults: the entity's
                last path part for a scalar, x/y/z for 2-3 elements, [i] beyond).

        Raises:
            ValueError: If the number of elements changes, or ``names`` does not match it.
        """
        row = np.ravel(values).tolist()
        series = self._series.get(entity)
        if series is None:
            series = self._new_series(entity, (len(row),), names)
        if len(row) != series.width:
            raise ValueError(
                f"{entity}: {len(row)} values at t={t}, {series.width} before; "
                "a series' width must not change"
            )
        series.t.append(t)
        series.rows.append(row)
        self._maybe_flush(t)

    def log_scalar_rows(
        self,
        entity: str,
        t: Sequence[float],
        rows: Sequence[Sequence[float]],
        names: Sequence[str] | None = None,
    ) -> None:
        """:meth:`log_scalars` of many samples at once: times ``t`` and one row of values each."""
        if not len(t):
            return
        width = len(rows[0])
        series = self._series.get(entity)
        if series is None:
            series = self._new_series(entity, (width,), names)
        if any(len(r) != series.width for r in rows) or len(rows) != len(t):
            raise ValueError(
                f"{entity}: rows of {sorted({len(r) for r in rows})} values for {len(t)} times, "
                f"{series.width} values each before; a series' width must not change"
            )
        series.t.extend(t)
        series.rows.extend(list(r) for r in rows)
        self._maybe_flush(t[-1])

    # ------------------------------------------------------------------ pictures and events

    def log_image(self, entity: str, t: float, image: np.ndarray) -> None:
        """Log one image: as JPEG at the next flush, or raw pixels (``jpeg_quality`` None) now.

        Args:
            entity: Entity path, e.g. ``"/camera/chase"``.
            t: Sim time (s).
            image: uint8, shape (H, W) (grey) or (H, W, 3) (RGB).

        Raises:
            ValueError: If the image is not uint8 grey or RGB.
        """
        img = np.asarray(image)
        if img.dtype != np.uint8 or not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3)):
            raise ValueError(
                f"{entity}: image of dtype {img.dtype} and shape {img.shape}; "
                "expected uint8 (H, W) or (H, W, 3)"
            )
        if self._jpeg_quality is None:
            self._set_time(t)
            self._rec.log(entity, rr.Image(img))
            self._maybe_flush(t)
            return
        # OpenCV's libjpeg-turbo: a third of the time of rr.Image.compress (PIL) for the same
        # JPEG quality scale; OpenCV reads three channels as BGR.
        bgr = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, self._jpeg_quality])
        if not ok:
            raise ValueError(f"{entity}: OpenCV could not JPEG-encode the image")
        times, blobs = self._images.setdefault(entity, ([], []))
        times.append(t)
        blobs.append(buf.tobytes())
        self._maybe_flush(t)

    def log_points2d(
        self,
        entity: str,
        t: float,
        points: np.ndarray,
        *,
        radius: float = 4.0,
        color: tuple[int, int, int] = scene.TRUTH_COLOR,
        label: str | None = None,
    ) -> None:
        """Log image-space points (e.g. a truth marker over a camera image), at the next flush.

        Args:
            entity: Entity path; a child of an image's entity draws over that image.
            t: Sim time (s).
            points: (N, 2) pixel coordinates (u, v); an empty array clears the marker.
            radius: Marker radius in pixels.
            color: RGB.
            label: Optional text shown with the points.
        """
        pts = np.asarray(points, dtype=np.float32).reshape(-1, 2)
        self._points2d.setdefault(entity, []).append((t, pts, float(radius), color, label or None))
        self._maybe_flush(t)

    def log_archetype(
        self, entity: str, archetype: object, *, t: float | None = None, static: bool = False
    ) -> None:
        """Log any Rerun archetype now at sim time ``t``, or as static data (``static=True``)."""
        if static:
            self._rec.log(entity, archetype, static=True)  # type: ignore[arg-type]
            return
        if t is None:
            raise ValueError(f"{entity}: a time-varying archetype needs t")
        self._set_time(t)
        self._rec.log(entity, archetype)  # type: ignore[arg-type]
        self._maybe_flush(t)

    def log_text(self, t: float, text: str, level: str = "INFO") -> None:
        """Log one event message to ``/log``.

        Args:
            t: Sim time (s).
            text: The message.
            level: ``"TRACE"``, ``"DEBUG"``, ``"INFO"``, ``"WARN"``, ``"ERROR"`` or ``"CRITICAL"``.
        """
        self._set_time(t)
        self._rec.log(LOG_ENTITY, rr.TextLog(text, level=level))
        self._maybe_flush(t)

    # ------------------------------------------------------------------ flush / close

    def flush(self) -> None:
        """Write every buffered column to the file and wait until it is on disk.

        Raises:
            RuntimeError: If samples were logged after :meth:`close`.
        """
        if self._closed:
            if (
                self._truth
                or any(s.t for s in self._series.values())
                or self._images
                or self._points2d
            ):
                raise RuntimeError(f"{self.path}: samples logged after close() are lost")
            return
        self._next_flush_t = math.inf
        rec = self._rec
        if self._truth:
            self._flush_truth()
        self._flush_pictures()
        # Series sampled together (the channels of one sensor, a filter's /nav series) have equal
        # times: their time columns are built once a flush (~60 us each, a third of a series').
        indexes: dict[tuple[int, float], list[tuple[list[float], list[rr.TimeColumn]]]] = {}
        for entity, series in self._series.items():
            t = series.t
            if t:
                values = np.asarray(series.rows, dtype=np.float64).reshape(len(t), -1)
                built = indexes.setdefault((len(t), t[-1]), [])
                index = next((cols for times, cols in built if times == t), None)
                if index is None:
                    index = self._time_columns(t)
                    built.append((t, index))
                rec.send_columns(entity, indexes=index, columns=rr.Scalars.columns(scalars=values))
                series.t = []
                series.rows = []
        rec.flush()

    def close(self) -> None:
        """Flush, then finalize the file (RRD footer). Idempotent; safe in a ``finally``."""
        if self._closed:
            return
        try:
            self.flush()
            if self._path_tail is not None:
                # End the track at the last truth sample, not at the last period boundary.
                t_end, p_end = self._path_tail
                self._path_tail = None
                self._send_path(np.array([t_end]), p_end[np.newaxis])
                self._rec.flush()
        finally:
            self._closed = True
            # disconnect() is what writes the footer; flush() alone leaves a footer-less file.
            self._rec.disconnect()
        if self._compact:
            compact(self.path)

    # ------------------------------------------------------------------ internals

    def _flush_pictures(self) -> None:
        """The buffered JPEG images and image-space points, a column per entity."""
        rec = self._rec
        for entity, (times, blobs) in self._images.items():
            rec.send_columns(
                entity,
                indexes=self._time_columns(times),
                columns=rr.EncodedImage.columns(blob=blobs, media_type=["image/jpeg"] * len(blobs)),
            )
        self._images = {}
        for entity, rows in self._points2d.items():
            # One row per call, its points a partition; each point carries its row's radius,
            # colour and label (rr.Points2D's one radius, colour and label per call, broadcast).
            lengths = [len(r[1]) for r in rows]
            labelled = any(r[4] is not None for r in rows)
            cols = rr.Points2D.columns(
                positions=np.concatenate([r[1] for r in rows]),
                radii=np.repeat([r[2] for r in rows], lengths),
                colors=np.repeat(np.array([r[3] for r in rows], dtype=np.uint8), lengths, axis=0),
                labels=[r[4] or "" for r, n in zip(rows, lengths, strict=True) for _ in range(n)]
                if labelled
                else None,
            ).partition(lengths)
            rec.send_columns(entity, indexes=self._time_columns([r[0] for r in rows]), columns=cols)
        self._points2d = {}

    def _maybe_flush(self, t: float) -> None:
        if t >= self._next_flush_t:
            self.flush()
        elif self._next_flush_t == math.inf:
            self._next_flush_t = t + self._flush_every_s

    def _set_time(self, t: float) -> None:
        ns = round(t * _NS_PER_S)
        self._rec.set_time(SIM_TIME, duration=np.timedelta64(ns, "ns"))
        self._rec.set_time(UTC, timestamp=np.datetime64(self._start_ns + ns, "ns"))

    def _time_columns(self, t: Sequence[float] | FloatArray) -> list[rr.TimeColumn]:
        ns = np.rint(np.asarray(t, dtype=np.float64) * _NS_PER_S).astype(np.int64)
        return [
            rr.TimeColumn(SIM_TIME, duration=ns.astype("timedelta64[ns]")),
            rr.TimeColumn(UTC, timestamp=(ns + self._start_ns).astype("datetime64[ns]")),
        ]

    def _new_series(
        self, entity: str, shape: tuple[int, ...], names: Sequence[str] | None
    ) -> _Series:
        series = _Series(shape)
        width = series.width
        if names is None:
            names = _default_names(width, entity.rstrip("/").rsplit("/", 1)[-1])
        elif len(names) != width:
            raise ValueError(f"{entity}: {len(names)} names for {width} values")
        self._series[entity] = series
        colors = _XYZ_COLORS[:width] if 1 < width <= 3 else None
        self._rec.log(entity, rr.SeriesLines(names=list(names), colors=colors), static=True)
        return series

    def _new_reading_series(self, sensor: str, channel: str, value: object) -> _Series | None:
        entity = f"/sensors/{sensor}/{channel}"
        shape = np.shape(value)
        if math.prod(shape) > MAX_SERIES_WIDTH:
            self.skipped_channels.add(entity)
            return None
        return self._new_series(entity, shape, None)

    def _log_truth_names(self) -> None:
        rec = self._rec
        rec.log(
            "/truth/rpy_deg",
            # Yaw (+-180 deg) would flatten roll and pitch (a few deg): hidden until asked for.
            rr.SeriesLines(
                names=["roll", "pitch", "yaw"],
                colors=_XYZ_COLORS,
                visible_series=[True, True, False],
            ),
            static=True,
        )
        rec.log("/truth/heading_deg", rr.SeriesLines(names=["heading"]), static=True)
        rec.log("/truth/depth_m", rr.SeriesLines(names=["depth (truth)"]), static=True)
        rec.log("/truth/speed_mps", rr.SeriesLines(names=["speed"]), static=True)
        rec.log(
            "/truth/velocity_n",
            rr.SeriesLines(names=["east", "north", "up"], colors=_XYZ_COLORS),
            static=True,
        )
        rec.log(
            "/world/path",
            rr.LineStrips3D.from_fields(radii=rr.Radius.ui_points(1.5), colors=[_PATH_COLOR]),
            static=True,
        )
        self._truth_names_logged = True

    def _flush_truth(self) -> None:
        rec = self._rec
        if not self._truth_names_logged:
            self._log_truth_names()
        data = np.asarray(self._truth, dtype=np.float64)
        self._truth = []
        if data.ndim != 2 or data.shape[1] != _TRUTH_WIDTH:
            raise ValueError(
                f"truth rows have shape {data.shape[1:]}, expected ({_TRUTH_WIDTH},): "
                "position_n, velocity_n and rpy_deg need 3 elements, quat_wxyz 4"
            )
        t = data[:, _T]
        index = self._time_columns(t)
        pos = data[:, _POS]
        rec.send_columns(
            "/world/auv",
            indexes=index,
            columns=rr.Transform3D.columns(
                translation=pos, quaternion=wxyz_to_xyzw(data[:, _QUAT])
            ),
        )
        vel = data[:, _VEL]
        for entity, values in (
            ("/truth/rpy_deg", data[:, _RPY]),
            ("/truth/heading_deg", data[:, _HDG]),
            ("/truth/depth_m", data[:, _DEPTH]),
            ("/truth/speed_mps", np.linalg.norm(vel, axis=1)),
            ("/truth/velocity_n", vel),
        ):
            rec.send_columns(entity, indexes=index, columns=rr.Scalars.columns(scalars=values))
        self._flush_path(t, pos)

    def _flush_path(self, t: FloatArray, pos: FloatArray) -> None:
        # The track is logged as short segments, one row each, and the 3D view shows all rows up to
        # the cursor (a visible time range): O(N) in the file and exact up to the cursor to within
        # path_period_s. Re-logging the whole polyline at every flush would grow the file as O(N^2).
        bins = np.floor(t / self._path_period_s).astype(np.int64)
        prev_bins = np.empty_like(bins)
        prev_bins[0] = bins[0] - 1 if self._path_last_bin is None else self._path_last_bin
        prev_bins[1:] = bins[:-1]
        keep = np.flatnonzero(bins != prev_bins)  # first sample of each new period
        self._path_last_bin = int(bins[-1])
        last = len(t) - 1
        self._path_tail = None if keep.size and keep[-1] == last else (float(t[last]), pos[last])
        if keep.size:
            self._send_path(t[keep], pos[keep])

    def _send_path(self, t: FloatArray, points: FloatArray) -> None:
        if self._path_last_point is None:
            # The very first point has no predecessor: it only starts the track.
            starts, ends, t = points[:-1], points[1:], t[1:]
        else:
            starts = np.concatenate([self._path_last_point[np.newaxis], points[:-1]])
            ends = points
        self._path_last_point = points[-1].copy()
        if len(ends) == 0:
            return
        segments = np.stack([starts, ends], axis=1)  # (M, 2, 3): one 2-point strip per row
        self._rec.send_columns(
            "/world/path",
            indexes=self._time_columns(t),
            columns=rr.LineStrips3D.columns(strips=list(segments)),
        )
