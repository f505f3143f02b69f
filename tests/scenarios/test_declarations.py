"""Each scenario field is declared once, on its schema dataclass (``twin.core.fields.declared``).

The loader takes every declared default and range from there; these tests hold it to that for
every declared field, table by table: a file that leaves the field out gets the declared default,
and a value just outside the declared range is refused with a line naming the field.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from typing import Any

import pytest

import scenarios
from scenarios import ScenarioError, parse_scenario, schema
from scenarios.reference import SECTIONS
from twin.core.fields import Range, declaration

#: Tables read into one dataclass each, as a scenario file names them ("" = the top level): the
#: field reference's own map of them.
TABLES: dict[str, type] = {"": schema.Scenario, **SECTIONS}
#: Fields a kind makes required although the dataclass has a default (the other kinds ignore them).
REQUIRED_BY_KIND = {("current", "sigma_mps"), ("current", "tau_s")}


def _base() -> dict[str, Any]:
    doc = scenarios.load("default").to_dict()
    doc["current"] = {"kind": "gauss_markov", "sigma_mps": 0.05, "tau_s": 30.0}
    return doc


def _declared_fields() -> list[tuple[str, str, Any]]:
    out = []
    for table, cls in TABLES.items():
        for f in dataclasses.fields(cls):
            if "allowed" in f.metadata:  # declared with twin.core.fields.declared
                out.append((table, f.name, declaration(cls, f.name)))
    return out


FIELDS = _declared_fields()


def _where(doc: dict[str, Any], table: str) -> dict[str, Any]:
    return doc if not table else doc.setdefault(table, {})


def test_the_tables_declare_their_fields() -> None:
    # Most of a table's fields carry their declaration (the rest are sub-tables and kinds' lists).
    assert len(FIELDS) >= 60
    assert {t for t, _, _ in FIELDS} == set(TABLES)


DEFAULTED = [
    (t, n, d)
    for t, n, d in FIELDS
    if d.default is not dataclasses.MISSING and (t, n) not in REQUIRED_BY_KIND
]


@pytest.mark.parametrize(("table", "name", "decl"), DEFAULTED, ids=lambda x: getattr(x, "name", x))
def test_a_field_left_out_gets_its_declared_default(table: str, name: str, decl: Any) -> None:
    doc = _base()
    if (table, name) == ("current", "kind"):
        doc["current"] = {}  # the kind's own keys would not be the default kind's
    _where(doc, table).pop(name, None)
    s = parse_scenario(doc, "default-less")
    got = getattr(s if not table else getattr(s, table), name)
    assert got == decl.default or (got is None and decl.default in ("", None))


def _outside(r: Range) -> list[float]:
    out = []
    if r.lo is not None and math.isfinite(r.lo):
        out.append(r.lo if r.lo_open else r.lo - max(1.0, abs(r.lo)) * 1e-3 - 1e-9)
    if r.hi is not None and math.isfinite(r.hi):
        out.append(r.hi if r.hi_open else r.hi + max(1.0, abs(r.hi)) * 1e-3 + 1e-9)
    return out


#: Fields of two numbers (``Vec2``), each in the declared range.
PAIRS = {f.name for cls in TABLES.values() for f in dataclasses.fields(cls)
         if "Vec2" in str(f.type)}  # fmt: skip
RANGED = [(t, n, d) for t, n, d in FIELDS if d.allowed is not None]


@pytest.mark.parametrize(("table", "name", "decl"), RANGED, ids=lambda x: getattr(x, "name", x))
def test_a_value_outside_the_declared_range_is_refused(table: str, name: str, decl: Any) -> None:
    for value in _outside(decl.allowed):
        doc = copy.deepcopy(_base())
        default = decl.default
        v: Any = value
        if name in PAIRS:  # a pair: the first number out of range
            v = [value, 1.0]
        elif isinstance(default, int) and not isinstance(default, bool):
            v = math.floor(value) if value < (decl.allowed.lo or 0) + 1e-9 else math.ceil(value)
            if v in decl.allowed:
                continue  # an integer range has no integer just outside this bound
        _where(doc, table)[name] = v
        with pytest.raises(ScenarioError) as err:
            parse_scenario(doc, "out")
        path = f"{table}.{name}" if table else name
        assert any(e.startswith(path) and str(decl.allowed) in e for e in err.value.errors), (
            path, v, err.value.errors)  # fmt: skip


CHOSEN = [(t, n, d) for t, n, d in FIELDS if d.choices is not None]


@pytest.mark.parametrize(("table", "name", "decl"), CHOSEN, ids=lambda x: getattr(x, "name", x))
def test_a_name_outside_the_declared_choices_is_refused(table: str, name: str, decl: Any) -> None:
    doc = _base()
    _where(doc, table)[name] = "no_such_thing"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(doc, "bad name")
    path = f"{table}.{name}" if table else name
    assert any(e.startswith(f'{path}: "no_such_thing" is not one of') for e in err.value.errors)
    assert all(f'"{c}"' in str(err.value) for c in list(decl.names())[:3])


# ---- the mission plan: the core's dataclasses (twin/core/mission.py), declared the same way ----
#: A shipped scenario of each mission kind, and the mission table's path to a leg of each kind.
MISSIONS = {
    "legs": "default",
    "lawnmower": "lawnmower_10m",
    "station_keeping": "station_keeping_10m",
    "planned": "gravity_aided",
}


def _mission_doc(kind: str) -> dict[str, Any]:
    doc = scenarios.load(MISSIONS[kind]).to_dict()
    if kind == "legs":  # a heading leg beside the waypoint legs
        doc["mission"]["legs"].append(
            {"heading_deg": 90.0, "duration_s": 30.0, "depth_m": 10.0, "speed_mps": 1.5}
        )
    return doc


def _mission_fields() -> list[tuple[str, str, str, Any]]:
    """(kind, path within the doc's mission, field, declaration) of every declared field."""
    from twin.core.mission import HeadingLeg, WaypointLeg

    out = []
    for kind in MISSIONS:
        cls = scenarios.load(MISSIONS[kind]).mission.__class__
        tables = [("", cls)]
        if kind == "legs":
            tables += [("legs[0]", WaypointLeg), ("legs[-1]", HeadingLeg)]
        for where, c in tables:
            for f in dataclasses.fields(c):
                if "allowed" in f.metadata:
                    out.append((kind, where, f.name, declaration(c, f.name)))
    return out


MISSION_FIELDS = _mission_fields()


def _mission_table(doc: dict[str, Any], where: str) -> dict[str, Any]:
    m = doc["mission"]
    return m if not where else m["legs"][0 if where == "legs[0]" else -1]


def test_every_mission_kind_and_leg_declares_its_numbers() -> None:
    kinds = {(k, w) for k, w, _, _ in MISSION_FIELDS}
    assert kinds == {*((k, "") for k in MISSIONS), ("legs", "legs[0]"), ("legs", "legs[-1]")}
    assert len(MISSION_FIELDS) >= 20


@pytest.mark.parametrize(
    ("kind", "where", "name", "decl"),
    [x for x in MISSION_FIELDS if x[3].default is not dataclasses.MISSING],
    ids=lambda x: getattr(x, "name", x),
)
def test_a_mission_field_left_out_gets_its_declared_default(
    kind: str, where: str, name: str, decl: Any
) -> None:
    doc = _mission_doc(kind)
    _mission_table(doc, where).pop(name, None)
    assert getattr(parse_scenario(doc, "default-less").mission, name) == decl.default


@pytest.mark.parametrize(
    ("kind", "where", "name", "decl"), MISSION_FIELDS, ids=lambda x: getattr(x, "name", x)
)
def test_a_mission_value_outside_the_declared_range_is_refused(
    kind: str, where: str, name: str, decl: Any
) -> None:
    tested = 0
    for value in _outside(decl.allowed):
        v: Any = value
        if isinstance(decl.default, int) or name == "lanes":
            v = math.floor(value) if value < (decl.allowed.lo or 0) + 1e-9 else math.ceil(value)
            if v in decl.allowed:
                continue
        doc = _mission_doc(kind)
        _mission_table(doc, where)[name] = v
        with pytest.raises(ScenarioError) as err:
            parse_scenario(doc, "out")
        leg = f"[{len(doc['mission']['legs']) - 1}]" if where == "legs[-1]" else "[0]"
        path = "mission." + (f"legs{leg}." if where else "") + name
        assert any(e.startswith(path) and str(decl.allowed) in e for e in err.value.errors), (
            path, v, err.value.errors)  # fmt: skip
        tested += 1
    assert tested >= 1
