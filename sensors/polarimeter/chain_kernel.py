"""The exact chain under a flat sea in one compiled kernel (the fast path's workhorse).

:meth:`FastPath._render_points` renders the coarse grid and the rough cells' pixels through the
exact chain: the sky model (:func:`sky.sky_radiance`), the flat sea's Fresnel transmission
(:func:`transmission.surface_transmission`), the water column (direct light × e^(−c z/v_z) plus
:func:`column_kernel.scatter_pixels`), the lens's meridional mapping
(:func:`camera.meridian_to_sensor_stokes`) and the photon scale, each stage a numpy pass over
all the rays. At the ~28 000 rays of a 612×512 frame those passes (about forty, and their Python
calls) cost more than the arithmetic; here they are one kernel
(:func:`~sensors.polarimeter.chain_passes.chain_points`, a block of rays at a time in passes
that LLVM vectorises). The same formulas, in float64 from the same float32 rays (but a product
of two of a ray's components, which numba rounds to float32), rounded once at the end: the
numpy chain stays the reference, and
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

from sensors.polarimeter.chain_passes import ROW, SCRATCH_ROWS, chain_points
from sensors.polarimeter.optics import sky as sky_mod
from sensors.polarimeter.optics.blocks import world_components
from sensors.polarimeter.optics.sun import NIGHT_ELEVATION_RAD
from twin.core.arrays import FloatArray


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
    w = np.empty(SCRATCH_ROWS * ROW, dtype=np.float64)
    nc = chain_points(
        x, y, z, cos_air, occ, basis[0], basis[1], out, scat, sees, cand, chi, resp,
        float(n_water), sky_t, cos_reach, c[2].copy(), c[1].copy(), scale, w, column_args,
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
