"""A live Rerun viewer: spawn one, or check that one answers, before a run streams to it."""

from __future__ import annotations

import datetime as dt
import socket
import time
import urllib.parse

import rerun as rr

SIM_TIME = "sim_time"
UTC = "utc"
LOG_ENTITY = "/log"

# A reading channel with more elements than this is a frame or a matrix, not a time series: it is
# skipped (and listed in ``Recorder.skipped_channels``); log images with ``log_image``.
MAX_SERIES_WIDTH = 16

_NS_PER_S = 1_000_000_000
_EPOCH = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
_XYZ = ("x", "y", "z")
_XYZ_COLORS = ((230, 60, 60), (60, 200, 60), (70, 110, 240))
_TRUTH_COLOR = (255, 200, 40)
_PATH_COLOR = (255, 140, 0)
_WAYPOINT_COLOR = (220, 40, 220)
_SURFACE_COLOR = (90, 170, 230)
_SEABED_COLOR = (150, 120, 80)
_TANK_COLOR = (170, 170, 170)

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
