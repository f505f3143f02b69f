"""A campaign as data: a TOML spec of seeded trials swept over scenario fields.

(Or over a study trial's parameters: ``trial = "moi_noise"``, see :mod:`twin.campaign.trials`.)

    name = "depth_water"
    base = "sea_trial_10m"            # a shipped scenario or a .toml path (relative to the spec)
    combine = "grid"                  # "grid" (every combination) or "zip" (axes in lock-step)
    seeds = 20                        # a count (seeds 0..N-1) or a list of seeds
    wall_time_limit_s = 900           # per run; a run past it is recorded as "timeout"
    metrics = ["navigation.variants.*.heading_rmse_deg"]   # flattened metrics.json keys to keep
                                                           # (fnmatch patterns; default: all)
    [set]                             # fixed changes to the base, by dotted path
    duration_s = 120.0

    [[sweep]]
    path = ["initial.depth_m", "mission.legs[*].depth_m"]   # one axis may set several fields
    values = [2.0, 5.0, 10.0, 20.0]
    [[sweep]]
    path = "water.jerlov_type"
    values = ["I", "II", "1C", "3C"]
    [[sweep]]
    path = "optics.wind_speed_mps"
    range = { start = 0.0, stop = 10.0, step = 2.0 }        # stop excluded, like Python's range
    [[sweep]]
    path = "start_utc"
    random = { distribution = "uniform", low = 0, high = 3600, count = 4, unit = "s_after_base" }

Validated before anything runs, in the scenarios' error style: every error names the field, the
value and what is allowed; unknown keys are errors; all errors are reported together. Every
resolved run is parsed as a scenario (:func:`scenarios.parse_scenario`), so a swept value that
makes an invalid scenario is an error of the spec, naming the run.

A run's identity is a hash of its resolved scenario and seed (:attr:`RunSpec.run_id`): the same
spec gives the same runs, ids and numbers whatever the backend or the worker count.
"""

from __future__ import annotations

import copy
import datetime as dt
import hashlib
import itertools
import json
import math
import re
import tomllib
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import scenarios
from scenarios import ScenarioError
from scenarios.ranges import SEED_MAX
from scenarios.schema import Scenario
from sensors.polarimeter.optics.rt.grid import MODEL_VERSION as LIGHT_MODEL_VERSION
from twin.campaign.paths import parse_path
from twin.campaign.paths import set_path as set_path
from twin.campaign.results import param_value
from twin.campaign.trials import SCENARIO, StudyTrial, load_trial

COMBINE = ("grid", "zip")
DISTRIBUTIONS = ("uniform", "normal", "loguniform", "choice")
_TOP_KEYS = {
    "name", "description", "base", "combine", "seeds", "wall_time_limit_s", "metrics", "set",
    "sweep", "random_seed", "timeseries", "keep_recordings", "worst_by", "trial",
}  # fmt: skip
_NAME = re.compile(r"[a-z0-9_]{1,64}")


class CampaignError(ValueError):
    """A campaign spec that cannot run: every problem found, one per line."""

    def __init__(self, errors: Sequence[str], source: str = "<campaign>"):
        self.errors = list(errors)
        self.source = source
        if len(self.errors) == 1:
            text = f"{source}: {self.errors[0]}"
        else:
            text = f"{source}: {len(self.errors)} problems:\n" + "\n".join(
                f"  {e}" for e in self.errors
            )
        super().__init__(text)

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.errors, self.source))


@dataclass(frozen=True, slots=True)
class Axis:
    """One sweep axis: the fields it sets (dotted paths) and the values it takes."""

    paths: tuple[str, ...]
    values: tuple[Any, ...]

    @property
    def name(self) -> str:
        return self.paths[0]


@dataclass(frozen=True, slots=True)
class RunSpec:
    """One resolved run: its swept values, its seed, its scenario (as a dict) and its id.

    For a study trial ``scenario`` is ``{"trial": name, "params": the resolved parameters}``.
    """

    index: int
    params: tuple[tuple[str, Any], ...]
    seed: int
    scenario: Mapping[str, Any] = field(repr=False)

    @property
    def run_id(self) -> str:
        """Hash of the resolved scenario, the seed and the light model's version.

        Independent of backend and order. The light model's version
        (:data:`sensors.polarimeter.optics.rt.grid.MODEL_VERSION`) is in it so that resuming into a
        folder of runs made with an older light field runs them again instead of reusing them.
        """
        blob = json.dumps(
            {"scenario": self.scenario, "seed": self.seed, "light_model": LIGHT_MODEL_VERSION},
            sort_keys=True,
        )
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


@dataclass(frozen=True, slots=True)
class CampaignSpec:
    """A validated campaign."""

    name: str
    description: str
    base: Scenario | None  # None for a study trial
    combine: str
    seeds: tuple[int, ...]
    axes: tuple[Axis, ...]
    fixed: tuple[tuple[str, Any], ...]
    metrics: tuple[str, ...]
    wall_time_limit_s: float
    timeseries: tuple[str, ...]
    timeseries_rate_hz: float
    keep_recordings: int
    worst_by: str = ""
    source: str = "<campaign>"
    runs: tuple[RunSpec, ...] = field(default=(), repr=False)
    trial: str = SCENARIO  # "scenario" or a study trial (twin.campaign.trials)

    def __len__(self) -> int:
        return len(self.runs)


# ---- loading --------------------------------------------------------------------------------
def _show(v: Any) -> str:
    return json.dumps(v) if isinstance(v, str) else repr(v)


def _number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _axis_values(i: int, t: Mapping[str, Any], rng: np.random.Generator, errs: list[str]) -> list:
    where = f"sweep[{i}]"
    kinds = [k for k in ("values", "range", "random") if k in t]
    if len(kinds) != 1:
        errs.append(f"{where}: give exactly one of values, range, random (got {kinds or 'none'})")
        return []
    kind = kinds[0]
    spec = t[kind]
    if kind == "values":
        if not isinstance(spec, list) or not spec:
            errs.append(f"{where}.values: {_show(spec)}; allowed: a non-empty array")
            return []
        return list(spec)
    if kind == "range":
        if not isinstance(spec, Mapping) or set(spec) - {"start", "stop", "step"}:
            errs.append(f"{where}.range: {_show(spec)}; allowed: {{start, stop, step}}")
            return []
        a, b, s = spec.get("start"), spec.get("stop"), spec.get("step", 1)
        if not (_number(a) and _number(b) and _number(s) and s > 0 and b > a):
            errs.append(
                f"{where}.range: start {a!r}, stop {b!r}, step {s!r}; allowed: numbers with "
                "stop > start and step > 0"
            )
            return []
        n = math.ceil((b - a) / s - 1e-9)
        if n > 100_000:
            errs.append(f"{where}.range: {n} values; allowed: at most 100000")
            return []
        ints = all(isinstance(x, int) for x in (a, b, s))
        return [a + k * s if ints else round(a + k * s, 12) for k in range(n)]
    # random draws from a named distribution, from the campaign's own Generator
    if not isinstance(spec, Mapping):
        errs.append(f"{where}.random: {_show(spec)}; allowed: a table")
        return []
    dist, count = spec.get("distribution"), spec.get("count")
    if dist not in DISTRIBUTIONS:
        errs.append(f"{where}.random.distribution: {_show(dist)}; allowed: {list(DISTRIBUTIONS)}")
        return []
    if not (isinstance(count, int) and not isinstance(count, bool) and 1 <= count <= 100_000):
        errs.append(f"{where}.random.count: {count!r}; allowed: an integer in [1, 100000]")
        return []
    allowed = {
        "uniform": {"low", "high"},
        "loguniform": {"low", "high"},
        "normal": {"mean", "std"},
        "choice": {"options"},
    }[dist] | {"distribution", "count"}
    extra = sorted(set(spec) - allowed)
    if extra:
        errs.append(f"{where}.random: unknown key(s) {extra}; allowed: {sorted(allowed)}")
        return []
    if dist in ("uniform", "loguniform"):
        lo, hi = spec.get("low"), spec.get("high")
        if not (_number(lo) and _number(hi) and hi > lo and (dist == "uniform" or lo > 0)):
            errs.append(
                f"{where}.random: low {lo!r}, high {hi!r}; allowed: numbers with high > low"
                + (" > 0" if dist == "loguniform" else "")
            )
            return []
        if dist == "uniform":
            return [float(x) for x in rng.uniform(lo, hi, count)]
        return [float(x) for x in np.exp(rng.uniform(math.log(lo), math.log(hi), count))]
    if dist == "normal":
        mu, sd = spec.get("mean"), spec.get("std")
        if not (_number(mu) and _number(sd) and sd > 0):
            errs.append(f"{where}.random: mean {mu!r}, std {sd!r}; allowed: numbers, std > 0")
            return []
        return [float(x) for x in rng.normal(mu, sd, count)]
    opts = spec.get("options")
    if not isinstance(opts, list) or not opts:
        errs.append(f"{where}.random.options: {_show(opts)}; allowed: a non-empty array")
        return []
    return [opts[int(k)] for k in rng.integers(0, len(opts), count)]


def parse_campaign(data: Mapping[str, Any], source: str = "<campaign>", root: Path | None = None):
    """Validate a campaign mapping; every problem at once (:class:`CampaignError`).

    The checks run in the file's reading order (the run's settings, the time series, the trial and
    its base, ``[set]``, the sweeps), each adding its problems to one list, so that a malformed
    campaign is reported whole, in that order.
    """
    errs: list[str] = []
    if not isinstance(data, Mapping):
        raise CampaignError(["the campaign is not a table"], source)
    for k in sorted(set(data) - _TOP_KEYS):
        errs.append(f"{k}: unknown key; allowed: {sorted(_TOP_KEYS)}")
    head = _parse_settings(data, errs)
    ts_keep, ts_rate = _parse_timeseries(data, errs)
    trial_name, study, base = _parse_trial(data, errs, root)
    fixed = _parse_set(data, errs)
    axes = _parse_sweeps(data, errs, np.random.default_rng(head.random_seed), head.combine)
    if errs:
        raise CampaignError(errs, source)
    if study is not None:
        runs = _resolve_study(study, axes, head.combine, head.seeds, fixed, source)
    else:
        assert base is not None
        runs = _resolve(base, axes, head.combine, head.seeds, fixed, source)
    _check_distinct(runs, source)
    return CampaignSpec(
        name=head.name,
        description=head.description,
        base=base,
        combine=head.combine,
        seeds=head.seeds,
        axes=tuple(axes),
        fixed=tuple(fixed),
        metrics=tuple(head.metrics),
        wall_time_limit_s=float(head.limit),
        timeseries=ts_keep,
        timeseries_rate_hz=float(ts_rate),
        keep_recordings=head.keep,
        worst_by=head.worst_by,
        source=source,
        runs=runs,
        trial=str(trial_name) if study is not None else SCENARIO,
    )


@dataclass(frozen=True)
class _Settings:
    """A campaign's top-level settings as parsed (a bad value replaced by its default)."""

    name: str
    description: str
    combine: str
    seeds: tuple[int, ...]
    limit: float
    metrics: list[str]
    random_seed: int
    keep: int
    worst_by: str


def _parse_settings(data: Mapping[str, Any], errs: list[str]) -> _Settings:
    name = data.get("name")
    if not (isinstance(name, str) and _NAME.fullmatch(name)):
        errs.append(f"name: {_show(name)}; allowed: 1-64 lowercase letters, digits and '_'")
    description = data.get("description", "")
    if not isinstance(description, str):
        errs.append(f"description: {_show(description)}; allowed: a string")
    combine = data.get("combine", "grid")
    if combine not in COMBINE:
        errs.append(f"combine: {_show(combine)}; allowed: {list(COMBINE)}")
    seeds = _parse_seeds(data.get("seeds", 1), errs)
    limit = data.get("wall_time_limit_s", 3600.0)
    if not (_number(limit) and limit > 0):
        errs.append(f"wall_time_limit_s: {_show(limit)}; allowed: a number > 0 (seconds)")
    metrics = data.get("metrics", ["*"])
    if not (isinstance(metrics, list) and metrics and all(isinstance(m, str) for m in metrics)):
        errs.append(f"metrics: {_show(metrics)}; allowed: a non-empty array of key patterns")
        metrics = ["*"]
    random_seed = data.get("random_seed", 0)
    if not (
        isinstance(random_seed, int) and not isinstance(random_seed, bool) and random_seed >= 0
    ):
        errs.append(f"random_seed: {_show(random_seed)}; allowed: an integer >= 0")
        random_seed = 0
    keep = data.get("keep_recordings", 0)
    if not (isinstance(keep, int) and not isinstance(keep, bool) and keep >= 0):
        errs.append(f"keep_recordings: {_show(keep)}; allowed: an integer >= 0 (the k worst)")
        keep = 0
    worst_by = data.get("worst_by", "")
    if not isinstance(worst_by, str):
        errs.append(f"worst_by: {_show(worst_by)}; allowed: a kept metric key (dotted)")
        worst_by = ""
    # A bad name, description, combine or limit stops the parse before these are used.
    return _Settings(name, description, combine, seeds, limit, metrics, random_seed, keep, worst_by)  # type: ignore[arg-type]


def _parse_seeds(seeds_raw: Any, errs: list[str]) -> tuple[int, ...]:
    if isinstance(seeds_raw, int) and not isinstance(seeds_raw, bool) and 1 <= seeds_raw <= 1e6:
        return tuple(range(seeds_raw))
    if (
        isinstance(seeds_raw, list)
        and seeds_raw
        and all(
            isinstance(s, int) and not isinstance(s, bool) and 0 <= s <= SEED_MAX for s in seeds_raw
        )
        and len(set(seeds_raw)) == len(seeds_raw)
    ):
        return tuple(seeds_raw)
    errs.append(
        f"seeds: {_show(seeds_raw)}; allowed: a count in [1, 1000000] or a list of distinct "
        f"integers in [0, {SEED_MAX}] (2**63 - 1: a Parquet int64)"
    )
    return ()


def _parse_timeseries(data: Mapping[str, Any], errs: list[str]) -> tuple[tuple[str, ...], float]:
    ts = data.get("timeseries", {})
    ts_keep: tuple[str, ...] = ()
    ts_rate = 1.0
    if not isinstance(ts, Mapping) or set(ts) - {"keep", "rate_hz"}:
        errs.append(f"timeseries: {_show(ts)}; allowed: a table with keep, rate_hz")
        return ts_keep, ts_rate
    k = ts.get("keep", [])
    if not (isinstance(k, list) and all(x in ("heading_error_deg",) for x in k)):
        errs.append(f"timeseries.keep: {_show(k)}; allowed: a list of ['heading_error_deg']")
    else:
        ts_keep = tuple(k)
    ts_rate = ts.get("rate_hz", 1.0)
    if not (_number(ts_rate) and 0 < ts_rate <= 10):
        errs.append(f"timeseries.rate_hz: {_show(ts_rate)}; allowed: (0, 10]")
        ts_rate = 1.0
    return ts_keep, ts_rate


def _parse_trial(
    data: Mapping[str, Any], errs: list[str], root: Path | None
) -> tuple[Any, StudyTrial | None, Scenario | None]:
    """The trial's name, the study trial (None for a scenario trial) and the base scenario."""
    trial_name = data.get("trial", SCENARIO)
    study: StudyTrial | None = None
    if trial_name != SCENARIO:
        if not isinstance(trial_name, str):
            errs.append(f"trial: {_show(trial_name)}; allowed: {SCENARIO!r} or a study trial name")
        else:
            try:
                study = load_trial(trial_name)
            except ValueError as exc:
                errs.append(f"trial: {exc}")
        if "base" in data:
            errs.append(f"base: {_show(data['base'])}; allowed: none for a study trial")
        if data.get("timeseries") or data.get("keep_recordings"):
            errs.append("timeseries, keep_recordings: allowed only for scenario trials")

    # The base scenario (a study trial has none: its parameters are its own).
    base_raw = data.get("base")
    base: Scenario | None = None
    if trial_name == SCENARIO and not isinstance(base_raw, str):
        errs.append(f"base: {_show(base_raw)}; allowed: a shipped scenario name or a .toml path")
    elif trial_name == SCENARIO:
        assert isinstance(base_raw, str)
        target = base_raw
        if base_raw.endswith(".toml") and root is not None and not Path(base_raw).is_absolute():
            target = str(root / base_raw)
        try:
            base = scenarios.load(target)
        except (ScenarioError, FileNotFoundError) as exc:
            errs.append(f"base: {_show(base_raw)}: {exc}")
    return trial_name, study, base


def _parse_set(data: Mapping[str, Any], errs: list[str]) -> list[tuple[str, Any]]:
    fixed_raw = data.get("set", {})
    fixed: list[tuple[str, Any]] = []
    if not isinstance(fixed_raw, Mapping):
        errs.append(f"set: {_show(fixed_raw)}; allowed: a table of dotted path = value")
        return fixed
    for k, v in _flatten_set(fixed_raw):
        if k == "seed":
            errs.append("set.seed: the campaign's `seeds` key gives every run its seed")
            continue
        fixed.append((k, v))
    return fixed


def _parse_sweeps(
    data: Mapping[str, Any], errs: list[str], rng: np.random.Generator, combine: Any
) -> list[Axis]:
    axes: list[Axis] = []
    sweeps = data.get("sweep", [])
    if not isinstance(sweeps, list):
        errs.append(f"sweep: {_show(sweeps)}; allowed: an array of [[sweep]] tables")
        sweeps = []
    for i, t in enumerate(sweeps):
        if not isinstance(t, Mapping):
            errs.append(f"sweep[{i}]: {_show(t)}; allowed: a table")
            continue
        extra = sorted(set(t) - {"path", "values", "range", "random"})
        if extra:
            errs.append(f"sweep[{i}]: unknown key(s) {extra}; allowed: path, values, range, random")
        p = t.get("path")
        paths = [p] if isinstance(p, str) else p
        if not (isinstance(paths, list) and paths and all(isinstance(x, str) for x in paths)):
            errs.append(f"sweep[{i}].path: {_show(p)}; allowed: a dotted path or a list of them")
            continue
        bad = [x for x in paths if parse_path(x) is None]
        if bad:
            errs.append(f"sweep[{i}].path: {bad} is not a dotted path (a.b, a.b[0], a.b[*])")
            continue
        if "seed" in paths:
            errs.append(
                f'sweep[{i}].path: "seed"; allowed: any scenario field but the seed (the '
                "campaign's `seeds` key gives every run its seed)"
            )
            continue
        values = _axis_values(i, t, rng, errs)
        counts = Counter(param_value(v) for v in values)
        dup = sorted(_show(v) for v, n in counts.items() if n > 1)
        if dup and combine == "grid":  # zipped axes may repeat a value (in other pairs)
            errs.append(
                f"sweep[{i}].values: {', '.join(dup)} given more than once; allowed: distinct "
                "values (a repeated value would fly the same runs twice)"
            )
            continue
        if values:
            axes.append(Axis(tuple(paths), tuple(values)))
    if combine == "zip" and len({len(a.values) for a in axes}) > 1:
        errs.append(
            'combine: "zip" needs axes of one length; got '
            + ", ".join(f"{a.name} ({len(a.values)})" for a in axes)
        )
    return axes


def _check_distinct(runs: Sequence[RunSpec], source: str) -> None:
    """Two runs with one id would be flown once and counted twice: an error, naming them."""
    seen: dict[str, RunSpec] = {}
    for r in runs:
        first = seen.setdefault(r.run_id, r)
        if first is not r:
            a = ", ".join(f"{k} = {_show(param_value(v))}" for k, v in first.params) or "base"
            b = ", ".join(f"{k} = {_show(param_value(v))}" for k, v in r.params) or "base"
            raise CampaignError(
                [f"runs {first.index} ({a}) and {r.index} ({b}), seed {r.seed}, resolve to the "
                 "same scenario; allowed: sweep values that make different runs"],
                source,
            )  # fmt: skip


def _flatten_set(t: Mapping[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    """[set] as dotted paths: nested tables become a.b keys; quoted keys may hold dots."""
    out = []
    for k, v in t.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out += _flatten_set(v, key + ".")
        else:
            out.append((key, v))
    return out


def _combos(axes: Sequence[Axis], combine: str, n_seeds: int, source: str) -> list[tuple]:
    if not axes:
        return [()]
    if combine == "grid":
        combos = list(itertools.product(*[a.values for a in axes]))
    else:
        combos = list(zip(*[a.values for a in axes], strict=True))
    if len(combos) * n_seeds > 1_000_000:
        raise CampaignError([f"{len(combos) * n_seeds} runs; allowed: at most 1000000"], source)
    return combos


def _resolve_study(study: StudyTrial, axes, combine, seeds, fixed, source) -> tuple[RunSpec, ...]:
    """Every run of a study trial: its defaults with [set] and the swept values, checked."""
    errs: list[str] = []
    known = sorted(study.defaults)
    for path in [p for p, _ in fixed] + [p for a in axes for p in a.paths]:
        if known and path not in study.defaults:
            errs.append(f"{path}: not a parameter of trial {study.name!r}; allowed: {known}")
    if errs:
        raise CampaignError(errs, source)
    base = {**copy.deepcopy(dict(study.defaults)), **dict(fixed)}
    runs: list[RunSpec] = []
    for combo in _combos(axes, combine, len(seeds), source):
        params = [(a.name, v) for a, v in zip(axes, combo, strict=True)]
        resolved = {**base, **{p: v for a, v in zip(axes, combo, strict=True) for p in a.paths}}
        bad = study.check(resolved)
        if bad:
            where = ", ".join(f"{k} = {_show(v)}" for k, v in params) or "the [set] table"
            errs.append(f"run with {where}: " + "; ".join(bad))
            if len(errs) > 20:
                break
            continue
        config = {"trial": study.name, "params": resolved}
        for seed in seeds:
            runs.append(RunSpec(len(runs), tuple(params), seed, config))
    if errs:
        raise CampaignError(errs, source)
    return tuple(runs)


def _resolve(base, axes, combine, seeds, fixed, source) -> tuple[RunSpec, ...]:
    """Every run: the base with [set] and the swept values applied, parsed as a scenario."""
    base_dict = base.to_dict()
    errs: list[str] = []
    for path, value in fixed:
        try:
            set_path(base_dict, path, value)
        except KeyError as exc:
            errs.append(f"set.{path}: {exc.args[0]}")
    if errs:
        raise CampaignError(errs, source)
    combos = _combos(axes, combine, len(seeds), source)
    runs: list[RunSpec] = []
    checked: dict[str, dict[str, Any]] = {}
    for combo in combos:
        d = copy.deepcopy(base_dict)
        params = []
        try:
            for axis, value in zip(axes, combo, strict=True):
                for path in axis.paths:
                    set_path(d, path, _for_path(path, value, base))
                params.append((axis.name, value))
        except KeyError as exc:
            errs.append(f"sweep {axis.name}: {exc.args[0]}")
            continue
        key = json.dumps(d, sort_keys=True, default=str)
        if key not in checked:
            try:
                # Every swept value must make a valid scenario: checked here, before any run.
                checked[key] = scenarios.parse_scenario(d, source).to_dict()
            except ScenarioError as exc:
                where = ", ".join(f"{k} = {_show(v)}" for k, v in params) or "the base"
                errs.append(f"run with {where}: " + "; ".join(exc.errors))
                continue
        for seed in seeds:
            runs.append(RunSpec(len(runs), tuple(params), seed, {**checked[key], "seed": seed}))
        if len(errs) > 20:
            break
    if errs:
        raise CampaignError(errs, source)
    return tuple(runs)


def _for_path(path: str, value: Any, base: Scenario) -> Any:
    """start_utc swept as seconds after the base start is written as a timestamp."""
    if path == "start_utc" and _number(value):
        t = base.start_utc + dt.timedelta(seconds=float(value))
        return t.isoformat().replace("+00:00", "Z")
    return value


def load_campaign(path: str | Path) -> CampaignSpec:
    """Read and validate a campaign TOML file (:class:`CampaignError` on any problem)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise CampaignError([f"cannot read the file: {exc.strerror or exc}"], str(p)) from None
    except UnicodeDecodeError:
        raise CampaignError(["not UTF-8 text"], str(p)) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError([f"TOML syntax error: {exc}"], str(p)) from None
    return parse_campaign(data, str(p), p.parent)
