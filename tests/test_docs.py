"""The docs hold together: every relative link in the repository's Markdown resolves.

Reports move (results of retired models go to ``validation/results/archive/``, experiments to
their campaigns); a link left behind is a reader's dead end. The archive is exempt: its files
keep the links of the day they were written (its README says so).
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_LINK = re.compile(r"\]\(([^)\s]+)\)")


def _markdown_files() -> list[Path]:
    out = subprocess.run(
        ["git", "-C", str(ROOT), "ls-files", "--cached", "--others", "--exclude-standard", "*.md"],
        capture_output=True, text=True, check=True,
    ).stdout.split()  # fmt: skip
    return [ROOT / f for f in out if "/archive/" not in f and (ROOT / f).exists()]


def test_every_relative_link_in_the_markdown_resolves() -> None:
    files = _markdown_files()
    assert any(f.name == "README.md" and f.parent == ROOT for f in files)
    dead = []
    for f in files:
        for m in _LINK.finditer(f.read_text(encoding="utf-8")):
            target = m.group(1)
            if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                continue  # a URL or an anchor in the same page
            path = target.split("#", 1)[0]
            if path and not (f.parent / path).exists():
                dead.append(f"{f.relative_to(ROOT)}: {target}")
    assert not dead, "dead links:\n" + "\n".join(dead)


def test_benchmarks_hold_speed_benchmarks_only() -> None:
    # Each paper experiment's one home is its campaign spec (validation/study_campaigns.py runs
    # them); benchmarks/ times the code. A script there that writes no timing is misfiled.
    scripts = sorted((ROOT / "benchmarks").glob("*.py"))
    assert scripts
    for p in scripts:
        text = p.read_text(encoding="utf-8")
        assert re.search(r"perf_counter|timeit|real[- ]time|runs/min|\bms\b", text), p.name
    specs = {p.stem for p in (ROOT / "scenarios" / "campaigns").glob("*.toml")}
    assert not specs & {p.stem for p in scripts}
