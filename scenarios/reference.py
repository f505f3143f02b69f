"""The scenario field reference, generated from the loader itself: ``docs/scenario-reference.md``.

Every field a scenario file may hold, as :func:`scenarios.loader.parse_scenario` reads it: its
dotted path, what it accepts (type, range or choices: the loader's own words, the ones its error
messages use), its default (or that it is required), its unit (from the name's suffix) and, where
the schema's dataclass documents it, what it means. The loader is run on every shipped scenario
and on variants that select each kind of current, mission and gravity map, with its field getter
watched; nothing is typed twice, so the reference cannot drift from what ``validate`` enforces
(``tests/scenarios/test_reference.py`` checks the committed file is current).

    python -m scenarios.reference   # docs/scenario-reference.md, scenarios/scenario.schema.json

The same reads give a JSON Schema for editors (:func:`json_schema`): a TOML language server
(Taplo, Even Better TOML) that reads it completes and checks a scenario file as it is typed.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import re
import sys
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import scenarios
from scenarios import loader, reading, schema
from twin.core.extensions import COMPASS_METHODS, WATER_BODIES

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "scenario-reference.md"

#: Units from a field name's suffix (the project's naming rule: a unit in every name).
UNITS: tuple[tuple[str, str], ...] = (
    ("_kg_m3", "kg/m³"),
    ("_per_m", "m⁻¹"),
    ("_mps", "m/s"),
    ("_rad_s", "rad/s"),
    ("_deg", "°"),
    ("_rad", "rad"),
    ("_hz", "Hz"),
    ("_ms", "ms"),
    ("_us", "µs"),
    ("_px", "px"),
    ("_psu", "PSU"),
    ("_mgal", "mGal"),
    ("_m", "m"),
    ("_s", "s"),
    ("_c", "°C"),
)

#: The schema's dataclass behind each top-level table (for the fields' descriptions).
SECTIONS: Mapping[str, type] = {
    "place": schema.Place,
    "water": schema.Water,
    "current": schema.Current,
    "initial": schema.Initial,
    "sensors": schema.Sensors,
    "optics": schema.Optics,
    "gravity": schema.Gravity,
    "hardware": schema.Hardware,
    "navigation": schema.Navigation,
    "autopilot": schema.Autopilot,
    "recording": schema.Recording,
}
#: Sub-tables with their own dataclass (their fields' descriptions come from it).
SUBSECTIONS: Mapping[str, type] = {"water.iops": schema.WaterIops}


@dataclasses.dataclass
class Field:
    """One field as the loader reads it.

    ``json`` is its JSON Schema (type, bounds, choices) where a typed getter read it; empty where
    only the raw value was taken (a free-form or custom-checked field).
    """

    path: str
    expected: str
    default: Any  # reading._MISSING: required
    json: dict[str, Any] = dataclasses.field(default_factory=dict)


def _range_schema(kind: str, allowed: reading.Range) -> dict[str, Any]:
    out: dict[str, Any] = {"type": kind}
    if allowed.lo is not None:
        out["exclusiveMinimum" if allowed.lo_open else "minimum"] = allowed.lo
    if allowed.hi is not None:
        out["exclusiveMaximum" if allowed.hi_open else "maximum"] = allowed.hi
    return out


def _normalise(path: str) -> str:
    return re.sub(r"\[\d+\]", "[]", path)


def _string_schema(allowed: Any, choices: Any) -> dict[str, Any]:
    return {"type": "string", **({"enum": list(choices)} if choices else {})}


#: The loader's typed getters and the JSON Schema each one's range or choices give (what the
#: getter was passed, else the field's declaration: twin.core.fields).
_TYPED: Mapping[str, Any] = {
    "number": lambda allowed, choices: _range_schema("number", allowed),
    "integer": lambda allowed, choices: _range_schema("integer", allowed),
    "string": _string_schema,
    "boolean": lambda allowed, choices: {"type": "boolean"},
    "vec2": lambda allowed, choices: {"type": "array", "items": {"type": "number"}, "minItems": 2,
                                      "maxItems": 2},
    "pair": lambda allowed, choices: {"type": "array", "items": _range_schema("number", allowed),
                                      "minItems": 2, "maxItems": 2},
    "table": lambda allowed, choices: {"type": "object"},
    "tables": lambda allowed, choices: {"type": "array", "items": {"type": "object"}},
}  # fmt: skip
_RANGED = ("number", "integer", "pair")


@contextmanager
def _watch() -> Iterator[dict[str, Field]]:
    """Every field the loader asks for, by normalised path, while the block runs."""
    seen: dict[str, Field] = {}
    original = reading._Table._raw

    def raw(self: reading._Table, key: str, default: Any, expected: str) -> Any:
        path = _normalise(self.at(key))
        seen.setdefault(path, Field(path, expected, default))
        return original(self, key, default, expected)

    # The project's own names only: an installed plug-in's would make the page the machine's.
    saved = [(p, p._plugins, dict(p._added)) for p in (COMPASS_METHODS, WATER_BODIES)]
    for p, _, _ in saved:
        p._plugins, p._added = {}, {}
    typed = {name: getattr(reading._Table, name) for name in _TYPED}

    def wrap(name: str) -> Any:
        def getter(self: reading._Table, key: str, *args: Any, **kwargs: Any) -> Any:
            out = typed[name](self, key, *args, **kwargs)
            field = seen.get(_normalise(self.at(key)))
            if field is not None and not field.json:
                given = args[0] if args and name in _RANGED else kwargs.get("allowed")
                allowed, _, choices = self._declared(
                    key, given, reading._MISSING, kwargs.get("choices")
                )
                field.json = _TYPED[name](allowed, choices)
            return out

        return getter

    reading._Table._raw = raw  # type: ignore[method-assign]
    for name in _TYPED:
        setattr(reading._Table, name, wrap(name))
    try:
        yield seen
    finally:
        reading._Table._raw = original  # type: ignore[method-assign]
        for name, fn in typed.items():
            setattr(reading._Table, name, fn)
        for p, plugins, added in saved:
            p._plugins, p._added = plugins, added


def _variants() -> Iterator[dict[str, Any]]:
    """Scenario documents that between them select every kind the loader branches on."""
    for path in scenarios.shipped().values():
        yield scenarios.load(path).to_dict()
    base = scenarios.load("default").to_dict()
    for kind in ("none", "constant", "profile", "gauss_markov"):
        doc = copy.deepcopy(base)
        doc["current"] = {"kind": kind}
        if kind == "profile":
            doc["current"]["profile"] = [
                {"depth_m": d, "speed_mps": 0.1, "toward_deg": 0.0} for d in (0.0, 10.0)
            ]
        yield doc
    for kind in schema.MISSION_KINDS:
        doc = copy.deepcopy(base)
        doc["mission"] = {"kind": kind}
        yield doc
    for kind in schema.GRAVITY_MAPS:
        doc = copy.deepcopy(base)
        doc["gravity"] = {"map": kind}
        yield doc
    # The water named by its own IOPs instead of a type (Jerlov II's values: a valid document).
    doc = copy.deepcopy(base)
    del doc["water"]["jerlov_type"]
    doc["water"]["iops"] = {"a_per_m": 0.0529, "b_per_m": 0.185, "kd_per_m": 0.07, "source": "-"}
    yield doc


def collect() -> dict[str, Field]:
    """Every field of every kind, in the loader's reading order."""
    with _watch() as seen:
        for doc in _variants():
            try:
                loader.parse_scenario(doc, "<reference>")
            except loader.ScenarioError:
                pass  # a variant missing its kind's fields still shows them being read
    return seen


def _attribute_docs(cls: type) -> dict[str, str]:
    """``Attributes:`` entries of a Google-style class docstring, name → one-line text."""
    doc = cls.__doc__ or ""
    if "Attributes:" not in doc:
        return {}
    body = doc.split("Attributes:", 1)[1]
    out: dict[str, str] = {}
    name = None
    for line in body.splitlines():
        m = re.match(r"^\s{4,8}(\w+): (.*)$", line)
        if m and len(line) - len(line.lstrip()) <= 8:
            name = m.group(1)
            out[name] = m.group(2).strip()
        elif name and line.strip():
            out[name] += " " + line.strip()
        elif not line.strip():
            name = None
    return out


def _plain_rst(text: str) -> str:
    """The roles and literals of a reStructuredText docstring as Markdown code spans."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", text)
    return text.replace("``", "`")


def _unit(name: str) -> str:
    return next((u for suffix, u in UNITS if name.endswith(suffix)), "")


def _default(f: Field) -> str:
    if f.default is reading._MISSING:
        return "required"
    value = getattr(f.default, "value", f.default)
    if type(value) is object:  # a sentinel: the loader decides (the field's meaning says how)
        return "derived"
    if value in ("", None, [], {}):
        return "—"
    return f"`{value!r}`" if not isinstance(value, str) else f'`"{value}"`'


def _meaning(docs: Mapping[str, Mapping[str, str]], path: str) -> str:
    """A field's description: its own table's dataclass, else its top-level table's."""
    parent, _, leaf = path.replace("[]", "").rpartition(".")
    top = parent.split(".", 1)[0]
    return _plain_rst(docs.get(parent, {}).get(leaf) or docs.get(top, {}).get(leaf, ""))


def _docs() -> dict[str, dict[str, str]]:
    return {key: _attribute_docs(cls) for key, cls in {**SECTIONS, **SUBSECTIONS}.items()}


def markdown() -> str:
    """The reference page."""
    fields = collect()
    docs = _docs()
    lines = [
        "# Scenario field reference",
        "",
        "Generated by `python -m scenarios.reference` from the loader itself (never edited: a",
        "test checks it is current). Every field a scenario file may hold, with what `validate`",
        "accepts, its default and unit; `[]` marks an array of tables. Kinds select their own",
        "fields (a current's `speed_mps` is read for `constant`, not for `none`). Examples of",
        "whole tables: [scenarios.md](scenarios.md); the shipped scenarios: `scenarios/*.toml`.",
        "Compass variants are the project's own; an installed plug-in adds its name",
        "([extending.md](extending.md)).",
        "",
        "Free-form tables, not listed field by field: `sensors.*_overrides` (a preset's spec",
        "fields), `sensors.extra.<name>` (an extra sensor: `kind`, optional `preset` and `site`,",
        "its spec's fields), `navigation.methods.<name>` (a compass method's config fields),",
        "`navigation.aids.<sensor>` (`aid` and the aid's parameters;",
        "[extending.md](extending.md)).",
        "",
    ]
    groups: dict[str, list[Field]] = {}
    for path, f in fields.items():
        groups.setdefault(path.split(".", 1)[0] if "." in path or path in SECTIONS else "", [])
        groups[path.split(".", 1)[0] if "." in path or path in SECTIONS else ""].append(f)
    for top, group in groups.items():
        lines += ["", f"## `[{top}]`" if top else "## Top level", ""]
        lines += ["| field | accepts | default | unit | meaning |", "|---|---|---|---|---|"]
        for f in group:
            leaf = f.path.rsplit(".", 1)[-1]
            meaning = _meaning(docs, f.path).replace("|", "\\|")
            accepts = f.expected.replace("|", "\\|")
            lines.append(f"| `{f.path}` | {accepts} | {_default(f)} | {_unit(leaf)} | {meaning} |")
    return "\n".join(lines) + "\n"


def json_schema() -> dict[str, Any]:
    """A JSON Schema of a scenario file, for editors (TOML language servers read one).

    Types, bounds, choices, defaults and descriptions from the same reads as the reference; a
    table's unknown keys are refused (as the loader refuses them) except in the free-form
    ``*_overrides`` and ``navigation.methods`` tables. The loader stays the judge: cross-field
    rules (a seabed below the mission, a tank's walls) are its alone.
    """
    fields = collect()
    docs = _docs()
    root: dict[str, Any] = {
        # Draft 7: what TOML language servers (Taplo) read.
        "$schema": "http://json-schema.org/draft-07/schema#",
        "title": "auv-twin scenario",
        "description": "Generated by python -m scenarios.reference; see docs/scenario-reference.md",
        "type": "object",
        "properties": {},
        "additionalProperties": False,
    }
    for path, f in fields.items():
        node = root
        parts = path.split(".")
        for part in parts[:-1]:
            is_array = part.endswith("[]")
            name = part.removesuffix("[]")
            prop = node["properties"].setdefault(name, {"type": "object"})
            if is_array:
                prop.setdefault("type", "array")
                prop["type"] = "array"
                prop = prop.setdefault("items", {"type": "object"})
            prop.setdefault("properties", {})
            prop.setdefault("additionalProperties", False)
            node = prop
        leaf = parts[-1].removesuffix("[]")
        entry = node["properties"].setdefault(leaf, {})
        for key, value in (f.json or {}).items():
            if key == "type" and entry.get("type") == "array":
                continue  # an array of tables already described by its items
            entry.setdefault(key, value)
        text = _meaning(docs, path) or f.expected
        entry.setdefault("description", text)
        default = getattr(f.default, "value", f.default)
        if f.default is not reading._MISSING and type(default) is not object:
            entry.setdefault("default", default)
        if f.default is reading._MISSING and len(parts) == 1:
            root.setdefault("required", []).append(leaf)
    nav = root["properties"]["navigation"]["properties"]
    free = [nav.get("methods", {}), nav.get("aids", {})]
    free += [v for k, v in root["properties"]["sensors"]["properties"].items()
             if k.endswith("_overrides") or k == "extra"]  # fmt: skip
    for table in free:
        table.pop("additionalProperties", None)
    return root


SCHEMA_OUT = ROOT / "scenarios" / "scenario.schema.json"


def main(argv: list[str] | None = None) -> int:
    text = markdown()
    OUT.write_text(text)
    print(f"wrote {OUT.relative_to(ROOT)} ({text.count(chr(10))} lines)", file=sys.stderr)
    SCHEMA_OUT.write_text(json.dumps(json_schema(), indent=1, default=str) + "\n")
    print(f"wrote {SCHEMA_OUT.relative_to(ROOT)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
