"""The water column between the sea surface and the camera: attenuation and scattering.

Stage 5 of the polarimeter's physics chain (see :mod:`sensors.polarimeter`). Look directions ``v``
(unit, from the camera outwards; the light travels ``d = −v``) are given in any frame F with
``rotation`` = C_F^n (ENU when None), exactly as :mod:`sky` takes them. Stokes (I, Q, U) in and out
use the chain's meridian convention: relative to ``stokes.meridian_reference(−v)`` in ENU
(:mod:`sensors.polarimeter.stokes`), the reference :mod:`sky` returns and
:meth:`surface.SurfaceTransmission.apply` keeps. Per frame::

    beam = surface.refract_sun_beam(sun_enu, n)
    state = column.state(depth_m, beam.look_dir, beam.irradiance_factor, beam.dop, e_sun, e_sky)
    window = transmission.apply(sky_stokes)          # surface stage, meridian reference
    stokes = column.render(rays, state, window, rotation=c_cam_to_enu, out=buffer)

What reaches the camera at depth z along v is the sum of three Stokes fields, all physics:

1. **Direct (unscattered) sky light.** Inside Snell's window the refracted sky Stokes just below
   the surface (from :mod:`~sensors.polarimeter.optics.surface`) is attenuated by Beer–Lambert along
   the
   slant path L = z / v_z: S_dir = S_window · exp(−c L), c = a + b. Its polarization is untouched.

2. **Single scattering of the refracted sun beam**, closed form. The beam (normal irradiance E_w
   just below the surface, in-water direction towards the sun ŝ, μ_s = ŝ_z) is attenuated to depth
   z' as exp(−c z'/μ_s); at distance s along the line of sight the scattering volume is at depth
   z − s v_z, scatters β(Θ) per unit solid angle (cos Θ = v·ŝ) and the light is attenuated exp(−c s)
   on its way back. For a homogeneous layer:

       L_ss(v) = β(Θ) E_w ∫₀^{s_max} exp(−c (z − s v_z)/μ_s) exp(−c s) ds
               = β(Θ) E_w μ_s [exp(−c z/μ_s) − exp(−c z/v_z)] / (c (μ_s − v_z)),   v_z > 0
               = β(Θ) E_w μ_s exp(−c z/μ_s) / (c (μ_s − v_z)),                       v_z ≤ 0

   (s_max = z/v_z up to the surface; ∞ for rays at or below the horizon in deep water). Its
   polarization is the sea-water phase matrix of :mod:`sensors.polarimeter.optics.scattering`
   (molecules
   with their depolarization ratio, particles with the Voss–Fry shape) applied to the beam's own
   Fresnel polarization, in the scattering plane: no depolarization factor, no effective sun.

3. **Everything else that was scattered** — the sun beam scattered more than once, the scattered
   sky light, the upwelling light and its Fresnel / total internal reflection at the surface —
   from the polarized radiative-transfer reference (:mod:`sensors.polarimeter.optics.rt`): a Monte
   Carlo
   solution of the vector radiative transfer equation for this water's a, b and phase matrix,
   tabulated over the refracted sun's zenith and the optical depth c z and interpolated per frame
   (:class:`sensors.polarimeter.optics.rt.table.LightFieldTable`). Nothing in it is fitted: where
   the
   polarization pattern's apparent sun goes with depth is what the transport gives.

The per-pixel work (2 and 3) is one compiled loop (:mod:`sensors.polarimeter.optics.column_kernel`).

Limits, honestly: one wavelength (the water's IOPs at 500 nm by default; see docs/polarimeter.md
for what a single band costs); homogeneous, deep water (no bottom); the closed-form single
scattering sees the mean refracted sun beam, the table's scattered light the Cox–Munk statistics
of the sea's wind (its nodes interpolated), and only the direct sky light the instantaneous waves
(surface stage); the scattered sky light is the sky model's own sky at the table's sun nodes
(interpolated between them); the table's multiply scattered light is resolved to its bins
(3–4° in look zenith, 15° in azimuth; the sharp parts, the direct light and the single-scattered
aureole, are closed form); Monte Carlo noise in the table (its standard error ships with it); no
inelastic scattering.

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
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from sensors.polarimeter.optics import column_kernel, scattering
from sensors.polarimeter.optics.blocks import (
    CHUNK,
    as_rotation,
    exp_into,
    flatten_directions,
    world_components,
)
from sensors.polarimeter.optics.rt import sky_table as rt_sky
from sensors.polarimeter.optics.rt import table as rt_table
from sensors.polarimeter.optics.scattering import (  # noqa: F401  (re-exported: the phase functions)
    ff_backscatter_fraction,
    ff_slope_for_backscatter,
    fournier_forand,
    molecular_phase,
)
from sensors.polarimeter.optics.sky import SkySpec
from sensors.polarimeter.stokes import meridian_reference
from twin.core.arrays import FloatArray
from twin.core.extensions import WATER_BODIES, ExtensionError
from twin.core.options import INLINE_WATER
from twin.core.options import JERLOV_TYPES as JERLOV_TYPES

# --------------------------------------------------------------------------------------------
# Jerlov water types
# --------------------------------------------------------------------------------------------

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
            "sensors.polarimeter.optics.water.WaterBody"
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


# --------------------------------------------------------------------------------------------
# Direct transmission
# --------------------------------------------------------------------------------------------


def path_length_to_surface(cos_zenith: ArrayLike, depth_m: float) -> FloatArray:
    """Slant path z / cos θ_w from the camera to the surface along each ray.

    Infinite for rays that never get there (at or below the horizon).

    Args:
        cos_zenith: Cosines of the rays' in-water zenith angles (v_z of the look directions).
        depth_m: Camera depth z >= 0.
    """
    z = _check_depth(depth_m)
    cz = np.asarray(cos_zenith)
    cz = cz.astype(np.result_type(cz, np.float32), copy=False)
    return np.divide(z, cz, out=np.full_like(cz, np.inf), where=cz > 0)


def beam_transmittance(cos_zenith: ArrayLike, depth_m: float, c_per_m: float) -> FloatArray:
    """Beer–Lambert transmittance exp(−c z / cos θ_w) of the direct (unscattered) light.

    Zero for rays that do not reach the surface (cos θ_w <= 0), one at z = 0 for rays that do.

    Args:
        cos_zenith: v_z of the look directions.
        depth_m: Camera depth z >= 0.
        c_per_m: Beam attenuation coefficient c.
    """
    z = _check_depth(depth_m)
    cz = np.asarray(cos_zenith)
    cz = cz.astype(np.result_type(cz, np.float32), copy=False)
    tau = np.divide(c_per_m * z, cz, out=np.full_like(cz, np.inf), where=cz > 0)
    out = np.exp(-tau)
    if z == 0.0:
        out = np.where(cz > 0, 1.0, 0.0).astype(cz.dtype)
    return out


# --------------------------------------------------------------------------------------------
# The column: per-frame state and per-pixel rendering
# --------------------------------------------------------------------------------------------


class ColumnState(NamedTuple):
    """Per-frame scalars of the water column (computed once by :meth:`WaterColumn.state`).

    Attributes:
        depth_m: Camera depth z.
        tau_c: c z.
        tau_b: b z.
        sun_look: (3,) direction towards the refracted sun (zenith when the sun is down).
        e_sun_normal: Normal irradiance of the refracted beam just below the surface (0 at night).
        beam_q: Q/I of that beam relative to its meridian (Fresnel: p-polarized, >= 0).
        e_sun_plane: The beam's downwelling plane irradiance just below the surface.
        e_sky_plane: The sky's downwelling plane irradiance just below the surface.
        field: This frame's scattered-light grid from the radiative-transfer table (None when
            the water does not scatter).
        window_cos: cos θ_c of this water.
    """

    depth_m: float
    tau_c: float
    tau_b: float
    sun_look: FloatArray
    e_sun_normal: float
    beam_q: float
    e_sun_plane: float
    e_sky_plane: float
    field: rt_table.FrameField | None
    window_cos: float


class WaterColumn:
    """Renders the in-water light field for one water body (precomputes what frames share).

    Per frame: ``state = column.state(depth_m, beam.look_dir, beam.irradiance_factor, beam.dop,
    e_sun_air, e_sky_air)`` once (``beam`` from :func:`surface.refract_sun_beam`), then
    ``column.render(look_dirs, state, window_stokes, rotation=C)``, or the separate terms (the
    scattered light is smooth away from the sun, so a renderer may evaluate :meth:`scattered` on a
    coarser grid and upsample it). Look directions are (..., 3) in a frame F with ``rotation`` =
    C_F^n (ENU when None); Stokes in and out use the chain's meridian convention.
    """

    _LUT_SIZE = 8192

    def __init__(
        self,
        water: WaterOptics,
        n: float,
        sky: SkySpec | None = None,
        wind_speed_mps: float = 0.0,
    ):
        """Set up the column.

        Args:
            water: Optical properties (:func:`jerlov_water` or custom).
            n: Water index (for Snell's window, :func:`surface.water_index`).
            sky: The sky model above (its shape sets the scattered sky light's distribution and
                polarization; default :class:`SkySpec`).
            wind_speed_mps: The sea's wind (the scattered light's tables are interpolated
                between the Cox–Munk seas of :data:`rt.table.WIND_NODES_MPS`; 0 = flat).
        """
        if not (math.isfinite(n) and 1.0 < n < 2.0):
            raise ValueError(f"n must be a water refractive index in (1, 2), got {n!r}")
        self.water = water
        self.n = float(n)
        self.phase = scattering.phase_matrix(
            water.b_molecular_per_m,
            water.b_particle_per_m,
            water.particle_backscatter_ratio,
            size=self._LUT_SIZE,
            particle_dop_max=water.particle_dop_max,
            depolarization_ratio=water.depolarization_ratio,
        )
        pm = self.phase
        self._luts = np.ascontiguousarray(np.stack([pm.beta, pm.m12, pm.m22, pm.m33]))
        self.sky_key = rt_sky.SkyKey.of(SkySpec() if sky is None else sky)
        self.wind_speed_mps = float(wind_speed_mps)
        # [(table key, weight)]: the wind nodes around this sea's wind.
        self._nodes = [
            (rt_table.WaterKey.of(water, node), wt)
            for node, wt in rt_table.wind_nodes(wind_speed_mps)
        ]

    @property
    def table(self) -> rt_table.LightFieldTable:
        """The radiative-transfer table of this water at the nearest wind node at or below.

        (Shipped, cached or computed on first use; :meth:`state` interpolates between nodes.)
        """
        return rt_table.table_for(self._nodes[0][0])

    @property
    def sky_table(self) -> rt_sky.SkyTable:
        """The scattered light of this sky over this water (as :attr:`table`)."""
        return rt_sky.sky_table_for(self._nodes[0][0], self.sky_key)

    def volume_scattering(self, cos_psi: ArrayLike) -> FloatArray:
        """β(Θ) = b_w p_w(Θ) + b_p p_FF(Θ) (m⁻¹ sr⁻¹) as the renderer uses it.

        From the table, linear in sin(Θ/2), as the per-pixel kernel reads it.
        """
        c = np.asarray(cos_psi)
        dt = np.result_type(c, np.float32)
        u = np.sqrt(np.maximum(0.5 - 0.5 * c.astype(np.float64), 0.0))
        return np.interp(u, self.phase.u, self.phase.beta).astype(dt)

    # ---- per frame -----------------------------------------------------------------------------
    def state(
        self,
        depth_m: float,
        sun_look_water: ArrayLike,
        sun_irradiance_factor: float,
        beam_dop: float,
        e_sun_air: float,
        e_sky_air: float = 0.0,
        *,
        multiple: bool = True,
        night: bool = False,
    ) -> ColumnState:
        """Gather the per-frame scalars.

        Args:
            depth_m: Camera depth below the mean surface, m.
            sun_look_water: (3,) ENU direction towards the refracted sun
                (``RefractedSunBeam.look_dir``).
            sun_irradiance_factor: In-water / in-air normal irradiance of the beam
                (``RefractedSunBeam.irradiance_factor``; 0 at night).
            beam_dop: Fresnel DoP of the beam (``RefractedSunBeam.dop``).
            e_sun_air: Normal irradiance of the sun in air (the sky model's units).
            e_sky_air: Diffuse horizontal irradiance of the sky in air (same units).
            multiple: Interpolate the radiative-transfer table for this frame (False: direct
                and single scattering only, and no table is loaded).
            night: The sky is the night's uniform unpolarized one (its scattered light from
                the table's uniform sky, not the sky model's day sky).

        Returns:
            :class:`ColumnState`.
        """
        z = _check_depth(depth_m)
        if not (e_sun_air >= 0 and e_sky_air >= 0):
            raise ValueError(
                f"e_sun_air and e_sky_air must be >= 0, got {e_sun_air!r}, {e_sky_air!r}"
            )
        w = self.water
        s = np.asarray(sun_look_water, dtype=np.float64).reshape(3)
        s = s / np.linalg.norm(s)
        mu_s = max(float(s[2]), 1e-3)
        e_sun = float(e_sun_air) * max(float(sun_irradiance_factor), 0.0)
        e_sun_plane = e_sun * mu_s
        e_sky_plane = float(e_sky_air) * FLAT_SEA_DIFFUSE_TRANSMITTANCE
        field = None
        if multiple and w.b_per_m > 0 and (e_sun_plane > 0 or e_sky_plane > 0):
            th = math.acos(min(mu_s, 1.0))
            # Each wind node's light with that sea's own sky transmittance (the sky model's light
            # is not uniform over the sky, and waves change how much of it enters), then blended.
            parts, e_sky_nodes = [], []
            for k, wt in self._nodes:
                table, sky, e_sky = rt_table.table_for(k), None, e_sky_plane
                if not night and e_sky_plane > 0:
                    sky = rt_sky.sky_table_for(k, self.sky_key)
                    e_sky = float(e_sky_air) * table.sky_transmittance(sky, th, self.n)
                parts.append((wt, table.frame(th, w.c_per_m * z, e_sun_plane, e_sky, self.n, sky)))
                e_sky_nodes.append(wt * e_sky)
            e_sky_plane = sum(e_sky_nodes)
            field = parts[0][1] if len(parts) == 1 else rt_table.blend(parts)
        return ColumnState(
            depth_m=z,
            tau_c=w.c_per_m * z,
            tau_b=w.b_per_m * z,
            sun_look=s,
            e_sun_normal=e_sun,
            beam_q=float(beam_dop),
            e_sun_plane=e_sun_plane,
            e_sky_plane=e_sky_plane,
            field=field,
            window_cos=math.sqrt(1.0 - 1.0 / self.n**2),
        )

    # ---- per pixel -----------------------------------------------------------------------------
    def render(
        self,
        look_dirs: ArrayLike,
        state: ColumnState,
        window_stokes: ArrayLike | None = None,
        *,
        rotation: ArrayLike | None = None,
        single: bool = True,
        diffuse: bool = True,
        out: FloatArray | None = None,
    ) -> FloatArray:
        """Stokes of everything the camera receives along each ray (meridian reference).

        direct (``window_stokes`` × exp(−c z/v_z)) + single-scattered sun (closed form) + the rest
        of the scattered light (radiative-transfer table).

        Args:
            look_dirs: (..., 3) unit look directions (frame F; ENU when ``rotation`` is None).
            state: This frame's :class:`ColumnState`.
            window_stokes: (..., 3) refracted sky Stokes just below the surface
                (:meth:`surface.SurfaceTransmission.apply`), or None for scattered light only.
            rotation: C_F^n.
            single: Include the single-scattered sun light.
            diffuse: Include the rest of the scattered light (the table).
            out: Optional planar (3, ...) buffer of the look directions' dtype to write into.

        Returns:
            (..., 3) Stokes, a view of planar (3, ...) storage, the look directions' dtype.
        """
        r = as_rotation(rotation)
        flat, shape = flatten_directions(look_dirs)
        dt = flat.dtype
        total = flat.shape[0]
        win_flat = None
        if window_stokes is not None:
            ws = np.asarray(window_stokes)
            if ws.shape != (*shape, 3):
                raise ValueError(f"window_stokes must have shape {(*shape, 3)}, got {ws.shape}")
            win_flat = ws.reshape(-1, 3)
        if out is None:
            out = np.empty((3, *shape), dtype=dt)
        elif out.shape != (3, *shape) or out.dtype != dt:
            raise ValueError(f"out must be a {dt} array of shape {(3, *shape)}, got {out.shape}")
        planes = out.reshape(3, total)
        k = self._kernel_args(state, single, diffuse)
        chunk = min(CHUNK, max(total, 1))
        wbuf = np.empty((3, chunk), dtype=dt)
        buf = np.empty((2, chunk), dtype=dt)
        for i0 in range(0, total, chunk):
            i1 = min(i0 + chunk, total)
            x, y, z = world_components(flat[i0:i1], r, wbuf)
            o = planes[:, i0:i1]
            if k is None:
                o.fill(0.0)
            else:
                column_kernel.scatter_pixels(x, y, z, o, *k)
            if win_flat is not None:
                _direct_block(state.tau_c, z, win_flat[i0:i1], o, buf)
        return np.moveaxis(out, 0, -1)

    def _kernel_args(self, state: ColumnState, single: bool, diffuse: bool) -> tuple | None:
        w = self.water
        do_single = single and state.e_sun_normal > 0.0 and w.b_per_m > 0.0
        f = state.field if diffuse else None
        if not do_single and f is None:
            return None
        s = state.sun_look
        r0 = meridian_reference(-s)
        h = math.hypot(float(s[0]), float(s[1]))
        cphi, sphi = (float(s[0]) / h, float(s[1]) / h) if h > 1e-12 else (1.0, 0.0)
        empty = column_kernel.empty_grid()
        empty_t = np.array([1.0, 0.0])
        return (
            do_single, state.tau_c, w.c_per_m, float(s[0]), float(s[1]), float(s[2]),
            state.e_sun_normal, state.beam_q, float(r0[0]), float(r0[1]), float(r0[2]),
            self._luts, f is not None,
            f.inside if f is not None else empty, f.inside_cos if f is not None else empty_t,
            f.outside if f is not None else empty, f.outside_cos if f is not None else empty_t,
            state.window_cos, math.cos(f.theta_c) if f is not None else 0.5,
            f.dphi if f is not None else 1.0, cphi, sphi,
            f.aureole if f is not None else empty, f.aureole_psi if f is not None else empty_t[:1],
            f.aureole_dom if f is not None else 1.0, f.up if f is not None else empty[:1],
            self.n,
        )  # fmt: skip

    def scattered(
        self, look_dirs: ArrayLike, state: ColumnState, *, rotation: ArrayLike | None = None
    ) -> FloatArray:
        """Stokes of the scattered light only (single + table); see :meth:`render`."""
        return self.render(look_dirs, state, None, rotation=rotation)

    def direct(
        self,
        look_dirs: ArrayLike,
        window_stokes: ArrayLike,
        state: ColumnState,
        *,
        rotation: ArrayLike | None = None,
    ) -> FloatArray:
        """Direct sky light only: ``window_stokes`` × exp(−c z / v_z) (any reference)."""
        return self.render(
            look_dirs, state, window_stokes, rotation=rotation, single=False, diffuse=False
        )

    def single_scattering(
        self, look_dirs: ArrayLike, state: ColumnState, *, rotation: ArrayLike | None = None
    ) -> FloatArray:
        """Stokes of the refracted sun beam scattered once into each ray (module eq. 2)."""
        return self.render(look_dirs, state, rotation=rotation, diffuse=False)

    def single_scattering_radiance(
        self, look_dirs: ArrayLike, state: ColumnState, *, rotation: ArrayLike | None = None
    ) -> FloatArray:
        """Radiance L_ss of an unpolarized sun beam scattered once into each ray (module eq. 2)."""
        st0 = state._replace(beam_q=0.0)
        return self.render(look_dirs, st0, rotation=rotation, diffuse=False)[..., 0]


def _direct_block(
    tau_c: float, z: FloatArray, window: FloatArray, out: FloatArray, buf: FloatArray
) -> None:
    """Out += window Stokes × exp(−c z / v_z⁺) (zero below the horizon, where the window is 0)."""
    m = z.shape[0]
    t = buf[0, :m]
    tmp = buf[1, :m]
    np.maximum(z, 1e-6, out=t)
    np.divide(-tau_c, t, out=t)
    exp_into(t, t)
    for i in range(3):
        np.multiply(window[:, i], t, out=tmp)
        out[i] += tmp
