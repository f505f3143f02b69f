"""Reading a scenario's tables: typed getters that record every problem, and the messages' words.

The machinery under :mod:`scenarios.loader` (which holds the scenario's sections and rules):
:class:`Range`, the one range check of a scenario field; :class:`_Table`, whose getters read a
field, check its type and range and record a ``path: message`` line for each problem (so that
all of a file's problems are reported at once); the error texts every message is built from; and
:class:`ScenarioError`, what a bad scenario raises.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import date, datetime, time
from typing import Any, TypeVar

from scenarios.schema import Vec2
from twin.core.fields import Range as Range
from twin.core.fields import declaration

T = TypeVar("T")


_SHOW_MAX_CHARS = 60

# ---- error text --------------------------------------------------------------------------------

MSG_MISSING = "missing; required: {expected}"
MSG_WRONG_TYPE = "{value} is {type_name}; expected {expected}"
MSG_NOT_FINITE = "{value} is not a finite number; expected {expected}"
MSG_OUT_OF_RANGE = "{value} is out of range; allowed: {allowed}"
MSG_NOT_A_CHOICE = "{value} is not one of {choices}"
MSG_BAD_NAME = "{value} is not a valid name; use lowercase letters, digits and '_' ([a-z0-9_]+)"
MSG_UNKNOWN_KEY = "unknown key; allowed keys{where}: {allowed}"
MSG_NOT_FOR_KIND = "not used {context}; its keys: {allowed}"


class ScenarioError(ValueError):
    """A scenario that cannot be run: every problem found, one per line.

    Attributes:
        errors: One message per problem, each starting with the field's dotted path.
        source: The file (or the name given to :func:`parse_scenario`).
    """

    def __init__(self, errors: Sequence[str], source: str = "<scenario>"):
        self.errors: list[str] = list(errors)
        self.source = source
        if len(self.errors) == 1:
            text = f"{source}: {self.errors[0]}"
        else:
            lines = "\n".join(f"  {e}" for e in self.errors)
            text = f"{source}: {len(self.errors)} problems:\n{lines}"
        super().__init__(text)

    def __reduce__(self) -> tuple[Any, ...]:
        # Pickle by the constructor's arguments (the default would pass the formatted text as
        # ``errors``): the error must cross process boundaries intact in Monte Carlo campaigns.
        return (type(self), (self.errors, self.source))


# ---- showing values in messages ----------------------------------------------------------------


def _show(value: Any) -> str:
    """A value as the user wrote it (TOML spelling), shortened."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    elif isinstance(value, float):
        text = "nan" if math.isnan(value) else ("inf" if value == math.inf else repr(value))
        text = "-inf" if value == -math.inf else text
    elif isinstance(value, datetime | date | time):
        text = value.isoformat()
    elif isinstance(value, list | tuple):
        text = "[" + ", ".join(_show(v) for v in value) + "]"
    elif isinstance(value, Mapping):
        text = "{" + ", ".join(f"{k} = {_show(v)}" for k, v in value.items()) + "}"
    else:
        text = repr(value)
    return text if len(text) <= _SHOW_MAX_CHARS else text[: _SHOW_MAX_CHARS - 3] + "..."


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a float"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, datetime):
        return "a datetime"
    if isinstance(value, date):
        return "a date"
    if isinstance(value, time):
        return "a time"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, Mapping):
        return "a table"
    return f"a {type(value).__name__}"


def _choices(options: Iterable[str]) -> str:
    return ", ".join(_show(o) for o in options)


# ---- the checker -------------------------------------------------------------------------------

_MISSING: Any = object()  # required: no default
#: A getter's default when not given: the field's declared default (twin.core.fields).
_DECLARED: Any = object()


class _Report:
    """Collects problems as ``path: message`` lines, and the facts the cross-field rules need.

    Facts are recorded field by field as each passes its own checks, so a bad value in one field
    of a table does not hide a cross-field problem in another (a bad ``initial.position_m`` does
    not keep ``initial.depth_m = 10`` in the tank from being reported).
    """

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.depths: list[_Depth] = []  # every commanded depth
        self.points: list[_Point] = []  # every horizontal position the vehicle is sent to
        self.seabed_m: float | None = None

    def depth(self, path: str, depth_m: float | None) -> None:
        """Record a commanded depth that passed its own checks (None: it did not)."""
        if depth_m is not None:
            self.depths.append(_Depth(path, depth_m))

    def point(self, path: str, what: str, en_m: Vec2 | None) -> None:
        """Record a commanded (East, North) position that passed its own checks."""
        if en_m is not None:
            self.points.append(_Point(path, what, en_m))

    def add(self, path: str, message: str) -> None:
        self.lines.append(f"{path}: {message}" if path else message)


def _expected(noun: str, allowed: Range) -> str:
    """'a number in [0, 360)', 'a number > 0', 'a number'."""
    if allowed.lo is None and allowed.hi is None:
        return noun
    if allowed.lo is not None and allowed.hi is not None:
        return f"{noun} in {allowed}"
    return f"{noun} {allowed}"


def _number(errs: _Report, path: str, value: Any, allowed: Range) -> float | None:
    expected = _expected("a number", allowed)
    if isinstance(value, bool) or not isinstance(value, int | float):
        errs.add(
            path,
            MSG_WRONG_TYPE.format(
                value=_show(value), type_name=_type_name(value), expected=expected
            ),
        )
        return None
    x = float(value)
    if not math.isfinite(x):
        errs.add(path, MSG_NOT_FINITE.format(value=_show(value), expected=expected))
        return None
    if x not in allowed:
        errs.add(path, MSG_OUT_OF_RANGE.format(value=_show(value), allowed=allowed))
        return None
    return x


def _integer(errs: _Report, path: str, value: Any, allowed: Range) -> int | None:
    expected = _expected("an integer", allowed)
    # TOML keeps 3 and 3.0 apart; an integer field given 3.0 is almost always a typo elsewhere.
    if isinstance(value, bool) or not isinstance(value, int):
        errs.add(
            path,
            MSG_WRONG_TYPE.format(
                value=_show(value), type_name=_type_name(value), expected=expected
            ),
        )
        return None
    if value not in allowed:
        errs.add(path, MSG_OUT_OF_RANGE.format(value=_show(value), allowed=allowed))
        return None
    return value


def _vec2(errs: _Report, path: str, value: Any) -> Vec2 | None:
    expected = "[East, North] in metres, two finite numbers"
    if not isinstance(value, list) or len(value) != 2:
        if isinstance(value, list):
            n = len(value)
            errs.add(
                path, f"{_show(value)} has {n} element{'' if n == 1 else 's'}; expected {expected}"
            )
        else:
            errs.add(
                path,
                MSG_WRONG_TYPE.format(
                    value=_show(value), type_name=_type_name(value), expected=expected
                ),
            )
        return None
    e = _number(errs, f"{path}[0]", value[0], Range())
    n = _number(errs, f"{path}[1]", value[1], Range())
    return None if e is None or n is None else (e, n)


class _Table:
    """One TOML table being read: typed getters that record problems and the keys they know."""

    def __init__(
        self, report: _Report, path: str, data: Mapping[str, Any], schema: type | None = None
    ):
        self.report = report
        self.path = path
        self.data = data
        self.known: list[str] = []
        # The dataclass this table is read into: its fields' declarations give the getters their
        # defaults, ranges and choices (twin.core.fields), so the loader writes none of them.
        self.schema = schema

    def of(self, schema: type) -> _Table:
        """This table, read into ``schema``'s fields (their declared defaults and ranges)."""
        self.schema = schema
        return self

    def _declared(
        self, key: str, allowed: Any, default: Any, choices: Any = None
    ) -> tuple[Any, Any, Any]:
        """(allowed, default, choices): what the getter was given, else the field's declaration.

        A default not given is the declared one; a field declared without one is required.
        """
        d = declaration(self.schema, key) if self.schema is not None else None
        if allowed is None and d is not None:
            allowed = d.allowed
        if choices is None and d is not None:
            choices = d.names()
        if default is _DECLARED:
            default = _MISSING if d is None or d.default is dataclasses.MISSING else d.default
        return allowed, default, choices

    def at(self, key: str) -> str:
        """Dotted path of a key in this table."""
        return f"{self.path}.{key}" if self.path else key

    def _raw(self, key: str, default: Any, expected: str) -> Any:
        """The raw value, the default, or _MISSING (after reporting it) when required."""
        self.known.append(key)
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            self.report.add(self.at(key), MSG_MISSING.format(expected=expected))
        return _MISSING if default is _MISSING else _Default(default)

    def number(self, key: str, allowed: Range | None = None, default: Any = _DECLARED) -> Any:
        allowed, default, _ = self._declared(key, allowed, default)
        if allowed is None:
            raise TypeError(f"{self.at(key)}: no range given or declared")
        raw = self._raw(key, default, _expected("a number", allowed))
        if raw is _MISSING or isinstance(raw, _Default):
            return None if raw is _MISSING else raw.value
        return _number(self.report, self.at(key), raw, allowed)

    def integer(self, key: str, allowed: Range | None = None, default: Any = _DECLARED) -> Any:
        allowed, default, _ = self._declared(key, allowed, default)
        if allowed is None:
            raise TypeError(f"{self.at(key)}: no range given or declared")
        raw = self._raw(key, default, _expected("an integer", allowed))
        if raw is _MISSING or isinstance(raw, _Default):
            return None if raw is _MISSING else raw.value
        return _integer(self.report, self.at(key), raw, allowed)

    def string(
        self,
        key: str,
        *,
        choices: Sequence[str] | None = None,
        non_empty: bool = False,
        default: Any = _DECLARED,
        expected: str = "",
    ) -> Any:
        _, default, choices = self._declared(key, None, default, choices)
        expected = expected or (f"one of {_choices(choices)}" if choices else "a string")
        raw = self._raw(key, default, expected)
        if raw is _MISSING or isinstance(raw, _Default):
            return None if raw is _MISSING else raw.value
        if not isinstance(raw, str):
            self.report.add(
                self.at(key),
                MSG_WRONG_TYPE.format(
                    value=_show(raw), type_name=_type_name(raw), expected=expected
                ),
            )
            return None
        if choices is not None and raw not in choices:
            self.report.add(
                self.at(key), MSG_NOT_A_CHOICE.format(value=_show(raw), choices=_choices(choices))
            )
            return None
        if non_empty and not raw.strip():
            self.report.add(self.at(key), f"{_show(raw)} is empty; expected a non-empty string")
            return None
        return raw

    def boolean(self, key: str, default: Any = _DECLARED) -> Any:
        _, default, _ = self._declared(key, None, default)
        raw = self._raw(key, default, "true or false")
        if raw is _MISSING or isinstance(raw, _Default):
            return None if raw is _MISSING else raw.value
        if not isinstance(raw, bool):
            self.report.add(
                self.at(key),
                MSG_WRONG_TYPE.format(
                    value=_show(raw), type_name=_type_name(raw), expected="true or false"
                ),
            )
            return None
        return raw

    def vec2(self, key: str, default: Any = _DECLARED) -> Any:
        _, default, _ = self._declared(key, None, default)
        raw = self._raw(key, default, "[East, North] in metres")
        if raw is _MISSING or isinstance(raw, _Default):
            return None if raw is _MISSING else raw.value
        return _vec2(self.report, self.at(key), raw)

    def pair(self, key: str, allowed: Range | None = None, default: Any = _DECLARED) -> Any:
        """Two numbers ``[a, b]``, each in ``allowed`` (None when a check failed)."""
        allowed, default, _ = self._declared(key, allowed, default)
        if allowed is None:
            raise TypeError(f"{self.at(key)}: no range given or declared")
        raw = self._raw(key, default, f"[a, b], two numbers in {allowed}")
        if raw is _MISSING or isinstance(raw, _Default):
            return None if raw is _MISSING else raw.value
        v = _vec2(self.report, self.at(key), raw)
        if v is None:
            return None
        ok = [_number(self.report, f"{self.at(key)}[{i}]", x, allowed) for i, x in enumerate(v)]
        return None if any(x is None for x in ok) else (float(v[0]), float(v[1]))

    def table(
        self, key: str, *, required: bool = False, expected: str = "a table"
    ) -> _Table | None:
        """A sub-table; an empty one when optional and absent; None when unusable."""
        raw = self._raw(key, _MISSING if required else {}, expected)
        if raw is _MISSING:
            return None
        if isinstance(raw, _Default):
            raw = raw.value
        if not isinstance(raw, Mapping):
            self.report.add(
                self.at(key),
                MSG_WRONG_TYPE.format(
                    value=_show(raw), type_name=_type_name(raw), expected=expected
                ),
            )
            return None
        return _Table(self.report, self.at(key), raw)

    def tables(self, key: str, *, min_len: int, expected: str) -> list[_Table | None] | None:
        """A required array of tables with at least ``min_len`` entries; None when unusable.

        An entry that is not a table is reported and comes back as None, so that the others are
        still checked.
        """
        raw = self._raw(key, _MISSING, expected)
        if raw is _MISSING:
            return None
        if not isinstance(raw, list):
            self.report.add(
                self.at(key),
                MSG_WRONG_TYPE.format(
                    value=_show(raw), type_name=_type_name(raw), expected=expected
                ),
            )
            return None
        if len(raw) < min_len:
            self.report.add(self.at(key), f"has {len(raw)} entries; expected {expected}")
            return None
        out: list[_Table | None] = []
        for i, item in enumerate(raw):
            path = f"{self.at(key)}[{i}]"
            if not isinstance(item, Mapping):
                self.report.add(
                    path,
                    MSG_WRONG_TYPE.format(
                        value=_show(item), type_name=_type_name(item), expected="a table"
                    ),
                )
                out.append(None)
            else:
                out.append(_Table(self.report, path, item))
        return out

    def finish(self, *, elsewhere: Iterable[str] = (), context: str = "") -> None:
        """Report keys nobody asked for.

        Keys in ``elsewhere`` belong to another variant of this table (another kind); they get a
        message saying so instead of "unknown".
        """
        other = set(elsewhere)
        allowed = ", ".join(self.known)
        for key in self.data:
            if key in self.known:
                continue
            if key in other:
                msg = MSG_NOT_FOR_KIND.format(context=context, allowed=allowed)
            else:
                where = f" in [{self.path}]" if self.path else " at the top level"
                msg = MSG_UNKNOWN_KEY.format(where=where, allowed=allowed)
            self.report.add(self.at(key), msg)


@dataclass(frozen=True, slots=True)
class _Default:
    """Marks a value that came from the schema's default rather than the file."""

    value: Any


def _all_set(*values: Any) -> bool:
    return all(v is not None for v in values)


def _build(ctor: Callable[..., T], **kwargs: Any) -> T | None:
    """Build a dataclass only from values that passed their checks."""
    return ctor(**kwargs) if _all_set(*kwargs.values()) else None


@dataclass(frozen=True, slots=True)
class _Depth:
    path: str
    depth_m: float


@dataclass(frozen=True, slots=True)
class _Point:
    path: str
    what: str
    en_m: Vec2
