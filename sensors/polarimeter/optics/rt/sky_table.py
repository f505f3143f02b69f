"""The sky's scattered light over a water, per sky shape: the second half of the light-field table.

For one water body and sea (:class:`sensors.polarimeter.optics.rt.grid.WaterKey`) and one sky shape
(:class:`SkyKey`: CIE type, polarization model, DoP maximum, Berry's δ; the sky's scale cancels,
everything is per unit irradiance), :class:`SkyTable` holds all the scattered light of the **sky
model's own sky** — its radiance distribution and its polarization for the sun at each of the
table's sun nodes, through the surface's Fresnel matrix, the disc excluded — per unit sky plane
irradiance below the surface, with its standard error and the sea's diffuse transmittance for
that sky. :meth:`sensors.polarimeter.optics.rt.table.LightFieldTable.frame` adds it to the sun's
light.

The default sky over every Jerlov type under a flat sea ships in the table's data file (prefix
``<type>/sky_model/``); any other sky, water or sea is computed on first use
(:data:`FIRST_USE_SKY_PHOTONS` histories per node) and cached under ``$AUV_TWIN_CACHE``.
"""

from __future__ import annotations

import functools
import hashlib
import math
import sys
from dataclasses import dataclass

import numpy as np

from sensors.polarimeter.optics.rt import reference, store
from sensors.polarimeter.optics.rt.grid import DATA_FILE, SUN_ZENITH_AIR_DEG, TABLE_PLANES, WaterKey
from sensors.polarimeter.optics.rt.poles import smooth
from sensors.polarimeter.optics.rt.store import cache_dir, per_ed, run_jobs, save
from sensors.polarimeter.optics.sky import SkySpec
from twin.core.arrays import FloatArray

#: Histories per sky node for the shipped tables (as many as the sun's: with half as many the
#: bins' noise, ~4 %, showed in the fast path's interpolation).
SHIPPED_SKY_PHOTONS = 1_500_000
#: Histories per sky node for sky tables computed on first use.
FIRST_USE_SKY_PHOTONS = 200_000
#: The prefix of a water's default-sky table in the shipped file.
SKY_PREFIX = "sky_model/"


@dataclass(frozen=True, slots=True)
class SkyKey:
    """What shapes a sky's light in the water (its scale cancels: tables are per irradiance)."""

    cie_type: int = 12
    polarization: str = "rayleigh"
    dop_max: float = 0.75
    berry_delta_rad: float = round(math.radians(30.0), 9)

    @classmethod
    def of(cls, sky: SkySpec) -> SkyKey:
        """From a :class:`sensors.polarimeter.optics.sky.SkySpec`."""
        return cls(
            int(sky.cie_type),
            str(sky.polarization),
            round(float(sky.dop_max), 9),
            round(float(sky.berry_delta_rad), 9),
        )

    @classmethod
    def from_array(cls, k: np.ndarray) -> SkyKey:
        """From a sky table's stored ``sky_key`` array (:meth:`SkyTable.arrays`)."""
        return cls(
            int(k[0]), "berry" if k[1] > 0.5 else "rayleigh", round(float(k[2]), 9),
            round(float(k[3]), 9),
        )  # fmt: skip

    def spec(self) -> SkySpec:
        """A :class:`SkySpec` with this shape (unit zenith radiance, no disc)."""
        return SkySpec(
            cie_type=self.cie_type,
            polarization=self.polarization,  # type: ignore[arg-type]
            dop_max=self.dop_max,
            berry_delta_rad=self.berry_delta_rad,
            zenith_radiance=1.0,
            sun_relative_radiance=0.0,
        )

    def digest(self, water: WaterKey) -> str:
        """A short stable name for the cache (this sky over that water)."""
        text = (
            f"{water.digest()},{self.cie_type},{self.polarization},{self.dop_max:.9g},"
            f"{self.berry_delta_rad:.9g}"
        )
        return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class SkyTable:
    """The scattered light of one sky model over one water, per sun node (module docstring).

    Attributes:
        water: The water.
        sky: The sky's shape.
        field: (S, P, T, n_phi, 3) all scattered sky light (single and multiple), per unit
            downwelling sky plane irradiance just below the surface.
        e_down: (S, P) the sky light's downwelling irradiance at the planes (direct included).
        transmittance: (S,) the sea's diffuse transmittance for this sky (flat: Fresnel over the
            sky's cells; wavy: the photons' mean facet transmittance).
        photons: Histories per node.
        field_se: (S, P, T, n_phi) the standard error of the field's radiance.
    """

    water: WaterKey
    sky: SkyKey
    field: FloatArray
    e_down: FloatArray
    transmittance: FloatArray
    photons: int
    field_se: FloatArray

    @classmethod
    def build(
        cls,
        water: WaterKey,
        sky: SkyKey,
        photons: int = FIRST_USE_SKY_PHOTONS,
        seed: int = 0,
        workers: int = 1,
    ) -> SkyTable:
        """Run the reference with the sky source at every sun node."""
        grid = reference.Grid(planes=TABLE_PLANES)
        seeds = np.random.SeedSequence([seed, 1]).spawn(len(SUN_ZENITH_AIR_DEG))
        args = [
            (water, "sky", z, grid, photons, int(s.generate_state(1)[0]), sky)
            for z, s in zip(SUN_ZENITH_AIR_DEG, seeds, strict=True)
        ]
        fields = run_jobs(args, workers)
        return cls(
            water=water,
            sky=sky,
            field=np.stack([f.total for f in fields]).astype(np.float32),
            e_down=np.stack([f.e_down for f in fields]),
            transmittance=np.array([f.surface_transmittance for f in fields]),
            photons=int(photons),
            field_se=np.stack([f.total_se_all()[..., 0] for f in fields]).astype(np.float16),
        )

    def arrays(self, prefix: str = "") -> dict[str, np.ndarray]:
        """The table as named arrays (for ``np.savez``)."""
        k = self.sky
        return {
            f"{prefix}sky_key": np.array(
                [
                    k.cie_type,
                    1.0 if k.polarization == "berry" else 0.0,
                    k.dop_max,
                    k.berry_delta_rad,
                ]
            ),
            f"{prefix}field_per_ed": per_ed(self.field, self.e_down[:, :, None, None, None]),
            f"{prefix}e_down": self.e_down,
            f"{prefix}transmittance": self.transmittance,
            f"{prefix}photons": np.array(self.photons),
            f"{prefix}field_se_per_ed": per_ed(self.field_se, self.e_down[:, :, None, None]),
        }

    @functools.cached_property
    def smooth(self) -> FloatArray:
        """:attr:`field`, its rings at the poles made smooth (:func:`poles.smooth`)."""
        return smooth(self.field, self.field.shape[3])

    @functools.cached_property
    def remainder(self) -> FloatArray:
        """:attr:`smooth` less the reflected upwelling light in the window's bins (flat sea).

        As node values that conserve the bins' means (:func:`decompose.conserve`). What the
        coarse bins keep (:mod:`sensors.polarimeter.optics.rt.decompose`); the renderer adds
        the reflection per pixel. A wavy sea keeps all of it in the bins. Computed once per
        machine and table (:func:`store.derived`).
        """
        return store.derived("sky_remainder", (self.water, self.sky, self.field), self._remainder)

    def _remainder(self) -> FloatArray:
        """:attr:`remainder`, computed."""
        from sensors.polarimeter.optics.rt import decompose
        from sensors.polarimeter.optics.rt.table import REMAINDER_POLE_ROWS, _n_inside, remainder_of

        rem = smooth(
            remainder_of(self.smooth, self.water, beams=None),
            self.field.shape[3],
            REMAINDER_POLE_ROWS,
        )
        edges = np.asarray(reference.Grid(planes=TABLE_PLANES).theta_edges_deg)
        return decompose.conserve(rem, edges, _n_inside(edges), noisy_azimuth=True).astype(
            np.float32
        )

    @classmethod
    def from_arrays(
        cls, d: dict[str, np.ndarray] | np.lib.npyio.NpzFile, water: WaterKey, prefix: str = ""
    ) -> SkyTable:
        """Inverse of :meth:`arrays`."""
        ed = np.asarray(d[f"{prefix}e_down"], dtype=float)
        return cls(
            water=water,
            sky=SkyKey.from_array(d[f"{prefix}sky_key"]),
            field=np.nan_to_num(
                np.asarray(d[f"{prefix}field_per_ed"], dtype=np.float32)
                * ed[:, :, None, None, None]
            ),
            e_down=ed,
            transmittance=np.asarray(d[f"{prefix}transmittance"], dtype=float),
            photons=int(d[f"{prefix}photons"]),
            field_se=(
                np.nan_to_num(
                    np.asarray(d[f"{prefix}field_se_per_ed"], dtype=np.float32)
                    * ed[:, :, None, None]
                )
                if f"{prefix}field_se_per_ed" in d
                else np.full(ed.shape + d[f"{prefix}field_per_ed"].shape[2:4], np.nan, np.float32)
            ),
        )


@functools.lru_cache(maxsize=1)
def _shipped_sky_names() -> dict[tuple[WaterKey, SkyKey], str]:
    """The shipped skies' (water, sky) and their names in ``DATA_FILE``, without their tables."""
    if not DATA_FILE.exists():
        return {}
    out = {}
    with np.load(DATA_FILE) as d:
        for name in (str(n) for n in d["names"]):
            if f"{name}/{SKY_PREFIX}sky_key" in d:
                sky = SkyKey.from_array(d[f"{name}/{SKY_PREFIX}sky_key"])
                out[(WaterKey.from_array(d[f"{name}/key"]), sky)] = name
    return out


@functools.lru_cache(maxsize=1)
def _shipped_skies() -> dict[tuple[WaterKey, SkyKey], SkyTable]:
    """Every shipped sky table (tests; a run loads its own, lazily)."""
    return {key: sky_table_for(*key) for key in _shipped_sky_names()}


@functools.lru_cache(maxsize=32)
def sky_table_for(water: WaterKey, sky: SkyKey) -> SkyTable:
    """The scattered light of a sky over a water: shipped, cached, or computed now (and cached)."""
    name = _shipped_sky_names().get((water, sky))
    if name is not None:
        with np.load(DATA_FILE) as d:
            return SkyTable.from_arrays(d, water, prefix=f"{name}/{SKY_PREFIX}")
    path = cache_dir() / f"sky-{sky.digest(water)}.npz"
    if path.exists():
        with np.load(path) as d:
            return SkyTable.from_arrays(d, water)
    print(
        f"auv-twin: computing the scattered sky light for CIE sky {sky.cie_type} "
        f"({sky.polarization}, DoP max {sky.dop_max:g}) over water a={water.a_per_m:g}, "
        f"b_w={water.b_molecular_per_m:g}, b_p={water.b_particle_per_m:g} /m, "
        f"wind {water.wind_speed_mps:g} m/s "
        f"({len(SUN_ZENITH_AIR_DEG)} Monte Carlo runs of {FIRST_USE_SKY_PHOTONS} photons; "
        f"cached in {path.parent})",
        file=sys.stderr,
    )
    t = SkyTable.build(water, sky, FIRST_USE_SKY_PHOTONS, seed=0, workers=1)
    save(path, t.arrays())
    return t
