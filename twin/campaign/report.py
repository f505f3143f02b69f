"""The campaign report: a supplement a paper can cite, generated from the rows, never edited.

``auv-twin campaign report DIR [--metric M]`` reads the rows of the folder's experiment
(:mod:`twin.campaign.results`) and writes, in ``DIR/report/<metric>/`` (each metric its own
folder, rewritten whole, so metrics never mix):

* ``report.md`` and ``report.html`` (one self-contained page, figures embedded: a reviewer opens
  it with a double click) with the same content:

  - a header: the provenance of the code, packages, light model and machine that made the runs
    and the report (:mod:`twin.record.provenance`), the base scenario, the ``[set]`` changes, the
    sweep, the seeds, the interval method and its level;
  - warnings: small groups, compass variants that fused too few fixes, runs that did not finish,
    row files that were ignored or set aside;
  - per group (the swept values × the variant): n, mean, RMSE, median, 95th percentile with their
    intervals (:mod:`twin.campaign.stats`), and the largest value;
  - paired comparisons between variants on the same runs;
  - figures with titles, captions, labelled axes and units (:mod:`twin.campaign.figures`);

* ``groups.csv`` and ``paired.csv``: the tables' numbers at full precision;
* every figure as PNG (200 dpi) and SVG.

Labels, units and definitions come from :mod:`twin.campaign.labels`; numbers are shown to three
significant digits, an interval to its value's decimals.
"""

from __future__ import annotations

import base64
import html
import json
import math
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from twin.campaign.figures import Figure, FigureMaker
from twin.campaign.labels import describe
from twin.campaign.stats import (
    BOOTSTRAP,
    CONFIDENCE,
    RESAMPLES,
    SMALL_N,
    STATISTICS,
    VARIANT_PREFIXES,
    bootstrap_ci,
    fmt,
    fmt_ci,
    group_statistics,
    long_table,
    paired_comparisons,
    variant_columns,
)
from twin.record.provenance import describe as describe_provenance
from twin.record.provenance import provenance

__all__ = [
    "bootstrap_ci",
    "group_statistics",
    "long_table",
    "paired_comparisons",
    "write_report",
]

_STAT_LABELS = {"mean": "mean", "rmse": "RMSE", "median": "median", "p95": "95th percentile"}


# ---- the document: blocks rendered as Markdown and as HTML ------------------------------------
@dataclass
class _Doc:
    blocks: list[tuple[str, Any]] = field(default_factory=list)

    def h(self, level: int, text: str) -> None:
        self.blocks.append(("h", (level, text)))

    def p(self, text: str) -> None:
        self.blocks.append(("p", text))

    def items(self, lines: list[str]) -> None:
        self.blocks.append(("ul", lines))

    def table(self, header: list[str], rows: list[list[str]]) -> None:
        self.blocks.append(("table", (header, rows)))

    def figure(self, fig: Figure, number: int) -> None:
        self.blocks.append(("figure", (fig, number)))

    def markdown(self) -> str:
        out: list[str] = []
        for kind, x in self.blocks:
            if kind == "h":
                out += ["#" * x[0] + " " + x[1], ""]
            elif kind == "p":
                out += [x, ""]
            elif kind == "ul":
                out += [f"- {line}" for line in x] + [""]
            elif kind == "table":
                header, rows = x
                out.append("| " + " | ".join(header) + " |")
                out.append("|" + "---|" * len(header))
                out += ["| " + " | ".join(r) + " |" for r in rows]
                out.append("")
            else:
                fig, n = x
                out += [
                    f"![{fig.title}]({fig.png.name})",
                    "",
                    f"*Figure {n}. {fig.title}.* {fig.caption} "
                    f"Vector version: [{fig.svg.name}]({fig.svg.name}).",
                    "",
                ]
        return "\n".join(out)

    def html(self, title: str) -> str:
        e = html.escape
        body: list[str] = []
        for kind, x in self.blocks:
            if kind == "h":
                body.append(f"<h{x[0]}>{_inline(x[1])}</h{x[0]}>")
            elif kind == "p":
                body.append(f"<p>{_inline(x)}</p>")
            elif kind == "ul":
                body.append("<ul>" + "".join(f"<li>{_inline(li)}</li>" for li in x) + "</ul>")
            elif kind == "table":
                header, rows = x
                head = "".join(f"<th>{_inline(h)}</th>" for h in header)
                trs = "".join(
                    "<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>" for r in rows
                )
                body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{trs}</tbody></table>")
            else:
                fig, n = x
                data = base64.b64encode(fig.png.read_bytes()).decode()
                body.append(
                    f'<figure><img src="data:image/png;base64,{data}" alt="{e(fig.title)}">'
                    f"<figcaption><b>Figure {n}. {e(fig.title)}.</b> {_inline(fig.caption)} "
                    f'<a href="{e(fig.svg.name)}">Vector version (SVG)</a>.</figcaption></figure>'
                )
        return (
            '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>{e(title)}</title><style>{_CSS}</style></head><body>\n"
            + "\n".join(body)
            + "\n</body></html>\n"
        )


_CSS = (
    "body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;"
    "line-height:1.45;color:#222}table{border-collapse:collapse;margin:1em 0;font-size:.9em}"
    "th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right}th{background:#f3f3f3}"
    "td:first-child,th:first-child{text-align:left}figure{margin:1.5em 0}"
    "img{max-width:100%;height:auto;border:1px solid #eee}figcaption{font-size:.9em;color:#444}"
    "code{background:#f5f5f5;padding:0 .2em}"
)


def _inline(text: str) -> str:
    """Markdown's inline code and bold as HTML; everything else escaped."""
    parts = html.escape(text).split("`")
    out = "".join(f"<code>{p}</code>" if i % 2 else p for i, p in enumerate(parts))
    bold = out.split("**")
    return "".join(f"<b>{p}</b>" if i % 2 else p for i, p in enumerate(bold))


# ---- the report ---------------------------------------------------------------------------------
def write_report(
    out: str | Path, metric: str | None = None, *, say: Callable[[str], None] | None = None
) -> Path:
    """Write ``out/report/<metric>/report.md`` (and .html, CSVs, figures); its path.

    ``metric`` None: each filter variant's ``heading_rmse_deg`` for a flight campaign, each
    method's ``error_deg`` for a study trial's (the MOI noise study).

    Raises:
        ValueError: No finished run, or no variant has ``metric``.
    """
    from twin.campaign.results import load_campaign_results

    out = Path(out)
    df = load_campaign_results(out, say=say)
    total = len(df)
    ok = df[df["status"] == "ok"] if total else df
    if ok.empty:
        extra = "; " + _left_out(df) if df.attrs.get("ignored") or df.attrs.get("corrupt") else ""
        raise ValueError(f"{out}: no finished run to report on ({total} rows on disk{extra})")
    if metric is None:
        metric = next(
            (m for m in ("heading_rmse_deg", "error_deg") if variant_columns(ok, m)), None
        )
        if metric is None:
            raise ValueError(f"{out}: the runs have no heading_rmse_deg or error_deg; {_have(ok)}")
    long = long_table(ok, metric)
    if long.empty:
        raise ValueError(f"--metric {metric}: no variant or run has it; {_have(ok)}")
    folder = out / "report" / metric
    if folder.exists():
        shutil.rmtree(folder)  # this metric's earlier report, figures included
    folder.mkdir(parents=True)
    groups = group_statistics(long)
    pairs = paired_comparisons(long)
    figures = FigureMaker(long, metric, folder).all()
    groups.to_csv(folder / "groups.csv", index=False)
    pairs.to_csv(folder / "paired.csv", index=False)

    record = df.attrs.get("record") or {}
    q = describe(metric)
    doc = _Doc()
    name = record.get("name", out.name)
    title = f"Campaign report: {name}, {q.label}"
    doc.h(1, title)
    doc.p(
        f"**{q.axis_label}**: {q.definition}. Metric key `{metric}` per variant "
        f"({', '.join(f'`{v}`' for v in pd.unique(long['variant']))}). Generated by "
        "`auv-twin campaign report` from the rows on disk; nothing in it is typed in."
    )
    _header(doc, record, df, ok)
    _warnings(doc, df, ok, groups)
    doc.h(2, "Per group")
    _group_table(doc, groups)
    doc.h(2, "Paired comparisons (same runs: same seed, same frames)")
    _paired_table(doc, pairs)
    doc.h(2, "Figures")
    for i, fig in enumerate(figures, 1):
        doc.figure(fig, i)
    path = folder / "report.md"
    path.write_text(doc.markdown())
    (folder / "report.html").write_text(doc.html(title))
    return path


def _have(ok: pd.DataFrame) -> str:
    per_variant = sorted(
        {c.rsplit(".", 1)[-1] for c in ok.columns if c.startswith(VARIANT_PREFIXES)}
    )
    per_run = sorted(
        c.removeprefix("metric.")
        for c in ok.columns
        if c.startswith("metric.") and not c.startswith(VARIANT_PREFIXES)
    )
    return f"choose --metric from the variants' {per_variant[:20]} or the runs' {per_run[:20]}"


def _left_out(df: pd.DataFrame) -> str:
    parts = []
    if df.attrs.get("ignored"):
        parts.append(f"{df.attrs['ignored']} row files of other experiments ignored")
    if df.attrs.get("corrupt"):
        parts.append(f"unreadable row files set aside: {', '.join(df.attrs['corrupt'])}")
    return "; ".join(parts)


def _header(doc: _Doc, record: Mapping[str, Any], df: pd.DataFrame, ok: pd.DataFrame) -> None:
    doc.h(2, "Provenance")
    mine = provenance(fingerprint=record.get("fingerprint"))
    lines = ["This report: " + "; ".join(describe_provenance(mine))]
    camp = record.get("provenance")
    if camp:
        lines.append("The campaign run: " + "; ".join(describe_provenance(camp)))
    lines += _row_provenance(df)
    doc.items(lines)
    doc.h(2, "Experiment")
    parts = record.get("parts") or {}
    if not record:
        doc.p(
            "This folder has no experiment record (made before auv-twin kept one): the spec's "
            "base, changes and sweep are not known; the rows are reported as found."
        )
    else:
        items = [
            f"Spec `{record.get('source')}`, fingerprint `{record.get('fingerprint')}`"
            + (f": {record['description']}" if record.get("description") else ""),
        ]
        if parts.get("trial") not in (None, "scenario"):
            items.append(f"Study trial `{parts['trial']}`")
        else:
            items.append(
                f"Base scenario `{parts.get('base_name')}` (content fingerprint "
                f"`{parts.get('base')}`)"
            )
        fixed = parts.get("set") or {}
        items.append(
            "Fixed changes (`[set]`): "
            + (
                ", ".join(f"`{k}` = {json.dumps(v, default=str)}" for k, v in fixed.items())
                if fixed
                else "none"
            )
        )
        axes = parts.get("axes") or {}
        for paths, values in axes.items():
            qd = describe(paths.split("; ")[0])
            vals = ", ".join(_cell(v) for v in values)
            items.append(f"Swept {qd.axis_label} (`{paths}`): {vals}")
        if len(axes) > 1:
            items.append(f"Axes combined as a {parts.get('combine')}")
        seeds = parts.get("seeds") or []
        items.append(f"Seeds: {_seeds_text(seeds)}")
        items.append(
            f"Kept metrics: {', '.join(f'`{m}`' for m in parts.get('metrics', []))}; light "
            f"model version {parts.get('light_model')}"
        )
        hist = record.get("history") or []
        if len(hist) > 1:
            items.append(
                f"The folder grew {len(hist) - 1} time(s): "
                + " → ".join(f"{h['runs']} runs ({h['created_utc']})" for h in hist)
            )
        doc.items(items)
    statuses = df["status"].value_counts().to_dict()
    doc.h(2, "Statistics")
    doc.items(
        [
            f"Rows of this experiment on disk: {len(df)} "
            f"({', '.join(f'{k} {v}' for k, v in sorted(statuses.items()))}); the statistics use "
            f"the {len(ok)} finished runs.",
            f"Intervals: {100 * CONFIDENCE:g} %. Groups of at least {SMALL_N} runs: "
            f"{BOOTSTRAP} ({RESAMPLES} resamples, seeded) of each statistic. Smaller groups: "
            "Student t for the mean, the order-statistic (binomial) interval for the median "
            "from 6 runs on, no interval for the RMSE and the 95th percentile.",
            "Paired comparisons: the mean of the per-run differences a − b over the same runs "
            "(same seed, same frames), with the same interval rule; 'a better' is the fraction "
            "of runs where a's value is lower.",
        ]
    )


def _seeds_text(seeds: list[int]) -> str:
    if not seeds:
        return "none"
    if seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{len(seeds)} ({seeds[0]}–{seeds[-1]})"
    return f"{len(seeds)} ({', '.join(map(str, seeds[:10]))}{', …' if len(seeds) > 10 else ''})"


def _row_provenance(df: pd.DataFrame) -> list[str]:
    """What the rows' own metadata say: the commits and package sets that made them."""
    seen: dict[str, int] = df.attrs.get("made_by") or {}
    if len(seen) == 1:
        return [f"Every run was made by {next(iter(seen))}."]
    return [
        f"**The runs were made by {len(seen)} different code or package versions:**",
        *[f"{n} runs: {k}" for k, n in seen.items()],
    ]


def _warnings(doc: _Doc, df: pd.DataFrame, ok: pd.DataFrame, groups: pd.DataFrame) -> None:
    lines = []
    small = groups[groups["n"] < SMALL_N]
    if len(small):
        lines.append(
            f"{len(small)} of {len(groups)} groups have fewer than {SMALL_N} runs (smallest "
            f"n = {int(small['n'].min())}): their intervals use the small-sample methods "
            "above, and their RMSE and 95th percentile have none. Add seeds for intervals of "
            "every statistic."
        )
    if "warnings" in ok.columns:
        warned = ok[ok["warnings"].fillna("").astype(str) != ""]
        counts: dict[tuple[str, str], int] = {}
        example: dict[tuple[str, str], str] = {}
        for text in warned["warnings"]:
            for w in str(text).split(" | "):
                # The same warning in many runs, with the run's own numbers: counted once.
                kind = "no compass fix" if "gave no fix" in w else "too few fixes fused"
                key = (w.split(":", 1)[0], kind)
                counts[key] = counts.get(key, 0) + 1
                example.setdefault(key, w)
        for key, n in sorted(counts.items(), key=lambda kv: -kv[1]):
            lines.append(f"**{key[0]}: {key[1]} in {n} of {len(ok)} runs**, e.g. {example[key]}")
    bad = df[df["status"] != "ok"]
    if len(bad):
        lines.append(
            f"{len(bad)} runs did not finish and are left out: "
            + ", ".join(f"{k} {v}" for k, v in bad["status"].value_counts().items())
            + f" (first error: {str(bad['error'].iloc[0])[:200]})"
        )
    left = _left_out(df)
    if left:
        lines.append(left[0].upper() + left[1:] + ".")
    if lines:
        doc.h(2, "Warnings")
        doc.items(lines)


def _param_header(c: str) -> str:
    return describe(c).axis_label


def _cell(v: Any) -> str:
    """A swept value as the spec wrote it (5.0 as 5, 12.5 as 12.5)."""
    if isinstance(v, float) and math.isfinite(v):
        return f"{v:g}"
    if isinstance(v, bool):
        return str(v)
    return str(v) if not (isinstance(v, float) and math.isnan(v)) else "—"


def _group_table(doc: _Doc, groups: pd.DataFrame) -> None:
    params = [c for c in groups.columns if c.startswith("param.")]
    methods = set(groups["ci_method"])
    uniform = len(methods) == 1
    doc.p(
        "Each statistic over the runs of a group, with its 95 % interval; "
        + (f"interval method: {next(iter(methods))}." if uniform else "the interval method is "
           "given per group (small groups differ).")
    )  # fmt: skip
    header = [_param_header(p) for p in params] + ["variant", "n"]
    header += [f"{_STAT_LABELS[s]} [95 % CI]" for s in STATISTICS] + ["max"]
    if not uniform:
        header.append("interval method")
    rows = []
    for _, r in groups.iterrows():
        cells = [_cell(r[p]) for p in params] + [str(r["variant"]), str(int(r["n"]))]
        cells += [fmt_ci(r[s], r[f"{s}_lo"], r[f"{s}_hi"]) for s in STATISTICS]
        cells.append(fmt(r["max"]))
        if not uniform:
            cells.append(str(r["ci_method"]))
        rows.append(cells)
    doc.table(header, rows)


def _paired_table(doc: _Doc, pairs: pd.DataFrame) -> None:
    if pairs.empty:
        doc.p("(one variant only)")
        return
    params = [c for c in pairs.columns if c.startswith("param.")]
    header = [_param_header(p) for p in params]
    header += ["a", "b", "pairs", "mean a − b [95 % CI]", "a better", "interval method"]
    rows = []
    for _, r in pairs.iterrows():
        rows.append(
            [_cell(r[p]) for p in params]
            + [str(r["a"]), str(r["b"]), str(int(r["n_pairs"]))]
            + [fmt_ci(r["mean_diff"], r["diff_lo"], r["diff_hi"], signed=True)]
            + [f"{100 * r['a_better_fraction']:.0f} %", str(r["ci_method"])]
        )
    doc.table(header, rows)
