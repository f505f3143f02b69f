"""docs/validation.md, generated: one section per claim, every number read from a results file.

The claims (what was checked against what) are declared in ``page_claims.py``; their numbers are
read by ``page_numbers.py`` from the files the validation studies, the campaigns, the benchmarks
and ``validation/checks.py`` wrote, and each source is named with the commit and date that made
it. Nothing here runs a study: regenerating the page after a study is cheap, and
``tests/test_docs.py`` fails when the checked-in page is not what this writes from the
checked-in results.

    python validation/page.py            # writes docs/validation.md
    python validation/page.py --check    # exit 1 when docs/validation.md is not current
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import re
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "validation.md"


class ResultsError(ValueError):
    """A results file the page needs is missing or lacks a quantity (named in the message)."""


@dataclass(frozen=True)
class Claim:
    """One section of the page.

    Attributes:
        title: The section's heading: the claim in a few words.
        checked: What was compared with what; a reference's value appears with its source.
        sources: Repo-relative results files the numbers come from (linked, with who made them).
        body: Reads the numbers and returns the section's lines (a table or bullets).
        reading: What the numbers mean, in words that stay true while the numbers move within
            their noise (no measured number here: those come from ``body``).
    """

    title: str
    checked: str
    sources: tuple[str, ...]
    body: Callable[[Results], list[str]]
    reading: str = ""


class Results:
    """Read access to the checked-in results, cached per file."""

    def __init__(self, root: Path = ROOT) -> None:
        self.root = root

    def _path(self, rel: str) -> Path:
        path = self.root / rel
        if not path.is_file():
            raise ResultsError(f"{rel}: missing (run the study that writes it)")
        return path

    @functools.cache  # noqa: B019 - one Results per page build; the cache dies with it
    def json(self, rel: str) -> Any:
        """The parsed JSON file."""
        return json.loads(self._path(rel).read_text())

    @functools.cache  # noqa: B019
    def text(self, rel: str) -> str:
        """The file's text."""
        return self._path(rel).read_text()

    def csv(self, rel: str) -> list[dict[str, str]]:
        """The rows of a CSV file (a campaign's groups.csv)."""
        with self._path(rel).open(newline="") as fh:
            return list(csv.DictReader(fh))

    def table(self, rel: str, heading: str, index: int = 0) -> list[dict[str, str]]:
        """The ``index``-th Markdown table of the section whose heading contains ``heading``.

        The section ends at the next heading of any level: a table is read from its own section
        only, never from the one after it.
        """
        lines = self.text(rel).splitlines()
        start = next((i for i, s in enumerate(lines) if s.startswith("#") and heading in s), None)
        if start is None:
            raise ResultsError(f"{rel}: no heading containing {heading!r}")
        tables: list[list[str]] = []
        current: list[str] = []
        for line in lines[start + 1 :]:
            if line.startswith("#"):
                break
            if line.startswith("|"):
                current.append(line)
            elif current:
                tables.append(current)
                current = []
        if current:
            tables.append(current)
        if index >= len(tables):
            raise ResultsError(f"{rel}: no table {index} under {heading!r}")
        head, _, *rows = tables[index]
        keys = _cells(head)
        return [dict(zip(keys, _cells(r), strict=True)) for r in rows]

    def measured(self, key: str) -> list[float]:
        """Every value a ``measures`` test recorded under ``key`` (validation/checks.py)."""
        values = self.json("validation/results/checks.json")["measured"].get(key)
        if not values:
            raise ResultsError(f"validation/results/checks.json: no measured {key!r}")
        return [float(v) for v in values]

    def made(self, rel: str) -> str:
        """'commit abc123456789, 2026-12-06' for the file, from its provenance (a report that
        draws on runs of several commits names each)."""
        if rel.endswith(".json"):
            data = self.json(rel)
            block = data.get("provenance") or data.get("meta", {}).get("provenance") or {}
            commit = block.get("commit")
            date = (block.get("created_utc") or data.get("date") or "")[:10]
            commits = [commit[:12]] if commit else []
        else:
            # A report names the commit of each run it draws on: all of them, the latest date.
            text = self.text(rel)
            commits = list(
                dict.fromkeys(c[:12] for c in re.findall(r"commit ([0-9a-f]{7,40})", text))
            )
            date = max(re.findall(r"20\d\d-\d\d-\d\d", text), default="")
        if not commits:
            parts = ["no commit recorded"]
        else:
            parts = [("commit " if len(commits) == 1 else "commits ") + ", ".join(commits)]
        if date:
            parts.append(date)
        return ", ".join(parts)


def _cells(line: str) -> list[str]:
    # A cell may hold an escaped pipe (\|): split only on bare ones.
    inner = line.strip().removeprefix("|").removesuffix("|")
    return [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", inner)]


def md_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> list[str]:
    """A Markdown table's lines."""
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out


def pick(rows: Iterable[Mapping[str, str]], columns: Sequence[str]) -> list[list[str]]:
    """The named columns of table rows (a missing column is an error naming it)."""
    out = []
    for row in rows:
        missing = [c for c in columns if c not in row]
        if missing:
            raise ResultsError(f"table has no column {missing[0]!r}; it has {list(row)}")
        out.append([row[c] for c in columns])
    return out


def g(v: float, digits: int = 3) -> str:
    """A number with ``digits`` significant digits, no exponent below 1e-3."""
    if v == 0:
        return "0"
    if abs(v) < 1e-3 or abs(v) >= 1e6:
        return f"{v:.{max(digits - 1, 0)}e}"
    return f"{v:.{digits}g}"


def pct(v: float, digits: int = 2) -> str:
    """A fraction as a percentage."""
    return f"{100 * v:.{digits}g} %"


def render(claims: Sequence[Claim], results: Results) -> str:
    """The whole page."""
    out = [
        "# Validation and performance",
        "",
        "<!-- Generated by validation/page.py from the results files; do not edit by hand. -->",
        "",
        "What the twin was checked against, one section per claim. Every number on this page is "
        "read from a results file (`validation/results/` for accuracy, `benchmarks/results/` for "
        "speed, `validation/results/checks.json` for what the test suite measures); each "
        "section links its files and says which commit and date made them, or that a file "
        "predates the recorded provenance (then its header gives the date and the command to "
        "run it again). What is not done yet is in [status.md](status.md).",
        "",
    ]
    for claim in claims:
        out += [f"## {claim.title}", "", claim.checked, ""]
        out += claim.body(results)
        if claim.reading:
            out += ["", claim.reading]
        links = "; ".join(
            f"[{Path(s).name if not s.endswith('report.md') else s.split('/')[-2]}]"
            f"(../{s}) ({results.made(s)})"
            for s in claim.sources
        )
        out += ["", f"Source: {links}", ""]
    return "\n".join(out).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    """Command line: write the page, or check it is current."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--check", action="store_true", help="exit 1 if the page is not current")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from page_claims import CLAIMS

    try:
        text = render(CLAIMS, Results())
    except ResultsError as exc:
        print(f"validation page: {exc}", file=sys.stderr)
        return 2
    if args.check:
        if PAGE.read_text() != text:
            print(f"{PAGE.relative_to(ROOT)} is not current: run python validation/page.py")
            return 1
        return 0
    PAGE.write_text(text)
    print(f"wrote {PAGE.relative_to(ROOT)} ({len(CLAIMS)} claims)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
