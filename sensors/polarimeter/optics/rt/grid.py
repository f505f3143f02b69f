"""What a light-field table is computed on, and the key of the water it belongs to.

The sun nodes, planes, winds and water index of every table, and :class:`WaterKey`: the water
body and sea a table is for.

One home for the grid, so that the table (:mod:`sensors.polarimeter.optics.rt.table`), the sky's
table (:mod:`~sensors.polarimeter.optics.rt.sky_table`) and the files they are kept in
(:mod:`~sensors.polarimeter.optics.rt.store`) agree on it, and a cached table made on another grid
is never read (:meth:`WaterKey.digest` names the grid and :data:`MODEL_VERSION`).
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from sensors.polarimeter.optics import scattering

#: Air zenith angles of the sun at which the table is computed (degrees). 7.5° apart to 60°,
#: closer towards the horizon: between nodes 15° apart the light 10–30° from the refracted sun
#: was 3–4 % off the reference (II, sun 52°); at 7.5° it is within ~2 % (the closing note of
#: the fidelity issue has the ring tables).
SUN_ZENITH_AIR_DEG: tuple[float, ...] = (
    0.0, 7.5, 15.0, 22.5, 30.0, 37.5, 45.0, 52.5, 60.0, 65.0, 70.0, 75.0, 80.0, 84.0, 87.0,
)  # fmt: skip
#: The table's planes, optical depths c z.
TABLE_PLANES: tuple[float, ...] = (
    0.0, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.5, 7.0, 9.0, 12.0, 16.0, 20.0,
)  # fmt: skip
#: Wind speeds (m/s at 12.5 m) of the surfaces the tables are computed for: 0 (flat, shipped)
#: and Cox–Munk seas (computed on first use); the renderer interpolates linearly in between (the
#: mean square slope is linear in the wind). Up to the surface stage's limit of 30 m/s.
WIND_NODES_MPS: tuple[float, ...] = (0.0, 5.0, 10.0, 20.0, 30.0)
#: Water index the tables are computed for (500 nm, S = 35, T ≈ 15–20 °C: Quan & Fry 1995).
TABLE_INDEX = 1.34
#: Histories per source for the shipped tables (about 2–3 % standard error per bin at c z ≈ 3–9).
SHIPPED_PHOTONS = 1_500_000
#: Histories per source for tables computed on first use.
FIRST_USE_PHOTONS = 200_000

#: Bumped whenever the transport changes what a table holds, so that stale caches are not read.
#: 3: δ = 0.044 and P = 0.75 (sourced), the Fournier–Forand peak sampled exactly (b, not
#: 1.009 b), the sun's aureole tallied about the refracted sun, sun nodes 7.5° apart.
MODEL_VERSION = 3

DATA_FILE = Path(__file__).resolve().parents[1] / "data" / "lightfield_jerlov_500nm.npz"


@dataclass(frozen=True, slots=True)
class WaterKey:
    """What a table depends on (besides the fixed grid and index): the water and its surface.

    ``wind_speed_mps`` is one of :data:`WIND_NODES_MPS` (the renderer interpolates between
    them): the Cox–Munk sea of the reference (0 = flat). ``particle_dop_max`` and
    ``depolarization_ratio`` are the phase matrix's P and δ
    (:mod:`sensors.polarimeter.optics.scattering`).
    """

    a_per_m: float
    b_molecular_per_m: float
    b_particle_per_m: float
    particle_backscatter_ratio: float
    wind_speed_mps: float = 0.0
    particle_dop_max: float = scattering.PARTICLE_DOP_MAX
    depolarization_ratio: float = scattering.WATER_DEPOLARIZATION_RATIO

    @classmethod
    def of(cls, water: object, wind_speed_mps: float = 0.0) -> WaterKey:
        """From a :class:`sensors.polarimeter.optics.water.WaterOptics` (and a wind node)."""
        return cls(
            round(float(water.a_per_m), 9),  # type: ignore[attr-defined]
            round(float(water.b_molecular_per_m), 9),  # type: ignore[attr-defined]
            round(float(water.b_particle_per_m), 9),  # type: ignore[attr-defined]
            round(float(water.particle_backscatter_ratio), 9),  # type: ignore[attr-defined]
            round(float(wind_speed_mps), 9),
            round(float(getattr(water, "particle_dop_max", scattering.PARTICLE_DOP_MAX)), 9),
            round(
                float(
                    getattr(water, "depolarization_ratio", scattering.WATER_DEPOLARIZATION_RATIO)
                ),
                9,
            ),
        )

    @classmethod
    def from_array(cls, k: Iterable[float]) -> WaterKey:
        """From a table's stored ``key`` array (rounded as :meth:`of` rounds)."""
        return cls(*(round(float(v), 9) for v in k))

    def digest(self) -> str:
        """A short stable name for the cache."""
        text = (
            f"{self.a_per_m:.9g},{self.b_molecular_per_m:.9g},{self.b_particle_per_m:.9g},"
            f"{self.particle_backscatter_ratio:.9g},{TABLE_INDEX},{SUN_ZENITH_AIR_DEG},"
            f"{TABLE_PLANES},{MODEL_VERSION},{self.wind_speed_mps:.9g},"
            f"{self.particle_dop_max:.9g},{self.depolarization_ratio:.9g}"
        )
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    @property
    def c_per_m(self) -> float:
        """Beam attenuation c = a + b."""
        return self.a_per_m + self.b_molecular_per_m + self.b_particle_per_m
