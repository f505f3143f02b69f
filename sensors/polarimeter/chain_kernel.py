"""The exact chain under a flat sea in one compiled pass per ray (the fast path's workhorse).

:meth:`FastPath._render_points` renders the coarse grid and the rough cells' pixels through the
exact chain: the sky model (:func:`sky.sky_radiance`), the flat sea's Fresnel transmission
(:func:`transmission.surface_transmission`), the water column (direct light × e^(−c z/v_z) plus
:func:`column_kernel.scatter_pixels`), the lens's meridional mapping
(:func:`camera.meridian_to_sensor_stokes`) and the photon scale, each stage a numpy pass over
all the rays. At the ~28 000 rays of a 612×512 frame those passes (about forty, and their Python
calls) cost more than the arithmetic; here they are one loop. The same formulas, in float64 from
the same float32 rays, rounded once at the end: the numpy chain stays the reference, and
``tests/sensors/polarimeter/test_chain_kernel.py`` holds the two within float32 rounding.

What stays in numpy: the rays' world components and each ray's cosine in air (so that Snell's
window mask is the numpy chain's bit for bit), the solar disc seen through each sample's PSF (the
non-central χ² CDF, scipy's; the kernel lists the few candidate rays and their response to a
unit unpolarized radiance) and the final clamp (``Polarimeter._finish``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import chndtr

from sensors.polarimeter.optics import sky as sky_mod
from sensors.polarimeter.optics.blocks import world_components
from sensors.polarimeter.optics.column_kernel import scatter_pixels
from sensors.polarimeter.optics.sun import NIGHT_ELEVATION_RAD
from twin.core.arrays import FloatArray
from twin.core.kernel_cache import njit


@njit(cache=True, inline="always")
def _sky(px, py, pz, sky):
    """The Rayleigh-polarized CIE sky (I, Q, U) along world direction p (sky.py's formulas).

    ``sky`` = (s_x, s_y, s_z, a, b, c, d, e, e^(dπ/2), scale, DoP_max): the sun and
    :class:`sky._FrameConstants`. Meridian reference of the light's direction −p.
    """
    sx, sy, sz, a_c, b_c, c_c, d_c, e_c, edh, scale, dmax = sky
    h = px * sx + py * sy
    cg = h + pz * sz
    rho2 = px * px + py * py
    rad = e_c * cg * cg + (1.0 - c_c * edh)
    if c_c != 0.0:
        rad += c_c * math.exp(d_c * math.acos(min(max(cg, -1.0), 1.0)))
    if a_c != 0.0:
        rad *= 1.0 + a_c * math.exp(b_c / pz)
    a = py * sx - px * sy
    b = rho2 * sz - pz * h
    if rho2 == 0.0:  # exact zenith: reference = North
        a = -sx
        b = sy
        rho2 = 1.0
    a2 = a * a
    b2 = b * b
    amp = rad / (2.0 * rho2 - a2 - b2) * (scale * dmax)
    return rad * scale, (a2 - b2) * amp, 2.0 * a * b * amp, cg


@njit(cache=True, inline="always")
def fresnel_in(n, g, ca, vz):
    """The flat sea's Fresnel transmission into the water, radiance factors (m00, m01, m22).

    transmission._flat_fresnel_block's: c_a the cosine in air, v_z in the water, g = n² (the n²
    radiance law); in the meridian reference, which is the plane of incidence's.
    """
    mu = max(vz, 0.0)
    num = 4.0 * n * ca * mu
    a_s = ca + n * mu
    a_p = n * ca + mu
    m22 = g * num / (a_s * a_p + 1e-30)
    t_s = num / (a_s * a_s + 1e-30)
    t_p = num / (a_p * a_p + 1e-30)
    return 0.5 * g * (t_p + t_s), 0.5 * g * (t_p - t_s), m22


@njit(cache=True, error_model="numpy", fastmath=True)
def chain_points(
    x, y, z, cos_air, occluded, basis, column, out, scat, sees, cand, cand_chi, cand_resp,
    n, sky, cos_reach, up_c, north_c, scale, sbuf, k,
):  # fmt: skip
    """The exact chain at m rays; returns the number of solar-disc candidates listed.

    Args (in order): x, y, z ((m,) float32 ENU look components); cos_air ((m,) float32 cosine
    of the refracted ray in air, 0 outside Snell's window); occluded ((m,) uint8, or (0,): none);
    basis, column ((6, M) the sensor axes r_s, t_s of M rays, and the column of each of the m);
    out ((m, 3) float32 sensor-plane Stokes, photons/s,
    before the clamp); scat ((m, 3) the scattered part alone, or (0, 3): not wanted); sees ((m,)
    bool); cand, cand_chi, cand_resp ((m,), (m,), (m, 3)): the rays that may see the solar disc,
    their angle from the sun in air and their sensor-plane response to a unit unpolarized sky
    radiance; n (the water's index); sky (:func:`_sky`'s tuple); cos_reach (a ray is a disc
    candidate when the cosine of its sky direction's angle from the sun is at least this);
    up_c, north_c (ENU up and North in the camera frame: rows 2 and 1 of C_c^n); scale (the
    photon scale); sbuf ((4, m) float64 scratch: the scattered light and the transmittance);
    k (:func:`column_kernel.scatter_pixels`'s arguments after ``out``).
    """
    m = x.shape[0]
    # The scattered light first, by the column kernel's own loop (float64, unrounded): its
    # per-ray body inlined here ran 35 % slower there too (numba's inliner, measured).
    scatter_pixels(x, y, z, sbuf, *k)
    want_scat = scat.shape[0] > 0
    any_occ = occluded.shape[0] > 0
    g = n * n  # the n² radiance law
    ncand = 0
    for i in range(m):
        vx = float(x[i])
        vy = float(y[i])
        vz = float(z[i])
        si = sbuf[0, i]
        sq = sbuf[1, i]
        su = sbuf[2, i]
        # The lens's meridional mapping: the meridian → sensor rotation (camera.py).
        j = column[i]
        rx, ry, rz = basis[0, j], basis[1, j], basis[2, j]
        tx, ty, tz = basis[3, j], basis[4, j], basis[5, j]
        cc = up_c[0] * rx + up_c[1] * ry + up_c[2] * rz
        ss = up_c[0] * tx + up_c[1] * ty + up_c[2] * tz
        n2 = cc * cc + ss * ss
        if n2 == 0.0:  # the exact zenith: North's projections
            cc = north_c[0] * rx + north_c[1] * ry + north_c[2] * rz
            ss = north_c[0] * tx + north_c[1] * ty + north_c[2] * tz
            n2 = 1.0
        c2 = (cc * cc - ss * ss) / n2
        s2 = 2.0 * cc * ss / n2
        if want_scat:
            scat[i, 0] = si * scale
            scat[i, 1] = (c2 * sq + s2 * su) * scale
            scat[i, 2] = (c2 * su - s2 * sq) * scale
        ca = float(cos_air[i])
        see = ca > 0.0
        sees[i] = see
        if see and not (any_occ and occluded[i] != 0):
            # The sky direction of a flat sea's window: n v + (c_a − n v_z) ẑ.
            px = n * vx
            py = n * vy
            wi, wq, wu, cg = _sky(px, py, ca, sky)
            m00, m01, m22 = fresnel_in(n, g, ca, vz)
            # water._direct_block's e^(−c z / max(v_z, 10⁻⁶)): the scattering kernel's, as
            # v_z > 0 inside the window (the same expression there, computed once).
            t = sbuf[3, i]
            ti = (m00 * wi + m01 * wq) * t
            tq = (m01 * wi + m00 * wq) * t
            tu = m22 * wu * t
            si += ti
            sq += tq
            su += tu
            if cg >= cos_reach:
                nrm = math.sqrt(px * px + py * py + ca * ca)
                dx = px / nrm - sky[0]
                dy = py / nrm - sky[1]
                dz = ca / nrm - sky[2]
                chord = math.sqrt(dx * dx + dy * dy + dz * dz)
                cand[ncand] = i
                cand_chi[ncand] = 2.0 * math.asin(min(0.5 * chord, 1.0))
                cand_resp[ncand, 0] = m00 * t * scale
                cand_resp[ncand, 1] = c2 * m01 * t * scale
                cand_resp[ncand, 2] = -s2 * m01 * t * scale
                ncand += 1
        out[i, 0] = si * scale
        out[i, 1] = (c2 * sq + s2 * su) * scale
        out[i, 2] = (c2 * su - s2 * sq) * scale
    return ncand


def applies(sky: sky_mod.SkySpec, sun_enu: NDArray[np.float64]) -> bool:
    """Whether the compiled chain covers this sky: Rayleigh polarization, the sun up."""
    return sky.polarization == "rayleigh" and float(sun_enu[2]) >= math.sin(NIGHT_ELEVATION_RAD)


def render_points(
    rays: FloatArray,
    basis: tuple[FloatArray, NDArray[np.intp]],
    psf: FloatArray,
    c_cn: NDArray[np.float64],
    n_water: float,
    sky: sky_mod.SkySpec,
    sun_enu: NDArray[np.float64],
    column_args: tuple[Any, ...],
    photon_scale: float,
    occluded: NDArray[np.bool_] | None,
    split: bool,
) -> tuple[FloatArray, NDArray[np.bool_], FloatArray | None]:
    """The exact chain at N rays under a flat sea (:meth:`FastPath._render_points`'s contract).

    Args:
        rays: (N, 3) float32 look directions, camera frame.
        basis: (6, M) sensor axes (:func:`camera.sensor_basis`) and the (N,) column of each ray
            (read in place: no gathered copy).
        psf: (N,) each sample's PSF σ (rad) for the solar disc.
        c_cn: C_c^n.
        n_water: The water's refractive index.
        sky: The sky (:func:`applies` must hold).
        sun_enu: ENU unit vector towards the sun.
        column_args: :meth:`WaterColumn._kernel_args` (not None).
        photon_scale: Radiance → photons/s.
        occluded: (N,) rays whose sky is blocked, or None.
        split: Also return the scattered light alone.

    Returns:
        (sensor-plane Stokes (N, 3) float32, sees the sky (N,), the scattered part or None),
        S0 ≥ 0, no NaN: ``Polarimeter._finish`` applied.
    """
    m = rays.shape[0]
    c = np.asarray(c_cn, dtype=np.float64)
    wbuf = np.empty((3, m), dtype=np.float32)
    x, y, z = world_components(rays, c, wbuf)
    cos_air = cos_in_air(z, n_water)
    s = np.asarray(sun_enu, dtype=np.float64)
    ctx = sky_mod._FrameConstants(sky, s, np.dtype(np.float64))
    a, b, cc, d, e = ctx.cie
    sky_t = (ctx.sx, ctx.sy, ctx.sz, a, b, cc, d, e, ctx.exp_d_half_pi, ctx.scale, ctx.dop_max)
    disc = ctx.disc > 0.0
    sig_max = float(np.max(psf, initial=0.0))
    # sky._add_sun_disc's candidates: the widest PSF's reach, a margin for rounding.
    reach = ctx.r_sun + 7.0 * sig_max
    cos_reach = math.cos(min(reach + 2e-3, math.pi)) if disc else 2.0
    out = np.empty((m, 3), dtype=np.float32)
    scat = np.empty((m if split else 0, 3), dtype=np.float32)
    sees = np.empty(m, dtype=bool)
    cand = np.empty(m, dtype=np.intp)
    chi = np.empty(m, dtype=np.float64)
    resp = np.empty((m, 3), dtype=np.float64)
    occ = np.empty(0, dtype=np.uint8) if occluded is None else occluded.view(np.uint8)
    scale = float(np.float32(photon_scale))
    sbuf = np.empty((4, m), dtype=np.float64)
    nc = chain_points(
        x, y, z, cos_air, occ, basis[0], basis[1], out, scat, sees, cand, chi, resp,
        float(n_water), sky_t, cos_reach, c[2].copy(), c[1].copy(), scale, sbuf, column_args,
    )  # fmt: skip
    if nc:
        idx, chi_c = cand[:nc], chi[:nc]
        sig = psf[idx].astype(np.float64)
        r_sun = ctx.r_sun
        sg = np.maximum(sig, 1e-12)
        frac = chndtr((r_sun / sg) ** 2, 2.0, (chi_c / sg) ** 2)
        frac = np.where(sig > 0, frac, (chi_c <= r_sun).astype(np.float64))
        frac[chi_c > r_sun + 7.0 * sig] = 0.0
        out[idx] += (ctx.disc * frac)[:, None] * resp[:nc]
    _clamp(out)
    if split:
        _clamp(scat)
    return out, sees, scat if split else None


def cos_in_air(z: FloatArray, n_water: float) -> FloatArray:
    """c_a = √max(n² v_z² + 1 − n², 0) for v_z ≥ 0, in float32 as the exact chain computes it.

    The same passes as ``transmission._flat_fresnel_block``: Snell's window's mask must be the
    numpy chain's bit for bit wherever it is taken (here and in the window grid).
    """
    cos_air = np.maximum(z, 0.0)
    np.multiply(cos_air, cos_air, out=cos_air)
    cos_air *= n_water * n_water
    cos_air += 1.0 - n_water * n_water
    np.maximum(cos_air, 0.0, out=cos_air)
    np.sqrt(cos_air, out=cos_air)
    return cos_air


def _clamp(st: FloatArray) -> None:
    """``Polarimeter._finish`` after the photon scale: no NaN/inf, S0 ≥ 0 (in place)."""
    bad = ~np.isfinite(st)
    if bad.any():
        st[bad] = 0.0
    np.maximum(st[:, 0], 0.0, out=st[:, 0])
