"""Issue 26 part 7: the package declares what it imports, and installs on its own.

The fast test reads every module of the package (AST) and maps each third-party import to the
distribution that provides it (``importlib.metadata.packages_distributions``): an import at module
level must be a declared runtime dependency; one inside a function (an optional backend) may also
come from an extra. The slow test installs the package into a fresh virtual environment with its
runtime dependencies only and imports every module there.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import venv
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("twin", "sensors", "scenarios", "models")


def _modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def _name(req: str) -> str:
    return re.split(r"[ ;<>=!~\[]", req, maxsplit=1)[0].lower().replace("_", "-")


def _declared() -> tuple[set[str], set[str]]:
    """(runtime dependencies, those of the extras) as normalised distribution names."""
    runtime, extras = set(), set()
    for req in metadata.requires("auv-twin") or []:
        (extras if "extra ==" in req else runtime).add(_name(req))
    return runtime, extras


def _imports(path: Path) -> tuple[set[str], set[str]]:
    """(top-level names imported at module level, names imported inside functions)."""
    tree = ast.parse(path.read_text(), str(path))
    top, inner = set(), set()

    def visit(node: ast.AST, nested: bool) -> None:
        for child in ast.iter_child_nodes(node):
            is_fn = isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef)
            if isinstance(child, ast.Import):
                names = {a.name.split(".")[0] for a in child.names}
            elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                names = {child.module.split(".")[0]}
            else:
                names = set()
            # `if TYPE_CHECKING:` imports are for the type checker only.
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                continue
            (inner if nested else top).update(names)
            visit(child, nested or is_fn)

    visit(tree, False)
    return top, inner


def test_every_runtime_import_is_a_declared_dependency() -> None:
    runtime, extras = _declared()
    dists = {k: {_name(d) for d in v} for k, v in metadata.packages_distributions().items()}
    stdlib = set(sys.stdlib_module_names)
    problems = []
    for path in _modules():
        top, inner = _imports(path)
        for names, allowed, where in ((top, runtime, "module level"),
                                      (inner, runtime | extras, "a function")):  # fmt: skip
            for n in sorted(names - stdlib - set(PACKAGES) - {"__future__"}):
                provided = dists.get(n, set())
                if not provided & allowed:
                    problems.append(f"{path.relative_to(ROOT)}: {n} ({where}) from {provided}")
    assert not problems, "\n".join(problems)
    assert "matplotlib" in runtime  # campaign reports and render draw with it


def test_license_citation_and_changelog_are_at_the_root() -> None:
    lic = (ROOT / "LICENSE").read_text()
    assert "Apache License" in lic and "Version 2.0" in lic
    assert 'license = { text = "Apache-2.0" }' in (ROOT / "pyproject.toml").read_text()
    cff = (ROOT / "CITATION.cff").read_text()
    version = metadata.version("auv-twin")
    for key in ("cff-version: 1.2.0", "title:", "authors:", f"version: {version}", "license:"):
        assert key in cff, key
    assert f"## {version}" in (ROOT / "CHANGELOG.md").read_text()


@pytest.mark.slow
def test_a_fresh_install_with_only_the_runtime_dependencies_imports_every_module(
    tmp_path: Path,
) -> None:
    env = tmp_path / "venv"
    venv.create(env, with_pip=True)
    py = env / "bin" / "python"
    # Built from a copy: a setuptools build writes build/ and *.egg-info into its source tree.
    import shutil

    src = tmp_path / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(
        ".git", ".venv", "runs", "build", "*.egg-info", "__pycache__", "benchmarks",
        "validation"))  # fmt: skip
    subprocess.run([str(py), "-m", "pip", "install", "-q", str(src)], check=True, timeout=1800)
    names = []
    for p in _modules():
        rel = p.relative_to(ROOT).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        names.append(".".join(parts))
    code = (
        "import importlib, sys\n"
        f"names = {names!r}\n"
        "bad = []\n"
        "for n in names:\n"
        "    try: importlib.import_module(n)\n"
        "    except Exception as e: bad.append(f'{n}: {type(e).__name__}: {e}')\n"
        "print('\\n'.join(bad)); sys.exit(1 if bad else 0)\n"
    )
    # Run from elsewhere: the installed package, not the source tree, is imported.
    r = subprocess.run([str(py), "-c", code], cwd=tmp_path, capture_output=True, text=True,
                       timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stdout + r.stderr
