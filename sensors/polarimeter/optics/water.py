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

The water bodies themselves (Jerlov's types, a plug-in's, a scenario's own IOPs) and their
optical properties: :mod:`sensors.polarimeter.optics.water_body` (re-exported here).
"""

from __future__ import annotations

import math
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
from sensors.polarimeter.optics.water_body import (  # noqa: F401  (re-exported)
    B_SEAWATER_500NM,
    FLAT_SEA_DIFFUSE_TRANSMITTANCE,
    JERLOV_500NM,
    JERLOV_TYPES,
    KIRK_G,
    PETZOLD_BACKSCATTER_RATIO,
    WaterBody,
    WaterOptics,
    _check_depth,
    _check_water_body,
    jerlov_water,
    optical_depths,
)
from sensors.polarimeter.stokes import meridian_reference
from twin.core.arrays import FloatArray

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
