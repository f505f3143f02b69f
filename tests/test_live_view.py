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
from pathlib import Path

import pytest
from rrd_helpers import entities

import scenarios
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


def test_a_run_streams_to_a_live_server_and_the_file_is_unchanged(tmp_path: Path) -> None:
    port = _free_port()
    received = tmp_path / "received.rrd"
    server = subprocess.Popen(
        [sys.executable, "-m", "rerun", "--port", str(port), "--save", str(received)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
                break
            except OSError:
                time.sleep(0.2)
        else:
            pytest.fail("the Rerun server did not start listening")
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
