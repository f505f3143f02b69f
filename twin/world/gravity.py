"""The world's gravity field: a synthetic seafloor, forward-modelled, and normal gravity.

World side. The PCRB paper's map (wang2023 Fig. 2) is a 1′ × 1′ region of Sandwell et al.'s
marine gravity model — "highly undulating … peaks, slopes, and flats" — which the project cannot
download. The twin builds its own map the way the ocean makes one: a seafloor, and the gravity
of its relief.

**Seafloor** (:class:`SeafloorSpec`), depths in metres below the sea surface, built from three
things the paper's map shows, each placed and sized by the spec:

* a mean depth, 4000 m by default (the abyssal plain's typical depth; Charette & Smith 2010,
  Oceanography 23(2), mean ocean depth 3682 m [uncertain: rounded]);
* abyssal hills: a Gaussian random field with the Goff & Jordan (1988, JGR 93(B11):13589) style
  of parameters — rms height 150 m, characteristic width 6 km [uncertain: mid-range of their
  fits for slow-spreading crust] — tapered to zero over the ``flats`` (sedimented plains);
* seamounts: Gaussian cones, height 1.5 km and radius (1/e) 8 km by default [uncertain: the
  scale of Wessel 2001's (JGR 106(B9):19431) seamount census], and ``slopes``: tanh steps of a
  plateau's flank, 1.5 km high over 10 km [uncertain].

**Gravity** of the relief with harmonica's prism layer (Fatiando a Terra; Uieda et al.): a
prism per node between the seafloor and the mean depth, density contrast crust − sea water,
2670 − 1030 = 1640 kg/m³ (Hinze 2003's standard crustal density; sea water at the seafloor's
temperature and the surface salinity), observed at the sea surface (where Sandwell's grid
is). The relief is padded by ``pad_m`` with its edge values so that the map's edges do not see
a missing neighbourhood. Not modelled: isostatic compensation (it removes the longest
wavelengths, > 100 km, beyond a 100 km map), sediment density, the crust's own density
variations. The anomaly is relative to the map's mean (an anomaly map's zero is arbitrary for
matching).

**Normal gravity** from boule's WGS84 ellipsoid (closed form, valid on and above it), and below
the sea surface the Poincaré–Prey gradient 0.3086 − 4πGρ_w = 0.222 mGal/m: down through water
gravity grows by the free-air gradient less twice the water layer's attraction.

Randomness: only the Generator passed in (abyssal hills).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from twin.core.earth import POINCARE_PREY_MGAL_PER_M
from twin.core.earth import RHO_SEAWATER_KG_M3 as RHO_SEAWATER
from twin.core.gravity_map import GravityGrid
from twin.world.gravity_random import gaussian_filtered_noise

RHO_CRUST = 2670.0  # kg/m³: Hinze 2003, the standard reduction density


@dataclass(frozen=True, slots=True)
class Seamount:
    """A Gaussian seamount: centre (m), height above the surroundings (m), 1/e radius (m)."""

    east_m: float
    north_m: float
    height_m: float = 1500.0
    radius_m: float = 8000.0


@dataclass(frozen=True, slots=True)
class Slope:
    """A plateau flank: a tanh step of ``height_m`` across a line, ``width_m`` wide.

    The plateau side is to the left of the direction ``azimuth_deg`` (compass, clockwise from
    North) through (``east_m``, ``north_m``).
    """

    east_m: float
    north_m: float
    azimuth_deg: float
    height_m: float = 1500.0
    width_m: float = 10000.0


@dataclass(frozen=True, slots=True)
class Flat:
    """A sedimented plain: the abyssal hills fade out within ``radius_m`` of its centre."""

    east_m: float
    north_m: float
    radius_m: float = 15000.0


@dataclass(frozen=True, slots=True)
class SeafloorSpec:
    """The synthetic seafloor, and its grid.

    Attributes:
        size_m: (East, North) extent of the map from its lower-left corner at (0, 0).
        spacing_m: Node spacing δ (the paper's 1 km).
        mean_depth_m: Depth of the abyssal plain.
        hill_rms_m: Abyssal hills' rms height; 0 = none.
        hill_width_m: Their characteristic width (Gaussian covariance e-folding).
        seamounts, slopes, flats: The features.
        pad_m: Relief padding beyond the map for the forward model.
    """

    size_m: tuple[float, float] = (100_000.0, 100_000.0)
    spacing_m: float = 1000.0
    mean_depth_m: float = 4000.0
    hill_rms_m: float = 150.0
    hill_width_m: float = 6000.0
    seamounts: tuple[Seamount, ...] = ()
    slopes: tuple[Slope, ...] = ()
    flats: tuple[Flat, ...] = ()
    pad_m: float = 10_000.0
    density_contrast_kg_m3: float = field(default=RHO_CRUST - RHO_SEAWATER)

    def __post_init__(self) -> None:
        if not (len(self.size_m) == 2 and all(s > 0 and math.isfinite(s) for s in self.size_m)):
            raise ValueError(f"seafloor size_m: {self.size_m!r}; allowed: two lengths > 0 m")
        if not (0 < self.spacing_m <= min(self.size_m) / 2):
            raise ValueError(
                f"seafloor spacing_m: {self.spacing_m!r}; allowed: (0, {min(self.size_m) / 2:g}] m"
            )
        if not (self.mean_depth_m > 0 and math.isfinite(self.mean_depth_m)):
            raise ValueError(f"seafloor mean_depth_m: {self.mean_depth_m!r}; allowed: > 0 m")
        if not (self.hill_rms_m >= 0 and self.hill_width_m > 0 and self.pad_m >= 0):
            raise ValueError("seafloor hill_rms_m >= 0, hill_width_m > 0 and pad_m >= 0")


def wang2023_seafloor() -> SeafloorSpec:
    """A 100 × 100 km map with the paper's stated features where its tests need them.

    wang2023 §4: Test 1 starts at (58, 73) km "within the slope area, where contour lines are
    densely distributed"; Test 2 at (30, 58) km "situated at a relatively gentle seabed"; both
    end at (65, 9) km. The twin puts a plateau flank through Test 1's start, a sedimented plain
    around Test 2's, seamounts elsewhere (the paper's "peaks"), abyssal hills everywhere else.
    Only the features' places come from the paper; their sizes are the sourced defaults above.
    """
    return SeafloorSpec(
        seamounts=(
            Seamount(18_000.0, 80_000.0),
            Seamount(45_000.0, 35_000.0, height_m=1200.0),
            Seamount(82_000.0, 45_000.0),
            Seamount(25_000.0, 15_000.0, height_m=1000.0, radius_m=6000.0),
        ),
        slopes=(Slope(58_000.0, 73_000.0, azimuth_deg=120.0),),
        flats=(Flat(30_000.0, 58_000.0), Flat(72_000.0, 15_000.0, radius_m=10_000.0)),
    )


def seafloor_depth(spec: SeafloorSpec, rng: np.random.Generator):
    """(east, north, depth) of the padded relief, depth (ny, nx) positive down (m)."""
    d = spec.spacing_m
    e = np.arange(-spec.pad_m, spec.size_m[0] + spec.pad_m + d / 2, d)
    n = np.arange(-spec.pad_m, spec.size_m[1] + spec.pad_m + d / 2, d)
    ee, nn = np.meshgrid(e, n)
    relief = np.zeros_like(ee)
    if spec.hill_rms_m > 0:
        # Gaussian covariance exp(−r²/w²), scaled to the rms.
        hills = gaussian_filtered_noise(ee.shape, d, spec.hill_width_m, rng)
        hills *= spec.hill_rms_m / max(float(hills.std()), 1e-12)
        taper = np.ones_like(ee)
        for f in spec.flats:
            r2 = ((ee - f.east_m) ** 2 + (nn - f.north_m) ** 2) / f.radius_m**2
            taper *= 1.0 - np.exp(-r2)
        relief += hills * taper
    for s in spec.seamounts:
        r2 = ((ee - s.east_m) ** 2 + (nn - s.north_m) ** 2) / s.radius_m**2
        relief += s.height_m * np.exp(-r2)
    for sl in spec.slopes:
        az = math.radians(sl.azimuth_deg)
        # Left of the direction (sin az, cos az) in ENU is (−cos az, sin az).
        across = (ee - sl.east_m) * (-math.cos(az)) + (nn - sl.north_m) * math.sin(az)
        relief += 0.5 * sl.height_m * np.tanh(across / (0.5 * sl.width_m))
    return e, n, spec.mean_depth_m - relief


def anomaly_grid(spec: SeafloorSpec, rng: np.random.Generator) -> GravityGrid:
    """The relief's gravity at the sea surface (mGal, zero mean over the map)."""
    import harmonica as hm

    e, n, depth = seafloor_depth(spec, rng)
    surface = -depth  # elevation (up)
    ref = -spec.mean_depth_m
    density = np.where(surface >= ref, spec.density_contrast_kg_m3, -spec.density_contrast_kg_m3)
    layer = hm.prism_layer((e, n), surface, ref, properties={"density": density})
    inside_e = (e >= -1e-9) & (e <= spec.size_m[0] + 1e-9)
    inside_n = (n >= -1e-9) & (n <= spec.size_m[1] + 1e-9)
    ge, gn = e[inside_e], n[inside_n]
    ee, nn = np.meshgrid(ge, gn)
    gz = layer.prism_layer.gravity((ee, nn, np.zeros_like(ee)), field="g_z")
    gz = np.asarray(gz, dtype=np.float64)
    return GravityGrid(ge, gn, gz - gz.mean(), source=f"synthetic seafloor {spec.size_m} m")


def normal_gravity_mgal(latitude_deg: float, depth_m: float = 0.0) -> float:
    """WGS84 normal gravity (boule) at the sea surface, continued down through the water."""
    import boule

    g0 = float(boule.WGS84.normal_gravity((0.0, latitude_deg, 0.0), si_units=False))
    return g0 + POINCARE_PREY_MGAL_PER_M * max(float(depth_m), 0.0)


__all__ = [
    "POINCARE_PREY_MGAL_PER_M",
    "Flat",
    "SeafloorSpec",
    "Seamount",
    "Slope",
    "anomaly_grid",
    "normal_gravity_mgal",
    "seafloor_depth",
    "wang2023_seafloor",
]
