"""The polarized radiative-transfer reference: Stokes radiance over in-water directions at depth.

``solve(water, source=...)`` runs the forward Monte Carlo of
:mod:`sensors.polarimeter.optics.rt.kernel`
for one water body and one source — the refracted sun beam at an in-water zenith angle, or the
sky's light through the surface (the sky model's radiance and polarization for that sun, or a
uniform unpolarized sky) — and returns a :class:`LightField`: the Stokes radiance (I, Q, U) of the
scattered light in look-direction bins (zenith θ of the look direction v, azimuth relative to the
sun folded onto [0, π]; the field is mirror-symmetric about the sun's vertical plane) on a set of
depth planes, split into the once-scattered light and the rest, with its Monte Carlo standard
error from independent batches; the up- and downwelling irradiances (direct light included) at
every plane, from the photons' plane crossings; and the energy budget.

Radiance is scored by binned plane crossings (:mod:`~sensors.polarimeter.optics.rt.kernel` says
why):
a bin's value is the flux its photons carry through the plane divided by ∫_bin |cos θ| dΩ (its
|μ|-weighted mean radiance, finite even in the bins at the horizon). The bins are coarse (3–10° in
look zenith, 15° in azimuth) because the scattered light they hold is smooth: the sharp parts —
the direct light and the once-scattered aureole — are computed in closed form by the renderer.

Units: everything is per unit downwelling (plane) irradiance of the source just below the surface,
so the renderer scales by the beam's or the sky's transmitted irradiance. Stokes use the chain's
meridian reference (:func:`sensors.polarimeter.stokes.meridian_reference` of the light's direction
d = −v).

Geometry and optics: plane-parallel homogeneous water, deep (photons below ``tau_bottom`` are lost;
the default is the deepest plane + 20 optical depths, where the light is e^-(≳ 5) weaker than at the
deepest plane even in the most scattering water), a flat surface with index n (Fresnel reflection
of the upwelling light from below, total internal reflection beyond the critical angle) or a
Cox–Munk sea (isotropic Gaussian slopes for a wind speed; the light enters through, and is
reflected from below by, facets drawn with their projected areas; no wave shadowing), the
phase matrix of :mod:`sensors.polarimeter.optics.scattering`. One wavelength: the water's IOPs are
given
at one wavelength, and the result is for that wavelength.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from sensors.polarimeter.optics import scattering
from sensors.polarimeter.optics.rt import kernel
from sensors.polarimeter.optics.sky import SkySpec, sky_radiance
from sensors.polarimeter.optics.surface import N_AIR, fresnel_elements
from sensors.polarimeter.optics.waves import cox_munk_variances
from twin.core.arrays import FloatArray

#: Default depth planes, optical depths τ = c z (0 is just below the surface).
DEFAULT_PLANES: tuple[float, ...] = (
    0.0, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.5, 7.0, 9.0, 12.0, 16.0,
    20.0, 25.0, 30.0,
)  # fmt: skip


#: Edges (degrees from the refracted sun) of the sun's aureole tally: fine where the multiply
#: scattered light of a forward-peaked phase function changes fastest (rings of 0.25° next to the
#: sun), to 30°; the renderer takes the aureole from here and only the rest from the coarse bins.
AUREOLE_PSI_EDGES_DEG: tuple[float, ...] = (
    0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0, 8.0, 10.0, 12.0, 14.0,
    16.0, 18.0, 20.0, 23.0, 26.0, 30.0,
)  # fmt: skip


def look_zenith_edges_deg(n_water: float) -> FloatArray:
    """Look-zenith bin edges (degrees), with an edge exactly at Snell's window's θ_c.

    ~3° inside the window, ~4° from its edge (where the upwelling light's total internal
    reflection starts) to the horizon, 10° below it (the upwelling light is smooth).
    """
    tc = math.degrees(math.asin(1.0 / n_water))
    inside = np.linspace(0.0, tc, math.ceil(tc / 3.0) + 1)
    outside = np.linspace(tc, 90.0, math.ceil((90.0 - tc) / 4.0) + 1)[1:]
    below = np.linspace(90.0, 180.0, 10)[1:]
    return np.concatenate([inside, outside, below])


@dataclass(frozen=True, slots=True)
class Grid:
    """Where the reference scores light.

    Attributes:
        planes: Optical depths c z of the scoring planes (ascending, the first 0).
        theta_edges_deg: Look-zenith bin edges, 0 … 180°.
        n_phi: Relative-azimuth bins over [0°, 180°].
        aureole_psi_edges_deg: The sun's aureole tally: bin edges in ψ, the angle of the look
            direction from the refracted sun (0 … its last edge); empty: no aureole tally.
        aureole_n_omega: Its bins in position angle about the sun, over [0°, 180°] from the
            sun's upward side (folded as the azimuth is).
    """

    planes: tuple[float, ...] = DEFAULT_PLANES
    theta_edges_deg: tuple[float, ...] = field(
        default_factory=lambda: tuple(look_zenith_edges_deg(1.34).tolist())
    )
    n_phi: int = 12
    aureole_psi_edges_deg: tuple[float, ...] = AUREOLE_PSI_EDGES_DEG
    aureole_n_omega: int = 6

    def __post_init__(self) -> None:
        p = np.asarray(self.planes, dtype=float)
        if p.size < 1 or p[0] != 0.0 or np.any(np.diff(p) <= 0) or not np.all(np.isfinite(p)):
            raise ValueError(f"planes must be ascending optical depths from 0, got {self.planes}")
        t = np.asarray(self.theta_edges_deg, dtype=float)
        if t[0] != 0.0 or t[-1] != 180.0 or np.any(np.diff(t) <= 0):
            raise ValueError("theta_edges_deg must rise from 0 to 180")
        if not (1 <= self.n_phi <= 360):
            raise ValueError(f"n_phi must be in [1, 360], got {self.n_phi}")
        a = np.asarray(self.aureole_psi_edges_deg, dtype=float)
        if a.size and (a[0] != 0.0 or np.any(np.diff(a) <= 0) or a[-1] > 60.0):
            raise ValueError("aureole_psi_edges_deg must rise from 0 to at most 60")
        if not (1 <= self.aureole_n_omega <= 36):
            raise ValueError(f"aureole_n_omega must be in [1, 36], got {self.aureole_n_omega}")

    def aureole_solid_angle_mu(self, sun_zenith_water_rad: float, n: int = 48) -> FloatArray:
        """(n_ψ, n_ω) ∫_bin |cos θ| dΩ of each folded aureole bin (both mirror halves).

        Numerical (midpoint rule, ``n`` × ``n`` per bin): a bin about the sun is not a zenith
        band, and |cos θ| varies over it.
        """
        edges = np.radians(np.asarray(self.aureole_psi_edges_deg, dtype=float))
        n_om = self.aureole_n_omega
        out = np.zeros((max(edges.size - 1, 0), n_om))
        st, ct = math.sin(sun_zenith_water_rad), math.cos(sun_zenith_water_rad)
        for i in range(edges.size - 1):
            psi = edges[i] + (np.arange(n) + 0.5) * (edges[i + 1] - edges[i]) / n
            for j in range(n_om):
                om = (j + (np.arange(n) + 0.5) / n) * math.pi / n_om
                p, o = np.meshgrid(psi, om, indexing="ij")
                # v = cos ψ ŝ + sin ψ (cos ω e_up + sin ω ŷ), e_up = (−cos θ_s, 0, sin θ_s).
                vz = np.cos(p) * ct + np.sin(p) * np.cos(o) * st
                d_omega = np.sin(p) * (edges[i + 1] - edges[i]) / n * (math.pi / n_om / n)
                out[i, j] = 2.0 * float(np.sum(np.abs(vz) * d_omega))
        return out

    def solid_angle_mu(self) -> FloatArray:
        """(T, n_phi) ∫_bin |cos θ| dΩ of each folded bin (both mirror halves)."""
        t = np.radians(np.asarray(self.theta_edges_deg))
        s2 = np.sin(t) ** 2
        # ∫ |cos θ| sin θ dθ over [t0, t1] = |sin²t1 − sin²t0|/2 on one side of the horizon.
        per = np.abs(np.diff(s2)) / 2.0
        straddle = (t[:-1] < math.pi / 2) & (t[1:] > math.pi / 2)
        per[straddle] = (1.0 - s2[:-1][straddle]) / 2.0 + (1.0 - s2[1:][straddle]) / 2.0
        dphi = 2.0 * math.pi / self.n_phi  # folded: two mirror bins of π/n_phi each
        return np.repeat(per[:, None], self.n_phi, axis=1) * dphi

    def centers_deg(self) -> tuple[FloatArray, FloatArray]:
        """(look zenith, relative azimuth) bin centres in degrees."""
        t = np.asarray(self.theta_edges_deg)
        ph = (np.arange(self.n_phi) + 0.5) * 180.0 / self.n_phi
        return 0.5 * (t[1:] + t[:-1]), ph


@dataclass(frozen=True)
class LightField:
    """The reference's answer for one water body and one source (module docstring for units).

    Attributes:
        grid: Where it was scored.
        source: "sun" or "sky".
        sun_zenith_water_deg: In-water zenith of the refracted sun (for the sky: of the sun the
            sky model was evaluated for).
        single: (P, T, n_phi, 3) once-scattered, never-reflected Stokes radiance per bin.
        multiple: (P, T, n_phi, 3) all other scattered light (a surface reflection included).
        single_se, multiple_se: Their standard errors (batch means).
        aureole: (P, n_ψ, n_ω, 3) the ``multiple`` light that the surface has not reflected,
            tallied again about the refracted sun (:attr:`Grid.aureole_psi_edges_deg`; the sun
            source only, else empty).
        aureole_se: Its standard error.
        e_down, e_up: (P,) downwelling and upwelling plane irradiance (direct light included).
        e_down_se, e_up_se: Their standard errors.
        absorbed: (P,) absorption in the layer below each plane.
        escaped_up: Leaving through the surface.
        lost_bottom: Lost below ``tau_bottom``.
        roulette_net: Roulette losses minus gains (zero in expectation).
        photons: Histories run.
        omega0: b/c.
        c_per_m: Beam attenuation of the water (to turn optical depths into metres).
        n_water: The surface's index.
        wind_speed_mps: The Cox–Munk sea's wind (0: flat).
        surface_transmittance: The share of the source's downwelling irradiance in air that
            the surface lets in (flat: Fresnel, closed form; rough: the photons' mean facet
            transmittance).
    """

    grid: Grid
    source: str
    sun_zenith_water_deg: float
    single: FloatArray
    multiple: FloatArray
    single_se: FloatArray
    multiple_se: FloatArray
    aureole: FloatArray
    aureole_se: FloatArray
    e_down: FloatArray
    e_up: FloatArray
    e_down_se: FloatArray
    e_up_se: FloatArray
    absorbed: FloatArray
    escaped_up: float
    lost_bottom: float
    roulette_net: float
    photons: int
    omega0: float
    c_per_m: float
    n_water: float
    wind_speed_mps: float = 0.0
    surface_transmittance: float = math.nan

    @property
    def total(self) -> FloatArray:
        """All scattered light, single + multiple."""
        return self.single + self.multiple

    def total_se(self, k: int) -> FloatArray:
        """Standard error of :attr:`total` at plane k.

        Single and multiple added in quadrature (they share histories: an approximation).
        """
        return np.hypot(self.single_se[k], self.multiple_se[k])

    def total_se_all(self) -> FloatArray:
        """:meth:`total_se` at every plane, (P, T, n_phi, 3)."""
        return np.hypot(self.single_se, self.multiple_se)

    def depths_m(self) -> FloatArray:
        """The planes' depths in metres."""
        return np.asarray(self.grid.planes) / self.c_per_m


def beam_polarization(sun_zenith_air_rad: float, n_water: float) -> float:
    """Q/I (meridian reference) of unpolarized sunlight after Fresnel transmission."""
    e = fresnel_elements(math.cos(sun_zenith_air_rad), N_AIR, n_water, "flux")
    m00 = float(e.m00)
    return float(e.m01) / m00 if m00 > 0 else 0.0


@dataclass(frozen=True)
class SkySource:
    """A sky's light just below a flat surface, as the kernel draws its photons (source 1).

    The sky above is gridded in air zenith (rows uniform in sin²θ_a, so that a cell's share of
    the flux through a plane is its radiance times its area in sin²θ_a: cosine weighting) and in
    azimuth from the sun's (full circle: the sky's polarization is odd under the mirror). Each
    cell's Stokes is the sky model's at its centre, through the Fresnel transmission Mueller
    matrix of the flat surface (whose plane of incidence is the meridian plane, so the meridian
    reference is the p-axis on both sides).

    Attributes:
        cdf: (N + 1,) cumulative transmitted flux over the cells, from 0 to 1.
        s2_edges: (n_θ + 1,) row edges in sin²θ_a.
        qu: (N, 2) transmitted (Q/I, U/I) per cell, meridian reference.
        cdf_air: (N + 1,) cumulative incident flux over the cells (a rough sea's source).
        qu_air: (N, 2) (Q/I, U/I) per cell in air.
        transmittance: Transmitted / incident downwelling plane irradiance (the flat sea's
            diffuse transmittance for this sky).
    """

    cdf: FloatArray
    s2_edges: FloatArray
    qu: FloatArray
    cdf_air: FloatArray
    qu_air: FloatArray
    transmittance: float


def sky_source(
    sky: SkySpec | None,
    sun_zenith_air_deg: float,
    n_water: float,
    n_theta: int = 64,
    n_phi: int = 72,
) -> SkySource:
    """The sky model's light below a flat surface (``sky=None``: a uniform unpolarized sky).

    The solar disc is not part of it (the sun is source 0). Sun in the x–z plane at azimuth 0.
    """
    s2_edges = np.linspace(0.0, 1.0, n_theta + 1)
    s2 = 0.5 * (s2_edges[1:] + s2_edges[:-1])
    phi = (np.arange(n_phi) + 0.5) * (2.0 * math.pi / n_phi)
    sin_a, cos_a = np.sqrt(s2), np.sqrt(1.0 - s2)
    dirs = np.stack(
        [
            sin_a[:, None] * np.cos(phi)[None, :],
            sin_a[:, None] * np.sin(phi)[None, :],
            np.broadcast_to(cos_a[:, None], (n_theta, n_phi)),
        ],
        axis=-1,
    )
    if sky is None:
        st = np.zeros((n_theta, n_phi, 3))
        st[..., 0] = 1.0
    else:
        zs = math.radians(sun_zenith_air_deg)
        sun = np.array([math.sin(zs), 0.0, math.cos(zs)])
        no_disc = dataclasses.replace(sky, sun_relative_radiance=0.0)
        st = np.asarray(sky_radiance(dirs, sun, no_disc).stokes, dtype=np.float64)
    e = fresnel_elements(cos_a, N_AIR, n_water, "flux")
    m00, m01, m22 = (np.asarray(x, dtype=float)[:, None] for x in (e.m00, e.m01, e.m22))
    i_t = m00 * st[..., 0] + m01 * st[..., 1]
    q_t = m01 * st[..., 0] + m00 * st[..., 1]
    u_t = m22 * st[..., 2]
    # Equal cells in sin²θ_a and φ: a cell's plane flux is proportional to its radiance.
    total_in = float(np.sum(st[..., 0]))
    total_t = float(np.sum(i_t))
    if not (total_in > 0 and total_t > 0):
        raise ValueError("the sky sends no light into the water")

    def cdf_of(x: FloatArray) -> FloatArray:
        c = np.concatenate([[0.0], np.cumsum(x.ravel()) / float(np.sum(x))])
        c[-1] = 1.0
        return c

    def ratios(i: FloatArray, q: FloatArray, u: FloatArray) -> FloatArray:
        with np.errstate(invalid="ignore", divide="ignore"):
            qu = np.stack([np.where(i > 0, q / i, 0.0), np.where(i > 0, u / i, 0.0)], -1)
        return np.ascontiguousarray(qu.reshape(-1, 2))

    return SkySource(
        cdf_of(i_t),
        s2_edges,
        ratios(i_t, q_t, u_t),
        cdf_of(st[..., 0]),
        ratios(st[..., 0], st[..., 1], st[..., 2]),
        total_t / total_in,
    )


def solve(
    a_per_m: float,
    b_molecular_per_m: float,
    b_particle_per_m: float,
    particle_backscatter_ratio: float,
    *,
    particle_dop_max: float = scattering.PARTICLE_DOP_MAX,
    depolarization_ratio: float = scattering.WATER_DEPOLARIZATION_RATIO,
    source: str = "sun",
    sun_zenith_air_deg: float = 30.0,
    sky: SkySpec | None = None,
    wind_speed_mps: float = 0.0,
    n_water: float = 1.34,
    grid: Grid | None = None,
    photons: int = 200_000,
    batches: int = 10,
    seed: int | np.random.Generator = 0,
    tau_bottom: float | None = None,
) -> LightField:
    """Run the reference for one water body and one source.

    Args:
        a_per_m: Absorption a.
        b_molecular_per_m: Molecular scattering b_w.
        b_particle_per_m: Particle scattering b_p.
        particle_backscatter_ratio: b_bp/b_p (sets the Fournier–Forand slope).
        particle_dop_max: The particles' peak linear polarization P.
        depolarization_ratio: The water molecules' depolarization ratio δ.
        source: "sun" (the refracted beam of a sun at ``sun_zenith_air_deg``) or "sky" (the
            sky's light through the surface, the solar disc excluded).
        sun_zenith_air_deg: The sun's zenith angle in air, [0, 90).
        sky: The sky model for ``source="sky"`` (radiance distribution and polarization for
            the sun at ``sun_zenith_air_deg``); None: a uniform unpolarized sky.
        wind_speed_mps: Wind at 12.5 m for a Cox–Munk sea (clean surface, isotropic with the
            total mean square slope σ_c² + σ_u² of
            :func:`sensors.polarimeter.optics.waves.cox_munk_variances`); 0 = a flat sea.
        n_water: Water index.
        grid: Scoring planes and nodes (default :class:`Grid`).
        photons: Histories in all (split over ``batches``).
        batches: Independent batches for the standard errors (>= 2).
        seed: Seed or numpy Generator; each batch's kernel seed is drawn from it.
        tau_bottom: Depth (optical) of the black, deep bottom; default deepest plane + 20.

    Returns:
        :class:`LightField`.
    """
    if source not in ("sun", "sky"):
        raise ValueError(f"source must be 'sun' or 'sky', got {source!r}")
    if not (0.0 <= sun_zenith_air_deg < 90.0):
        raise ValueError(f"sun_zenith_air_deg must lie in [0, 90), got {sun_zenith_air_deg!r}")
    if not (a_per_m > 0 and b_molecular_per_m >= 0 and b_particle_per_m >= 0):
        raise ValueError("a must be > 0 and b_w, b_p >= 0")
    if b_molecular_per_m + b_particle_per_m <= 0:
        raise ValueError("the water must scatter (b_w + b_p > 0)")
    if batches < 2 or photons < batches:
        raise ValueError(f"need batches >= 2 and photons >= batches, got {photons}, {batches}")
    g = grid or Grid()
    b = b_molecular_per_m + b_particle_per_m
    c = a_per_m + b
    omega0 = b / c
    pm = scattering.phase_matrix(
        b_molecular_per_m,
        b_particle_per_m,
        particle_backscatter_ratio,
        particle_dop_max=particle_dop_max,
        depolarization_ratio=depolarization_ratio,
    )
    icdf = scattering.inverse_cdf_cos(pm)
    mu_table = np.stack([pm.beta, pm.m12, pm.m22, pm.m33, pm.m44])
    planes = np.asarray(g.planes, dtype=np.float64)
    bottom = float(planes[-1] + 20.0) if tau_bottom is None else float(tau_bottom)
    if bottom <= planes[-1]:
        raise ValueError("tau_bottom must lie below the deepest plane")
    edges_cos = np.cos(np.radians(np.asarray(g.theta_edges_deg, dtype=np.float64)))
    edges_cos[0], edges_cos[-1] = 1.0, -1.0
    n_t, n_p = len(g.theta_edges_deg) - 1, g.n_phi
    aur_edges = np.asarray(g.aureole_psi_edges_deg if source == "sun" else (), dtype=float)
    aur_cos = np.cos(np.radians(aur_edges)) if aur_edges.size else np.ones(1)
    n_psi, n_om = max(aur_edges.size - 1, 0), g.aureole_n_omega
    sky_src = sky_source(sky if source == "sky" else None, sun_zenith_air_deg, n_water)
    # The refracted sun (the sky source ignores it but is labelled with it).
    theta_w = math.asin(math.sin(math.radians(sun_zenith_air_deg)) / n_water)
    beam_q = beam_polarization(math.radians(sun_zenith_air_deg), n_water) if source == "sun" else 0
    slope_sigma = math.sqrt(0.5 * sum(cox_munk_variances(wind_speed_mps)))
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    seeds = rng.integers(0, 2**31 - 1, size=batches)
    n_pl = len(planes)
    per_batch = [photons // batches + (1 if i < photons % batches else 0) for i in range(batches)]
    rads, aurs, irrs, fluxes = [], [], [], []
    absorbed = np.zeros(n_pl)
    totals = np.zeros(4)
    for nb, sd in zip(per_batch, seeds, strict=True):
        rad = np.zeros((2, n_pl, n_t, n_p, 3))
        aur = np.zeros((n_pl, n_psi, n_om, 3))
        irr = np.zeros((n_pl, 2))
        flux = np.zeros(1)
        kernel.transport(
            nb, int(sd), 0 if source == "sun" else 1, theta_w, beam_q, omega0, n_water,
            slope_sigma, math.radians(sun_zenith_air_deg), icdf, mu_table, sky_src.cdf,
            sky_src.s2_edges, sky_src.qu, sky_src.cdf_air, sky_src.qu_air, planes, bottom,
            edges_cos, n_p, rad, aur, aur_cos, irr, absorbed, totals, flux,
        )  # fmt: skip
        # Per unit downwelling irradiance below the surface (a flat sea: per history).
        rads.append(rad / flux[0])
        aurs.append(aur / flux[0])
        irrs.append(irr / flux[0])
        fluxes.append(flux[0])
    rad_b = np.stack(rads) / g.solid_angle_mu()[None, None, None, :, :, None]
    aur_b = np.stack(aurs)
    if n_psi:
        aur_b = aur_b / g.aureole_solid_angle_mu(theta_w)[None, None, :, :, None]
    irr_b = np.stack(irrs)
    src_total = float(sum(fluxes))
    if slope_sigma > 0.0:
        t_surface = src_total / photons
    elif source == "sun":
        cz = math.cos(math.radians(sun_zenith_air_deg))
        t_surface = float(fresnel_elements(cz, N_AIR, n_water, "flux").m00)
    else:
        t_surface = sky_src.transmittance
    wts = np.asarray(fluxes, dtype=float) / src_total

    def mean_se(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        m = np.tensordot(wts, x, axes=1)
        se = np.std(x, axis=0, ddof=1) / math.sqrt(len(x))
        return m, se

    rm, rse = mean_se(rad_b)
    am, ase = mean_se(aur_b)
    im, ise = mean_se(irr_b)
    return LightField(
        grid=g,
        source=source,
        sun_zenith_water_deg=math.degrees(theta_w),
        single=rm[0],
        multiple=rm[1],
        single_se=rse[0],
        multiple_se=rse[1],
        aureole=am,
        aureole_se=ase,
        e_down=im[:, 0],
        e_up=im[:, 1],
        e_down_se=ise[:, 0],
        e_up_se=ise[:, 1],
        absorbed=absorbed / src_total,
        escaped_up=float(totals[0] / src_total),
        lost_bottom=float(totals[1] / src_total),
        roulette_net=float((totals[2] - totals[3]) / src_total),
        wind_speed_mps=float(wind_speed_mps),
        surface_transmittance=t_surface,
        photons=int(photons),
        omega0=omega0,
        c_per_m=c,
        n_water=float(n_water),
    )
