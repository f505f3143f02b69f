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

import functools
import math
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sensors.polarimeter import stokes as st
from twin.core.arrays import BoolArray, FloatArray

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
    # A frame asks for its sun's beam three times (its light field, its bubbles, its marine
    # snow); the numpy calls on one vector cost ~0.1 ms each time. Cached by value: the same
    # beam, bit for bit, and a read-only direction, shared.
    return _refracted(float(a[0]), float(a[1]), float(a[2]), float(n))


@functools.lru_cache(maxsize=8)
def _refracted(x: float, y: float, z: float, n: float) -> RefractedSunBeam:
    """:func:`refract_sun_beam` of the direction (x, y, z) (cached)."""
    a = np.array([x, y, z])
    if a[2] <= 0.0:
        look = np.array([0.0, 0.0, 1.0])
        look.setflags(write=False)
        return RefractedSunBeam(look, 0.0, 0.0, False)
    r = water_directions_from_sky(a, n)
    e = fresnel_elements(a[2], N_AIR, n, "flux")
    m00, m01 = float(e.m00), float(e.m01)
    factor = m00 * float(a[2]) / float(r.cos_t)
    look = np.array(r.directions, dtype=np.float64)
    look.setflags(write=False)
    return RefractedSunBeam(look, factor, abs(m01) / m00, True)


# --------------------------------------------------------------------------------------------
# Flat camera port
