"""A live Rerun viewer: spawn one, or check that one answers, before a run streams to it."""

from __future__ import annotations

import socket
import time
import urllib.parse

import rerun as rr

#: Where a spawned viewer listens (Rerun's default port).
VIEWER_URL = "rerun+http://127.0.0.1:9876/proxy"


def spawn_viewer(wait_s: float = 10.0) -> str:
    """Start a Rerun viewer (or reuse the one on the default port); its gRPC URL.

    Raises:
        OSError: No viewer listens after ``wait_s`` (no ``rerun`` executable, no display).
    """
    try:
        # spawn() acts only for an enabled recording: a throwaway one (nothing is sent on it).
        rr.spawn(
            connect=False,
            hide_welcome_screen=True,
            recording=rr.RecordingStream("auv_twin", recording_id="spawn"),
        )
    except Exception as exc:  # rerun raises plain RuntimeErrors and FileNotFoundErrors here
        raise OSError(f"could not spawn a Rerun viewer ({type(exc).__name__}: {exc})") from exc
    check_live(VIEWER_URL, wait_s)
    return VIEWER_URL


def check_live(url: str, wait_s: float = 2.0) -> None:
    """Raise OSError unless something accepts connections at the gRPC URL's host and port.

    A gRPC sink with nobody listening would hold the run at its first flush.
    """
    parsed = urllib.parse.urlsplit(url.replace("rerun+", "", 1))
    if parsed.scheme not in ("http", "https") or not parsed.hostname:
        raise OSError(f"{url!r} is not a Rerun gRPC URL (e.g. {VIEWER_URL})")
    port = parsed.port or (443 if parsed.scheme == "https" else 80)
    deadline = time.monotonic() + wait_s
    while True:
        try:
            with socket.create_connection((parsed.hostname, port), timeout=0.5):
                return
        except OSError as exc:
            if time.monotonic() >= deadline:
                raise OSError(
                    f"no Rerun viewer or server answers at {url} ({exc.strerror or exc})"
                ) from exc
            time.sleep(0.2)
