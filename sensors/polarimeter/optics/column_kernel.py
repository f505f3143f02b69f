"""Per-pixel scattered light of the water column (numba): closed-form single scattering + table.

One loop over look directions v (ENU) computes, for each pixel, in the meridian reference of the
light's direction d = −v (:func:`sensors.polarimeter.stokes.meridian_reference`):

1. the refracted sun beam scattered once (:mod:`sensors.polarimeter.optics.water`, eq. 2): magnitude
   β(Θ) E G(v) in closed form, polarization R(−χ₂) M(Θ) R(χ₁) (1, q_b, 0) with the sea-water phase
   matrix M of :mod:`sensors.polarimeter.optics.scattering` and the beam's Fresnel polarization q_b;
2. everything else that was scattered (the multiply scattered sun, the scattered sky, the upwelling
   light and its reflection at the surface), sampled bilinearly from the frame's
   :class:`sensors.polarimeter.optics.rt.table.FrameField` at (look zenith, azimuth from the sun),
   never
   across Snell's window edge.

Why a compiled loop: the polarization of single scattering needs two frame rotations per pixel
(about 150 floating-point operations); in numpy that is ~40 temporaries per pixel, in a loop it is
registers.
"""

from __future__ import annotations

import math

import numpy as np

from sensors.polarimeter.optics.rt.kernel import lut_index
from sensors.polarimeter.optics.rt.surface_kernel import meridian
from twin.core.kernel_cache import njit


@njit(cache=True, inline="always")
def _row(cz, grid_c):
    """Index i with grid_c[i] >= cz > grid_c[i + 1] (descending cos θ, clamped), the fraction."""
    n = grid_c.shape[0]
    if cz >= grid_c[0]:
        return 0, 0.0
    if cz <= grid_c[n - 1]:
        return n - 2, 1.0
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if cz <= grid_c[mid]:
            lo = mid
        else:
            hi = mid
    return lo, (grid_c[lo] - cz) / (grid_c[lo] - grid_c[lo + 1])


@njit(cache=True, inline="always")
def _atan2_pos(y, x):
    """atan2(y, x) for y >= 0, to 1e-5 rad (libm's atan2 costs ~60 ns a call here).

    Octant reduction and the minimax polynomial of atan on [0, 1] (Abramowitz & Stegun 4.4.49
    family, 9th order).
    """
    ax = abs(x)
    if ax >= y:
        t = y / ax if ax > 0.0 else 0.0
        swap = False
    else:
        t = ax / y
        swap = True
    t2 = t * t
    a = t * (0.99997726 + t2 * (-0.33262347 + t2 * (0.19354346 + t2 * (-0.11643287
             + t2 * (0.05265332 + t2 * -0.01172120)))))  # fmt: skip
    if swap:
        a = 0.5 * math.pi - a
    if x < 0.0:
        a = math.pi - a
    return a


@njit(cache=True, inline="always")
def _single(vx, vy, vz, cz, c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z, luts, e_a1, e_a2):
    """The refracted beam scattered once into look direction v (meridian reference of d = −v).

    Magnitude (water.py eq. 2): β e^(−min(a1, a2)) (1 − e^(−x)) E μ_s / (c |μ_s − v_z|) looking
    up; looking down (v_z <= 0) the line of sight is infinite at any depth, so
    β e^(−a1) E μ_s / (c (μ_s − v_z)) exactly (the clamped v_z of the upward branch gave
    1 − e^(−x) < 1 there within ~10 µm of the surface). ``e_a1`` = e^(−a1) (a1 = c z/μ_s, one
    per frame) and ``e_a2`` = e^(−a2) (a2 = c z/v_z, v_z > 0; the caller's transmittance to the
    surface) are the caller's: x = |a2 − a1|, so e^(−min) (1 − e^(−x)) = |e^(−a1) − e^(−a2)|, two
    exponentials fewer a pixel; within x < 1e-3 of the sun's direction, where the difference
    cancels, the expm1 form (relative error of the difference form: < 1e-13 elsewhere).
    """
    mx, my, mz = meridian(-vx, -vy, -vz)
    mu_s = max(sz, 1e-3)
    a1 = cz / mu_s
    ct = vx * sx + vy * sy + vz * sz
    ct = min(max(ct, -1.0), 1.0)
    # e1 ⟂ d0 = −ŝ towards d = −v: (−v + ct ŝ)/sin Θ.
    e1x = -vx + ct * sx
    e1y = -vy + ct * sy
    e1z = -vz + ct * sz
    st = math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    if st > 1e-9:
        e1x /= st
        e1y /= st
        e1z /= st
    else:
        e1x, e1y, e1z = r0x, r0y, r0z
        st = 0.0
    # χ₁ from r0 to e1 about d0 = −ŝ.
    c1 = r0x * e1x + r0y * e1y + r0z * e1z
    s1 = -((r0y * e1z - r0z * e1y) * sx + (r0z * e1x - r0x * e1z) * sy
           + (r0x * e1y - r0y * e1x) * sz)  # fmt: skip
    q1 = (c1 * c1 - s1 * s1) * beam_q
    u1 = -2.0 * c1 * s1 * beam_q
    # lut_at's interpolation, its index found once for the four rows.
    j, f = lut_index(luts, ct)
    g0 = 1.0 - f
    beta = luts[0, j] * g0 + luts[0, j + 1] * f
    m12 = luts[1, j] * g0 + luts[1, j + 1] * f
    m22 = luts[2, j] * g0 + luts[2, j + 1] * f
    m33 = luts[3, j] * g0 + luts[3, j + 1] * f
    oi = 1.0 + m12 * q1
    oq = m12 + m22 * q1
    ou = m33 * u1
    # e2 = cos Θ e1 − sin Θ d0 = cos Θ e1 + sin Θ ŝ; χ₂ from e2 to m about d = −v.
    e2x = ct * e1x + st * sx
    e2y = ct * e1y + st * sy
    e2z = ct * e1z + st * sz
    c2 = e2x * mx + e2y * my + e2z * mz
    s2 = -((e2y * mz - e2z * my) * vx + (e2z * mx - e2x * mz) * vy
           + (e2x * my - e2y * mx) * vz)  # fmt: skip
    n2 = c2 * c2 + s2 * s2
    if n2 > 0.0:
        cc = (c2 * c2 - s2 * s2) / n2
        ss = 2.0 * c2 * s2 / n2
    else:
        cc, ss = 1.0, 0.0
    if vz > 0.0:
        a2 = cz / vz
        dm = max(abs(mu_s - vz), 1e-9)
        if abs(a2 - a1) > 1e-3:
            g = abs(e_a1 - e_a2) / dm
        else:
            xx = cz * dm / (mu_s * vz)
            g = math.exp(-min(a1, a2)) * (-math.expm1(-xx)) / dm
    else:
        g = e_a1 / (mu_s - vz)
    lss = beta * g * e_sun * mu_s / c
    return lss * oi, lss * (cc * oq + ss * ou), lss * (-ss * oq + cc * ou)


@njit(cache=True, inline="always")
def _lookup(grid, t_cos, cz_t, phi, dphi):
    """Bilinear (look-zenith row by cos θ, folded azimuth φ) in a padded frame grid."""
    r, fr = _row(cz_t, t_cos)
    p = phi / dphi + 0.5
    jc = int(p)
    if jc >= grid.shape[1] - 1:
        jc = grid.shape[1] - 2
    fp = p - jc
    w00 = (1.0 - fr) * (1.0 - fp)
    w01 = (1.0 - fr) * fp
    w10 = fr * (1.0 - fp)
    w11 = fr * fp
    i = w00 * grid[r, jc, 0] + w01 * grid[r, jc + 1, 0] + w10 * grid[r + 1, jc, 0]
    i += w11 * grid[r + 1, jc + 1, 0]
    q = w00 * grid[r, jc, 1] + w01 * grid[r, jc + 1, 1] + w10 * grid[r + 1, jc, 1]
    q += w11 * grid[r + 1, jc + 1, 1]
    u = w00 * grid[r, jc, 2] + w01 * grid[r, jc + 1, 2] + w10 * grid[r + 1, jc, 2]
    u += w11 * grid[r + 1, jc + 1, 2]
    return i, q, u


@njit(cache=True, inline="always")
def aureole_at(vx, vy, vz, sx, sy, sz, cphi, sphi, agrid, apsi, dom):
    """The sun's aureole (tapered, :mod:`~sensors.polarimeter.optics.rt.decompose`) along v.

    ``agrid`` (n_rows, n_ω + 2, 3): rows at ψ = ``apsi`` (0, the bin centres, the last edge where
    the taper is 0), columns at position angle ω = (j − ½) ``dom`` about the sun from its upward
    side, mirrored at 0 and π. Linear in ψ, linear in ω; U's sign follows the mirror.
    """
    cpsi = vx * sx + vy * sy + vz * sz
    n = apsi.shape[0]
    if n < 2 or cpsi <= math.cos(apsi[n - 1]):
        return 0.0, 0.0, 0.0
    dx = vx - sx
    dy = vy - sy
    dz = vz - sz
    psi = 2.0 * math.asin(min(0.5 * math.sqrt(dx * dx + dy * dy + dz * dz), 1.0))
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if psi >= apsi[mid]:
            lo = mid
        else:
            hi = mid
    fr = (psi - apsi[lo]) / (apsi[lo + 1] - apsi[lo])
    # ω: from e_up = (ẑ − cos θ_s ŝ)/sin θ_s towards the side axis (−sin φ_s, cos φ_s, 0).
    hs = math.sqrt(sx * sx + sy * sy)
    up = vz * hs - sz * (vx * cphi + vy * sphi)
    side = -vx * sphi + vy * cphi
    sign = 1.0
    if side < 0.0:
        side = -side
        sign = -1.0
    om = _atan2_pos(side, up)
    p = om / dom + 0.5
    jc = int(p)
    if jc >= agrid.shape[1] - 1:
        jc = agrid.shape[1] - 2
    fp = p - jc
    w00 = (1.0 - fr) * (1.0 - fp)
    w01 = (1.0 - fr) * fp
    w10 = fr * (1.0 - fp)
    w11 = fr * fp
    r = lo
    i = w00 * agrid[r, jc, 0] + w01 * agrid[r, jc + 1, 0] + w10 * agrid[r + 1, jc, 0]
    i += w11 * agrid[r + 1, jc + 1, 0]
    q = w00 * agrid[r, jc, 1] + w01 * agrid[r, jc + 1, 1] + w10 * agrid[r + 1, jc, 1]
    q += w11 * agrid[r + 1, jc + 1, 1]
    u = w00 * agrid[r, jc, 2] + w01 * agrid[r, jc + 1, 2] + w10 * agrid[r + 1, jc, 2]
    u += w11 * agrid[r + 1, jc + 1, 2]
    return i, q, sign * u


@njit(cache=True, inline="always")
def fresnel_up_meridian(cos_i, n_water, si, sq, su):
    """Light coming up at incidence cosine ``cos_i`` inside Snell's window, reflected by a flat sea.

    In the meridian references of the incident and the reflected light. The plane of incidence of
    a flat sea is the vertical plane through the light's direction, so both meridian references
    lie in it: each is the p-axis up to its sign (turned by π, which leaves Q and U as they are),
    and the reference's general chain (``rt.surface_kernel.reflect_from_below``: into the p-basis,
    Fresnel, back into the meridian, two atan2-sized rotations) reduces to the
    Fresnel Mueller matrix itself; ``tests/sensors/polarimeter/test_column_kernel.py`` checks the
    two agree. Inside the window (cos_i above the critical cosine) there is no total reflection,
    so r_s, r_p are real and V stays 0.
    """
    sin_t2 = n_water * n_water * (1.0 - cos_i * cos_i)
    cos_t = math.sqrt(max(1.0 - sin_t2, 0.0))
    rs = (n_water * cos_i - cos_t) / (n_water * cos_i + cos_t)
    rp = (cos_i - n_water * cos_t) / (cos_i + n_water * cos_t)
    a = 0.5 * (rp * rp + rs * rs)
    d = 0.5 * (rp * rp - rs * rs)
    return a * si + d * sq, d * si + a * sq, rp * rs * su


@njit(cache=True, inline="always")
def _reflected(
    vx, vy, vz, phi, sign, n_water, t, up, t_out, dphi,
    single, cz0, c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z, luts,
):  # fmt: skip
    """:func:`reflected_at` given the folded azimuth ``phi`` from the sun and its ``sign``.

    ``t`` = exp(−tau_c / max(v_z, 1e-6)), the caller's (the direct light's transmittance too).
    """
    ui, uq, uu = _lookup(up, t_out, -vz, phi, dphi)
    uu *= sign
    if single:
        # Looking down (−v_z < 0) only e^(−a1) enters.
        si, sq, su = _single(
            vx, vy, -vz, cz0, c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z, luts,
            math.exp(-cz0 / max(sz, 1e-3)), 0.0,
        )  # fmt: skip
        ui += si
        uq += sq
        uu += su
    # The upwelling light travels along d = −v' = (−v_x, −v_y, v_z): incidence cosine v_z.
    ni, nq, nu = fresnel_up_meridian(vz, n_water, ui, uq, uu)
    return t * ni, t * nq, t * nu


@njit(cache=True, inline="always")
def reflected_at(
    vx, vy, vz, n_water, tau_c, up, t_out, dphi, cphi, sphi,
    single, cz0, c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z, luts,
):  # fmt: skip
    """The upwelling light at the surface Fresnel-reflected into v, attenuated to the camera.

    Inside Snell's window only (there the reflectance rises from 2 % to 1 at the edge, too fast
    for the table's bins). The upwelling Stokes at the surface, in look direction
    v' = (v_x, v_y, −v_z): ``up`` (the frame's scattered light at the surface, rows from the
    window's edge to the nadir; the table's) plus, if ``single``, the sun beam scattered once
    (:func:`_single` at c z = ``cz0`` = 0). Reflected (:func:`fresnel_up_meridian`, the
    reference's reflection in the meridian basis), times exp(−c z / v_z).
    """
    px = vx * cphi + vy * sphi
    py = -vx * sphi + vy * cphi
    sign = 1.0
    if py < 0.0:
        py = -py
        sign = -1.0
    phi = _atan2_pos(py, px)
    return _reflected(
        vx, vy, vz, phi, sign, n_water, math.exp(-tau_c / max(vz, 1e-6)), up, t_out, dphi,
        single, cz0, c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z, luts,
    )  # fmt: skip


@njit(cache=True, error_model="numpy", fastmath=True)
def scatter_pixels(
    x, y, z, out,
    single, cz, c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z, luts,
    has_field, f_in, t_in, f_out, t_out, cos_c_frame, cos_c_table, dphi, cphi, sphi,
    agrid, apsi, dom, up, n_water,
):  # fmt: skip
    """Fill ``out[0..2, i]`` with the scattered Stokes of look direction (x, y, z)[i] (ENU).

    An ``out`` of four rows also gets each ray's transmittance from the surface, e^(−c z/v_z)
    (0 looking down), in its fourth: the direct light's (``chain_kernel``).

    Arguments, in order: x, y, z ((m,) look-direction components); out ((3, m)); single (add
    single scattering: a lit beam, b > 0); cz, c (c z and c); sx, sy, sz (the look direction
    towards the refracted sun); e_sun (the beam's normal irradiance below the surface); beam_q
    (its Q/I relative to its meridian, Fresnel: > 0); r0x, r0y, r0z (the beam's meridian
    reference, light direction −ŝ); luts ((4, K) β, m12, m22, m33 against u = sin(Θ/2)); has_field
    (add the table's light); f_in, t_in, f_out, t_out (the frame field's padded grids of the
    table's remainder and the cosines of their look zeniths, descending); cos_c_frame,
    cos_c_table (cos of Snell's window edge in this water and in the table's); dphi (the table's
    azimuth bin width); cphi, sphi (the sun's azimuth: the table's φ = 0); agrid, apsi, dom (the
    sun's aureole, :func:`aureole_at`; one row: none); up (the upwelling light at the surface for
    :func:`reflected_at`, the flat sea's share; one row: none); n_water (this water's index).
    """
    m = x.shape[0]
    do_refl = has_field and up.shape[0] > 1
    do_aur = has_field and apsi.shape[0] > 1
    # The aureole's outer edge as a cosine, once (aureole_at tests it again, exactly so).
    cos_aur = math.cos(apsi[apsi.shape[0] - 1]) if do_aur else 2.0
    e_a1 = math.exp(-cz / max(sz, 1e-3))  # the beam's attenuation to the camera's depth
    keep_t = out.shape[0] > 3  # a fourth row: each ray's transmittance from the surface
    for i in range(m):
        vx = float(x[i])
        vy = float(y[i])
        vz = float(z[i])
        si = 0.0
        sq = 0.0
        su = 0.0
        # Transmittance from the surface along v (single scattering's a2, the reflection's t).
        e_a2 = math.exp(-cz / vz) if vz > 0.0 else 0.0
        if keep_t:
            out[3, i] = e_a2
        if single:
            si, sq, su = _single(
                vx, vy, vz, cz, c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z, luts, e_a1, e_a2
            )
        if has_field:
            # Rows by cos θ (no acos); this water's window edge mapped onto the table's, linearly
            # in cos θ on either side (the indices differ by < 1 %).
            inside = vz > cos_c_frame
            if inside:
                cz_t = 1.0 - (1.0 - vz) * (1.0 - cos_c_table) / (1.0 - cos_c_frame)
                grid = f_in
                tc = t_in
            else:
                cz_t = vz * cos_c_table / cos_c_frame if vz > 0.0 else vz
                grid = f_out
                tc = t_out
            # Azimuth from the sun, folded onto [0, π] (U changes sign under the mirror).
            px = vx * cphi + vy * sphi
            py = -vx * sphi + vy * cphi
            sign = 1.0
            if py < 0.0:
                py = -py
                sign = -1.0
            phi = _atan2_pos(py, px)
            ti, tq, tu = _lookup(grid, tc, cz_t, phi, dphi)
            si += ti
            sq += tq
            su += sign * tu
            if do_aur and vx * sx + vy * sy + vz * sz > cos_aur:
                ai, aq, au = aureole_at(vx, vy, vz, sx, sy, sz, cphi, sphi, agrid, apsi, dom)
                si += ai
                sq += aq
                su += au
            if do_refl and inside:
                # v and its mirror v' share the azimuth: phi and sign as above.
                ri, rq, ru = _reflected(
                    vx, vy, vz, phi, sign, n_water, e_a2, up, t_out, dphi,
                    single, 0.0, c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z, luts,
                )  # fmt: skip
                si += ri
                sq += rq
                su += ru
        out[0, i] = si
        out[1, i] = sq
        out[2, i] = su


def empty_grid() -> np.ndarray:
    """A placeholder grid for frames without table light (numba needs typed arrays)."""
    return np.zeros((2, 2, 3), dtype=np.float32)
