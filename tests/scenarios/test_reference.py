"""The generated scenario field reference is current and says what the loader enforces."""

from __future__ import annotations

from scenarios import reference


def test_the_committed_reference_is_what_the_loader_generates() -> None:
    # Regenerate with `python -m scenarios.reference` after changing a field.
    assert reference.OUT.read_text() == reference.markdown()


def test_the_reference_lists_each_kinds_fields_with_the_loaders_ranges() -> None:
    fields = reference.collect()
    assert fields["place.latitude_deg"].expected == "a number in (-90, 90)"
    assert fields["place.latitude_deg"].default is reference.loader._MISSING
    # Fields read only for one kind of current, mission or gravity map are there too.
    for path in ("current.sigma_mps", "current.profile[].depth_m", "mission.legs[].to_m"):
        assert path in fields, path
    assert any(p.startswith("gravity.") and p != "gravity.map" for p in fields)
    page = reference.markdown()
    assert "| `water.salinity_psu` | a number in" in page and "| PSU |" in page
    assert "sun_spot" not in page  # an installed plug-in is the machine's, not the project's
