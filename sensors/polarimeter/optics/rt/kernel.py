"""The photon-transport kernel of the radiative-transfer reference (numba, one thread).

Forward Monte Carlo of polarized light in a plane-parallel, homogeneous, deep water column under a
flat surface. Why forward Monte Carlo with binned plane crossings:

* the fast renderer needs the whole radiance distribution at many depths, and a forward history
  scores every plane it crosses, so one run gives every direction at every depth of the table;
* sea water's phase function is so strongly forward-peaked (half the particle scattering within
  ~4°) that discrete ordinates or adding–doubling need hundreds of streams, or a δ-M truncation
  that removes exactly the near-sun light a compass looks at; Monte Carlo samples the peak exactly;
* local (next-event) estimates towards fixed directions were tried and measured: for this phase
  function the radiance in a direction is mostly light already travelling near it, so the
  estimate is heavy-tailed (10–25 % standard error per direction at 10⁴ histories, at ~100 times
  the cost per history of a crossing);
* photon bookkeeping makes energy conservation a check rather than an assumption.

Conventions (see :mod:`sensors.polarimeter.stokes`): ENU axes, z up; depth as optical depth τ = c z
(positive down), so a photon travelling along d moves dτ = −d_z ds. Stokes (I, Q, U, V) relative
to a reference unit vector r ⟂ d; the E-vector at ψ from r is cos ψ r + sin ψ (d × r). The sun's
look direction lies in the x–z plane (azimuth 0), so the field is mirror-symmetric about it and
the tallies fold the azimuth onto [0, π] (U and V change sign under the mirror).

Per history: implicit capture (the Stokes vector is multiplied by ω₀ = b/c at each collision and
the loss scored as absorption in that layer), Russian roulette below 1e-4 of the start weight
(survival 1/10); scattering angle Θ from the inverse-CDF table, scattering-plane azimuth uniform,
and the full Mueller matrix applied, so the Stokes vector itself carries the polarization-dependent
azimuth weight (unbiased: the mean of 1 + m12 (Q cos 2φ + U sin 2φ)/I over φ is 1). At the
surface the photon is split deterministically: the transmitted share escapes (scored), the
Fresnel-reflected Stokes vector (total internal reflection beyond the critical angle, with its
retardance) goes on. A plane crossing scores the photon's Stokes vector, turned to the local
meridian reference of its direction, into the bin of its look direction v = −d: class 0 if it has
been scattered exactly once and never reflected (the closed-form single scattering of
:mod:`sensors.polarimeter.optics.water`), class 1 otherwise; unscattered photons score only
irradiance.
"""

from __future__ import annotations

import math

import numpy as np

from sensors.polarimeter.optics.rt.surface_kernel import (
    enter_facet,
    facet,
    meridian,
    reflect_facet,
    reflect_from_below,
    rotate,
)
from twin.core.kernel_cache import njit

ROULETTE_WEIGHT = 1e-4
ROULETTE_SURVIVAL = 0.1


@njit(cache=True, inline="always")
def lut_at(table, row, cos_theta):
    """Row ``row`` of a phase-matrix table uniform in u = sin(Θ/2), linearly interpolated at Θ.

    Shared by this kernel and :mod:`sensors.polarimeter.optics.column_kernel`, so that the reference
    and
    the renderer read the phase matrix the same way.
    """
    j, f = lut_index(table, cos_theta)
    return table[row, j] * (1.0 - f) + table[row, j + 1] * f


@njit(cache=True, inline="always")
def lut_index(table, cos_theta):
    """The node j and fraction f of :func:`lut_at` at Θ (one square root for all the rows)."""
    k = table.shape[1] - 1
    uu = math.sqrt(max(0.5 - 0.5 * cos_theta, 0.0)) * k
    j = int(uu)
    if j >= k:
        j = k - 1
    return j, uu - j


@njit(cache=True)
def _seed(seed: int) -> None:
    np.random.seed(seed)


@njit(cache=True)
def _score(rad, irr, k, cls, ph, scattered, edges_cos, n_phi, aur, aur_cos, ssx, ssz):
    """Score one crossing of plane k by a photon ph = (d, r, I, Q, U).

    Irradiance always; radiance (in the look direction's bin) only if the photon has scattered
    (class 0: once, never reflected; 1: more, never reflected; 2: reflected by the surface, tallied
    with 1); and, for class 1 — never reflected, so that the surface's reflection, which the
    renderer computes itself, is not in it — within the aureole's last edge of the look direction
    towards the refracted sun (ssx, 0, ssz), into the aureole tally ``aur`` (P, n_ψ, n_ω, 3):
    ψ bins with edges ``aur_cos`` (cos ψ, descending), position angle ω about the sun from its
    upward side, folded onto [0, π] as the azimuth is (U changes sign).
    """
    dx, dy, dz, rx, ry, rz, si, sq, su = ph
    if dz < 0.0:
        irr[k, 0] += si
    else:
        irr[k, 1] += si
    if not scattered:
        return
    vz = -dz
    # Look-zenith bin: edges are given as cos θ, decreasing from 1 to −1.
    lo = 0
    hi = edges_cos.shape[0] - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if vz <= edges_cos[mid]:
            lo = mid
        else:
            hi = mid
    phi = math.atan2(-dy, -dx)
    mirror = phi < 0.0
    pj = int(abs(phi) / math.pi * n_phi)
    if pj >= n_phi:
        pj = n_phi - 1
    mx, my, mz = meridian(dx, dy, dz)
    # χ from r to the meridian about d, without trigonometry.
    c1 = rx * mx + ry * my + rz * mz
    s1 = (ry * mz - rz * my) * dx + (rz * mx - rx * mz) * dy + (rx * my - ry * mx) * dz
    nrm = c1 * c1 + s1 * s1
    c2 = (c1 * c1 - s1 * s1) / nrm
    s2 = 2.0 * c1 * s1 / nrm
    q = c2 * sq + s2 * su
    u = -s2 * sq + c2 * su
    if mirror:
        u = -u
    tally = min(cls, 1)
    rad[tally, k, lo, pj, 0] += si
    rad[tally, k, lo, pj, 1] += q
    rad[tally, k, lo, pj, 2] += u
    n_psi = aur_cos.shape[0] - 1
    if cls == 1 and n_psi > 0:
        cpsi = -(dx * ssx + dz * ssz)
        if cpsi > aur_cos[n_psi]:
            a = 0
            b = n_psi
            while b - a > 1:
                mid = (a + b) // 2
                if cpsi <= aur_cos[mid]:
                    a = mid
                else:
                    b = mid
            # ω from the sun's upward side e_up = (−cos θ_s, 0, sin θ_s), the side axis y.
            up = -dx * -ssz + -dz * ssx
            side = abs(dy)
            n_om = aur.shape[2]
            oj = int(math.atan2(side, up) / math.pi * n_om)
            if oj >= n_om:
                oj = n_om - 1
            aur[k, a, oj, 0] += si
            aur[k, a, oj, 1] += q
            aur[k, a, oj, 2] += u


@njit(cache=True)
def _score_segment(
    rad, irr, planes, tau_a, tau_b, cls, ph, scattered, edges_cos, n_phi, aur, aur_cos, ssx, ssz
):
    """Score every plane k >= 1 a flight from τ_a to τ_b crosses (plane 0 is the surface's)."""
    n = planes.shape[0]
    if tau_b > tau_a:
        for k in range(1, n):
            if tau_a < planes[k] <= tau_b:
                _score(rad, irr, k, cls, ph, scattered, edges_cos, n_phi, aur, aur_cos, ssx, ssz)
    else:
        for k in range(n - 1, 0, -1):
            if tau_b <= planes[k] < tau_a:
                _score(rad, irr, k, cls, ph, scattered, edges_cos, n_phi, aur, aur_cos, ssx, ssz)


@njit(cache=True, inline="always")
def _draw_sky(cdf, s2_edges, n_cols):
    """A sky photon: its cell, its sin²θ_a and its azimuth (uniform within the cell).

    The cell is the first whose cumulative flux exceeds a uniform draw (binary search).
    """
    x = np.random.random()
    lo = 0
    hi = cdf.shape[0] - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if cdf[mid] <= x:
            lo = mid
        else:
            hi = mid
    row = lo // n_cols
    col = lo - row * n_cols
    s2 = s2_edges[row] + np.random.random() * (s2_edges[row + 1] - s2_edges[row])
    phi = (col + np.random.random()) * (2.0 * math.pi / n_cols)
    return lo, s2, phi


@njit(cache=True)
def _roulette(si, sq, su, sv, start, totals):
    """Russian roulette below ROULETTE_WEIGHT of the start weight.

    Unbiased: the survivors gain what the others lose, in expectation; both are tallied.
    """
    if si >= ROULETTE_WEIGHT * start:
        return True, si, sq, su, sv
    if np.random.random() < ROULETTE_SURVIVAL:
        f = 1.0 / ROULETTE_SURVIVAL
        totals[3] += si * (f - 1.0)
        return True, si * f, sq * f, su * f, sv * f
    totals[2] += si
    return False, si, sq, su, sv


@njit(cache=True)
def transport(
    n_photons: int,
    seed: int,
    source: int,
    sun_theta: float,
    beam_q: float,
    omega0: float,
    n_water: float,
    slope_sigma: float,
    sun_theta_air: float,
    icdf_cos,
    mu_table,
    sky_cdf,
    sky_s2_edges,
    sky_qu,
    sky_cdf_air,
    sky_qu_air,
    planes,
    tau_bottom: float,
    edges_cos,
    n_phi: int,
    rad,
    aur,
    aur_cos,
    irr,
    absorbed,
    totals,
    source_flux,
):
    """Run ``n_photons`` histories, adding their scores into the tally arrays.

    Args:
        n_photons: Histories to run.
        seed: Seed of numba's generator for this call.
        source: 0 = the refracted sun beam (every photon starts along it), 1 = a sky refracted
            by the surface (start directions drawn from the sky grid ``sky_cdf``).
        sun_theta: In-water zenith angle of the refracted sun (source 0), radians.
        beam_q: Q/I of the beam relative to its meridian (Fresnel p-polarization, source 0).
        omega0: Single-scattering albedo b/c.
        n_water: Refractive index of the water (surface reflection from below).
        slope_sigma: Cox–Munk slope σ per component (isotropic; 0 = a flat sea). On a rough sea
            every photon enters through a facet drawn by :func:`facet` (Fresnel at the facet,
            its transmitted flux the photon's start weight) and meets a facet each time it
            comes up to the surface (reflected there until it heads down).
        sun_theta_air: The sun's zenith in air (source 0 on a rough sea).
        icdf_cos: (K,) cos Θ at uniform probabilities (:func:`scattering.inverse_cdf_cos`).
        mu_table: (5, M) β-table rows m12, m22, m33, m44 against u = sin(Θ/2) uniform in [0, 1]
            (row 0 unused).
        sky_cdf: (N + 1,) cumulative transmitted flux of the sky grid's cells, 0 … 1 (source 1);
            cell c = i n_s + j is air zenith row i (edges ``sky_s2_edges`` in sin²θ_a) and
            azimuth column j of n_s = N / (len(sky_s2_edges) − 1) over [0, 2π) from the sun's.
        sky_s2_edges: (n_θ + 1,) the rows' edges in sin²θ_a (within a cell the start direction is
            uniform in sin²θ_a and φ: cosine-weighted, as the flux through a plane is).
        sky_qu: (N, 2) each cell's transmitted (Q/I, U/I), meridian reference.
        sky_cdf_air: (N + 1,) as ``sky_cdf`` for the light in air, before the surface (a rough
            sea, where the transmission is the facet's).
        sky_qu_air: (N, 2) the cells' (Q/I, U/I) in air.
        planes: (P,) optical depths of the scoring planes, ascending, planes[0] = 0 (just below
            the surface).
        tau_bottom: Optical depth below which photons are lost downwards (deep water).
        edges_cos: (T + 1,) look-zenith bin edges as cos θ, from 1 down to −1.
        n_phi: Relative-azimuth bins over [0, π].
        rad: (2, P, T, n_phi, 3) radiance tallies Σ (I, Q, U) per class (meridian reference).
        aur: (P, n_ψ, n_ω, 3) the multiply scattered light's tallies about the refracted sun
            (:func:`_score`); source 1 passes ``aur_cos`` with one entry (no aureole).
        aur_cos: (n_ψ + 1,) the aureole's ψ edges as cos ψ, from 1 down.
        irr: (P, 2) down-/up-going crossings Σ I.
        absorbed: (P,) absorption in the layer below each plane.
        totals: (4,) escaped through the surface, lost at the bottom, lost to roulette, gained
            from roulette.
        source_flux: (1,) Σ of the start weights (the downwelling irradiance the source puts
            below the surface; the number of histories on a flat sea).
    """
    _seed(seed)
    ssx = math.sin(sun_theta)
    ssz = math.cos(sun_theta)
    n_planes = planes.shape[0]
    k_icdf = icdf_cos.shape[0] - 1
    n_cells = sky_cdf.shape[0] - 1
    n_rows = sky_s2_edges.shape[0] - 1
    n_cols = max(n_cells // max(n_rows, 1), 1)
    for _ in range(n_photons):
        # ---- start just below the surface -----------------------------------------------------
        if slope_sigma <= 0.0:
            # A flat sea: straight from the transmitted source.
            if source == 0:
                st = math.sin(sun_theta)
                ct = math.cos(sun_theta)
                phi0 = 0.0
                w0 = 1.0
                q0 = beam_q
                u0 = 0.0
            else:
                lo, s2, phi0 = _draw_sky(sky_cdf, sky_s2_edges, n_cols)
                st = math.sqrt(max(s2, 0.0)) / n_water  # Snell: sin θ_w = sin θ_a / n
                ct = math.sqrt(max(1.0 - st * st, 0.0))
                w0 = 1.0
                q0 = sky_qu[lo, 0]
                u0 = sky_qu[lo, 1]
            # Travelling down, away from the source at azimuth phi0.
            cp = math.cos(phi0)
            sp = math.sin(phi0)
            dx = -st * cp
            dy = -st * sp
            dz = -ct
            # Reference: the meridian (⟂ d, in the vertical plane, towards +z).
            rx = -ct * cp
            ry = -ct * sp
            rz = st
            if st < 1e-12:
                rx, ry, rz = 0.0, 1.0, 0.0
                # a vertical beam: Q is relative to North; unpolarized by symmetry anyway
            si = w0
            sq = w0 * q0
            su = w0 * u0
            sv = 0.0
        else:
            # A rough sea: the light in air, through the facet it meets.
            if source == 0:
                sa = math.sin(sun_theta_air)
                ca = math.cos(sun_theta_air)
                aphi = 0.0
                aq = 0.0
                au = 0.0
            else:
                lo, s2, aphi = _draw_sky(sky_cdf_air, sky_s2_edges, n_cols)
                sa = math.sqrt(min(max(s2, 0.0), 1.0))
                ca = math.sqrt(max(1.0 - sa * sa, 0.0))
                aq = sky_qu_air[lo, 0]
                au = sky_qu_air[lo, 1]
            ax = -sa * math.cos(aphi)
            ay = -sa * math.sin(aphi)
            az = -ca
            mx, my, mz = meridian(ax, ay, az)
            nx, ny, nz = facet(ax, ay, az, slope_sigma)
            si, sq, su, sv, dx, dy, dz, rx, ry, rz = enter_facet(
                ax, ay, az, mx, my, mz, 1.0, aq, au, n_water, nx, ny, nz
            )
            w0 = si
        source_flux[0] += w0
        irr[0, 0] += w0  # the source's own crossing of the surface plane
        tau = 0.0
        n_scat = 0
        reflected = False
        start = w0
        while True:
            s = -math.log(1.0 - np.random.random())
            tau_new = tau - dz * s
            # 0: once scattered, never reflected; 1: more often, never reflected; 2: reflected
            # by the surface (radiance tally 1 for both; the aureole tallies class 1 only).
            cls = 0 if (n_scat == 1 and not reflected) else (2 if reflected else 1)
            ph = (dx, dy, dz, rx, ry, rz, si, sq, su)
            if tau_new <= 0.0:
                # Up to the surface: score the planes above, then the surface plane itself.
                _score_segment(
                    rad,
                    irr,
                    planes,
                    tau,
                    0.0,
                    cls,
                    ph,
                    n_scat > 0,
                    edges_cos,
                    n_phi,
                    aur,
                    aur_cos,
                    ssx,
                    ssz,
                )
                _score(rad, irr, 0, cls, ph, n_scat > 0, edges_cos, n_phi, aur, aur_cos, ssx, ssz)
                if slope_sigma > 0.0:
                    # Facet after facet until the reflected light heads down (a few rays
                    # reflected upwards by a steep facet meet the next wave).
                    for _hit in range(10):
                        nx, ny, nz = facet(dx, dy, dz, slope_sigma)
                        si, sq, su, sv, dx, dy, dz, rx, ry, rz, escaped = reflect_facet(
                            dx, dy, dz, rx, ry, rz, si, sq, su, sv, n_water, nx, ny, nz
                        )
                        totals[0] += escaped
                        if dz < 0.0:
                            break
                    if dz >= 0.0:  # still heading up after 10 facets: count it as escaped
                        totals[0] += si
                        break
                else:
                    si, sq, su, sv, dz, rx, ry, rz, escaped = reflect_from_below(
                        dx, dy, dz, rx, ry, rz, si, sq, su, sv, n_water
                    )
                    totals[0] += escaped
                tau = 0.0
                reflected = True
                ph = (dx, dy, dz, rx, ry, rz, si, sq, su)
                _score(rad, irr, 0, 2, ph, n_scat > 0, edges_cos, n_phi, aur, aur_cos, ssx, ssz)
                alive, si, sq, su, sv = _roulette(si, sq, su, sv, start, totals)
                if not alive:
                    break
                continue
            if tau_new >= tau_bottom:
                _score_segment(
                    rad,
                    irr,
                    planes,
                    tau,
                    tau_bottom,
                    cls,
                    ph,
                    n_scat > 0,
                    edges_cos,
                    n_phi,
                    aur,
                    aur_cos,
                    ssx,
                    ssz,
                )
                totals[1] += si
                break
            _score_segment(
                rad,
                irr,
                planes,
                tau,
                tau_new,
                cls,
                ph,
                n_scat > 0,
                edges_cos,
                n_phi,
                aur,
                aur_cos,
                ssx,
                ssz,
            )
            tau = tau_new
            # ---- collision: absorption (implicit capture) --------------------------------------
            layer = n_planes - 1
            for k in range(1, n_planes):
                if tau < planes[k]:
                    layer = k - 1
                    break
            absorbed[layer] += si * (1.0 - omega0)
            si *= omega0
            sq *= omega0
            su *= omega0
            sv *= omega0
            # ---- scattering ---------------------------------------------------------------------
            x = np.random.random() * k_icdf
            j = int(x)
            if j >= k_icdf:
                j = k_icdf - 1
            f = x - j
            ctheta = icdf_cos[j] * (1.0 - f) + icdf_cos[j + 1] * f
            stheta = math.sqrt(max(1.0 - ctheta * ctheta, 0.0))
            phi = 2.0 * math.pi * np.random.random()
            # Turn the reference by φ about d: r1 = cos φ r + sin φ (d × r).
            ex = dy * rz - dz * ry
            ey = dz * rx - dx * rz
            ez = dx * ry - dy * rx
            cph = math.cos(phi)
            sph = math.sin(phi)
            r1x = cph * rx + sph * ex
            r1y = cph * ry + sph * ey
            r1z = cph * rz + sph * ez
            sq, su = rotate(sq, su, phi)
            # Mueller matrix in the scattering plane (d, r1).
            m12 = lut_at(mu_table, 1, ctheta)
            m22 = lut_at(mu_table, 2, ctheta)
            m33 = lut_at(mu_table, 3, ctheta)
            m44 = lut_at(mu_table, 4, ctheta)
            ni = si + m12 * sq
            nq = m12 * si + m22 * sq
            su = m33 * su
            sv = m44 * sv
            si = ni
            sq = nq
            # New direction and reference, both in the scattering plane.
            ndx = ctheta * dx + stheta * r1x
            ndy = ctheta * dy + stheta * r1y
            ndz = ctheta * dz + stheta * r1z
            rx = ctheta * r1x - stheta * dx
            ry = ctheta * r1y - stheta * dy
            rz = ctheta * r1z - stheta * dz
            nn = 1.0 / math.sqrt(ndx * ndx + ndy * ndy + ndz * ndz)
            dx = ndx * nn
            dy = ndy * nn
            dz = ndz * nn
            # Keep r exactly ⟂ d and unit (rounding drifts over hundreds of collisions).
            dot = rx * dx + ry * dy + rz * dz
            rx -= dot * dx
            ry -= dot * dy
            rz -= dot * dz
            nr = 1.0 / math.sqrt(rx * rx + ry * ry + rz * rz)
            rx *= nr
            ry *= nr
            rz *= nr
            n_scat += 1
            alive, si, sq, su, sv = _roulette(si, sq, su, sv, start, totals)
            if not alive:
                break
