"""Study trials for the campaign tests (importable by the pool's spawned workers)."""

from __future__ import annotations

import os
import signal
from collections.abc import Mapping
from typing import Any


def crash_or_echo(params: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """A real worker death (SIGSEGV) when ``params["crash"]``; else the seed back as a metric."""
    if params.get("crash"):
        os.kill(os.getpid(), signal.SIGSEGV)
    return {"value": float(seed) + float(params.get("offset", 0.0))}


def sleep_then_echo(params: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """Sleep ``params["sleep_s"]`` (a run long enough to be caught in flight), then echo."""
    import time

    time.sleep(float(params.get("sleep_s", 0.0)))
    return {"value": float(seed)}
