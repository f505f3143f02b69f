"""The world/onboard boundary, as the import graph shows it.

The folders are the rooms of the house (docs/architecture.md):

* ``twin/core``: the contract both sides may import (frames, earth, messages, calibration, the
  sun ephemeris, the mission plan). It imports nothing else from the project.
* ``twin/onboard``: the vehicle computer. It imports only ``twin.onboard`` and ``twin.core``.
* ``twin/world`` and ``sensors``: the world (truth). They never import the vehicle computer, the
  scorer, the recorder or the app.
* ``scenarios``: the scenario files' schema and checks. They import only ``scenarios`` and
  ``twin.core`` (the checks that build the vehicle are named in ``twin.core.extensions``).
* ``twin/sim``: the stepping core and the vehicle's build; sees both sides, never the
  scorer, the recorder or the front doors.
* ``twin/scoring``, ``twin/record``: see both sides and the stepping core, never the front doors
  (``twin/app``) or the campaigns.
* ``twin/app``, ``twin/campaign``: the front doors, on top.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PROJECT_PACKAGES = ("twin", "sensors", "scenarios", "models")


def _imports(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    out: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            # `from twin import earth` imports twin.earth: judge each imported name.
            out += [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level > 0:
            out.append("." * node.level + (node.module or ""))
    return out


def _violations(folder: Path, allowed: tuple[str, ...]) -> list[str]:
    bad = []
    for path in sorted(folder.rglob("*.py")):
        for name in _imports(path):
            if name.startswith("."):
                bad.append(f"{path.relative_to(ROOT)}: relative import {name}")
            elif name.split(".")[0] in PROJECT_PACKAGES and not any(
                name == a or name.startswith(a + ".") for a in allowed
            ):
                bad.append(f"{path.relative_to(ROOT)} imports {name}")
    return bad


@pytest.mark.parametrize(
    ("room", "allowed"),
    [
        ("twin/onboard", ("twin.onboard", "twin.core")),
        ("twin/core", ("twin.core",)),
        ("twin/world", ("twin.world", "twin.core", "models", "sensors", "scenarios.schema")),
        ("sensors", ("sensors", "twin.core")),
        ("scenarios", ("scenarios", "twin.core")),
        (
            "twin/sim",
            ("twin.sim", "twin.core", "twin.onboard", "twin.world", "sensors", "scenarios.schema"),
        ),
        (
            "twin/scoring",
            ("twin.scoring", "twin.sim", "twin.core", "twin.onboard", "twin.world", "sensors",
             "scenarios.schema"),
        ),
        (
            "twin/campaign",  # the run loop (app.run) below it, never the CLI above it
            ("twin.campaign", "twin.app.run", "twin.sim", "twin.scoring", "twin.record",
             "twin.core", "twin.onboard", "twin.world", "sensors", "scenarios", "models"),
        ),
        (
            "twin/record",
            ("twin.record", "twin.scoring", "twin.sim", "twin.core", "twin.onboard", "twin.world",
             "sensors", "scenarios.schema"),
        ),
    ],
)  # fmt: skip
def test_each_room_imports_only_what_it_may(room: str, allowed: tuple[str, ...]) -> None:
    assert _violations(ROOT / room, allowed) == []


def test_the_checker_catches_a_world_import(tmp_path: Path) -> None:
    # The test above must be able to fail: an onboard module that reads truth is caught.
    bad = tmp_path / "onboard"
    bad.mkdir()
    (bad / "leak.py").write_text(
        "from twin.world.truth import Truth\nfrom twin.core import frames\n"
    )
    global ROOT
    saved, ROOT = ROOT, tmp_path
    try:
        assert _violations(bad, ("twin.onboard", "twin.core")) == [
            "onboard/leak.py imports twin.world.truth.Truth"
        ]
    finally:
        ROOT = saved


def test_twin_has_no_flat_modules_left() -> None:
    # Every module lives in a room; twin/ itself holds only the package marker.
    assert sorted(p.name for p in (ROOT / "twin").glob("*.py")) == ["__init__.py"]
