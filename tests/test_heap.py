"""The start-up heap is frozen while a run flies, and handed back after it, however it ends."""

from __future__ import annotations

import dataclasses
import gc
from pathlib import Path

import pytest

from tests.scenario_helpers import minimal_scenario
from twin.app import run as run_mod
from twin.app.heap import start_up_frozen


def test_the_block_runs_frozen_and_unfreezes_after_it_even_on_an_error() -> None:
    assert gc.get_freeze_count() == 0
    alive = [object() for _ in range(10)]  # noqa: F841 (objects alive when the block starts)
    with start_up_frozen():
        assert gc.get_freeze_count() >= 10
    assert gc.get_freeze_count() == 0
    with pytest.raises(RuntimeError), start_up_frozen():
        raise RuntimeError("the flight failed")
    assert gc.get_freeze_count() == 0


def test_a_runs_flight_sees_the_start_up_heap_frozen(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[int] = []
    loop = run_mod._loop

    def spy(*args, **kwargs):  # type: ignore[no-untyped-def]
        seen.append(gc.get_freeze_count())
        return loop(*args, **kwargs)

    monkeypatch.setattr(run_mod, "_loop", spy)
    sc = dataclasses.replace(minimal_scenario(), duration_s=1.0)
    run_mod.run_scenario(sc, tmp_path / "run", camera=False, record=False)
    # The imports, the model and the tables (far more than a bare interpreter's few thousand).
    assert seen and seen[0] > 50_000
    assert gc.get_freeze_count() == 0
