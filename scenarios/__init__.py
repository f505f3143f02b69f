"""Sea trials as data: TOML scenario files, their schema, and the shipped trials.

>>> from scenarios import load
>>> s = load("default")            # a shipped name, or a path to any .toml file
>>> s.mission.kind, s.place.latitude_deg
('legs', 37.54)
"""

from __future__ import annotations

import os
from pathlib import Path

from scenarios.loader import ScenarioError, load_scenario, parse_scenario
from scenarios.schema import Scenario

__all__ = [
    "SCENARIOS_DIR",
    "Scenario",
    "ScenarioError",
    "load",
    "load_scenario",
    "parse_scenario",
    "shipped",
]

SCENARIOS_DIR: Path = Path(__file__).resolve().parent


def shipped() -> dict[str, Path]:
    """Every shipped scenario: file stem (which is also the scenario's ``name``) to path, sorted."""
    return {p.stem: p for p in sorted(SCENARIOS_DIR.glob("*.toml"))}


def load(name_or_path: str | os.PathLike[str]) -> Scenario:
    """Load a shipped scenario by name (``"default"``), or any scenario file by path.

    A string that names a shipped scenario wins over a file of the same name in the working
    directory; anything else is taken as a path.

    Raises:
        ScenarioError: No such shipped scenario or file, or the file is not a valid scenario.
    """
    if isinstance(name_or_path, str):
        ships = shipped()
        if name_or_path in ships:
            return load_scenario(ships[name_or_path])
        if not Path(name_or_path).exists() and Path(name_or_path).suffix != ".toml":
            raise ScenarioError(
                ["no shipped scenario of that name and no such file; shipped: " + ", ".join(ships)],
                source=name_or_path,
            )
    return load_scenario(name_or_path)
