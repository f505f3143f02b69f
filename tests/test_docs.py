"""The docs hold together: every relative link in the repository's Markdown resolves.

Reports move (results of retired models go to ``validation/results/archive/``, experiments to
their campaigns); a link left behind is a reader's dead end. The archive is exempt: its files
keep the links of the day they were written (its README says so).
"""

from __future__ import annotations

import re
import subprocess
import sys
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


def test_the_validation_page_is_generated_from_the_results_on_disk() -> None:
    # docs/validation.md quotes numbers only through validation/page.py, which reads them from
    # the checked-in results: a hand edit, or a study rerun without regenerating, fails here.
    out = subprocess.run(
        [sys.executable, str(ROOT / "validation" / "page.py"), "--check"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert out.returncode == 0, out.stdout + out.stderr


def test_every_number_the_validation_page_reads_from_the_suite_is_recorded_by_a_test() -> None:
    # Each quantity the page asks checks.json for is one a `measures` test records, so that
    # rerunning validation/checks.py refreshes it (a renamed quantity fails here, not silently).
    numbers = (ROOT / "validation" / "page_numbers.py").read_text()
    asked = set(
        re.findall(r"(?:_one\(r, |_max_abs\(r, |\.measured\()[\"']([a-z0-9_]+)[\"']", numbers)
    )
    # ... and the {key:spec} fields of the claims' measured_lines templates.
    claims = (ROOT / "validation" / "page_claims.py").read_text()
    asked |= set(re.findall(r"\{([a-z][a-z0-9_]*)(?::[a-z0-9.%]*)?\}", claims))
    assert len(asked) > 20
    recorded = set()
    for path in (ROOT / "tests").rglob("test_*.py"):
        recorded |= set(re.findall(r"record_property\(\s*f?\"([a-z0-9_]+)", path.read_text()))
    assert asked <= recorded, sorted(asked - recorded)


def test_the_readme_quotes_the_sea_trials_measured_speed() -> None:
    """The README's real-time factor is the benchmark's last run, not a number typed once."""
    import json

    d = json.loads((ROOT / "benchmarks" / "results" / "sea_trial_rtf.json").read_text())
    rows = [r for r in d["rows"]["current"] if len(r["variants"]) == 3]
    off = next(r for r in rows if not r["recording"])
    on = next(r for r in rows if r["recording"])
    quote = (
        f"**{off['sim_s'] / off['wall_s']:.0f}× real time** on one core "
        f"({on['sim_s'] / on['wall_s']:.0f}× with the recording"
    )
    assert quote in (ROOT / "README.md").read_text(encoding="utf-8")
