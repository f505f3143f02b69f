"""Trial kinds a campaign can run: a scenario (the default) or a registered study trial.

A *scenario* trial flies one resolved scenario with one seed (:func:`twin.app.run.run_scenario`).
A *study* trial is a function of a parameter table and a seed that returns a metrics mapping,
for studies that are not a flight: the MOI paper's noise study runs one random solar azimuth
through the three axis methods on an ideal imager (:mod:`twin.campaign.moi_noise`). The campaign
machinery (sweeps, seeds, run ids, workers, Ray, resume, reports) is the same for both.

A study is named in a spec by ``trial = "<name>"`` (:data:`twin.core.extensions.STUDY_TRIALS`:
the project's and installed packages' ``auv_twin.trials`` entry points) or
``trial = "package.module:function"`` for a user's own, importable in every worker. Its
parameters are the study's ``defaults`` overridden by ``[set]`` and the sweep axes (plain
names); ``check`` names every bad parameter before anything runs.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from twin.core.extensions import STUDY_TRIALS

#: The trial kind of a spec without ``trial``.
SCENARIO = "scenario"


@dataclass(frozen=True)
class StudyTrial:
    """A study trial: ``run(params, seed) -> metrics`` with its defaults and checks.

    Attributes:
        name: How a spec names it.
        run: One trial; deterministic in (params, seed); returns a JSON-able metrics mapping
            (nested tables are flattened to dotted columns like a run's metrics.json).
        defaults: Every parameter and its default; a spec may set or sweep only these.
        check: Errors for a parameter table (each names the parameter, the value and what is
            allowed); empty when the table is valid.
    """

    name: str
    run: Callable[[Mapping[str, Any], int], Mapping[str, Any]]
    defaults: Mapping[str, Any] = field(default_factory=dict)
    check: Callable[[Mapping[str, Any]], list[str]] = field(default=lambda _p: [])


def load_trial(name: str) -> StudyTrial:
    """The study trial of a spec's ``trial`` value.

    A name from :data:`twin.core.extensions.STUDY_TRIALS` (the project's trials and installed
    packages' ``auv_twin.trials`` entry points), or ``"package.module:name"``.

    Raises:
        ValueError: Unknown name, or a ``module:attr`` that does not import or is not a trial.
    """
    if name in STUDY_TRIALS.names():
        obj = STUDY_TRIALS.load(name)
        return _as_trial(name, obj)
    target = name
    if ":" not in target:
        raise ValueError(
            f"{name!r}; allowed: {SCENARIO!r}, one of {list(STUDY_TRIALS.names())}, or "
            "'package.module:name'"
        )
    module, _, attr = target.partition(":")
    try:
        obj = getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"{name!r} does not import: {exc}") from None
    return _as_trial(name, obj)


def _as_trial(name: str, obj: Any) -> StudyTrial:
    if isinstance(obj, StudyTrial):
        return obj
    if callable(obj):  # a bare function: no defaults, any parameters
        return StudyTrial(name, obj)
    raise ValueError(f"{name!r} is not a StudyTrial or a function")


def wrap180(x: float) -> float:
    """An angle difference in degrees wrapped to [−180, 180)."""
    return (x + 180.0) % 360.0 - 180.0


# ---- a study's parameter checks (one line per problem: the parameter, the value, what is allowed)


def number_problem(p: Mapping[str, Any], key: str, lo: float, hi: float, what: str) -> list[str]:
    """``[]`` when ``p[key]`` is a number in [lo, hi], else the one-line problem."""
    v = p.get(key)
    if isinstance(v, int | float) and not isinstance(v, bool) and lo <= v <= hi:
        return []
    return [f"{key}: {v!r}; allowed: a number in [{lo:g}, {hi:g}] ({what})"]


def choice_problem(p: Mapping[str, Any], key: str, allowed: Sequence[str]) -> list[str]:
    """``[]`` when ``p[key]`` is one of ``allowed``, else the one-line problem."""
    if p.get(key) in allowed:
        return []
    return [f"{key}: {p.get(key)!r}; allowed: {list(allowed)}"]


def names_problem(p: Mapping[str, Any], key: str, allowed: Sequence[str]) -> list[str]:
    """``[]`` when ``p[key]`` is a non-empty list of distinct names from ``allowed``."""
    m = p.get(key)
    if isinstance(m, list) and m and all(x in allowed for x in m) and len(set(m)) == len(m):
        return []
    return [f"{key}: {m!r}; allowed: a non-empty list of distinct {list(allowed)}"]
