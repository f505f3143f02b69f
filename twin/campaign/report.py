"""The campaign report: statistics with bootstrap confidence intervals, paired comparisons, plots.

``auv-twin campaign report DIR`` reads the campaign's rows (:mod:`twin.campaign.results`) and
writes ``DIR/report/report.md`` with PNG figures beside it:

* per group (the swept values × the filter variant): n, mean, RMSE, median and 95th percentile of
  the chosen per-run metric (default: each variant's heading RMSE), each with a 95 % bootstrap
  confidence interval (``scipy.stats.bootstrap``, percentile method, seeded: the same rows give
  the same report);
* paired comparisons between variants on the same runs (same seed, same frames): the mean paired
  difference with its bootstrap CI, and how often the first is better;
* figures: the metric against each swept parameter with CI bands per variant, the CDF per variant,
  box plots per variant.

Every number in the report is computed from the rows on disk; nothing is typed in.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

# Where a run's per-variant metrics live: a flight's filter variants, a study trial's methods.
_VARIANT_PREFIXES = ("metric.navigation.variants.", "metric.methods.")
_CONFIDENCE = 0.95
_RESAMPLES = 2000


def _rmse(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.sqrt(np.mean(np.square(x), axis=axis))


def _p95(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.percentile(x, 95, axis=axis)


STATISTICS: dict[str, Callable[..., np.ndarray]] = {
    "mean": np.mean,
    "rmse": _rmse,
    "median": np.median,
    "p95": _p95,
}


def bootstrap_ci(x: Sequence[float], statistic: Callable, seed: int = 0) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of ``statistic`` over ``x`` (NaN for n < 2)."""
    a = np.asarray(x, dtype=np.float64)
    a = a[np.isfinite(a)]
    if a.size < 2 or np.all(a == a[0]):
        v = float(statistic(a)) if a.size else math.nan
        return (v, v) if a.size else (math.nan, math.nan)
    res = stats.bootstrap(
        (a,),
        statistic,
        confidence_level=_CONFIDENCE,
        n_resamples=_RESAMPLES,
        method="percentile",
        vectorized=True,
        rng=np.random.default_rng(seed),
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def variants_of(df: pd.DataFrame, metric: str) -> list[str]:
    """Filter variants with a ``metric`` column (e.g. ``heading_rmse_deg``)."""
    return sorted(_variant_columns(df, metric))


def _variant_columns(df: pd.DataFrame, metric: str) -> dict[str, str]:
    """{variant: column} of ``metric`` under any of the variant prefixes."""
    out = {}
    for c in df.columns:
        for prefix in _VARIANT_PREFIXES:
            if c.startswith(prefix) and c.endswith("." + metric):
                out[c[len(prefix) : -len(metric) - 1]] = c
    return out


def long_table(df: pd.DataFrame, metric: str) -> pd.DataFrame:
    """One row per (run, variant): run_id, seed, the params, variant, value."""
    params = [c for c in df.columns if c.startswith("param.")]
    rows = []
    for v, col in sorted(_variant_columns(df, metric).items()):
        part = df[["run_id", "seed", *params]].copy()
        part["variant"] = v
        part["value"] = df[col].astype(float)
        rows.append(part)
    if not rows:
        return pd.DataFrame(columns=["run_id", "seed", *params, "variant", "value"])
    return pd.concat(rows, ignore_index=True)


def group_statistics(long: pd.DataFrame) -> pd.DataFrame:
    """Per (params, variant): n and every statistic with its CI."""
    params = [c for c in long.columns if c.startswith("param.")]
    keys = [*params, "variant"]
    out = []
    for key, g in long.groupby(keys, sort=True, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        x = g["value"].to_numpy(dtype=float)
        x = x[np.isfinite(x)]
        row = dict(zip(keys, key, strict=True))
        row["n"] = int(x.size)
        for i, (name, f) in enumerate(STATISTICS.items()):
            row[name] = float(f(x)) if x.size else math.nan
            row[f"{name}_lo"], row[f"{name}_hi"] = bootstrap_ci(x, f, seed=i)
        # The largest value, as the MOI paper reports it; no interval (a bootstrap of a maximum
        # never exceeds the sample's own and says nothing of the population's).
        row["max"] = float(x.max()) if x.size else math.nan
        out.append(row)
    return pd.DataFrame(out)


def paired_comparisons(long: pd.DataFrame) -> pd.DataFrame:
    """Per (params, variant pair): the mean paired difference a − b over the same runs, its CI."""
    params = [c for c in long.columns if c.startswith("param.")]
    wide = long.pivot_table(index=["run_id", *params], columns="variant", values="value")
    wide = wide.reset_index()
    variants = [c for c in wide.columns if c not in ("run_id", *params)]
    out = []
    groups = wide.groupby(params, sort=True, dropna=False) if params else [((), wide)]
    for key, g in groups:
        key = key if isinstance(key, tuple) else (key,)
        for a, b in itertools.combinations(sorted(variants), 2):
            d = (g[a] - g[b]).to_numpy(dtype=float)
            d = d[np.isfinite(d)]
            lo, hi = bootstrap_ci(d, np.mean)
            out.append(
                {
                    **dict(zip(params, key, strict=True)),
                    "a": a,
                    "b": b,
                    "n_pairs": int(d.size),
                    "mean_diff": float(np.mean(d)) if d.size else math.nan,
                    "diff_lo": lo,
                    "diff_hi": hi,
                    "a_better_fraction": float(np.mean(d < 0)) if d.size else math.nan,
                }
            )
    return pd.DataFrame(out)


# ---- figures --------------------------------------------------------------------------------
def _numeric(col: pd.Series) -> bool:
    return all(isinstance(x, int | float | np.number) and not isinstance(x, bool) for x in col)


def _mean_ci_by(g: pd.DataFrame, by: str) -> tuple[list, list, list, list]:
    """Per value of ``by``: the mean of ``value`` and its bootstrap CI."""
    xs, means, los, his = [], [], [], []
    # Numbers in order; names (a water type) in the spec's order, which is the rows' order.
    for x, gg in g.groupby(by, sort=_numeric(g[by])):
        vals = gg["value"].to_numpy(dtype=float)
        xs.append(x)
        means.append(float(np.nanmean(vals)))
        lo, hi = bootstrap_ci(vals, np.mean)
        los.append(lo)
        his.append(hi)
    return xs, means, los, his


def _figures(long: pd.DataFrame, metric: str, folder: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written: list[Path] = []
    stem = metric.replace(".", "_")  # file names without dots but the extension's

    def save(fig, name: str) -> None:
        fig.tight_layout()
        fig.savefig(folder / name)
        plt.close(fig)
        written.append(folder / name)

    params = [c for c in long.columns if c.startswith("param.")]
    variants = sorted(long["variant"].unique())
    # Values over decades (the MOI study: 1e-6° for PATZ without noise, 1° with): a log axis.
    pos_vals = long["value"].to_numpy(dtype=float)
    pos_vals = pos_vals[np.isfinite(pos_vals)]
    log = bool(pos_vals.size and pos_vals.min() > 0 and pos_vals.max() / pos_vals.min() > 1e3)
    scale = "log" if log else "linear"
    for p in params:
        fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=110)
        for v in variants:
            xs, means, los, his = _mean_ci_by(long[long["variant"] == v], p)
            numeric = _numeric(pd.Series(xs))
            pos = np.asarray(xs, dtype=float) if numeric else np.arange(len(xs))
            (line,) = ax.plot(pos, means, marker="o", label=v)
            ax.fill_between(pos, los, his, alpha=0.2, color=line.get_color())
            if not numeric:
                labels = [str(x) for x in xs]
                long_labels = max(map(len, labels)) > 8  # timestamps: tilted, not overlapping
                ax.set_xticks(pos, labels, rotation=30 if long_labels else 0,
                              ha="right" if long_labels else "center")  # fmt: skip
        ax.set_xlabel(p.removeprefix("param."))
        ax.set_ylabel(f"{metric} (mean, 95 % CI)")
        ax.set_yscale(scale)
        ax.grid(alpha=0.3)
        ax.legend(title="variant")
        save(fig, f"{stem}_vs_{p.removeprefix('param.').replace('.', '_')}.png")
    if len(params) == 2:
        # Two swept parameters: the pooled lines above average one over the other; small
        # multiples show each, the first (numeric if one is) along x, one panel per value of
        # the other.
        x_p, panel_p = params
        if not _numeric(long[x_p]) and _numeric(long[panel_p]):
            x_p, panel_p = panel_p, x_p
        values = list(pd.unique(long[panel_p].dropna()))
        panels = sorted(values) if _numeric(pd.Series(values)) else values
        fig, axes = plt.subplots(
            1, len(panels), figsize=(3.2 * len(panels) + 0.8, 3.6), dpi=110, sharey=True,
            squeeze=False,
        )  # fmt: skip
        for ax, pv in zip(axes[0], panels, strict=True):
            sub = long[long[panel_p] == pv]
            for v in variants:
                xs, means, los, his = _mean_ci_by(sub[sub["variant"] == v], x_p)
                pos = np.asarray(xs, dtype=float) if _numeric(pd.Series(xs)) else np.arange(len(xs))
                (line,) = ax.plot(pos, means, marker="o", label=v)
                ax.fill_between(pos, los, his, alpha=0.2, color=line.get_color())
            ax.set_title(f"{panel_p.removeprefix('param.')} = {pv}", fontsize=9)
            ax.set_xlabel(x_p.removeprefix("param."))
            ax.set_yscale(scale)
            ax.grid(alpha=0.3)
        axes[0][0].set_ylabel(f"{metric} (mean, 95 % CI)")
        axes[0][-1].legend(title="variant", fontsize=8)
        name = f"{stem}_vs_{x_p.removeprefix('param.')}_by_{panel_p.removeprefix('param.')}"
        save(fig, name.replace(".", "_") + ".png")
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=110)
    for v in variants:
        vals = np.sort(long.loc[long["variant"] == v, "value"].to_numpy(dtype=float))
        vals = vals[np.isfinite(vals)]
        ax.step(vals, np.arange(1, vals.size + 1) / max(vals.size, 1), where="post", label=v)
    ax.set_xlabel(metric)
    ax.set_xscale(scale)
    ax.set_ylabel("fraction of runs ≤ x")
    ax.grid(alpha=0.3)
    ax.legend(title="variant")
    save(fig, f"{stem}_cdf.png")
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=110)
    data = [long.loc[long["variant"] == v, "value"].dropna().to_numpy() for v in variants]
    ax.boxplot(data, tick_labels=variants)
    ax.set_yscale(scale)
    ax.set_ylabel(metric)
    ax.grid(alpha=0.3, axis="y")
    save(fig, f"{stem}_box.png")
    return written


def _md_table(df: pd.DataFrame, float_fmt: str = "{:.3f}") -> str:
    cols = list(df.columns)
    lines = ["| " + " | ".join(c.removeprefix("param.") for c in cols) + " |"]
    lines.append("|" + "---|" * len(cols))
    for _, r in df.iterrows():
        cells = []
        for c in cols:
            v = r[c]
            cells.append(float_fmt.format(v) if isinstance(v, float) else str(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_report(out: str | Path, metric: str | None = None) -> Path:
    """Write ``out/report/report.md`` and its figures from the campaign's rows; its path.

    ``metric`` None: each filter variant's ``heading_rmse_deg`` for a flight campaign, each
    method's ``error_deg`` for a study trial's (the MOI noise study).

    Raises:
        ValueError: No finished run, or no variant has ``metric``.
    """
    from twin.campaign.results import load_campaign_results

    out = Path(out)
    df = load_campaign_results(out)
    total = len(df)
    ok = df[df["status"] == "ok"] if total else df
    if ok.empty:
        raise ValueError(f"{out}: no finished run to report on ({total} rows on disk)")
    if metric is None:
        metric = "heading_rmse_deg" if _variant_columns(ok, "heading_rmse_deg") else "error_deg"
    long = long_table(ok, metric)
    if long.empty:
        have = {c.rsplit(".", 1)[-1] for c in ok.columns if c.startswith(tuple(_VARIANT_PREFIXES))}
        raise ValueError(f"--metric {metric}: no variant has it; the rows have {sorted(have)}")
    folder = out / "report"
    folder.mkdir(parents=True, exist_ok=True)
    groups = group_statistics(long)
    pairs = paired_comparisons(long)
    figures = _figures(long, metric, folder)
    groups.to_csv(folder / "groups.csv", index=False)
    pairs.to_csv(folder / "paired.csv", index=False)

    def with_ci(name: str) -> pd.Series:
        return groups.apply(
            lambda r: f"{r[name]:.4g} [{r[name + '_lo']:.4g}, {r[name + '_hi']:.4g}]", axis=1
        )

    table = groups[[c for c in groups.columns if c.startswith("param.")] + ["variant", "n"]].copy()
    for name in STATISTICS:
        table[name] = with_ci(name)
    table["max"] = groups["max"].map(lambda v: f"{v:.4g}")
    ptable = pairs.copy()
    if not ptable.empty:
        ptable["a − b"] = ptable.apply(
            lambda r: f"{r['mean_diff']:+.4g} [{r['diff_lo']:+.4g}, {r['diff_hi']:+.4g}]", axis=1
        )
        ptable = ptable[
            [c for c in ptable.columns if c.startswith("param.")]
            + ["a", "b", "n_pairs", "a − b", "a_better_fraction"]
        ]
    statuses = df["status"].value_counts().to_dict()
    md = [
        f"# Campaign report: {metric}",
        "",
        f"Rows on disk: {total} ({', '.join(f'{k} {v}' for k, v in sorted(statuses.items()))}); "
        f"the statistics use the {len(ok)} finished runs. Intervals are 95 % percentile "
        f"bootstrap ({_RESAMPLES} resamples, seeded). Generated by `auv-twin campaign report`.",
        "",
        "## Per group",
        "",
        _md_table(table),
        "",
        "## Paired comparisons (same runs: same seed, same frames)",
        "",
        _md_table(ptable) if not ptable.empty else "(one variant only)",
        "",
        "## Figures",
        "",
        *[f"![{p.stem}]({p.name})" for p in figures],
        "",
    ]
    path = folder / "report.md"
    path.write_text("\n".join(md))
    return path
