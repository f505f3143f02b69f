"""Water bodies and their optical properties at 500 nm: Jerlov's types, a plug-in's, a scenario's.

A water body (:class:`WaterBody`) is its absorption a, scattering b and diffuse attenuation K_d
with where they come from; :func:`jerlov_water` makes the :class:`WaterOptics` the light field
is computed for (turbidity, the particles' P and the molecules' δ applied). The column stage
(:mod:`sensors.polarimeter.optics.water`) renders with them.

Jerlov water types at 500 nm (the table :data:`JERLOV_500NM`, transcribed from the ``jerlov``
package 0.22.0 data files, Apache-2.0, so that there is no runtime dependency on a very new,
single-author package; optics.md §2.8): K_d from Jerlov (1976) *Marine Optics* Table XXVII;
a and b measured by Williamson & Hollins (2022, Appl. Opt. 61:9951) for IB, II, III, 1C, 3C, 5C,
and from Solonenko & Mobley (2015, Appl. Opt. 54:5392, inverted from K_d, not measured) for the
types Williamson & Hollins lack (I, IA, 7C, 9C; their b for I and IA is flagged suspect by the
package, being at the pure-seawater level).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sensors.polarimeter.optics import scattering
from twin.core.extensions import WATER_BODIES, ExtensionError
from twin.core.options import INLINE_WATER
from twin.core.options import JERLOV_TYPES as JERLOV_TYPES

# JERLOV_TYPES: declared in twin.core.options (imported above), the keys of JERLOV_500NM below.


@dataclass(frozen=True, slots=True)
class WaterBody:
    """A water body's optical properties at 500 nm (m⁻¹) and where they come from.

    The built-in ones are Jerlov's types (:data:`JERLOV_500NM`); a package adds its own through
    the ``auv_twin.water_bodies`` entry-point group (:data:`twin.core.extensions.WATER_BODIES`,
    docs/extending.md). The particles' phase function, P and δ are the project's (the scenario's
    ``optics`` table), whatever the water.

    Attributes:
        kd_per_m: Diffuse attenuation of downwelling irradiance K_d (> 0).
        a_per_m: Absorption a (> 0).
        b_per_m: Scattering b, water molecules included (≥ 0; the molecules' share is
            min(:data:`B_SEAWATER_500NM`, b)).
        iop_source: Where a, b and K_d come from (a citation; "assumption: …" where they are).
    """

    kd_per_m: float
    a_per_m: float
    b_per_m: float
    iop_source: str

    def __post_init__(self) -> None:
        for name, lo_open in (("kd_per_m", True), ("a_per_m", True), ("b_per_m", False)):
            v = getattr(self, name)
            ok = isinstance(v, int | float) and math.isfinite(v) and (v > 0 if lo_open else v >= 0)
            if not ok or v > 100.0:
                bound = "(0, 100]" if lo_open else "[0, 100]"
                raise ValueError(f"WaterBody.{name}: {v!r}; allowed: a number in {bound} (1/m)")
        if self.kd_per_m < self.a_per_m:
            # K_d ≈ (a + b_b)/μ̄_d with μ̄_d ≤ 1: diffuse light cannot fade slower than absorbed.
            raise ValueError(
                f"WaterBody.kd_per_m: {self.kd_per_m!r} is below a_per_m = {self.a_per_m!r}; "
                "allowed: K_d >= a (1/m)"
            )
        if not isinstance(self.iop_source, str) or not self.iop_source.strip():
            raise ValueError(
                f"WaterBody.iop_source: {self.iop_source!r}; allowed: a citation or an assumption"
            )


_WH22 = "Williamson & Hollins 2022 (measured)"
_SM15 = "Solonenko & Mobley 2015 (inverted from Kd)"

#: K_d: Jerlov (1976) Table XXVII at 500 nm. a, b at 500 nm: see ``iop_source``. Transcribed from
#: jerlov 0.22.0 ``data/jerlov1976_kd.csv``, ``williamson2022_iop.csv``, ``solonenko2015_iop.csv``.
JERLOV_500NM: dict[str, WaterBody] = {
    "I": WaterBody(0.027, 0.026, 0.00249, _SM15),
    "IA": WaterBody(0.032, 0.0282, 0.00461, _SM15),
    "IB": WaterBody(0.042, 0.0398, 0.128, _WH22),
    "II": WaterBody(0.070, 0.0529, 0.185, _WH22),
    "III": WaterBody(0.115, 0.0835, 0.297, _WH22),
    "1C": WaterBody(0.14, 0.104, 0.44, _WH22),
    "3C": WaterBody(0.22, 0.144, 0.664, _WH22),
    "5C": WaterBody(0.36, 0.199, 1.23, _WH22),
    "7C": WaterBody(0.58, 0.29, 2.76, _SM15),
    "9C": WaterBody(0.99, 0.543, 3.67, _SM15),
}

#: Molecular scattering of seawater (S ≈ 35) at 500 nm: Morel (1974), b_w = (8π/3) β_w(90°)
#: (2 + δ)/(1 + δ) with β_w(90°) = 1.38e-4 (1 + 0.3 S/37) m⁻¹ sr⁻¹, δ = 0.09 → 0.0029 m⁻¹.
B_SEAWATER_500NM = 0.0029
#: Petzold's average-particle backscatter fraction (Mobley et al. 2002).
PETZOLD_BACKSCATTER_RATIO = 0.0183
#: Kirk (1984, Limnol. Oceanogr. 29:350) K_d = (1/μ₀) √(a² + G a b), G(μ₀) = 0.425 μ₀ − 0.19, at
#: μ₀ = 1; used only to rescale a type's tabulated K_d when its scattering is scaled.
KIRK_G = 0.235
#: Diffuse transmittance of a flat sea for a uniform sky, 1 − 0.066 (Mobley 1994, Light and Water
#: §4.3: the uniform-sky reflectance of a level surface is 0.066).
FLAT_SEA_DIFFUSE_TRANSMITTANCE = 0.934


@dataclass(frozen=True, slots=True)
class WaterOptics:
    """Optical properties of a homogeneous water layer at one wavelength.

    Attributes:
        a_per_m: Absorption coefficient a.
        b_per_m: Total scattering coefficient b (molecular + particulate).
        kd_per_m: Diffuse attenuation coefficient of downwelling irradiance K_d.
        name: A label (the Jerlov type, or "custom").
        wavelength_nm: The wavelength the coefficients are for.
        b_water_per_m: Molecular (pure seawater) share of b; clipped to b.
        particle_backscatter_ratio: b_bp/b_p of the particles (the Fournier–Forand B).
        particle_dop_max: Peak linear polarization P of the particles' scattering, [0, 1]
            (:data:`scattering.PARTICLE_DOP_MAX`, sourced there; measured 0.6–0.9).
        depolarization_ratio: Depolarization ratio δ of the water molecules, [0, 0.5)
            (:data:`scattering.WATER_DEPOLARIZATION_RATIO` for S = 35; 0.039 for fresh water).
    """

    a_per_m: float
    b_per_m: float
    kd_per_m: float
    name: str = "custom"
    wavelength_nm: float = 500.0
    b_water_per_m: float = B_SEAWATER_500NM
    particle_backscatter_ratio: float = PETZOLD_BACKSCATTER_RATIO
    particle_dop_max: float = scattering.PARTICLE_DOP_MAX
    depolarization_ratio: float = scattering.WATER_DEPOLARIZATION_RATIO

    def __post_init__(self) -> None:
        for field_name, lo in (("a_per_m", 1e-6), ("kd_per_m", 1e-6)):
            v = getattr(self, field_name)
            if not (math.isfinite(v) and lo <= v <= 100.0):
                raise ValueError(f"{field_name} must lie in [{lo:g}, 100] m⁻¹, got {v!r}")
        for field_name in ("b_per_m", "b_water_per_m"):
            v = getattr(self, field_name)
            if not (math.isfinite(v) and 0.0 <= v <= 500.0):
                raise ValueError(f"{field_name} must lie in [0, 500] m⁻¹, got {v!r}")
        if not (0.001 <= self.particle_backscatter_ratio <= 0.1):
            raise ValueError(
                "particle_backscatter_ratio must lie in [0.001, 0.1] "
                f"(b_bp/b_p of ocean particles), got {self.particle_backscatter_ratio!r}"
            )
        if not (math.isfinite(self.particle_dop_max) and 0.0 <= self.particle_dop_max <= 1.0):
            raise ValueError(
                f"particle_dop_max must lie in [0, 1] (the particles' peak linear polarization), "
                f"got {self.particle_dop_max!r}"
            )
        if not (
            math.isfinite(self.depolarization_ratio) and 0.0 <= self.depolarization_ratio < 0.5
        ):
            raise ValueError(
                "depolarization_ratio must lie in [0, 0.5) (the water molecules' δ), "
                f"got {self.depolarization_ratio!r}"
            )

    @property
    def c_per_m(self) -> float:
        """Beam attenuation c = a + b."""
        return self.a_per_m + self.b_per_m

    @property
    def b_molecular_per_m(self) -> float:
        """Molecular scattering (≤ b)."""
        return min(self.b_water_per_m, self.b_per_m)

    @property
    def b_particle_per_m(self) -> float:
        """Particulate scattering b − b_w."""
        return self.b_per_m - self.b_molecular_per_m


def _check_water_body(name: str, obj: object) -> None:
    if name == INLINE_WATER:
        raise ExtensionError(
            f"water body {name!r} is reserved for a scenario's own [water.iops]; rename it"
        )
    if not isinstance(obj, WaterBody):
        raise ExtensionError(
            f"water body {name!r} is {type(obj).__name__}; expected a "
            "sensors.polarimeter.optics.water_body.WaterBody"
        )


def jerlov_water(
    water_type: str | WaterBody,
    turbidity: float = 1.0,
    *,
    particle_dop_max: float = scattering.PARTICLE_DOP_MAX,
    depolarization_ratio: float = scattering.WATER_DEPOLARIZATION_RATIO,
) -> WaterOptics:
    """A water body's optical properties at 500 nm, optionally made more or less turbid.

    ``turbidity`` scales the particulate scattering b_p = b − b_w (e.g. milk in a test tank is
    nearly pure scattering): b = b_w + turbidity · b_p. K_d is rescaled by Kirk's (1984)
    √(a² + G a b) ratio so turbidity = 1 reproduces Jerlov's K_d exactly; a is unchanged.

    Args:
        water_type: One of :data:`JERLOV_TYPES` (case-insensitive) or a plug-in's water body
            (:data:`twin.core.extensions.WATER_BODIES`), or a :class:`WaterBody` itself (a
            scenario's ``[water.iops]``: named ``"inline"``).
        turbidity: Particulate-scattering multiplier, 0 (particle-free) to 1000.
        particle_dop_max: The particles' peak linear polarization P (:class:`WaterOptics`).
        depolarization_ratio: The water molecules' δ (:class:`WaterOptics`).

    Raises:
        ValueError: an unknown type (the message lists the allowed ones) or turbidity out of range;
            ExtensionError (a ValueError) for a plug-in that does not import or is no WaterBody.
    """
    key = INLINE_WATER if isinstance(water_type, WaterBody) else str(water_type).strip()
    if isinstance(water_type, WaterBody):
        pass
    elif key.upper() in JERLOV_500NM:
        key = key.upper()
    elif key not in WATER_BODIES.names():
        allowed = ", ".join(WATER_BODIES.names())
        raise ValueError(f"water_type must be one of {allowed}, got {water_type!r}")
    t = float(turbidity)
    if not (math.isfinite(t) and 0.0 <= t <= 1000.0):
        raise ValueError(f"turbidity must lie in [0, 1000], got {turbidity!r}")
    if isinstance(water_type, WaterBody):
        e = water_type
    elif key in JERLOV_500NM:
        e = JERLOV_500NM[key]
    else:
        e = WATER_BODIES.load(key, _check_water_body)
    b_w = min(B_SEAWATER_500NM, e.b_per_m)
    b = b_w + t * (e.b_per_m - b_w)
    kd = e.kd_per_m * math.sqrt(
        (e.a_per_m**2 + KIRK_G * e.a_per_m * b) / (e.a_per_m**2 + KIRK_G * e.a_per_m * e.b_per_m)
    )
    name = key if t == 1.0 else f"{key}×{t:g}"
    return WaterOptics(
        e.a_per_m,
        b,
        kd,
        name=name,
        b_water_per_m=b_w,
        particle_dop_max=particle_dop_max,
        depolarization_ratio=depolarization_ratio,
    )


def _check_depth(depth_m: float) -> float:
    z = float(depth_m)
    if not (math.isfinite(z) and 0.0 <= z <= 11000.0):
        raise ValueError(f"depth_m must lie in [0, 11000] m, got {depth_m!r}")
    return z


def optical_depths(water: WaterOptics, depth_m: float) -> tuple[float, float]:
    """(τ_c, τ_b) = (c z, b z): attenuation and scattering optical depth of the layer above z."""
    z = _check_depth(depth_m)
    return water.c_per_m * z, water.b_per_m * z
