"""Ctrl-C while the command line imports its modules: held, then raised once they are loaded.

A SIGINT that lands while a C extension initialises is turned by the extension into an
``ImportError`` ("initialization failed"), and a library that probes for an optional module
(``try: import x except ImportError: pass``) then swallows the user's Ctrl-C: measured with the
default trial under load, a Ctrl-C 1.5 s into start-up exited 1 as an "internal error", and in
one full test run the interrupted run flew on to the end and exited 0. While the command's
heavy imports run, :class:`held` only notes the Ctrl-C; leaving the block raises
``KeyboardInterrupt`` (exit 130), so a Ctrl-C at any moment of start-up means "stop".
"""

from __future__ import annotations

import signal
import threading
from types import FrameType, TracebackType


class held:
    """Hold SIGINT for the block; raise ``KeyboardInterrupt`` after it if one came.

    Args:
        raise_after: False: only note it (``pending``), for module-level imports that run before
            the command's own error handling.
    """

    def __init__(self, raise_after: bool = True) -> None:
        self.raise_after = raise_after
        self.pending = False
        self._old: object = None
        self._active = False

    def _note(self, signum: int, frame: FrameType | None) -> None:
        self.pending = True

    def __enter__(self) -> held:
        # Signal handlers can be set in the main thread only (elsewhere: nothing to hold).
        self._active = threading.current_thread() is threading.main_thread()
        if self._active:
            self._old = signal.signal(signal.SIGINT, self._note)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._active:
            signal.signal(signal.SIGINT, self._old)  # type: ignore[arg-type]
        if self.pending and self.raise_after and exc_type is None:
            raise KeyboardInterrupt
