"""A campaign's statistics: per-group summaries and paired differences with honest intervals.

Intervals are at 95 %. With at least :data:`SMALL_N` values a group's mean, RMSE, median and
95th percentile get percentile-bootstrap intervals (``scipy.stats.bootstrap``, seeded: the same
rows give the same report). Below that a percentile bootstrap of a median or a 95th percentile
is no more than the sample's own [min, max], so a small group gets methods valid there:

* the mean: Student's t interval (exact for normal values; said so);
* the median: the distribution-free order-statistic interval (the binomial bound; it exists from
  6 values on and covers at least 95 %);
* the RMSE and the 95th percentile: no interval (the values only).

Every group's row names its method (``ci_method``), and the report says which groups are small.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd
from scipy import stats

CONFIDENCE = 0.95
RESAMPLES = 2000
#: Below this many values a group gets the small-sample methods (module docstring).
SMALL_N = 10
BOOTSTRAP = "percentile bootstrap"
SMALL = "small sample"
# Where a run's per-variant metrics live: a flight's filter variants, a study trial's methods.
VARIANT_PREFIXES = ("metric.navigation.variants.", "metric.methods.")


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
        confidence_level=CONFIDENCE,
        n_resamples=RESAMPLES,
        method="percentile",
        vectorized=True,
        rng=np.random.default_rng(seed),
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def t_interval(a: np.ndarray) -> tuple[float, float]:
    """Student's t interval of the mean (NaN for n < 2)."""
    if a.size < 2:
        return (math.nan, math.nan)
    m, se = float(np.mean(a)), float(stats.sem(a))
    if se == 0:
        return (m, m)
    lo, hi = stats.t.interval(CONFIDENCE, a.size - 1, loc=m, scale=se)
    return float(lo), float(hi)


def median_interval(a: np.ndarray) -> tuple[float, float]:
    """The order-statistic interval of the median, coverage ≥ 95 % (NaN below 6 values).

    [x_(k), x_(n−k+1)] with the largest k such that P(Binomial(n, ½) < k) ≤ 2.5 %.
    """
    n = a.size
    k = int(stats.binom.ppf((1 - CONFIDENCE) / 2, n, 0.5))  # P(X <= k) >= 2.5 %
    while k >= 1 and stats.binom.cdf(k - 1, n, 0.5) > (1 - CONFIDENCE) / 2:
        k -= 1
    if k < 1:
        return (math.nan, math.nan)
    s = np.sort(a)
    return float(s[k - 1]), float(s[n - k])


def interval(a: np.ndarray, name: str, seed: int = 0) -> tuple[float, float, str]:
    """(low, high, method) of statistic ``name`` over the finite values ``a``."""
    a = a[np.isfinite(a)]
    if a.size >= SMALL_N:
        return (*bootstrap_ci(a, STATISTICS[name], seed=seed), BOOTSTRAP)
    if name == "mean":
        return (*t_interval(a), "Student t")
    if name == "median":
        lo, hi = median_interval(a)
        return lo, hi, "order statistics" if math.isfinite(lo) else "none (n < 6)"
    return (math.nan, math.nan, f"none (n < {SMALL_N})")


#: The one "variant" of a metric that is per run, not per filter variant (a study's own metric).
RUN = "run"


def variant_columns(df: pd.DataFrame, metric: str) -> dict[str, str]:
    """{variant: column} of ``metric`` under any of the variant prefixes.

    A metric that no variant has but the run does (``metric.<metric>``, e.g. a user's study
    trial's ``value``) is one series named :data:`RUN`.
    """
    out = {}
    for c in df.columns:
        for prefix in VARIANT_PREFIXES:
            if c.startswith(prefix) and c.endswith("." + metric):
                out[c[len(prefix) : -len(metric) - 1]] = c
    if not out and f"metric.{metric}" in df.columns:
        out[RUN] = f"metric.{metric}"
    return out


def long_table(df: pd.DataFrame, metric: str) -> pd.DataFrame:
    """One row per (run, variant): run_id, seed, the params, variant, value."""
    params = [c for c in df.columns if c.startswith("param.")]
    rows = []
    for v, col in sorted(variant_columns(df, metric).items()):
        part = df[["run_id", "seed", *params]].copy()
        part["variant"] = v
        part["value"] = df[col].astype(float)
        rows.append(part)
    if not rows:
        return pd.DataFrame(columns=["run_id", "seed", *params, "variant", "value"])
    return pd.concat(rows, ignore_index=True)


def group_statistics(long: pd.DataFrame) -> pd.DataFrame:
    """Per (params, variant): n, every statistic with its interval and method, and the max."""
    params = [c for c in long.columns if c.startswith("param.")]
    keys = [*params, "variant"]
    out = []
    for key, g in long.groupby(keys, sort=False, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        x = g["value"].to_numpy(dtype=float)
        x = x[np.isfinite(x)]
        row = dict(zip(keys, key, strict=True))
        row["n"] = int(x.size)
        methods = []
        for i, (name, f) in enumerate(STATISTICS.items()):
            row[name] = float(f(x)) if x.size else math.nan
            row[f"{name}_lo"], row[f"{name}_hi"], method = interval(x, name, seed=i)
            methods.append(method if method == BOOTSTRAP else f"{name}: {method}")
        row["ci_method"] = BOOTSTRAP if set(methods) == {BOOTSTRAP} else "; ".join(methods)
        # The largest value, as the MOI paper reports it; no interval (a bootstrap of a maximum
        # never exceeds the sample's own and says nothing of the population's).
        row["max"] = float(x.max()) if x.size else math.nan
        out.append(row)
    return _sorted(pd.DataFrame(out), keys)


def _sorted(df: pd.DataFrame, keys: list[str], like: pd.DataFrame | None = None) -> pd.DataFrame:
    """Numbers ascending; categories (a water type) in the spec's order.

    The spec's order is the order of first appearance in ``like`` (default ``df``).
    """
    if df.empty:
        return df
    like = df if like is None else like
    order = []
    for k in keys:
        col = df[k]
        if is_numeric(col):
            order.append(col.astype(float))
        else:
            first = {v: i for i, v in enumerate(pd.unique(like[k]))}
            order.append(col.map(first))
    idx = np.lexsort([o.to_numpy() for o in reversed(order)])
    return df.iloc[idx].reset_index(drop=True)


def paired_comparisons(long: pd.DataFrame) -> pd.DataFrame:
    """Per (params, variant pair): the mean paired difference a − b over the same runs, its CI."""
    params = [c for c in long.columns if c.startswith("param.")]
    wide = long.pivot_table(index=["run_id", *params], columns="variant", values="value")
    wide = wide.reset_index()
    variants = [c for c in wide.columns if c not in ("run_id", *params)]
    out = []
    groups = wide.groupby(params, sort=False, dropna=False) if params else [((), wide)]
    for key, g in groups:
        key = key if isinstance(key, tuple) else (key,)
        for a, b in itertools.combinations(sorted(variants), 2):
            d = (g[a] - g[b]).to_numpy(dtype=float)
            d = d[np.isfinite(d)]
            lo, hi, method = interval(d, "mean")
            out.append(
                {
                    **dict(zip(params, key, strict=True)),
                    "a": a,
                    "b": b,
                    "n_pairs": int(d.size),
                    "mean_diff": float(np.mean(d)) if d.size else math.nan,
                    "diff_lo": lo,
                    "diff_hi": hi,
                    "ci_method": method,
                    "a_better_fraction": float(np.mean(d < 0)) if d.size else math.nan,
                }
            )
    df = pd.DataFrame(out)
    return _sorted(df, params, like=long) if params and not df.empty else df


def is_numeric(col: pd.Series | Sequence) -> bool:
    """Whether every value is a number (not a bool): drawn on a numeric axis."""
    return all(isinstance(x, int | float | np.number) and not isinstance(x, bool) for x in col)


def significant(x: float, sig: int = 3) -> int:
    """The decimals that show ``x`` to ``sig`` significant digits (0 for large numbers)."""
    if not math.isfinite(x) or x == 0:
        return 0
    return max(sig - 1 - math.floor(math.log10(abs(x))), 0)


def fmt(x: float, decimals: int | None = None, sig: int = 3) -> str:
    """A number to ``sig`` significant digits (or to ``decimals``); "—" for NaN.

    E-notation only outside [1e-4, 1e6).
    """
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    if isinstance(x, bool | np.bool_):
        return str(bool(x))
    if isinstance(x, int | np.integer):
        return f"{int(x)}"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x != 0 and not 1e-4 <= abs(x) < 1e6:
        return f"{x:.{sig - 1}e}"
    d = significant(x, sig) if decimals is None else decimals
    return f"{x:.{d}f}"


def fmt_ci(v: float, lo: float, hi: float, sig: int = 3, signed: bool = False) -> str:
    """``v [lo, hi]`` with the bounds to the value's decimals (``v`` alone without bounds)."""
    d = significant(v, sig)
    if math.isfinite(lo) and math.isfinite(hi) and hi > lo:
        # The interval says how many of the value's digits mean anything: the value is shown
        # no finer than the width's third significant digit.
        d = min(d, significant(hi - lo, sig))
    s = (lambda x: ("+" if x > 0 else "") + fmt(x, d)) if signed else (lambda x: fmt(x, d))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return s(v)
    return f"{s(v)} [{s(lo)}, {s(hi)}]"
