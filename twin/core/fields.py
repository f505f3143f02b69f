"""A scenario field's one declaration: its default and what a file may give, on its dataclass.

Each field of a scenario table is declared once, on its dataclass (:mod:`scenarios.schema`, and
the mission plan's in :mod:`twin.core.mission`, the contract the vehicle flies):
its type (the annotation), its default (or none: required), the numbers it allows
(:class:`Range`) or the names it allows (a tuple, or a registry's ``names`` for names a plug-in
can add), and what it means (the class's ``Attributes:``); its unit is in its name's suffix.
The loader's getters (:class:`scenarios.reading._Table`) take the default and the range from
here, the field reference and the JSON Schema (:mod:`scenarios.reference`) from the loader's
reads: nothing is written twice.

Why not pydantic (v2): its validation would give the types and bounds, but the scenario's rules
are mostly between fields (a seabed below every leg, a tank's walls, a kind that selects its
fields, a sensor built as a run builds it) and its messages are its own; the project's promise is
one line per problem, naming the field, the value and what is allowed, all problems at once, in
its own words (docs/cli.md). Field metadata on the frozen dataclasses keeps one declaration
without a second model of every table.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

#: A field's names: a fixed tuple, or a function giving them (a registry a plug-in extends).
Choices = Sequence[str] | Callable[[], Sequence[str]]


@dataclass(frozen=True, slots=True)
class Range:
    """A closed, open or half-open interval of allowed numbers; None for no bound."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False

    def __contains__(self, x: float) -> bool:
        if self.lo is not None and (x <= self.lo if self.lo_open else x < self.lo):
            return False
        return not (self.hi is not None and (x >= self.hi if self.hi_open else x > self.hi))

    def __str__(self) -> str:
        def num(x: float) -> str:  # an int bound exactly (a seed's 2**63 - 1), a float short
            return str(x) if isinstance(x, int) else f"{x:g}"

        if self.hi is None:
            return (
                f"{'>' if self.lo_open else '>='} {num(self.lo)}" if self.lo is not None else "any"
            )
        if self.lo is None:
            return f"{'<' if self.hi_open else '<='} {num(self.hi)}"
        left, right = "(" if self.lo_open else "[", ")" if self.hi_open else "]"
        return f"{left}{num(self.lo)}, {num(self.hi)}{right}"

    def check(self, name: str, value: Any) -> None:
        """Refuse anything but a finite real number in the range (numpy scalars count).

        Raises:
            ValueError: ``"<name>: <value>; allowed <range>"``.
        """
        ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
        if not (ok and math.isfinite(float(value)) and float(value) in self):
            raise ValueError(f"{name}: {value!r}; allowed {self}")


def check_ranges(owner: str, checks: Iterable[tuple[str, Any, Range]]) -> None:
    """:meth:`Range.check` for each (field, value, range) of a configuration named ``owner``.

    The one range check of the configurations (a compass method's, a sky's, a lens's): the
    first field out of range is the error, ``"<owner>.<field>: <value>; allowed <range>"``.
    """
    for name, value, allowed in checks:
        allowed.check(f"{owner}.{name}", value)


def declared(
    default: Any = dataclasses.MISSING,
    allowed: Range | None = None,
    *,
    choices: Choices | None = None,
) -> Any:
    """A schema field with its default and what a scenario file may give for it.

    Args:
        default: The value when a file leaves the field out; none given: the field is required.
        allowed: The numbers allowed (a number field).
        choices: The names allowed (a string field), or a function that lists them.
    """
    meta = {"allowed": allowed, "choices": choices}
    if default is dataclasses.MISSING:
        return dataclasses.field(metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


@dataclass(frozen=True, slots=True)
class Declaration:
    """What a field's declaration says: its default (MISSING: required), range and choices."""

    default: Any
    allowed: Range | None
    choices: Choices | None

    def names(self) -> Sequence[str] | None:
        """The allowed names now (a registry's are read when asked)."""
        return self.choices() if callable(self.choices) else self.choices


def declaration(cls: type, name: str) -> Declaration | None:
    """The declaration of ``cls``'s field ``name``; None when the class has no such field."""
    for f in dataclasses.fields(cls):
        if f.name == name:
            return Declaration(f.default, f.metadata.get("allowed"), f.metadata.get("choices"))
    return None


# ---- ranges many fields share (a field's own range lives with its dataclass or scenarios.ranges)
NON_NEGATIVE = Range(0.0)
POSITIVE = Range(0.0, lo_open=True)
#: A compass direction in degrees.
COMPASS_DEG = Range(0.0, 360.0, hi_open=True)
#: A duration up to a day (a scenario's, a heading leg's).
DURATION_S = Range(0.0, 86400.0, lo_open=True)
