"""The start-up heap kept out of the cyclic garbage collector's full passes during a flight.

By the time a run flies, the process holds ~250 000 objects that live as long as it does (the
imported modules, MuJoCo's bindings, the light-field tables, numba's dispatchers). CPython's
oldest-generation pass walks every one of them each time it runs: once in a 10-minute sea
trial, 124–129 ms of its 13–17 s (measured by ``gc.callbacks`` on this project's 2-core VM,
with and without the recording; frozen, the pass took 0–4 ms). :func:`gc.freeze` moves them to
the permanent generation, which no pass walks; the objects the flight makes are collected as
before, and :func:`gc.unfreeze` at the end hands the start-up objects back (a campaign worker's
earlier runs' leftovers among them), so nothing a later run drops stays uncollectable. The
numbers a run computes do not depend on when the collector runs.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def start_up_frozen() -> Iterator[None]:
    """Freeze the objects alive now for the block, and unfreeze them after it (however it ends).

    Nested or concurrent uses in one process are safe: an inner block's unfreeze only makes the
    outer block's remaining passes walk more objects.
    """
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
