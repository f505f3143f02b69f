"""`auv-twin run --connect URL`: the recording streamed live to a real Rerun server, file unchanged.

The server is Rerun's own (``python -m rerun --port P --save FILE``: it listens for SDKs as a
viewer does and writes what arrives), started as a user starts it; no display is needed.
"""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest
from rerun.chunk import RrdReader
from rrd_helpers import entities

import scenarios
from twin.core.messages import Reading
from twin.record.recorder import FLUSH_EVERY_S, LIVE_FLUSH_EVERY_S, Recorder
from twin.record.rrd_files import salvage


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _run(tmp: Path, out: Path, *extra: str) -> subprocess.CompletedProcess:
    text = (
        scenarios.shipped()["default"].read_text().replace("duration_s = 300.0", "duration_s = 6.0")
    )
    f = tmp / "short.toml"
    f.write_text(text)
    return subprocess.run(
        [sys.executable, "-m", "twin.app.cli", "run", str(f), "--out", str(out), "--quiet",
         "--no-camera", *extra],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip


def _server(port: int, received: Path) -> subprocess.Popen:
    """Rerun's own server on ``port``, saving what arrives to ``received``, once it listens."""
    server = subprocess.Popen(
        [sys.executable, "-m", "rerun", "--port", str(port), "--save", str(received)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
            return server
        except OSError:
            time.sleep(0.2)
    server.kill()
    pytest.fail("the Rerun server did not start listening")


def test_a_run_streams_to_a_live_server_and_the_file_is_unchanged(tmp_path: Path) -> None:
    port = _free_port()
    received = tmp_path / "received.rrd"
    server = _server(port, received)
    try:
        live = _run(
            tmp_path, tmp_path / "live", "--connect", f"rerun+http://127.0.0.1:{port}/proxy"
        )
        assert live.returncode == 0, live.stderr
    finally:
        server.send_signal(signal.SIGINT)
        server.wait(timeout=60)
    alone = _run(tmp_path, tmp_path / "alone")
    assert alone.returncode == 0, alone.stderr
    file_live = entities(tmp_path / "live" / "recording.rrd")
    file_alone = entities(tmp_path / "alone" / "recording.rrd")
    # The file with a live viewer attached is the file without one (same seed: same rows).
    assert file_live == file_alone
    # The server got the whole run as it went: every entity, every row (its file has no footer:
    # rewritten by Rerun's own CLI to be read back).
    got = entities(salvage(received, tmp_path / "received_footered.rrd"))
    assert got == file_live
    assert got["/world/auv"] > 0 and any(e.startswith("/nav/") for e in got)


def test_connecting_to_nothing_is_a_clear_error_before_the_run(tmp_path: Path) -> None:
    port = _free_port()  # nobody listens there
    proc = _run(tmp_path, tmp_path / "o", "--connect", f"rerun+http://127.0.0.1:{port}/proxy")
    assert proc.returncode == 2
    assert "no Rerun viewer or server answers" in proc.stderr
    assert not (tmp_path / "o" / "metrics.json").exists()
    proc = _run(tmp_path, tmp_path / "o", "--connect", "127.0.0.1:9876")
    assert proc.returncode == 2 and "is not a Rerun gRPC URL" in proc.stderr


def test_a_live_viewer_is_flushed_to_more_often_than_a_file(tmp_path: Path) -> None:
    """A file alone is written every FLUSH_EVERY_S of sim time (cheaper); a live viewer every
    LIVE_FLUSH_EVERY_S, so that it sees the run that little behind."""
    import datetime as dt

    import numpy as np

    assert LIVE_FLUSH_EVERY_S < FLUSH_EVERY_S
    start = dt.datetime(2024, 6, 21, tzinfo=dt.UTC)
    port = _free_port()
    received = tmp_path / "received.rrd"
    server = _server(port, received)
    try:
        url = f"rerun+http://127.0.0.1:{port}/proxy"
        live_file = tmp_path / "live.rrd"
        with Recorder(live_file, recording_id="l", start_utc=start, live=url) as rec:
            assert rec.flush_every_s == LIVE_FLUSH_EVERY_S
            for k in range(round(LIVE_FLUSH_EVERY_S * 100) + 1):
                t = k * 0.01
                rec.log_reading(Reading("imu", t, t, {"accel": np.array([k, 0.0, 9.81])}))
            # Written at t = LIVE_FLUSH_EVERY_S, before the recording closes (its file sink is
            # fed by the same stream as the viewer).
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # "RRD file has no footer" while it is open
                written = RrdReader(live_file).stream().collect().summary()
            assert "/sensors/imu/accel" in written
        with Recorder(tmp_path / "file.rrd", recording_id="f", start_utc=start) as rec:
            assert rec.flush_every_s == FLUSH_EVERY_S
    finally:
        server.send_signal(signal.SIGINT)
        server.wait(timeout=60)
    got = entities(salvage(received, tmp_path / "received_footered.rrd"))
    assert got["/sensors/imu/accel"] == round(LIVE_FLUSH_EVERY_S * 100) + 1
