"""The campaign report's figures: labelled, with units, n and the interval method, PNG and SVG.

Each figure is a :class:`Figure`: its files (PNG at :data:`DPI` and SVG beside it), its title and
a caption that says what the points and bars are, how many runs each holds, the interval's
method, and over which swept axes a figure pools. Numeric sweeps are lines with interval bands;
categorical sweeps (a water type) are categories: points with error bars, the variants side by
side. Labels and units come from :mod:`twin.campaign.labels`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from twin.campaign.labels import describe
from twin.campaign.stats import SMALL_N, interval, is_numeric

DPI = 200
_WIDTH = 6.4


@dataclass(frozen=True)
class Figure:
    """One figure: ``stem.png`` and ``stem.svg`` in the report's folder, with its caption."""

    png: Path
    svg: Path
    title: str
    caption: str


def _mean_ci(values: np.ndarray) -> tuple[float, float, float, str, int]:
    a = values[np.isfinite(values)]
    lo, hi, method = interval(a, "mean")
    return (float(np.mean(a)) if a.size else np.nan), lo, hi, method, int(a.size)


def _by(g: pd.DataFrame, by: str) -> list[tuple[object, np.ndarray]]:
    """Values of ``value`` per value of ``by``: numbers ascending, names in the rows' order."""
    keys = pd.unique(g[by].dropna())
    keys = sorted(keys) if is_numeric(keys) else list(keys)
    return [(k, g.loc[g[by] == k, "value"].to_numpy(dtype=float)) for k in keys]


def _n_text(ns: list[int]) -> str:
    lo, hi = (min(ns), max(ns)) if ns else (0, 0)
    return f"n = {lo}" if lo == hi else f"n = {lo}–{hi}"


def _methods_text(methods: set[str]) -> str:
    if methods == {"percentile bootstrap"}:
        return "95 % percentile-bootstrap interval of the mean"
    return "95 % interval of the mean (" + ", ".join(sorted(methods)) + ")"


class FigureMaker:
    """Draws a report's figures for one metric into ``folder``."""

    def __init__(self, long: pd.DataFrame, metric: str, folder: Path):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        self.plt = plt
        self.long = long
        self.metric = describe(metric)
        self.stem = metric.replace(".", "_")
        self.folder = folder
        self.params = [c for c in long.columns if c.startswith("param.")]
        self.variants = list(pd.unique(long["variant"]))
        vals = long["value"].to_numpy(dtype=float)
        vals = vals[np.isfinite(vals)]
        # Values over decades (the MOI study: 1e-6° for PATZ without noise, 1° with): a log axis.
        log = bool(vals.size and vals.min() > 0 and vals.max() / vals.min() > 1e3)
        self.scale = "log" if log else "linear"
        self.figures: list[Figure] = []

    def all(self) -> list[Figure]:
        for p in self.params:
            self.versus(p)
        if len(self.params) == 2:
            self.small_multiples(*self.params)
        self.cdf()
        self.box()
        return self.figures

    # ---- one figure each ----------------------------------------------------------------------
    def _save(self, fig, name: str, title: str, caption: str, note: str = "") -> None:
        """Title on top, the note (n, interval, pooling) in small print under the axes."""
        fig.suptitle(title, fontsize=11)
        if note:
            fig.text(0.01, 0.01, note, fontsize=7, color="#444", va="bottom", wrap=True)
        fig.tight_layout(rect=(0, 0.05 if note else 0, 1, 1))
        png, svg = self.folder / f"{name}.png", self.folder / f"{name}.svg"
        # No date in the files and fixed SVG ids: the same rows give the same figure files.
        fig.savefig(png, dpi=DPI, metadata={"Software": None})
        with self.plt.rc_context({"svg.hashsalt": "auv-twin"}):
            fig.savefig(svg, metadata={"Date": None})
        self.plt.close(fig)
        self.figures.append(Figure(png, svg, title, caption))

    def _pooled_short(self, shown: list[str]) -> str:
        others = [describe(p).label for p in self.params if p not in shown]
        return f"; pooled over {', '.join(others)}" if others else ""

    def _pooled(self, shown: list[str]) -> str:
        others = [describe(p).label for p in self.params if p not in shown]
        if not others:
            return ""
        return (
            " Pooled over " + ", ".join(others) + ": each point holds the runs of every value "
            "of " + ("that axis" if len(others) == 1 else "those axes") + "."
        )

    def _draw(self, ax, sub: pd.DataFrame, p: str) -> tuple[list[int], set[str]]:
        """The metric's mean and interval against ``p``, one series per variant."""
        ns: list[int] = []
        methods: set[str] = set()
        numeric = is_numeric(sub[p].dropna())
        cats = list(pd.unique(sub[p].dropna()))
        width = 0.8 / max(len(self.variants), 1)
        for j, v in enumerate(self.variants):
            pts = _by(sub[sub["variant"] == v], p)
            stats_ = [_mean_ci(vals) for _, vals in pts]
            xs = [k for k, _ in pts]
            means = np.array([s[0] for s in stats_])
            los = np.array([s[1] for s in stats_])
            his = np.array([s[2] for s in stats_])
            ns += [s[4] for s in stats_]
            methods |= {s[3] for s in stats_}
            if numeric:
                x = np.asarray(xs, dtype=float)
                (line,) = ax.plot(x, means, marker="o", label=v)
                ax.fill_between(x, los, his, alpha=0.2, color=line.get_color())
            else:
                x = (
                    np.array([cats.index(k) for k in xs])
                    + (j - (len(self.variants) - 1) / 2) * width
                )
                err = np.vstack([means - los, his - means])
                err = np.where(np.isfinite(err), err, 0.0)
                ax.errorbar(x, means, yerr=err, fmt="o", capsize=3, label=v)
        if not numeric:
            labels = [str(c) for c in cats]
            tilt = max(map(len, labels), default=0) > 8  # timestamps: tilted, not overlapping
            ax.set_xticks(range(len(cats)), labels, rotation=30 if tilt else 0,
                          ha="right" if tilt else "center")  # fmt: skip
        ax.set_yscale(self.scale)
        ax.grid(alpha=0.3)
        return ns, methods

    def versus(self, p: str) -> None:
        q = describe(p)
        fig, ax = self.plt.subplots(figsize=(_WIDTH, 4.2))
        ns, methods = self._draw(ax, self.long, p)
        ax.set_xlabel(q.axis_label)
        ax.set_ylabel(f"{self.metric.axis_label}, mean")
        ax.legend(title="variant", fontsize=8)
        title = f"{self.metric.label} vs {q.label}"
        kind = "categories" if not is_numeric(self.long[p].dropna()) else "a numeric axis"
        caption = (
            f"{self.metric.label} ({self.metric.unit or 'no unit'}) per {q.label} ({kind}) and "
            f"variant: the mean over runs ({_n_text(ns)} a point) with its "
            f"{_methods_text(methods)} as {'band' if kind != 'categories' else 'error bar'}."
            + self._pooled([p])
        )
        note = f"{_n_text(ns)} runs a point; {_methods_text(methods)}{self._pooled_short([p])}"
        self._save(fig, f"{self.stem}_vs_{_name(p)}", title, caption, note)

    def small_multiples(self, a: str, b: str) -> None:
        # The first numeric parameter along x, one panel per value of the other.
        x_p, panel_p = (a, b)
        if not is_numeric(self.long[x_p].dropna()) and is_numeric(self.long[panel_p].dropna()):
            x_p, panel_p = panel_p, x_p
        panels = [k for k, _ in _by(self.long.assign(value=0.0), panel_p)]
        fig, axes = self.plt.subplots(
            1, len(panels), figsize=(3.2 * len(panels) + 0.8, 3.8), sharey=True, squeeze=False
        )
        ns: list[int] = []
        methods: set[str] = set()
        pq_ = describe(panel_p)
        for ax, pv in zip(axes[0], panels, strict=True):
            n, m = self._draw(ax, self.long[self.long[panel_p] == pv], x_p)
            ns += n
            methods |= m
            ax.set_title(f"{pq_.label} = {pv}{' ' + pq_.unit if pq_.unit else ''}", fontsize=9)
            ax.set_xlabel(describe(x_p).axis_label)
        axes[0][0].set_ylabel(f"{self.metric.axis_label}, mean")
        axes[0][-1].legend(title="variant", fontsize=8)
        title = f"{self.metric.label} vs {describe(x_p).label}, one panel per {pq_.label}"
        caption = (
            f"As the figure against {describe(x_p).label}, without pooling: one panel per "
            f"{pq_.label}; the mean over runs ({_n_text(ns)} a point) with its "
            f"{_methods_text(methods)}."
        )
        note = f"{_n_text(ns)} runs a point; {_methods_text(methods)}"
        self._save(fig, f"{self.stem}_vs_{_name(x_p)}_by_{_name(panel_p)}", title, caption, note)

    def cdf(self) -> None:
        fig, ax = self.plt.subplots(figsize=(_WIDTH, 4.2))
        ns = []
        for v in self.variants:
            vals = np.sort(self.long.loc[self.long["variant"] == v, "value"].to_numpy(dtype=float))
            vals = vals[np.isfinite(vals)]
            ns.append(vals.size)
            ax.step(vals, np.arange(1, vals.size + 1) / max(vals.size, 1), where="post",
                    label=f"{v} (n = {vals.size})")  # fmt: skip
        ax.set_xlabel(self.metric.axis_label)
        ax.set_xscale(self.scale)
        ax.set_ylabel("fraction of runs ≤ x")
        ax.grid(alpha=0.3)
        ax.legend(title="variant", fontsize=8)
        title = f"Distribution of {self.metric.label} per variant"
        caption = (
            f"Empirical CDF of {self.metric.label} over every run of each variant "
            f"({_n_text(ns)} runs)." + self._pooled([])
        )
        note = f"every run of each variant{self._pooled_short([])}"
        self._save(fig, f"{self.stem}_cdf", title, caption, note)

    def box(self) -> None:
        fig, ax = self.plt.subplots(figsize=(_WIDTH, 4.2))
        data = [
            self.long.loc[self.long["variant"] == v, "value"].dropna().to_numpy()
            for v in self.variants
        ]
        ax.boxplot(
            data,
            tick_labels=[f"{v}\n(n = {d.size})" for v, d in zip(self.variants, data, strict=True)],
        )
        ax.set_yscale(self.scale)
        ax.set_ylabel(self.metric.axis_label)
        ax.set_xlabel("variant")
        ax.grid(alpha=0.3, axis="y")
        title = f"{self.metric.label} per variant"
        caption = (
            f"Box plot of {self.metric.label} per variant: the box spans the quartiles, the line "
            "is the median, the whiskers reach the furthest run within 1.5 interquartile ranges, "
            "points beyond are single runs." + self._pooled([])
        )
        note = f"every run of each variant{self._pooled_short([])}"
        self._save(fig, f"{self.stem}_box", title, caption, note)


def _name(p: str) -> str:
    return p.removeprefix("param.").replace(".", "_")


__all__ = ["DPI", "SMALL_N", "Figure", "FigureMaker"]
