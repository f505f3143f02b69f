"""The generated scenario field reference is current and says what the loader enforces."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import jsonschema
import pytest

import scenarios
from scenarios import reference

ROOT = Path(__file__).resolve().parents[2]


def _json(value):
    # A TOML document as JSON sees it (an editor's language server converts the same way).
    if isinstance(value, dict):
        return {k: _json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_json(v) for v in value]
    return value.isoformat() if isinstance(value, dt.datetime) else value


def test_the_committed_reference_is_what_the_loader_generates() -> None:
    # Regenerate with `python -m scenarios.reference` after changing a field.
    assert reference.OUT.read_text() == reference.markdown()
    assert json.loads(reference.SCHEMA_OUT.read_text()) == json.loads(
        json.dumps(reference.json_schema(), default=str)
    )


@pytest.mark.parametrize(
    "path",
    [*scenarios.shipped().values(), ROOT / "examples/compass_plugin/sun_spot_trial.toml"],
    ids=lambda p: Path(p).stem,
)
def test_the_json_schema_accepts_every_shipped_scenario(path) -> None:
    import tomllib

    schema = json.loads(reference.SCHEMA_OUT.read_text())
    jsonschema.validate(_json(tomllib.loads(Path(path).read_text())), schema)


def test_the_json_schema_refuses_what_the_loader_refuses() -> None:
    import tomllib

    schema = json.loads(reference.SCHEMA_OUT.read_text())
    doc = _json(tomllib.loads(scenarios.shipped()["default"].read_text()))
    for bad in (
        {"place": {**doc["place"], "latitude_deg": 95.0}},  # out of range
        {"water": {**doc["water"], "jerlov_type": "XI"}},  # not a choice
        {"navigation": {**doc["navigation"], "variant": ["ins"]}},  # an unknown key
    ):
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate({**doc, **bad}, schema)


def test_the_reference_lists_each_kinds_fields_with_the_loaders_ranges() -> None:
    fields = reference.collect()
    assert fields["place.latitude_deg"].expected == "a number in (-90, 90)"
    assert fields["place.latitude_deg"].default is reference.reading._MISSING
    # Fields read only for one kind of current, mission or gravity map are there too.
    for path in ("current.sigma_mps", "current.profile[].depth_m", "mission.legs[].to_m"):
        assert path in fields, path
    assert any(p.startswith("gravity.") and p != "gravity.map" for p in fields)
    page = reference.markdown()
    assert "| `water.salinity_psu` | a number in" in page and "| PSU |" in page
    assert "sun_spot" not in page  # an installed plug-in is the machine's, not the project's
