"""The air–water interface: Snell refraction, the Fresnel transmission Mueller matrix, ports.

Stage 4 of the polarimeter's physics chain (see :mod:`sensors.polarimeter`). Everything here is
vectorised numpy over leading axes of ``(..., 3)`` direction arrays and ``(..., 3)`` Stokes arrays
(I, Q, U) with explicit reference axes, in the one convention of
:mod:`sensors.polarimeter.stokes` (``d`` = the direction the light travels; the E-vector at ψ is
``cos ψ · ref + sin ψ · (d × ref)``). Arrays keep the caller's float dtype (float32 for frames).

Two layers: general functions (:func:`refract`, :func:`transmit_stokes`, …) take any directions,
normals and references; the per-frame renderer path (:func:`surface_transmission` →
:class:`SurfaceTransmission`) takes the camera's rays in their own frame F with ``rotation`` =
C_F^n, as :mod:`sky` does, works over cache-sized blocks, and keeps Stokes in the chain's
meridian reference (``stokes.meridian_reference(d)`` in ENU), which for a flat sea *is* the
Fresnel p-axis, so a frame costs three multiplies a pixel after the per-ray factors.

Two kinds of direction appear and are named apart:

* a *look* direction points away from the observer, towards what is seen (a camera ray looking
  up at the surface, ``look_dirs``; the direction of a sky point, ``sky_dirs``);
* a *travel* direction ``d`` is where the light goes, ``d = −look``.

Physics and sources (``shared/reference/optics.md`` §2):

* Water index n(S, T, λ): Quan & Fry (1995), Appl. Opt. 34(18):3477, the form coded in Powell et al.
  (2018)'s ``simulate.py`` (optics.md §2.1). Snell's window half-angle θ_c = arcsin(1/n).
* Vector Snell's law for arbitrary (per-ray) facet normals; total internal reflection (TIR)
  flagged by a mask, never by NaN.
* Fresnel amplitude transmission t_s, t_p and the linear (I, Q, U) block of the transmission
  Mueller matrix in the plane-of-incidence basis, reference = p-axis (Q = I_p − I_s)::

      M_T = K · ½ [[t_p² + t_s², t_p² − t_s², 0], [t_p² − t_s², t_p² + t_s², 0], [0, 0, 2 t_p t_s]]

  with K_flux = (n_t cos θ_t)/(n_i cos θ_i) (flux/irradiance transmittance) or
  K_radiance = (n_t/n_i)² K_flux (the n² law: L/n² is conserved apart from Fresnel loss).
  The products K t² are computed in the singularity-free form 4 n_i n_t cos θ_i cos θ_t / (…)².
  Horváth & Varjú (1995) Vision Res. 35(12):1651 treat the underwater refraction-polarization
  pattern the same way.
* The waves that perturb the facet normals: :mod:`sensors.polarimeter.optics.waves`.
* A flat camera port: water → glass → air through parallel interfaces (optics.md §2.4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sensors.polarimeter import stokes as st

FloatArray = NDArray[np.floating]
BoolArray = NDArray[np.bool_]

#: Refractive index of air used at the sea surface and inside a camera housing. Quan & Fry's
#: formula gives the index of water relative to air, so air is 1 here by construction.
N_AIR = 1.0
#: Refractive index of a PMMA (acrylic) port at ~500 nm (Sultanova et al. 2009, Acta Phys. Pol. A
#: 116:585: 1.4905 at 589 nm, ≈1.497 at 500 nm). BK7 glass is 1.5214 at 500 nm (Schott datasheet).
N_ACRYLIC = 1.49

# Validity ranges of Quan & Fry (1995)'s fit (optics.md §2.1; the paper fits Austin & Halikas
# (1976) data over these ranges; −2 °C is the freezing point of seawater).
SALINITY_RANGE_PSU = (0.0, 42.0)
TEMPERATURE_RANGE_C = (-2.0, 40.0)
WAVELENGTH_RANGE_NM = (350.0, 800.0)

Factor = Literal["radiance", "flux", "none"]


def _check_range(name: str, value: ArrayLike, lo: float, hi: float, unit: str) -> NDArray:
    arr = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr < lo) or np.any(arr > hi):
        raise ValueError(f"{name} must lie in [{lo:g}, {hi:g}] {unit}, got {value!r}")
    return arr


def _like(result: NDArray, *inputs: ArrayLike) -> float | NDArray:
    """A float for all-scalar input, an array otherwise."""
    if all(np.ndim(x) == 0 for x in inputs):
        return float(result)
    return result


def _dtype(*arrays: ArrayLike) -> np.dtype:
    """The dtype to compute in: float32 arrays stay float32 (frames), anything else float64."""
    arrs = [a for a in arrays if isinstance(a, np.ndarray)]
    if not arrs:
        return np.dtype(np.float64)
    return np.result_type(*arrs, np.float32)


def _dot(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise dot product of (..., 3) arrays (einsum: no (..., 3) temporary)."""
    a, b = np.broadcast_arrays(a, b)
    return np.einsum("...i,...i->...", a, b)


def _unit(v: FloatArray, fallback: FloatArray | None = None) -> FloatArray:
    n = np.sqrt(_dot(v, v))[..., None]
    ok = n > 1e-12
    out = v / np.where(ok, n, 1.0)
    if fallback is not None:
        out = np.where(ok, out, fallback)
    return out


# --------------------------------------------------------------------------------------------
# Water index and Snell's window
# --------------------------------------------------------------------------------------------


def water_index(
    salinity_psu: ArrayLike = 35.0,
    temperature_c: ArrayLike = 20.0,
    wavelength_nm: ArrayLike = 500.0,
) -> float | NDArray:
    """Refractive index of (sea) water relative to air, Quan & Fry (1995).

    n = 1.31405 + (1.779e-4 − 1.05e-6 T + 1.6e-8 T²) S − 2.02e-6 T²
        + (15.868 + 0.01155 S − 0.00423 T)/λ − 4382/λ² + 1.1455e6/λ³

    (Quan & Fry 1995, Appl. Opt. 34(18):3477; optics.md §2.1, whose table this reproduces:
    fresh water at 20 °C and 589 nm → 1.3330, seawater S = 35, 20 °C, 500 nm → 1.3430.)

    Args:
        salinity_psu: Salinity S in PSU (‰), 0 to 42.
        temperature_c: Temperature T in °C, −2 to 40.
        wavelength_nm: Vacuum wavelength λ in nm, 350 to 800.

    Returns:
        n, a float for scalar arguments, else an array of their broadcast shape.

    Raises:
        ValueError: an argument outside its range (the fit is not validated beyond it).
    """
    s = _check_range("salinity_psu", salinity_psu, *SALINITY_RANGE_PSU, "PSU")
    t = _check_range("temperature_c", temperature_c, *TEMPERATURE_RANGE_C, "°C")
    lam = _check_range("wavelength_nm", wavelength_nm, *WAVELENGTH_RANGE_NM, "nm")
    n = (
        1.31405
        + (1.779e-4 - 1.05e-6 * t + 1.6e-8 * t * t) * s
        - 2.02e-6 * t * t
        + (15.868 + 0.01155 * s - 0.00423 * t) / lam
        - 4382.0 / lam**2
        + 1.1455e6 / lam**3
    )
    return _like(n, salinity_psu, temperature_c, wavelength_nm)


def snell_window_half_angle(n: ArrayLike) -> float | NDArray:
    """Half-angle θ_c = arcsin(1/n) of Snell's window, in radians (48.61° for n = 1.3330).

    Args:
        n: Refractive index of the water relative to air, > 1.

    Raises:
        ValueError: ``n`` not greater than 1.
    """
    arr = np.asarray(n, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr <= 1.0):
        raise ValueError(f"n must be a refractive index > 1, got {n!r}")
    return _like(np.arcsin(1.0 / arr), n)


def _check_index(name: str, n: float) -> float:
    if not (math.isfinite(n) and n >= 1.0):
        raise ValueError(f"{name} must be a refractive index >= 1, got {n!r}")
    return float(n)


# --------------------------------------------------------------------------------------------
# Fresnel transmission
# --------------------------------------------------------------------------------------------


class FresnelElements(NamedTuple):
    """The three distinct elements of the linear transmission Mueller block (p-axis reference).

    ``m00`` = K(t_p² + t_s²)/2, ``m01`` = K(t_p² − t_s²)/2, ``m22`` = K t_p t_s; zero where the
    ray is totally internally reflected. ``cos_t`` is the cosine of the transmission angle.
    """

    m00: FloatArray
    m01: FloatArray
    m22: FloatArray
    cos_t: FloatArray
    transmitted: BoolArray


def fresnel_elements(
    cos_i: ArrayLike, n_i: float, n_t: float, factor: Factor = "radiance"
) -> FresnelElements:
    """Transmission Mueller elements for incidence cosine ``cos_i`` from index ``n_i`` into ``n_t``.

    Power transmittances (Born & Wolf §1.5), in a form with no division by cos θ_i, so grazing
    incidence and the critical angle give 0, not NaN::

        T_s = K_flux t_s² = 4 n_i n_t cos θ_i cos θ_t / (n_i cos θ_i + n_t cos θ_t)²
        T_p = K_flux t_p² = 4 n_i n_t cos θ_i cos θ_t / (n_t cos θ_i + n_i cos θ_t)²
        K_flux t_p t_s   = √(T_s T_p)

    ``factor="radiance"`` multiplies by (n_t/n_i)² (the n² radiance law), ``"flux"`` gives the
    irradiance/flux transmittance, ``"none"`` gives the bare amplitude products ½(t_p² ± t_s²),
    t_p t_s.

    Args:
        cos_i: Cosine of the angle of incidence, in [0, 1].
        n_i: Index of the medium the light comes from.
        n_t: Index of the medium it enters.
        factor: "radiance", "flux" or "none" (see above).

    Returns:
        :class:`FresnelElements`.
    """
    n_i = _check_index("n_i", n_i)
    n_t = _check_index("n_t", n_t)
    ci = np.clip(np.asarray(cos_i, dtype=_dtype(cos_i)), 0.0, 1.0)
    eta = n_i / n_t
    k = 1.0 - eta * eta * (1.0 - ci * ci)
    transmitted = k > 0.0
    ct = np.sqrt(np.maximum(k, 0.0))
    a_s = n_i * ci + n_t * ct
    a_p = n_t * ci + n_i * ct
    if factor == "none":
        # Amplitude coefficients t_s = 2 n_i cos θ_i / a_s, t_p = 2 n_i cos θ_i / a_p.
        ts = np.divide(2.0 * n_i * ci, a_s, out=np.zeros_like(ci), where=a_s > 0)
        tp = np.divide(2.0 * n_i * ci, a_p, out=np.zeros_like(ci), where=a_p > 0)
        tss, tpp, tps = ts * ts, tp * tp, tp * ts
    else:
        num = 4.0 * n_i * n_t * ci * ct
        tss = np.divide(num, a_s * a_s, out=np.zeros_like(ci), where=a_s > 0)
        tpp = np.divide(num, a_p * a_p, out=np.zeros_like(ci), where=a_p > 0)
        tps = np.sqrt(tss * tpp)
        if factor == "radiance":
            g = (n_t / n_i) ** 2
            tss, tpp, tps = tss * g, tpp * g, tps * g
        elif factor != "flux":
            raise ValueError(f"factor must be 'radiance', 'flux' or 'none', got {factor!r}")
    zero = np.zeros_like(ci)
    m00 = np.where(transmitted, 0.5 * (tpp + tss), zero)
    m01 = np.where(transmitted, 0.5 * (tpp - tss), zero)
    m22 = np.where(transmitted, tps, zero)
    return FresnelElements(m00, m01, m22, ct, transmitted)


def fresnel_transmission_mueller(
    theta_i: ArrayLike, n_t: float, n_i: float = N_AIR, factor: Factor = "radiance"
) -> FloatArray:
    """The 3×3 linear (I, Q, U) Fresnel transmission Mueller matrix, p-axis reference.

    Stokes in the plane-of-incidence basis with x = p (in the plane of incidence; for a flat sea
    the local meridian), Q = I_p − I_s, U at +45° (optics.md §2.2). With the s-axis as reference
    the off-diagonal sign flips (Powell et al.'s ``Mueller.polarizer(t_s, t_p)``).

    Args:
        theta_i: Angle(s) of incidence in radians, [0, π/2].
        n_t: Index of the medium entered (water: :func:`water_index`).
        n_i: Index of the medium the light comes from (air: 1).
        factor: "radiance" (n² law, default), "flux" or "none"; see :func:`fresnel_elements`.

    Returns:
        Array of shape ``theta_i.shape + (3, 3)``; zero beyond the critical angle.
    """
    th = np.asarray(theta_i, dtype=np.float64)
    if np.any(th < 0) or np.any(th > math.pi / 2 + 1e-12):
        raise ValueError(f"theta_i must lie in [0, π/2] rad, got {theta_i!r}")
    e = fresnel_elements(np.cos(th), n_i, n_t, factor)
    m = np.zeros((*th.shape, 3, 3))
    m[..., 0, 0] = m[..., 1, 1] = e.m00
    m[..., 0, 1] = m[..., 1, 0] = e.m01
    m[..., 2, 2] = e.m22
    return m


def _apply_elements(
    stokes: FloatArray, m00: FloatArray, m01: FloatArray, m22: FloatArray
) -> FloatArray:
    """(I, Q, U) ↦ M_T (I, Q, U) for the block [[m00, m01, 0], [m01, m00, 0], [0, 0, m22]]."""
    i, q, u = stokes[..., 0], stokes[..., 1], stokes[..., 2]
    return np.stack([m00 * i + m01 * q, m01 * i + m00 * q, m22 * u], axis=-1)


# --------------------------------------------------------------------------------------------
# Vector Snell refraction
# --------------------------------------------------------------------------------------------


class Refracted(NamedTuple):
    """Rays after an interface.

    Attributes:
        directions: Unit directions after the interface. Where ``transmitted`` is False they say
            where the ray goes instead: the mirror reflection for total internal reflection, or
            the unchanged input ray where it never meets the interface from the right side.
        transmitted: True where the ray crosses the interface.
        cos_i: Cosine of the angle of incidence (0 where the ray does not meet the interface).
        cos_t: Cosine of the angle of transmission (0 where not transmitted).
    """

    directions: FloatArray
    transmitted: BoolArray
    cos_i: FloatArray
    cos_t: FloatArray


def refract(d: ArrayLike, normals: ArrayLike, n_i: float, n_t: float) -> Refracted:
    """Vector Snell's law for rays travelling along ``d`` from index ``n_i`` into ``n_t``.

    With the normal oriented against the ray (n̂·d < 0), cos θ_i = −n̂·d and
    d_t = η d + (η cos θ_i − √(1 − η²(1 − cos² θ_i))) n̂, η = n_i/n_t. A negative radicand is
    total internal reflection: the reflected ray d + 2 cos θ_i n̂ is returned, masked.

    Args:
        d: (..., 3) unit travel directions.
        normals: (..., 3) or (3,) unit interface normals, either orientation.
        n_i: Index of the medium the ray travels in.
        n_t: Index of the medium beyond the interface.

    Returns:
        :class:`Refracted`.
    """
    n_i = _check_index("n_i", n_i)
    n_t = _check_index("n_t", n_t)
    dt = _dtype(d, normals)
    d = np.asarray(d, dtype=dt)
    nrm = np.broadcast_to(np.asarray(normals, dtype=dt), d.shape)
    dn = _dot(nrm, d)
    # Orient the normal against the ray: then cos_i = |n·d| and the formula is one-sided.
    sign = np.where(dn > 0, -1.0, 1.0).astype(dt)
    nrm = nrm * sign[..., None]
    cos_i = np.abs(dn)
    eta = n_i / n_t
    k = 1.0 - eta * eta * (1.0 - cos_i * cos_i)
    transmitted = (k > 0.0) & (cos_i > 0.0)
    cos_t = np.sqrt(np.maximum(k, 0.0))
    out = eta * d + (eta * cos_i - cos_t)[..., None] * nrm
    reflected = d + (2.0 * cos_i)[..., None] * nrm
    out = np.where(transmitted[..., None], out, reflected)
    cos_t = np.where(transmitted, cos_t, 0.0).astype(dt)
    return Refracted(out, transmitted, cos_i, cos_t)


def sky_directions_from_water(
    look_dirs: ArrayLike, n: float, normals: ArrayLike | None = None
) -> Refracted:
    """Inverse Snell: the sky direction each in-water camera ray sees through the surface.

    A camera ray looking up along ``look_dirs`` meets the surface from below; by reversibility the
    sky light it receives came from the refracted direction (the ray traced on into the air).
    Rays outside Snell's window (n sin θ_w > 1, relative to the facet normal) are totally
    internally reflected and see the water below mirrored, not the sky: ``transmitted`` is False
    and ``directions`` is the reflected (downward) ray. Rays that do not meet the surface from
    below (looking at or below the horizon, or at the back of a steep facet) are not transmitted
    and keep their direction. A wavy-surface ray that leaves the facet going downwards would hit
    the sea again, so it is masked too.

    Args:
        look_dirs: (..., 3) unit in-water look directions (ENU world frame).
        n: Water index relative to air.
        normals: Facet normals (..., 3) pointing up into the air; None for a flat sea (+z).

    Returns:
        :class:`Refracted` whose ``directions`` are sky look directions (towards the sky point),
        ``cos_i`` the in-water and ``cos_t`` the in-air angle cosines relative to the normal.
    """
    w = np.asarray(look_dirs, dtype=_dtype(look_dirs))
    if normals is None:
        return _flat_water_to_air(w, _check_index("n", n))
    r = refract(w, normals, n, N_AIR)
    up = np.asarray(normals, dtype=w.dtype)
    # The ray must meet the facet from below (w·n̂ > 0) and the sky ray must point upwards.
    meets = _dot(np.broadcast_to(up, w.shape), w) > 0.0
    ok = r.transmitted & meets & (r.directions[..., 2] > 0.0)
    dirs = np.where(meets[..., None], r.directions, w)
    return Refracted(dirs, ok, np.where(meets, r.cos_i, 0.0).astype(w.dtype), r.cos_t * ok)


def _flat_water_to_air(w: FloatArray, n: float) -> Refracted:
    """Flat sea (normal +z): the horizontal components scale by n, θ_a = arcsin(n sin θ_w)."""
    cz = w[..., 2]
    k = 1.0 - n * n * (1.0 - cz * cz)
    ok = (k > 0.0) & (cz > 0.0)
    ca = np.sqrt(np.maximum(k, 0.0))
    # Transmitted: (n w_x, n w_y, cos θ_a). TIR: the mirror ray (w_x, w_y, −w_z). Below the
    # horizon: the ray itself.
    scale = np.where(ok, n, 1.0).astype(w.dtype)
    z = np.where(ok, ca, np.where(cz > 0, -cz, cz))
    dirs = np.stack([w[..., 0] * scale, w[..., 1] * scale, z], axis=-1)
    return Refracted(dirs, ok, np.maximum(cz, 0.0), np.where(ok, ca, 0.0).astype(w.dtype))


def water_directions_from_sky(
    sky_dirs: ArrayLike, n: float, normals: ArrayLike | None = None
) -> Refracted:
    """Forward Snell: the in-water look direction at which a sky point appears.

    Light from the sky point travels along −``sky_dirs``, refracts into the water, and reaches
    the camera travelling along d_t; the camera sees it looking along −d_t. Air → water never
    totally reflects; sky points below the facet's horizon are not transmitted.

    Args:
        sky_dirs: (..., 3) unit sky look directions (towards the sky point, z > 0).
        n: Water index relative to air.
        normals: Facet normals (..., 3) pointing up; None for a flat sea.

    Returns:
        :class:`Refracted` with in-water look directions (pointing up into Snell's window),
        ``cos_i`` the in-air and ``cos_t`` the in-water angle cosines.
    """
    a = np.asarray(sky_dirs, dtype=_dtype(sky_dirs))
    nrm = np.array([0.0, 0.0, 1.0], dtype=a.dtype) if normals is None else normals
    meets = _dot(np.broadcast_to(np.asarray(nrm, dtype=a.dtype), a.shape), a) > 0.0
    r = refract(-a, nrm, N_AIR, _check_index("n", n))
    ok = r.transmitted & meets
    dirs = np.where(ok[..., None], -r.directions, a)
    return Refracted(dirs, ok, r.cos_i * ok, r.cos_t * ok)


# --------------------------------------------------------------------------------------------
# Stokes through an interface
# --------------------------------------------------------------------------------------------


def _plane_of_incidence_axes(
    d_i: FloatArray, d_t: FloatArray, normals: FloatArray, ref_fallback: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """p-axes of the incident and the transmitted ray: p = s × d, s ⟂ the plane of incidence.

    With the same s for both rays, d × p = s on both sides of the interface, so the Stokes (Q, U)
    frames have the same handedness and the transmission block has + t_p t_s on U (Born & Wolf's
    sign convention for transmission). At normal incidence the plane is undefined and M_T is
    isotropic; the caller's reference is then used as the p-axis.
    """
    s = np.cross(normals, d_i)
    s_fb = np.cross(d_i, ref_fallback)
    s = _unit(s, fallback=None)
    degenerate = _dot(s, s) < 0.5
    s = np.where(degenerate[..., None], _unit(s_fb), s)
    return np.cross(s, d_i), np.cross(s, d_t)


class TransmittedStokes(NamedTuple):
    """Light after an interface: Stokes, travel direction, reference (the p-axis), mask."""

    stokes: FloatArray
    d: FloatArray
    ref: FloatArray
    transmitted: BoolArray


def transmit_stokes(
    stokes: ArrayLike,
    ref: ArrayLike,
    d: ArrayLike,
    normals: ArrayLike,
    n_i: float,
    n_t: float,
    factor: Factor = "radiance",
) -> TransmittedStokes:
    """Carry Stokes vectors with arbitrary references through an interface (any n_i → n_t).

    Each ray's Stokes is rotated from ``ref`` to the p-axis of its plane of incidence
    (:func:`stokes.rotate_reference`), multiplied by the Fresnel transmission block
    (:func:`fresnel_elements`), and returned relative to the transmitted ray's p-axis.
    For fully polarized light this gives tan ψ' = (t_s/t_p) tan ψ (ψ from the p-axis).

    Args:
        stokes: (..., 3) Stokes (I, Q, U) of the incident light.
        ref: (..., 3) their reference axes (⟂ ``d``).
        d: (..., 3) unit travel directions of the incident light.
        normals: (..., 3) or (3,) interface normals (either orientation).
        n_i: Index of the medium the light comes from.
        n_t: Index of the medium it enters.
        factor: "radiance" (n² law), "flux" or "none"; see :func:`fresnel_elements`.

    Returns:
        :class:`TransmittedStokes`; Stokes are zero where the ray is totally reflected.
    """
    dt = _dtype(stokes, ref, d)
    s_in = np.asarray(stokes, dtype=dt)
    ref = np.asarray(ref, dtype=dt)
    d = np.asarray(d, dtype=dt)
    nrm = np.broadcast_to(np.asarray(normals, dtype=dt), d.shape)
    r = refract(d, nrm, n_i, n_t)
    p_i, p_t = _plane_of_incidence_axes(d, r.directions, nrm, ref)
    s_p = st.rotate_reference(s_in, d, ref, p_i)
    e = fresnel_elements(r.cos_i, n_i, n_t, factor)
    out = _apply_elements(s_p, e.m00, e.m01, e.m22) * r.transmitted[..., None]
    return TransmittedStokes(out.astype(dt, copy=False), r.directions, p_t, r.transmitted)


# --------------------------------------------------------------------------------------------
# Elementwise kernels for the per-frame blocks (shared with sky and water)
# --------------------------------------------------------------------------------------------


def exp_into(x: FloatArray, out: FloatArray) -> FloatArray:
    """Exponential into ``out``: exp(x) for a contiguous 1-D float32/float64 block.

    In place allowed. OpenCV's exp: the same accuracy as numpy's (≤ 2.1e-7 relative in
    float32, 4.5e-16 in float64, measured over [−20, 5]), the same 0 / inf / NaN at the
    extremes, and ~5× faster on this class of machine (numpy's float32 exp is not vectorised
    for x86-64-v3 here).
    """
    if out.flags.c_contiguous and x.flags.c_contiguous and x.dtype == out.dtype:
        r = cv2.exp(x, out)
        if r is out or np.shares_memory(r, out):
            return out
        out[...] = r.reshape(out.shape)
        return out
    return np.exp(x, out=out)


def arccos_into(x: FloatArray, out: FloatArray, tmp: FloatArray) -> FloatArray:
    """Into ``out``: arccos(x) for x in [−1, 1]; float32: a polynomial, float64: numpy's.

    Float32 uses Abramowitz & Stegun 4.4.46, arccos|x| = √(1 − |x|) Σ a_k |x|^k (|error| ≤ 2e-8
    rad, below float32's own rounding here) with arccos(−x) = π − arccos x: ~3× numpy's float32
    arccos. The result is in [0, π]; in place allowed.
    """
    if x.dtype != np.float32:
        return np.arccos(x, out=out)
    ax = np.abs(x, out=tmp)
    neg = x < 0
    # Horner in |x| into out, then × √(1 − |x|).
    np.multiply(ax, _ACOS_POLY[0], out=out)
    for c in _ACOS_POLY[1:-1]:
        out += c
        out *= ax
    out += _ACOS_POLY[-1]
    np.subtract(1.0, ax, out=ax)
    np.sqrt(ax, out=ax)
    out *= ax
    np.subtract(np.float32(math.pi), out, out=out, where=neg)
    return out


#: Abramowitz & Stegun 4.4.46 coefficients a7 … a0 (Horner order).
_ACOS_POLY = (
    -0.0012624911,
    0.0066700901,
    -0.0170881256,
    0.0308918810,
    -0.0501743046,
    0.0889789874,
    -0.2145988016,
    1.5707963050,
)


#: Rays per block in the per-frame kernels: temporaries of a block stay in cache (numpy is
#: memory-bound on whole-frame float32 arrays; the same choice as :mod:`sky`).
CHUNK = 65536


def as_rotation(rotation: ArrayLike | None) -> NDArray[np.float64] | None:
    """Validate a frame rotation C_F^n (3×3 orthonormal) or pass None (directions already ENU)."""
    if rotation is None:
        return None
    r = np.asarray(rotation, dtype=np.float64)
    if r.shape != (3, 3) or not is_rotation(r):
        raise ValueError("rotation must be an orthonormal 3x3 matrix C_F^n (frame F to ENU)")
    return r


_ORTHO_TOL = 1e-6 + 1e-5 * np.eye(3)  # np.allclose(r rᵀ, I, atol=1e-6)'s tolerance, elementwise


def is_rotation(r: NDArray[np.float64]) -> bool:
    """Whether a finite 3×3 matrix is orthonormal: ``np.allclose(r @ r.T, I, atol=1e-6)``.

    The same test without allclose's overhead (~10× faster; it runs several times a frame).
    """
    d = r @ r.T
    d -= np.eye(3)
    return bool(np.all(np.abs(d) <= _ORTHO_TOL))


def flatten_directions(look_dirs: ArrayLike) -> tuple[FloatArray, tuple[int, ...]]:
    """(n, 3) view of (..., 3) directions (no copy for views of planar storage) and the shape."""
    p = np.asarray(look_dirs)
    if p.shape[-1:] != (3,):
        raise ValueError(f"look_dirs must have shape (..., 3), got {p.shape}")
    if p.dtype not in (np.float32, np.float64):
        p = p.astype(np.float64)
    shape = p.shape[:-1]
    return p.reshape(-1, 3), shape


def world_components(
    block: FloatArray, r: NDArray[np.float64] | None, out: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """ENU components (x, y, z) of a block of (m, 3) directions given in frame F (C_F^n = r)."""
    if r is None:
        return block[:, 0], block[:, 1], block[:, 2]
    # Three fused multiply-adds a component: numpy's matmul takes a slow non-BLAS path on the
    # strided (3, m) view of planar storage (measured 5.7 ms vs ~1 ms a 65 k block).
    m = block.shape[0]
    x, y, z = block[:, 0], block[:, 1], block[:, 2]
    rc = r.astype(block.dtype)
    for i in range(3):
        o = out[i, :m]
        np.multiply(x, rc[i, 0], out=o)
        o += y * rc[i, 1]
        o += z * rc[i, 2]
    return out[0, :m], out[1, :m], out[2, :m]


@dataclass(frozen=True, slots=True)
class SurfaceTransmission:
    """Per-ray air → water Fresnel factors and geometry for one frame's camera rays.

    Built once per frame by :func:`surface_transmission` (the rays move with the vehicle, the
    facets with the waves); :meth:`apply` carries any number of sky Stokes fields through.
    Stokes on both sides use the chain's *meridian* convention (as :mod:`sky` returns them):
    relative to ``stokes.meridian_reference(d)`` of the light's travel direction d in ENU — for the
    sky light d = −sky_dir, for the light reaching the camera d = −look_dir. For a flat sea both
    meridians are the p-axes of the plane of incidence (up to sign, which Stokes ignore), so the
    transmission is three products a pixel; for waves the Stokes are rotated into and out of each
    facet's plane of incidence.

    Attributes:
        storage: (5, ...) planes (m00, m01, m22, cos_water, cos_air), exposed as properties;
            pass the object back as ``out=`` to :func:`surface_transmission` to reuse it next
            frame (no allocation, no page faults on full frames).
        n: The water index.
        look_dirs: The (..., 3) look directions it was built for (frame F).
        rotation: C_F^n (None: ENU).
        normals: (..., 3) ENU facet normals for waves, None for a flat sea.
        rot_in: (2, ...) cos 2χ, sin 2χ of the rotation sky meridian → p-axis (waves only).
        rot_out: (2, ...) cos 2χ, sin 2χ of the rotation p-axis → in-water meridian (waves only).
    """

    storage: FloatArray
    n: float
    look_dirs: FloatArray
    rotation: NDArray[np.float64] | None
    normals: FloatArray | None
    rot_in: FloatArray | None
    rot_out: FloatArray | None

    @property
    def m00(self) -> FloatArray:
        """(...) K(t_p² + t_s²)/2, radiance factor (n² law), p basis; 0 outside the window."""
        return self.storage[0]

    @property
    def m01(self) -> FloatArray:
        """(...) K(t_p² − t_s²)/2 (p-axis reference: transmission favours p)."""
        return self.storage[1]

    @property
    def m22(self) -> FloatArray:
        """(...) K t_p t_s."""
        return self.storage[2]

    @property
    def cos_water(self) -> FloatArray:
        """(...) cosine of each ray's in-water zenith angle (v_z in ENU)."""
        return self.storage[3]

    @property
    def cos_air(self) -> FloatArray:
        """(...) cosine of the in-air angle of incidence on the facet (0 outside the window)."""
        return self.storage[4]

    @property
    def sees_sky(self) -> BoolArray:
        """(...) True inside Snell's window (the ray reaches the sky)."""
        return self.storage[4] > 0.0

    def apply(self, sky_stokes: ArrayLike, out: FloatArray | None = None) -> FloatArray:
        """Transmit sky Stokes (meridian reference) into the water (meridian reference).

        Args:
            sky_stokes: (..., 3) sky (I, Q, U) seen along :meth:`sky_directions`, relative to
                ``stokes.meridian_reference(-sky_dir)`` (what :func:`sky.sky_radiance` returns).
            out: Optional planar (3, ...) buffer to write into (reuse it across frames).

        Returns:
            (..., 3) in-water Stokes (a view of planar (3, ...) storage) relative to
            ``stokes.meridian_reference(-look_dir)``; zero outside Snell's window.
        """
        s = np.asarray(sky_stokes)
        dt = self.storage.dtype
        shape = self.storage.shape[1:]
        if s.shape != (*shape, 3):
            raise ValueError(f"sky_stokes must have shape {(*shape, 3)}, got {s.shape}")
        if out is None:
            out = np.empty((3, *shape), dtype=dt)
        elif out.shape != (3, *shape) or out.dtype != dt:
            raise ValueError(f"out must be a {dt} array of shape {(3, *shape)}, got {out.shape}")
        total = int(np.prod(shape, dtype=np.int64))
        src = s.reshape(total, 3)
        res = self.storage.reshape(5, total)
        dst = out.reshape(3, total)
        rin = None if self.rot_in is None else self.rot_in.reshape(2, total)
        rout = None if self.rot_out is None else self.rot_out.reshape(2, total)
        chunk = min(CHUNK, max(total, 1))
        buf = np.empty((4, chunk), dtype=dt)
        for i0 in range(0, total, chunk):
            i1 = min(i0 + chunk, total)
            m = i1 - i0
            q, u, t, t2 = (row[:m] for row in buf)
            i = src[i0:i1, 0]
            q[...] = src[i0:i1, 1]
            u[...] = src[i0:i1, 2]
            if rin is not None:  # sky meridian → facet p-axis
                _rotate_qu(q, u, rin[0, i0:i1], rin[1, i0:i1], t, t2)
            m00, m01, m22 = res[0, i0:i1], res[1, i0:i1], res[2, i0:i1]
            o = dst[:, i0:i1]
            np.multiply(m00, i, out=o[0])
            np.multiply(m01, q, out=t)
            o[0] += t
            np.multiply(m01, i, out=o[1])
            np.multiply(m00, q, out=t)
            o[1] += t
            np.multiply(m22, u, out=o[2])
            if rout is not None:  # facet p-axis → in-water meridian
                _rotate_qu(o[1], o[2], rout[0, i0:i1], rout[1, i0:i1], t, t2)
        return np.moveaxis(out, 0, -1)

    def sky_directions(self) -> FloatArray:
        """(..., 3) the sky look direction each ray sees, in the rays' frame F.

        Pass them to :func:`sky.sky_radiance` with the same ``rotation``. Rays outside the window
        get the direction :func:`sky_directions_from_water` gives them (TIR mirror / unchanged);
        their transmission factors are zero, so what the sky model returns there is irrelevant.
        """
        r = self.rotation
        w = np.asarray(self.look_dirs)
        if self.normals is None:
            return self._flat_sky_directions(w)
        if r is not None:
            w = w @ r.T.astype(w.dtype)  # to ENU
        res = sky_directions_from_water(w, self.n, self.normals)
        d = res.directions
        if r is not None:
            d = d @ r.astype(d.dtype)  # back to F: C^T d
        return d.astype(self.storage.dtype, copy=False)

    def _flat_sky_directions(self, w: FloatArray) -> FloatArray:
        """Flat sea, in frame F directly, from the stored cosines (no world-frame ray array).

        :func:`_flat_water_to_air` in ENU is d = α w + β ẑ with α = n, β = c_a − n w_z inside the
        window, α = 1, β = −2 w_z for the TIR mirror (w_z > 0), α = 1, β = 0 below the horizon;
        in F (d_F = Cᵀ d) that is α w_F + β Cᵀẑ, with w_z and c_a the stored cos_water and
        cos_air: two per-ray scalars and three multiply-adds, over cache-sized blocks.
        """
        flat, shape = flatten_directions(w)
        dt = self.storage.dtype
        total = flat.shape[0]
        up_f = np.array([0.0, 0.0, 1.0]) if self.rotation is None else self.rotation[2]
        up_f = up_f.astype(dt)
        cos_w = self.storage[3].reshape(total)
        cos_a = self.storage[4].reshape(total)
        out = np.empty((3, total), dtype=dt)
        chunk = min(CHUNK, max(total, 1))
        buf = np.empty((3, chunk), dtype=dt)
        n = np.asarray(self.n, dtype=dt)
        for i0 in range(0, total, chunk):
            i1 = min(i0 + chunk, total)
            m = i1 - i0
            alpha, beta, tmp = (row[:m] for row in buf)
            wz, ca = cos_w[i0:i1], cos_a[i0:i1]
            ok = ca > 0.0
            np.multiply(wz, -2.0, out=beta)  # TIR mirror
            np.minimum(beta, 0.0, out=beta)  # 0 below the horizon (w_z ≤ 0)
            np.multiply(wz, -n, out=tmp)
            tmp += ca  # c_a − n w_z
            np.copyto(beta, tmp, where=ok)
            alpha.fill(1.0)
            alpha[ok] = n
            for k in range(3):
                o = out[k, i0:i1]
                np.multiply(flat[i0:i1, k], alpha, out=o)
                np.multiply(beta, up_f[k], out=tmp)
                o += tmp
        return np.moveaxis(out.reshape(3, *shape), 0, -1)

    def apply_with_reference(self, sky_stokes: ArrayLike, sky_ref: ArrayLike) -> TransmittedStokes:
        """Transmit sky Stokes given relative to arbitrary references (general, slower path).

        Args:
            sky_stokes: (..., 3) sky Stokes at :meth:`sky_directions`.
            sky_ref: (..., 3) their reference axes, ENU, ⟂ the light's travel direction.

        Returns:
            :class:`TransmittedStokes` relative to the transmitted rays' p-axes (ENU).
        """
        w = np.asarray(self.look_dirs)
        if self.rotation is not None:
            w = w @ self.rotation.T.astype(w.dtype)
        a = sky_directions_from_water(w, self.n, self.normals).directions
        nrm = np.array([0.0, 0.0, 1.0]) if self.normals is None else self.normals
        t = transmit_stokes(sky_stokes, sky_ref, -a, nrm, N_AIR, self.n)
        return TransmittedStokes(t.stokes * self.sees_sky[..., None], -w, t.ref, self.sees_sky)


def _rotate_qu(
    q: FloatArray, u: FloatArray, c2: FloatArray, s2: FloatArray, t: FloatArray, t2: FloatArray
) -> None:
    """In place (Q, U) ← (c2 Q + s2 U, −s2 Q + c2 U), as :func:`stokes.rotate_reference`."""
    np.multiply(s2, q, out=t)  # s2 Q
    np.multiply(s2, u, out=t2)  # s2 U
    q *= c2
    q += t2
    u *= c2
    u -= t


def _meridian_to_p(s_ax: FloatArray, d: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(cos 2χ, sin 2χ) of the rotation from the ENU meridian reference of d to p = s × d.

    With m = (ẑ − (ẑ·d) d)/ρ and p = s × d (s ⟂ d): cos χ = m·p = p_z/ρ and
    sin χ = (m × p)·d = −m·s = −s_z/ρ, and p_z² + s_z² = |s|² ρ², so an unnormalised s will do:
    cos 2χ = (p_z² − s_z²)/(p_z² + s_z²), sin 2χ = −2 p_z s_z/(p_z² + s_z²). Where that vanishes
    (normal incidence, or d vertical) the rotation is taken as the identity; there the Fresnel
    block is isotropic, or the meridian itself is a convention.
    """
    p_z = s_ax[..., 0] * d[..., 1] - s_ax[..., 1] * d[..., 0]
    s_z = s_ax[..., 2]
    a2, b2 = p_z * p_z, s_z * s_z
    norm = a2 + b2
    ok = norm > 1e-20
    inv = 1.0 / np.where(ok, norm, 1.0)
    return np.where(ok, (a2 - b2) * inv, 1.0), np.where(ok, -2.0 * p_z * s_z * inv, 0.0)


def _flat_fresnel_block(z: FloatArray, n: float, out: FloatArray, buf: FloatArray) -> None:
    """Fill out[0..4] = (m00, m01, m22, cos_water, cos_air) for one block of ENU v_z (flat sea).

    With μ = max(v_z, 0) (in water) and c_a = √max(1 − n²(1 − μ²), 0) (in air; 0 beyond the
    critical angle), the radiance-factor elements are n² × the flux forms of
    :func:`fresnel_elements` with n_i = 1, n_t = n, cos θ_i = c_a, cos θ_t = μ. Their numerator
    4 n c_a μ vanishes outside the window and below the horizon, so no mask is needed.
    """
    m = z.shape[0]
    m00, m01, m22, cos_w, ca = (row[:m] for row in out)
    mu, num, a_s, a_p, tmp = (row[:m] for row in buf)
    cos_w[...] = z
    np.maximum(z, 0.0, out=mu)
    np.multiply(mu, mu, out=ca)
    ca *= n * n
    ca += 1.0 - n * n
    np.maximum(ca, 0.0, out=ca)
    np.sqrt(ca, out=ca)
    np.multiply(ca, mu, out=num)
    num *= 4.0 * n
    np.multiply(mu, n, out=a_s)
    a_s += ca  # c_a + n μ
    np.multiply(ca, n, out=a_p)
    a_p += mu  # n c_a + μ
    g = n * n  # the n² radiance law
    np.multiply(a_s, a_p, out=tmp)
    tmp += 1e-30
    np.divide(num, tmp, out=m22)
    m22 *= g  # n² K t_p t_s
    np.multiply(a_s, a_s, out=tmp)
    tmp += 1e-30
    np.divide(num, tmp, out=a_s)  # a_s now T_s
    np.multiply(a_p, a_p, out=tmp)
    tmp += 1e-30
    np.divide(num, tmp, out=a_p)  # a_p now T_p
    np.add(a_p, a_s, out=m00)
    m00 *= 0.5 * g
    np.subtract(a_p, a_s, out=m01)
    m01 *= 0.5 * g


def surface_transmission(
    look_dirs: ArrayLike,
    n: float,
    *,
    rotation: ArrayLike | None = None,
    normals: ArrayLike | None = None,
    out: SurfaceTransmission | None = None,
) -> SurfaceTransmission:
    """Per-ray refraction and Fresnel radiance factors through the sea surface, for one frame.

    Args:
        look_dirs: (..., 3) unit in-water camera look directions in frame F (e.g. the camera's
            rays, ideally a view of planar (3, ...) storage), or ENU when ``rotation`` is None.
        n: Water index relative to air.
        rotation: C_F^n, the 3×3 rotation from F to ENU (the camera attitude).
        normals: (..., 3) ENU facet normals pointing up (waves, e.g.
            :meth:`waves.WaveSurface.normals_for_rays`), or None for a flat sea.
        out: Last frame's result, whose storage is overwritten (flat sea only).

    Returns:
        :class:`SurfaceTransmission`.
    """
    n = _check_index("n", n)
    if n <= 1.0:
        raise ValueError(f"n must be > 1 for water, got {n!r}")
    r = as_rotation(rotation)
    flat, shape = flatten_directions(look_dirs)
    dt = flat.dtype
    if normals is not None:
        return _wavy_transmission(np.asarray(look_dirs), flat, shape, n, r, normals)
    total = flat.shape[0]
    if out is not None and out.storage.shape == (5, *shape) and out.storage.dtype == dt:
        storage = out.storage
    else:
        storage = np.empty((5, *shape), dtype=dt)
    res = storage.reshape(5, total)
    chunk = min(CHUNK, max(total, 1))
    buf = np.empty((5, chunk), dtype=dt)
    wbuf = np.empty((3, chunk), dtype=dt)
    for i0 in range(0, total, chunk):
        i1 = min(i0 + chunk, total)
        _, _, z = world_components(flat[i0:i1], r, wbuf)
        _flat_fresnel_block(z, n, res[:, i0:i1], buf)
    return SurfaceTransmission(storage, n, np.asarray(look_dirs), r, None, None, None)


def _wavy_transmission(
    look_dirs: FloatArray,
    flat: FloatArray,
    shape: tuple[int, ...],
    n: float,
    r: NDArray[np.float64] | None,
    normals: ArrayLike,
) -> SurfaceTransmission:
    """General path: per-ray facet normals (vector Snell, facet planes of incidence)."""
    dt = flat.dtype
    w = flat if r is None else flat @ r.T.astype(dt)  # ENU
    nrm = np.asarray(normals, dtype=dt).reshape(-1, 3)
    res = sky_directions_from_water(w, n, nrm)
    e = fresnel_elements(res.cos_t, N_AIR, n, "radiance")
    ok = res.transmitted
    d_i = -res.directions
    d_t = -w
    # The facet's s-axis (⟂ the plane of incidence), unnormalised; p = s × d on both sides.
    s_ax = np.cross(nrm, d_i)
    c2i, s2i = _meridian_to_p(s_ax, d_i)
    c2o, s2o = _meridian_to_p(s_ax, d_t)
    s2o = -s2o  # the way out: p-axis → meridian
    zero = np.zeros((), dtype=dt)

    def plane(x: FloatArray) -> FloatArray:
        return np.where(ok, x, zero).astype(dt).reshape(shape)

    storage = np.stack(
        [plane(e.m00), plane(e.m01), plane(e.m22), w[:, 2].reshape(shape), plane(res.cos_t)]
    )
    return SurfaceTransmission(
        storage,
        n,
        look_dirs,
        r,
        nrm.reshape((*shape, 3)),
        np.stack([c2i, s2i]).astype(dt).reshape((2, *shape)),
        np.stack([c2o, s2o]).astype(dt).reshape((2, *shape)),
    )


class RefractedSunBeam(NamedTuple):
    """The direct solar beam below a flat surface.

    Attributes:
        look_dir: (3,) in-water look direction towards the refracted sun (z > 0).
        irradiance_factor: Normal irradiance in water per unit normal irradiance in air,
            T_flux(θ_a) cos θ_a / cos θ_w (the beam narrows on refraction).
        dop: Degree of polarization Fresnel transmission gives unpolarized sunlight.
        transmitted: False when the sun is at or below the horizon (a dark beam).
    """

    look_dir: FloatArray
    irradiance_factor: float
    dop: float
    transmitted: bool


def refract_sun_beam(sun_dir: ArrayLike, n: float) -> RefractedSunBeam:
    """Refract the (unpolarized) direct sun beam through a flat surface.

    The transmitted beam is partially p-polarized (E-vector in the vertical plane through the
    beam): DoP = |T_p − T_s|/(T_p + T_s), optics.md §2.2's "DoLP created from unpolarized".

    Args:
        sun_dir: (3,) unit ENU direction towards the sun in air.
        n: Water index relative to air.

    Returns:
        :class:`RefractedSunBeam` (zero irradiance and a zenith direction for a sun at or below
        the horizon, so that a night frame is dark and finite).
    """
    a = np.asarray(sun_dir, dtype=np.float64).reshape(3)
    if a[2] <= 0.0:
        return RefractedSunBeam(np.array([0.0, 0.0, 1.0]), 0.0, 0.0, False)
    r = water_directions_from_sky(a, n)
    e = fresnel_elements(a[2], N_AIR, n, "flux")
    m00, m01 = float(e.m00), float(e.m01)
    factor = m00 * float(a[2]) / float(r.cos_t)
    return RefractedSunBeam(np.asarray(r.directions), factor, abs(m01) / m00, True)


# --------------------------------------------------------------------------------------------
# Flat camera port
# --------------------------------------------------------------------------------------------


class PortTransmission(NamedTuple):
    """Rays through a flat port and their water → glass → air Fresnel factors.

    Attributes:
        directions: The other side's look directions (water side for
            :func:`flat_port_from_camera`, housing-air side for :func:`flat_port_from_water`).
        valid: True where the ray passes the port (inside: looks out through the port; outside:
            inside the port's own Snell window).
        m00: Product of the two interfaces' Mueller blocks (radiance factor, light going water →
            glass → air), p-axis reference relative to the port normal.
        m01: see ``m00``.
        m22: see ``m00``.
    """

    directions: FloatArray
    valid: BoolArray
    m00: FloatArray
    m01: FloatArray
    m22: FloatArray


def _port_elements(
    cos_w: FloatArray, n_water: float, n_glass: float
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    e1 = fresnel_elements(cos_w, n_water, n_glass, "radiance")  # water → glass
    e2 = fresnel_elements(e1.cos_t, n_glass, N_AIR, "radiance")  # glass → air
    # Parallel interfaces share the plane of incidence: the blocks multiply in one basis.
    m00 = e2.m00 * e1.m00 + e2.m01 * e1.m01
    m01 = e2.m00 * e1.m01 + e2.m01 * e1.m00
    m22 = e2.m22 * e1.m22
    return m00, m01, m22, e1.transmitted & e2.transmitted


def flat_port_from_camera(
    look_dirs_air: ArrayLike, port_normal: ArrayLike, n_water: float, n_glass: float = N_ACRYLIC
) -> PortTransmission:
    """Camera rays (inside the housing, in air) traced out through a flat port into the water.

    Through parallel interfaces the glass only shifts the ray sideways (ignored: the port is thin
    next to the scene), so n_water sin θ_w = sin θ_air and every camera ray that meets the port
    sees the water within θ_c = arcsin(1/n_water) of the port normal; a 185° lens sees no more.

    Args:
        look_dirs_air: (..., 3) camera look directions inside the housing.
        port_normal: (3,) outward port normal (the optical axis for a centred port).
        n_water: Water index.
        n_glass: Port index (acrylic 1.49 by default; BK7 ≈ 1.52).

    Returns:
        :class:`PortTransmission` with in-water look directions; rays at or beyond 90° from the
        normal (they see the housing) are invalid and keep their direction.
    """
    u = np.asarray(look_dirs_air, dtype=_dtype(look_dirs_air))
    nrm = np.asarray(port_normal, dtype=u.dtype).reshape(3)
    nrm = nrm / np.linalg.norm(nrm)
    cos_a = u @ nrm
    r = refract(u, nrm, N_AIR, _check_index("n_water", n_water))
    valid = r.transmitted & (cos_a > 0.0)
    m00, m01, m22, _ = _port_elements(r.cos_t, n_water, _check_index("n_glass", n_glass))
    dirs = np.where(valid[..., None], r.directions, u)
    z = np.zeros_like(m00)
    return PortTransmission(
        dirs, valid, np.where(valid, m00, z), np.where(valid, m01, z), np.where(valid, m22, z)
    )


def flat_port_from_water(
    look_dirs_water: ArrayLike, port_normal: ArrayLike, n_water: float, n_glass: float = N_ACRYLIC
) -> PortTransmission:
    """In-water look directions traced in through a flat port to the camera (inverse mapping).

    Rays more than θ_c from the port normal are totally internally reflected (at the glass–air
    face) and never reach the camera: ``valid`` is False.

    Args:
        look_dirs_water: (..., 3) in-water look directions (away from the camera).
        port_normal: (3,) outward port normal.
        n_water: Water index.
        n_glass: Port index.

    Returns:
        :class:`PortTransmission` with look directions inside the housing.
    """
    w = np.asarray(look_dirs_water, dtype=_dtype(look_dirs_water))
    nrm = np.asarray(port_normal, dtype=w.dtype).reshape(3)
    nrm = nrm / np.linalg.norm(nrm)
    cos_w = w @ nrm
    r = refract(w, nrm, _check_index("n_water", n_water), N_AIR)
    valid = r.transmitted & (cos_w > 0.0)
    m00, m01, m22, ok = _port_elements(np.maximum(cos_w, 0.0), n_water, n_glass)
    valid &= ok
    dirs = np.where(valid[..., None], r.directions, w)
    z = np.zeros_like(m00)
    return PortTransmission(
        dirs, valid, np.where(valid, m00, z), np.where(valid, m01, z), np.where(valid, m22, z)
    )


def interface_chain_elements(
    interfaces: tuple[tuple[float, float, ArrayLike, ArrayLike], ...], factor: Factor = "radiance"
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Combined Mueller elements of parallel interfaces crossed in order (e.g. a flat port).

    Takes the camera module's ``PortRays.interfaces()`` tuples ``(n_i, n_t, cos_i, cos_t)``;
    parallel interfaces share the plane of incidence, so the 2×2 (I, Q) blocks multiply in one
    p basis and the U elements multiply. An empty chain (a dome port) is the identity.

    Args:
        interfaces: ``(n_i, n_t, cos_i, cos_t)`` per interface, in the order the light crosses
            them (``cos_t`` is implied by Snell and recomputed; it is accepted for the
            camera module's signature).
        factor: "radiance", "flux" or "none" (see :func:`fresnel_elements`).

    Returns:
        (m00, m01, m22) of the product, p-axis reference (Q = I_p − I_s).
    """
    m00: FloatArray | float = 1.0
    m01: FloatArray | float = 0.0
    m22: FloatArray | float = 1.0
    for n_i, n_t, cos_i, _cos_t in interfaces:
        e = fresnel_elements(cos_i, n_i, n_t, factor)
        m00, m01, m22 = e.m00 * m00 + e.m01 * m01, e.m00 * m01 + e.m01 * m00, e.m22 * m22
    return np.asarray(m00), np.asarray(m01), np.asarray(m22)
