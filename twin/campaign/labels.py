"""What a report's numbers are: one table of labels, units and definitions.

The campaign report's tables and figures and the docs' reference (docs/campaigns.md, generated
from :func:`markdown_table`) read every metric's and swept field's label, unit and one-line
definition from here; nothing else writes them. A key not in the table gets its unit from its
name's suffix (``_deg``, ``_m``, ``_mps``, ...: the project's convention of units in names) and
its dotted path as its label, so a new metric is never unlabelled, only less well described.

    python -m twin.campaign.labels      # print the docs' table
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Quantity:
    """A reported quantity.

    Attributes:
        key: The metric (per variant, e.g. ``heading_rmse_deg``) or the swept field's dotted path.
        label: A reader's name for it.
        unit: Its unit as printed ("" for a dimensionless number or a category).
        definition: One line: what it is, over what.
    """

    key: str
    label: str
    unit: str
    definition: str

    @property
    def axis_label(self) -> str:
        """``label (unit)``, or the label alone."""
        return f"{self.label} ({self.unit})" if self.unit else self.label


#: Per-variant metrics (a filter variant's, or a study method's).
METRICS: tuple[Quantity, ...] = (
    Quantity(
        "heading_rmse_deg",
        "heading RMSE",
        "°",
        "root-mean-square of the filter's heading error against truth over a run (the truth rate "
        "samples); the report's RMSE row is the root-mean-square of these over runs",
    ),
    Quantity(
        "heading_mae_deg",
        "heading MAE",
        "°",
        "mean absolute heading error of the filter against truth over a run",
    ),
    Quantity(
        "heading_max_deg",
        "largest heading error",
        "°",
        "the largest absolute heading error of the filter over a run",
    ),
    Quantity(
        "heading_final_deg",
        "final heading error",
        "°",
        "the filter's signed heading error at the end of a run (estimate − truth)",
    ),
    Quantity(
        "roll_rmse_deg",
        "roll RMSE",
        "°",
        "root-mean-square of the filter's roll error against truth over a run",
    ),
    Quantity(
        "pitch_rmse_deg",
        "pitch RMSE",
        "°",
        "root-mean-square of the filter's pitch error against truth over a run",
    ),
    Quantity(
        "position_drift_final_m",
        "final position error",
        "m",
        "horizontal distance between the filter's position and the truth at the end of a run",
    ),
    Quantity(
        "nees_attitude_mean",
        "attitude NEES",
        "",
        "mean over a run of the attitude's normalised estimation error squared (φᵀP⁻¹φ, three "
        "degrees of freedom); metrics.json gives the band a consistent filter stays in",
    ),
    Quantity(
        "compass.fused_fraction",
        "fused compass fixes",
        "",
        "the fraction of the compass's fixes that the filter fused (the rest failed its gate)",
    ),
    Quantity(
        "compass_fix_errors.heading_error_rmse_deg",
        "compass fix heading RMSE",
        "°",
        "root-mean-square over a run of each compass fix's heading against the true heading, "
        "before any filter",
    ),
    Quantity(
        "error_deg",
        "azimuth error",
        "°",
        "a study trial's absolute error of the method's solar azimuth (or heading) against truth",
    ),
    Quantity(
        "zenith_error_deg",
        "zenith error",
        "°",
        "a study trial's absolute error of the method's solar zenith angle against truth",
    ),
    Quantity(
        "zenith_bias_deg",
        "zenith bias",
        "°",
        "a study trial's signed solar zenith error (negative: the apparent sun towards the zenith)",
    ),
    Quantity("ok", "fixed", "", "1 when the method gave a fix on the frame, else 0"),
    Quantity(
        "flip",
        "sun/anti-sun flip",
        "",
        "1 when the method chose the anti-sun direction (a 180° error), else 0",
    ),
    Quantity("yaw_error_deg", "yaw error", "°", "a study trial's absolute yaw error against truth"),
)

#: Swept fields (dotted scenario paths) and study parameters.
FIELDS: tuple[Quantity, ...] = (
    Quantity("initial.depth_m", "depth", "m", "the vehicle's depth at the start (and its legs')"),
    Quantity(
        "water.jerlov_type", "Jerlov water type", "",
        "the water's optical class (Jerlov 1976: I–III oceanic, 1C–9C coastal)",
    ),
    Quantity("water.temperature_c", "water temperature", "°C", "the sea water's temperature"),
    Quantity("water.salinity_psu", "salinity", "PSU", "the sea water's practical salinity"),
    Quantity(
        "optics.wind_speed_mps", "wind speed", "m/s",
        "wind speed at 12.5 m that roughens the sea surface (Cox–Munk slopes)",
    ),
    Quantity("optics.wind_beaufort", "wind force", "Bft", "wind force on the Beaufort scale"),
    Quantity(
        "optics.turbidity", "turbidity", "",
        "multiplier on the water type's particle scattering (1 = the Jerlov type)",
    ),
    Quantity(
        "water.particle_peak_polarization", "particle peak polarization P", "",
        "the particles' −m12/m11 near 90° (measured 0.6–0.9)",
    ),
    Quantity(
        "water.depolarization_ratio", "depolarization ratio δ", "",
        "the water molecules' depolarization ratio (0.039 fresh, ~0.044 sea water)",
    ),
    Quantity("start_utc", "start time", "UTC", "the trial's start, which sets the sun's place"),
    Quantity("duration_s", "duration", "s", "the trial's simulated length"),
    Quantity("elevation_deg", "solar elevation", "°", "the sun's elevation above the horizon"),
    Quantity("case", "case", "", "the study's case (noise and method set)"),
    Quantity(
        "navigation.gate_probability", "NIS gate probability", "",
        "chi-square probability of the filter's innovation gate (1 fuses every measurement)",
    ),
    Quantity(
        "navigation.sun_measurement", "sun measurement", "",
        "what a compass fix aids: the full solar vector or its azimuth alone",
    ),
)  # fmt: skip

_BY_KEY = {q.key: q for q in (*METRICS, *FIELDS)}

#: Units read off a name's suffix (the project's convention: units in names).
SUFFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("_deg", "°"),
    ("_rad", "rad"),
    ("_mps", "m/s"),
    ("_km", "km"),
    ("_m", "m"),
    ("_s", "s"),
    ("_hz", "Hz"),
    ("_c", "°C"),
    ("_psu", "PSU"),
    ("_mgal", "mGal"),
    ("_us", "µs"),
    ("_ms", "ms"),
    ("_px", "px"),
    ("_pa", "Pa"),
)


def describe(key: str) -> Quantity:
    """The quantity of a metric or a swept field (a ``param.`` prefix is dropped).

    A key not in the table: its label is the dotted key itself with the unit suffix removed,
    its unit from the suffix, its definition says it is not described.
    """
    key = key.removeprefix("param.")
    if key in _BY_KEY:
        return _BY_KEY[key]
    last = key.rsplit(".", 1)[-1]
    for suffix, unit in SUFFIX_UNITS:
        if last.endswith(suffix):
            label = key[: -len(suffix)].replace("_", " ")
            return Quantity(key, label, unit, f"`{key}` (not described in the label table)")
    return Quantity(key, key.replace("_", " "), "", f"`{key}` (not described in the label table)")


def markdown_table() -> str:
    """The docs' reference of every described quantity (docs/campaigns.md, generated)."""
    lines = ["| key | label | unit | definition |", "|---|---|---|---|"]
    for title, qs in (("metric", METRICS), ("swept field", FIELDS)):
        for q in qs:
            lines.append(f"| `{q.key}` ({title}) | {q.label} | {q.unit or '—'} | {q.definition} |")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    print(markdown_table())
