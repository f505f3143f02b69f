"""Test-wide settings. MUJOCO_GL must be set before mujoco is first imported."""

from __future__ import annotations

import os
import signal

os.environ.setdefault("MUJOCO_GL", "egl")

# A suite started as a background job of a non-interactive shell (`cmd &` in a script) inherits
# SIGINT ignored, and an ignored signal stays ignored across exec: the command lines the Ctrl-C
# tests start would never see their SIGINT. A handled signal is reset to the default at exec,
# so the children start as a terminal's foreground job does.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
