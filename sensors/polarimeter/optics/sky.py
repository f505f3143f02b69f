"""Stage 3 of the polarimeter chain: radiance and polarization of the sky above the sea surface.

Evaluated for arrays of sky directions ``p`` (unit vectors from the observer towards the sky point,
ENU, z ≥ 0) given the apparent sun direction ``s`` (:mod:`sensors.polarimeter.optics.sun`).

Radiance — CIE standard general sky (CIE S 011/E:2003 = ISO 15469:2004; optics.md §1.5)
---------------------------------------------------------------------------------------
Relative radiance of a sky element at zenith angle Z and angular distance χ from the sun, for a sun
at zenith angle Z_s::

    L(Z, χ) / L_z = f(χ) φ(Z) / (f(Z_s) φ(0))                              (CIE eq. 1)
    φ(Z) = 1 + a exp(b / cos Z)        gradation  (φ(90°) = 1)              (CIE eq. 2)
    f(χ) = 1 + c [exp(d χ) − exp(d π/2)] + e cos² χ     indicatrix          (CIE eq. 3)

with (a, b, c, d, e) of the 15 sky types in :data:`sensors.polarimeter.optics.cie.CIE_SKY_TYPES`
(the formulas point by point: :mod:`~sensors.polarimeter.optics.cie`). The model is photometric
(luminance); it is used here as the angular shape of the spectral radiance at one wavelength.

**Absolute scale** (the sensor stage needs photons): ``I`` is spectral radiance in
W m⁻² sr⁻¹ nm⁻¹ at ``SkySpec.wavelength_nm``, with L_z = ``SkySpec.zenith_radiance``.
The default 0.05 W m⁻² sr⁻¹ nm⁻¹ is the order of a clear-sky zenith at 550 nm with the sun well up
[uncertain: order of magnitude; real zenith radiance changes ~10× between a low and a high sun and
with turbidity — set it per scenario]. :func:`photon_radiance` converts to photons. The solar disc
(angular radius ``sun_radius_rad`` = 0.2665°, uniform, unpolarized) is added on top of the CIE sky,
with radiance ``sun_relative_radiance`` × L_z. The default 4e5 follows from a direct-beam
irradiance of ≈1.4 W m⁻² nm⁻¹ at 550 nm spread over the disc's 6.8e-5 sr (≈2e4 W m⁻² sr⁻¹ nm⁻¹)
against the 0.05 zenith [uncertain, order of magnitude]; overcast types (1–4) and the "obscured sun"
type 9 default to no disc.

Polarization
------------
* ``"rayleigh"``: single scattering, DoP = DoP_max sin²γ / (1 + cos²γ) with γ the sun–point angle,
  E-vector ∝ s × p (optics.md §1.1; MOI paper eqs. 9–15).
* ``"berry"``: Berry, Dennis & Lee (2004), New J. Phys. 6:162, the complex four-neutral-point model
  (optics.md §1.2; :mod:`~sensors.polarimeter.optics.berry`). With ζ = tan(θ/2) e^{iφ}
  (stereographic; φ counter-clockwise from East)::

      ζ_Bab = tan((θ_s − δ/2)/2) e^{iφ_s},   ζ_Bre = tan((θ_s + δ/2)/2) e^{iφ_s},
      ζ_Ara = −1/conj(ζ_Bre),                ζ_4th = −1/conj(ζ_Bab),
      w(ζ) = −4 (ζ−ζ_Bab)(ζ−ζ_Bre)(ζ−ζ_Ara)(ζ−ζ_4th)
             / [(1+|ζ|²)² |ζ_Bab − ζ_4th| |ζ_Bre − ζ_Ara|]
      AoP in the ζ-plane = ½ arg(w e^{−2iφ_s}),     DoP = DoP_max |w| / (2 − |w|).

  It is evaluated in the equivalent finite form (a singular point at ζ = ∞ when a neutral point
  reaches the zenith is harmless)::

      (ζ − ζ_4th) / |ζ_Bab − ζ_4th| = e^{iφ_s} sgn(t_Bab) (1 + conj(ζ_Bab) ζ) / (1 + t_Bab²),
      t_Bab = tan((θ_s − δ/2)/2)   (likewise Brewster/Arago),

  and reduces exactly to Rayleigh at δ = 0 (tested). Berry et al.'s extra horizon depolarization
  is not included (no public implementation has it; optics.md §1.2). ``berry_delta_rad`` δ is the
  full Babinet–Brewster separation (default 30°, pyskylumos's default [uncertain: real separations
  depend on aerosols and ground albedo]).
* ``dop_max`` scales both (default 0.75, a typical clear sky [uncertain, optics.md §1.1]; 1 = the
  ideal single-scattering sky of the MOI paper).

Output convention
-----------------
Stokes (I, Q, U) follow :mod:`sensors.polarimeter.stokes` for the light travelling from the sky
point to the observer, ``d = −p``, relative to the **local meridian reference**
``stokes.meridian_reference(d)`` — the unit vector ⊥ d in the vertical plane through d, towards
+z (= the tangent of the sky point's meridian towards the zenith, = the plane of incidence of a
flat sea surface). At the exact zenith the meridian is undefined and the reference is North (+y).
E-vector angles ψ turn from that reference towards d × ref (= the sky point's eastward-turning
azimuthal tangent ∂p/∂φ / sin θ, φ counter-clockwise from East). In components the Rayleigh
E-vector has, along (ref, d × ref), the unnormalised coordinates

    a = (s × p)·ẑ = s_x p_y − s_y p_x,       b = s_z (p_x² + p_y²) − p_z (s_x p_x + s_y p_y),

so Q = I·DoP_max (a² − b²) / ((1 + cos²γ) ρ²), U = I·DoP_max 2ab / ((1 + cos²γ) ρ²) with
ρ² = p_x² + p_y², a² + b² = ρ² sin²γ: no trigonometry, exact at the sun (Q = U = 0) and accurate
in float32 near the zenith.

Night and the horizon: when the sun's apparent elevation is below
:data:`sensors.polarimeter.optics.sun.NIGHT_ELEVATION_DEG`, the sky is dark: I = ``night_radiance``
(default 0), Q = U = 0. Directions below the horizon (p_z < 0) see no sky: I = Q = U = 0.
Nothing returns NaN for unit inputs.

Speed: the evaluation runs over flattened blocks of ``_CHUNK`` directions so that temporaries stay
in cache (numpy on this class of machine is memory-bound: ~4× faster than whole-frame arrays),
in the input dtype (float32 for rendering, float64 for the 1e-6 tests). Directions may come in
any frame F with ``rotation`` = C_F^n (e.g. camera rays and the camera attitude): the rotation is
applied block by block, so no world-ray frame is ever written to memory; pass ``out=`` to reuse
the output frame. exp is OpenCV's and float32 arccos a polynomial
(:func:`~sensors.polarimeter.optics.blocks.exp_into`,
:func:`~sensors.polarimeter.optics.blocks.arccos_into`:
numpy's float32 versions are ~5× and ~3× slower here). Cost is ~20–30 ns a direction for
Rayleigh + a CIE clear sky on one core of the development VM, about 1.7× that for Berry: the
renderer evaluates the smooth sky on a coarse grid and exactly only where it is not smooth
(``render.Polarimeter._render_fast``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import chndtr

from sensors.polarimeter import stokes as stokes_mod
from sensors.polarimeter.optics.berry import BerryFrame, berry_block
from sensors.polarimeter.optics.blocks import arccos_into, exp_into, is_rotation
from sensors.polarimeter.optics.cie import CIE_SKY_TYPES, NO_DISC_TYPES
from sensors.polarimeter.optics.sun import NIGHT_ELEVATION_RAD, SunPosition, sun_vector
from twin.core.arrays import FloatArray
from twin.core.fields import Range, check_ranges

Polarization = Literal["rayleigh", "berry"]
#: The polarization models (the scenario's ``optics.sky_polarization``).
POLARIZATIONS: tuple[str, ...] = ("rayleigh", "berry")


_CHUNK = 16384
_PLANCK_H = 6.62607015e-34
_LIGHT_C = 299792458.0


@dataclass(frozen=True, slots=True)
class SkySpec:
    """The sky model's parameters (see the module docstring for the physics and sources).

    Attributes:
        cie_type: CIE standard general sky type, 1..15 (12 = standard clear sky).
        polarization: ``"rayleigh"`` or ``"berry"``.
        dop_max: Maximum degree of polarization, in [0, 1].
        berry_delta_rad: Berry's δ, the Babinet–Brewster separation, in [0, π/2).
        zenith_radiance: L_z, W m⁻² sr⁻¹ nm⁻¹ at ``wavelength_nm`` (≥ 0).
        sun_radius_rad: Angular radius of the solar disc, in [0, 0.1] (default 0.2665°).
        sun_relative_radiance: Disc radiance / L_z (≥ 0); None = 4e5, or 0 for types 1–4 and 9.
        night_radiance: Uniform unpolarized radiance at night (≥ 0; default 0 = dark).
        wavelength_nm: The wavelength the radiance refers to (for :func:`photon_radiance`).
    """

    cie_type: int = 12
    polarization: Polarization = "rayleigh"
    dop_max: float = 0.75
    berry_delta_rad: float = math.radians(30.0)
    zenith_radiance: float = 0.05
    sun_radius_rad: float = math.radians(0.2665)
    sun_relative_radiance: float | None = None
    night_radiance: float = 0.0
    wavelength_nm: float = 550.0

    def __post_init__(self) -> None:
        """Validate every field; raise ValueError naming the field and its allowed range."""
        if isinstance(self.cie_type, bool) or self.cie_type not in CIE_SKY_TYPES:
            raise ValueError(f"SkySpec.cie_type must be an integer 1..15, got {self.cie_type!r}")
        if self.polarization not in POLARIZATIONS:
            raise ValueError(
                f"SkySpec.polarization must be 'rayleigh' or 'berry', got {self.polarization!r}"
            )
        checks = [
            ("dop_max", self.dop_max, Range(0.0, 1.0)),
            ("berry_delta_rad", self.berry_delta_rad, Range(0.0, math.pi / 2, hi_open=True)),
            ("zenith_radiance", self.zenith_radiance, Range(0.0)),
            ("sun_radius_rad", self.sun_radius_rad, Range(0.0, 0.1)),
        ]
        if self.sun_relative_radiance is not None:
            checks.append(("sun_relative_radiance", self.sun_relative_radiance, Range(0.0)))
        checks.append(("night_radiance", self.night_radiance, Range(0.0)))
        checks.append(("wavelength_nm", self.wavelength_nm, Range(200.0, 2000.0)))
        check_ranges("SkySpec", checks)

    @property
    def cie_parameters(self) -> tuple[float, float, float, float, float]:
        """(a, b, c, d, e) of the sky type."""
        return CIE_SKY_TYPES[self.cie_type][:5]

    @property
    def sun_disc_radiance(self) -> float:
        """Radiance of the solar disc (same units as ``zenith_radiance``)."""
        rel = self.sun_relative_radiance
        if rel is None:
            rel = 0.0 if self.cie_type in NO_DISC_TYPES else 4e5
        return rel * self.zenith_radiance


def photon_radiance(radiance_w: ArrayLike, wavelength_nm: float) -> FloatArray:
    """Spectral radiance W m⁻² sr⁻¹ nm⁻¹ → photons s⁻¹ m⁻² sr⁻¹ nm⁻¹ (E = hc/λ)."""
    return np.asarray(radiance_w) * (wavelength_nm * 1e-9 / (_PLANCK_H * _LIGHT_C))


# --------------------------------------------------------------------------------------------------
# The evaluation
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class SkyRadiance:
    """The sky seen along each direction.

    Attributes:
        stokes: (..., 3) Stokes (I, Q, U), I in the units of ``SkySpec.zenith_radiance``, for light
            travelling along d = −p, relative to the local meridian reference (module docstring).
            A view of planar (3, ...) storage.
        directions: (..., 3) the directions as given (frame F, see ``rotation``).
        rotation: C_F^n, the rotation from the directions' frame to ENU (identity if world).
        night: Whether the sky was dark (sun below the night threshold).
    """

    stokes: FloatArray
    directions: FloatArray
    rotation: NDArray[np.float64]
    night: bool

    def reference(self) -> FloatArray:
        """(..., 3) the Stokes reference axes, in the directions' own frame F.

        The ENU local-meridian reference ``stokes.meridian_reference(−p_world)`` rotated back into
        F (computed on demand: the renderer often needs only the angles, not the vectors).
        """
        r = self.rotation
        p = np.asarray(self.directions)
        w = p @ r.T.astype(p.dtype)  # world components
        x, y, z = w[..., 0], w[..., 1], w[..., 2]
        # ẑ − z p normalised = (−z x/ρ, −z y/ρ, ρ) with ρ² = x² + y² (the same test for the
        # zenith as the evaluation, and accurate near it); North at the exact zenith.
        rho = np.sqrt(x * x + y * y)
        zen = rho == 0.0
        inv = 1.0 / np.where(zen, 1.0, rho)
        ref_w = np.stack([-z * x * inv, -z * y * inv, rho], axis=-1)
        ref_w[zen] = (0.0, 1.0, 0.0)
        return ref_w @ r.astype(p.dtype)  # back into frame F: C^T ref_w

    def aop_dop(self) -> tuple[FloatArray, FloatArray]:
        """(AoP from the meridian reference in [−π/2, π/2), DoP in [0, 1])."""
        return stokes_mod.to_aop_dop(self.stokes)


def sky_radiance(
    dirs: ArrayLike,
    sun: SunPosition | ArrayLike,
    spec: SkySpec | None = None,
    *,
    rotation: ArrayLike | None = None,
    psf_sigma_rad: float | ArrayLike | None = None,
    out: FloatArray | None = None,
) -> SkyRadiance:
    """Radiance and polarization of the sky along each direction.

    Args:
        dirs: (..., 3) unit vectors from the observer to the sky, float32 or float64 (the output
            has the same dtype). ENU, or frame F when ``rotation`` is given. Fastest as a view of
            planar (3, ...) storage (``Camera.rays``), whose components are contiguous.
        sun: :class:`SunPosition` (one instant) or an ENU unit vector towards the (apparent) sun.
        spec: Sky parameters (default :class:`SkySpec`).
        rotation: 3×3 C_F^n taking the directions into ENU (default identity).
        psf_sigma_rad: Gaussian point-spread σ of each sample (radians; scalar, or broadcastable
            to ``dirs[..., 0]``). When given, the solar disc is seen through that PSF: a sample
            gets L_sun · P(|X + χ| ≤ r_sun), X ~ N(0, σ²I₂), the disc convolved with the Gaussian
            (exact, via the non-central χ² CDF). With σ ≈ 0.6·√Ω_pixel the disc's energy on a
            pixel grid is kept to < 1% even when the disc is smaller than a pixel and falls between
            pixel centres, at the price of a ~1-pixel blur (a real lens's PSF is no sharper). Only
            the disc is convolved; the smooth sky is sampled. None: a sharp disc.
        out: Optional planar (3, ...) output buffer (dtype of ``dirs``, ``dirs.shape[:-1]`` after
            the 3) to fill instead of allocating one: reuse it across frames (a fresh full-frame
            array costs ~10–30 ms of page faults on first touch). ``stokes`` is a view of it.

    Returns:
        The :class:`SkyRadiance`.
    """
    spec = SkySpec() if spec is None else spec
    s = sun_vector(sun)
    p = np.asarray(dirs)
    if p.shape[-1:] != (3,) or p.dtype not in (np.float32, np.float64):
        raise ValueError(
            f"dirs must be a float32/float64 array of shape (..., 3), got {p.dtype} {p.shape}"
        )
    r = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    if r.shape != (3, 3) or not np.all(np.isfinite(r)) or not is_rotation(r):
        raise ValueError("rotation must be a finite orthonormal 3x3 matrix (C_F^n)")
    dtype = p.dtype
    batch_shape = p.shape[:-1]
    n = int(np.prod(batch_shape, dtype=np.int64))
    flat = p.reshape(n, 3)
    if out is None:
        out = np.empty((3, n), dtype=dtype)
    else:
        if out.shape != (3, *batch_shape) or out.dtype != dtype or not out.flags.c_contiguous:
            raise ValueError(
                f"out must be a C-contiguous {dtype} array of shape {(3, *batch_shape)}, "
                f"got {out.dtype} {out.shape}"
            )
        out = out.reshape(3, n)
    night = bool(s[2] < math.sin(NIGHT_ELEVATION_RAD))
    if night:
        out[...] = 0.0
        out[0] = spec.night_radiance
        if spec.night_radiance > 0:
            out[0] *= _world_z(flat, r) >= 0  # below the horizon: no sky
        return _result(out, p, r, night, batch_shape)

    fp = None
    if psf_sigma_rad is not None:
        fp = np.broadcast_to(np.asarray(psf_sigma_rad, dtype=np.float64), batch_shape).reshape(n)
        if not np.all(np.isfinite(fp)) or np.any(fp < 0):
            raise ValueError("psf_sigma_rad must be finite and >= 0")

    ctx = _FrameConstants(spec, s, dtype)
    r_t = None if rotation is None else r.astype(dtype)
    chunk = min(_CHUNK, max(n, 1))
    buf = np.empty((7, chunk), dtype=dtype)
    world = np.empty((3, chunk), dtype=dtype)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        for i0 in range(0, n, chunk):
            i1 = min(i0 + chunk, n)
            blk = flat[i0:i1]
            if r_t is not None:  # rotate this block only: no world-ray frame in memory
                w = np.matmul(r_t, blk.T, out=world[:, : i1 - i0])
                x, y, z = w[0], w[1], w[2]
            else:
                x, y, z = blk[:, 0], blk[:, 1], blk[:, 2]
            fp_blk = None if fp is None else fp[i0:i1]
            _evaluate_block(ctx, x, y, z, out[:, i0:i1], fp_blk, buf)
    return _result(out, p, r, night, batch_shape)


def _world_z(flat: FloatArray, r: NDArray[np.float64]) -> FloatArray:
    return flat @ r[2].astype(flat.dtype)


def _result(
    out: FloatArray, p: FloatArray, r: NDArray[np.float64], night: bool, shape: tuple[int, ...]
) -> SkyRadiance:
    stokes = np.moveaxis(out.reshape((3, *shape)), 0, -1)
    return SkyRadiance(stokes, p, r, night)


class _FrameConstants:
    """Everything that depends on the sun and the spec only: computed once per evaluation."""

    def __init__(self, spec: SkySpec, s: NDArray[np.float64], dtype: np.dtype) -> None:
        self.spec = spec
        self.dtype = dtype
        self.s = s
        self.sx, self.sy, self.sz = (float(v) for v in s)
        a, b, c, d, e = spec.cie_parameters
        self.cie = (a, b, c, d, e)
        self.exp_d_half_pi = math.exp(d * math.pi / 2)
        # L_z / (f(Z_s) φ(0)): CIE eq. 1 normalisation; Z_s = χ of the zenith point.
        f_zs = 1.0 + c * (math.exp(d * math.acos(max(-1.0, min(1.0, s[2])))) - self.exp_d_half_pi)
        f_zs += e * s[2] ** 2
        phi0 = 1.0 + a * math.exp(b)
        self.scale = spec.zenith_radiance / (f_zs * phi0)
        self.dop_max = spec.dop_max
        self.disc = spec.sun_disc_radiance
        self.r_sun = spec.sun_radius_rad
        self.berry = (
            BerryFrame.of(s, spec.berry_delta_rad) if spec.polarization == "berry" else None
        )


def _evaluate_block(
    ctx: _FrameConstants,
    x: FloatArray,
    y: FloatArray,
    z: FloatArray,
    out: FloatArray,
    psf_sigma: NDArray[np.float64] | None,
    buf: FloatArray,
) -> None:
    """Fill out[0..2] (I, Q, U) for one block of world directions (x, y, z).

    Every step writes into the preallocated block buffers ``buf`` (no temporaries: numpy is
    memory-bound here). The arithmetic is the module docstring's, in this order: cos γ, ρ², the CIE
    radiance, the meridian-frame E-vector coordinates (a, b), then Q and U.
    """
    m = x.shape[0]
    h, cos_g, rho2, rad, tmp, a, b = (row[:m] for row in buf)
    sx, sy, sz = ctx.sx, ctx.sy, ctx.sz
    a_cie, b_cie, c_cie, d_cie, e_cie = ctx.cie

    np.multiply(x, sx, out=h)  # h = s_x p_x + s_y p_y, the horizontal part of cos γ
    np.multiply(y, sy, out=tmp)
    h += tmp
    np.multiply(z, sz, out=cos_g)
    cos_g += h
    np.multiply(x, x, out=rho2)  # ρ² = sin²θ, accurate near the zenith (unlike 1 − z²)
    np.multiply(y, y, out=tmp)
    rho2 += tmp

    # --- radiance, CIE eq. 1 (the constant scale L_z/(f(Z_s)φ(0)) is applied at the end) --------
    # f(χ) = (1 − c e^{dπ/2}) + c e^{dχ} + e cos²χ
    np.multiply(cos_g, cos_g, out=rad)
    rad *= e_cie
    rad += 1.0 - c_cie * ctx.exp_d_half_pi
    if c_cie != 0.0:
        np.clip(cos_g, -1.0, 1.0, out=a)  # rounding can put |cos γ| a hair above 1
        arccos_into(a, tmp, b)
        tmp *= d_cie
        exp_into(tmp, tmp)
        tmp *= c_cie
        rad += tmp
    if a_cie != 0.0:  # φ(Z) = 1 + a exp(b / cos Z); b < 0, so z → 0⁺ gives exp(−∞) = 0
        np.divide(b_cie, z, out=tmp)
        exp_into(tmp, tmp)
        tmp *= a_cie
        tmp += 1.0
        rad *= tmp

    # --- polarization, meridian frame --------------------------------------------------------
    if ctx.spec.polarization == "rayleigh":
        np.multiply(y, sx, out=a)  # a = s_x p_y − s_y p_x
        np.multiply(x, sy, out=tmp)
        a -= tmp
        np.multiply(rho2, sz, out=b)  # b = s_z ρ² − p_z h
        np.multiply(z, h, out=tmp)
        b -= tmp
        if rho2.min() == 0.0:  # exact zenith: reference = North, (a, b) = (E·ŷ, E·x̂), E = s × ẑ
            zen = np.flatnonzero(rho2 == 0.0)
            a[zen] = -sx
            b[zen] = sy
            rho2[zen] = 1.0
        # amp = I DoP_max / ((1 + cos²γ) ρ²) with (1 + cos²γ) ρ² = 2ρ² − (a² + b²)
        np.multiply(a, a, out=h)  # h, no longer needed, holds a²; tmp holds b²
        np.multiply(b, b, out=tmp)
        rho2 *= 2.0
        rho2 -= h
        rho2 -= tmp
        np.divide(rad, rho2, out=rho2)
        rho2 *= ctx.scale * ctx.dop_max  # rho2 now holds amp
        h -= tmp  # a² − b²
        np.multiply(h, rho2, out=out[1])
        a *= b
        a *= 2.0
        np.multiply(a, rho2, out=out[2])
    else:
        assert ctx.berry is not None
        berry_block(ctx.berry, ctx.dop_max, x, y, z, rad * ctx.scale, out)

    # --- solar disc and horizon --------------------------------------------------------------
    np.multiply(rad, ctx.scale, out=out[0])
    if ctx.disc > 0.0:
        _add_sun_disc(ctx, x, y, z, cos_g, out, psf_sigma)
    if z.min() < 0.0:
        below = np.flatnonzero(z < 0.0)
        out[:, below] = 0.0


def _add_sun_disc(
    ctx: _FrameConstants,
    x: FloatArray,
    y: FloatArray,
    z: FloatArray,
    cos_g: FloatArray,
    out: FloatArray,
    psf_sigma: NDArray[np.float64] | None,
) -> None:
    """Add the unpolarized solar disc to out[0] for the samples that can see it.

    A sample more than 7 of its own σ beyond the disc's rim gets none of it: the Gaussian's
    tail there, P(|X| > 7σ) = e^(−24.5) = 2.3e-11 of the disc radiance, is dropped. The cut is
    each sample's own, so its value does not depend on the block it is evaluated in.
    """
    # Candidates by the block's widest PSF (a cheap superset), then each sample's own cut.
    reach = ctx.r_sun + (0.0 if psf_sigma is None else 7.0 * float(np.max(psf_sigma, initial=0)))
    # Candidates from the cheap cos γ with a margin for float32 rounding, then exact angles.
    cand = np.flatnonzero(cos_g >= math.cos(min(reach + 2e-3, math.pi)))
    if cand.size == 0:
        return
    p = np.stack([x[cand], y[cand], z[cand]], axis=-1).astype(np.float64)
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    chord = np.linalg.norm(p - ctx.s, axis=-1)
    chi = 2.0 * np.arcsin(np.minimum(chord / 2.0, 1.0))  # accurate for small angles
    if psf_sigma is None:
        frac = (chi <= ctx.r_sun).astype(np.float64)
    else:
        # P(|X + χ|² ≤ r²) for X ~ N(0, σ²I₂): the non-central χ² CDF, 2 degrees of freedom,
        # non-centrality (χ/σ)² (small-angle plane geometry on the tangent plane at the sun).
        sig = np.maximum(psf_sigma[cand], 1e-12)
        frac = chndtr((ctx.r_sun / sig) ** 2, 2.0, (chi / sig) ** 2)
        frac = np.where(psf_sigma[cand] > 0, frac, (chi <= ctx.r_sun).astype(np.float64))
        frac[chi > ctx.r_sun + 7.0 * psf_sigma[cand]] = 0.0
    out[0, cand] += (ctx.disc * frac).astype(out.dtype)
