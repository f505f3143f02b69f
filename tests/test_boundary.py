"""The world/onboard boundary, as the import graph shows it."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# What onboard code may import from this project: itself and the shared, truth-free modules.
ALLOWED_PROJECT_MODULES = ("twin.onboard", "twin.messages", "twin.frames", "twin.earth")
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


def test_onboard_imports_nothing_from_the_world_side() -> None:
    bad = []
    for path in sorted((ROOT / "twin" / "onboard").rglob("*.py")):
        for name in _imports(path):
            if name.startswith("."):
                continue  # relative imports stay inside twin.onboard
            if name.split(".")[0] in PROJECT_PACKAGES and not name.startswith(
                ALLOWED_PROJECT_MODULES
            ):
                bad.append(f"{path.relative_to(ROOT)} imports {name}")
    assert bad == []


def test_shared_modules_are_truth_free() -> None:
    for mod in ("messages", "frames", "earth"):
        for name in _imports(ROOT / "twin" / f"{mod}.py"):
            assert name.split(".")[0] not in PROJECT_PACKAGES or name.startswith(
                ALLOWED_PROJECT_MODULES
            ), f"twin/{mod}.py imports {name}"
