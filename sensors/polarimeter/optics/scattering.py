"""The scattering phase matrix of sea water: molecules plus particles, one Mueller matrix.

Both the closed-form single scattering of the renderer (:mod:`sensors.polarimeter.optics.water`) and
the
radiative-transfer reference (:mod:`sensors.polarimeter.optics.rt`) scatter with this matrix, so the
reference's optically thin limit and the renderer's single scattering are the same physics.

The volume scattering function is β(Θ) = b_w p_w(Θ) + b_p p_p(Θ) and the normalised phase matrix
(in the scattering-plane reference, Stokes (I, Q, U, V), m11 = 1)::

    M(Θ) = [[1,   m12, 0,    0  ],
            [m12, m22, 0,    0  ],
            [0,   0,   m33,  0  ],
            [0,   0,   0,    m44]]

each element the β-weighted mean of the two components' normalised matrices:

* **Molecules** (pure sea water): the Rayleigh matrix with the depolarization ratio δ of the
  anisotropic water molecule (Hansen & Travis 1974, Space Sci. Rev. 16:527, eq. 2.15;
  Chandrasekhar 1950 §18): with Δ = (1 − δ)/(1 + δ/2), Δ' = (1 − 2δ)/(1 − δ),
  P11 = ¾Δ(1 + cos²Θ) + (1 − Δ), P12 = −¾Δ sin²Θ, P22 = ¾Δ(1 + cos²Θ), P33 = (3/2)Δ cos Θ,
  P44 = (3/2)ΔΔ' cos Θ. δ = 0.044 for sea water of S = 35 (Hu, Zhang et al. 2019, Appl. Opt.
  58(4):991, "Light scattering by pure water and seawater: the depolarization ratio and its
  variation with salinity", read: pure water 0.039 ± 0.001, sea water 0.039 + a₁S with
  a₁ = 1–2 × 10⁻⁴, so 0.0425–0.046 at S = 35; the twin takes a₁ = 1.5 × 10⁻⁴). Morel's (1974)
  δ = 0.09, used here before, is the value that paper's introduction puts "at least ±50 %"
  uncertain. δ is a water parameter (:attr:`~sensors.polarimeter.optics.water.WaterOptics`; a
  scenario's ``[water] depolarization_ratio``; 0.039 for fresh water).
* **Particles**: the Fournier–Forand phase function (below), with the reduced Mueller matrix of
  the Voss & Fry (1984, Appl. Opt. 23:4427) ocean measurements — Rayleigh-like, all off-diagonal
  elements but m12 = m21 zero (their abstract, read) — in the form that Kattawar & Adams (1989,
  Limnol. Oceanogr. 34:1453) and later polarized ocean codes use: m12 = −P sin²Θ/(1 + cos²Θ),
  m22 = 1, m33 = m44 = 2 cos Θ/(1 + cos²Θ). The peak linear polarization P = −m12/m11 near 90°
  is 0.75, the middle of the range "[0.6, 0.9]" that the particulate DoLP peak magnitudes of six
  diverse natural waters span in "The Degree of Linear Polarization for Suspended Particle Fields
  from Diverse Natural Waters", Front. Remote Sens. 2:735512 (2021), read (abstract; peaks at
  90–95°); P = 0.6 and 0.9 are the ends a sensitivity study uses. (The value 0.8 used before was
  recalled, not read.) P is a water parameter as δ is. The form keeps m22 = 1 and m33 → 1 in the
  forward direction, so the many small-angle scatterings by particles do not depolarize, as
  measured; it is a physical Mueller matrix (m12² + m33² ≤ 1 for every Θ).

Circular polarization V is carried by the reference (total internal reflection at the surface
turns linear into circular polarization) but never produced by scattering (m34 = 0 for both).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from twin.core.arrays import FloatArray

# δ and P with their ranges (module docstring), declared in twin.core.options: the scenario
# schema offers them from there.
from twin.core.options import PARTICLE_DOP_MAX as PARTICLE_DOP_MAX
from twin.core.options import PARTICLE_DOP_MAX_RANGE as PARTICLE_DOP_MAX_RANGE
from twin.core.options import WATER_DEPOLARIZATION_RANGE as WATER_DEPOLARIZATION_RANGE
from twin.core.options import WATER_DEPOLARIZATION_RATIO as WATER_DEPOLARIZATION_RATIO

#: Fournier–Forand particle index relative to water (Mobley, Sundman & Boss 2002).
FF_INDEX = 1.10


def fournier_forand(
    cos_psi: ArrayLike, n_p: float = 1.10, mu: float = 3.5835, psi_min: float = 1e-9
) -> FloatArray:
    """Fournier–Forand phase function p̃(ψ) (sr⁻¹, ∫ p̃ dΩ = 1).

    Fournier & Forand (1994) SPIE 2258:194, normalised as in Fournier & Jonasz (1999) SPIE
    3761:62 and Mobley et al. (2002) Appl. Opt. 41(6):1035 (optics.md §2.5)::

        δ = 4 sin²(ψ/2) / (3 (n_p − 1)²),  ν = (3 − μ)/2,  δ₁₈₀ = δ(π)
        p̃ = [ν(1 − δ) − (1 − δ^ν) + (δ(1 − δ^ν) − ν(1 − δ)) / sin²(ψ/2)] / (4π (1 − δ)² δ^ν)
            + (1 − δ₁₈₀^ν)(3 cos²ψ − 1) / (16π (δ₁₈₀ − 1) δ₁₈₀^ν)

    n_p is the particles' relative index, μ the Junge slope. The forward peak diverges
    (integrably, as ψ^(μ−5)) as ψ → 0; ψ is floored at ``psi_min`` (default 1e-9 rad) only so
    that ψ = 0 gives a finite number: the function is not renormalised, and the sampler
    (:func:`inverse_cdf_cos`) integrates the peak below its grid analytically, so the particles
    scatter exactly b_p. Near δ = 1 the bracket cancels to second order (a removable
    singularity); δ is kept 1e-4 away from 1 there.

    Args:
        cos_psi: Cosines of the scattering angle.
        n_p: Particle refractive index relative to water (> 1).
        mu: Junge (hyperbolic) size-distribution slope, 3 < μ <= 5.
        psi_min: The floor on ψ (radians) that keeps ψ = 0 finite.
    """
    c = np.clip(np.asarray(cos_psi, dtype=np.float64), -1.0, 1.0)
    # sin²(ψ/2) from ψ itself near the peak (1 − cos ψ loses every digit below ~1e-8 rad).
    psi = np.maximum(np.arccos(c), psi_min)
    s2 = np.sin(0.5 * psi) ** 2
    k = 4.0 / (3.0 * (n_p - 1.0) ** 2)
    nu = 0.5 * (3.0 - mu)
    d = k * s2
    d = np.where(np.abs(d - 1.0) < 1e-4, np.where(d < 1.0, 1.0 - 1e-4, 1.0 + 1e-4), d)
    dn = d**nu
    first = (nu * (1 - d) - (1 - dn) + (d * (1 - dn) - nu * (1 - d)) / s2) / (
        4 * math.pi * (1 - d) ** 2 * dn
    )
    d180 = k
    d180n = d180**nu
    second = (1 - d180n) * (3 * c * c - 1) / (16 * math.pi * (d180 - 1) * d180n)
    return first + second


def ff_backscatter_fraction(n_p: float, mu: float) -> float:
    """Backscatter fraction B of the Fournier–Forand function (Mobley et al. 2002, eq. 2).

    B = 1 − [1 − δ₉₀^(ν+1) − ½(1 − δ₉₀^ν)] / [(1 − δ₉₀) δ₉₀^ν], δ₉₀ = δ(ψ = 90°).
    """
    nu = 0.5 * (3.0 - mu)
    d90 = 4.0 / (3.0 * (n_p - 1.0) ** 2) * 0.5
    return 1.0 - (1.0 - d90 ** (nu + 1) - 0.5 * (1.0 - d90**nu)) / ((1.0 - d90) * d90**nu)


@functools.lru_cache(maxsize=64)
def ff_slope_for_backscatter(backscatter_ratio: float, n_p: float = 1.10) -> float:
    """The Junge slope μ that gives a Fournier–Forand backscatter fraction B at index n_p.

    Mobley et al. (2002) fix n_p = 1.10 and vary μ; B = 0.0183 ⇒ μ ≈ 3.5835.
    """
    return float(brentq(lambda m: ff_backscatter_fraction(n_p, m) - backscatter_ratio, 3.001, 5.0))


def _molecular_delta(
    depolarization_ratio: float = WATER_DEPOLARIZATION_RATIO,
) -> tuple[float, float]:
    d = depolarization_ratio
    return (1.0 - d) / (1.0 + 0.5 * d), (1.0 - 2.0 * d) / (1.0 - d)


def molecular_phase(
    cos_psi: ArrayLike, depolarization_ratio: float = WATER_DEPOLARIZATION_RATIO
) -> FloatArray:
    """Pure-seawater phase function P11/(4π) = (¾Δ(1 + cos²ψ) + 1 − Δ)/(4π).

    ∝ 1 + cos²ψ (1 − δ)/(1 + δ): 1 + 0.916 cos²ψ at the default δ = 0.044.
    """
    c = np.asarray(cos_psi)
    big_d, _ = _molecular_delta(depolarization_ratio)
    return (0.75 * big_d * (1.0 + c * c) + (1.0 - big_d)) / (4.0 * math.pi)


@dataclass(frozen=True, slots=True)
class PhaseMatrix:
    """The mixture's phase function and normalised Mueller elements on a table in u = sin(Θ/2).

    Attributes:
        u: (K,) table nodes, uniform in [0, 1] (fine near the forward peak).
        beta: (K,) volume scattering function β(Θ) = b p(Θ), m⁻¹ sr⁻¹.
        m12, m22, m33, m44: (K,) normalised elements (m11 = 1).
        b_molecular_per_m: b_w.
        b_particle_per_m: b_p.
        ff_slope: The Fournier–Forand Junge slope of the particles.
        particle_dop_max: P of the particle matrix.
        depolarization_ratio: δ of the water molecules.
    """

    u: FloatArray
    beta: FloatArray
    m12: FloatArray
    m22: FloatArray
    m33: FloatArray
    m44: FloatArray
    b_molecular_per_m: float
    b_particle_per_m: float
    ff_slope: float
    particle_dop_max: float = PARTICLE_DOP_MAX
    depolarization_ratio: float = WATER_DEPOLARIZATION_RATIO

    @property
    def b_per_m(self) -> float:
        """Total scattering coefficient b."""
        return self.b_molecular_per_m + self.b_particle_per_m

    def beta_exact(self, cos_theta: ArrayLike) -> FloatArray:
        """β(Θ) from the formulas (not the table), m⁻¹ sr⁻¹."""
        c = np.asarray(cos_theta, dtype=np.float64)
        out = self.b_molecular_per_m * molecular_phase(c, self.depolarization_ratio)
        if self.b_particle_per_m > 0:
            out = out + self.b_particle_per_m * fournier_forand(c, FF_INDEX, self.ff_slope)
        return out

    def elements(self, cos_theta: ArrayLike) -> tuple[FloatArray, ...]:
        """(β, m12, m22, m33, m44) at each cos Θ, linearly interpolated in u."""
        c = np.asarray(cos_theta, dtype=np.float64)
        u = np.sqrt(np.maximum(0.5 - 0.5 * c, 0.0))
        return tuple(
            np.interp(u, self.u, t) for t in (self.beta, self.m12, self.m22, self.m33, self.m44)
        )


def phase_matrix(
    b_molecular_per_m: float,
    b_particle_per_m: float,
    particle_backscatter_ratio: float,
    size: int = 8192,
    particle_dop_max: float = PARTICLE_DOP_MAX,
    depolarization_ratio: float = WATER_DEPOLARIZATION_RATIO,
) -> PhaseMatrix:
    """Tabulate the mixture's β and normalised Mueller matrix (module docstring).

    Args:
        b_molecular_per_m: Molecular scattering b_w.
        b_particle_per_m: Particle scattering b_p.
        particle_backscatter_ratio: B = b_bp/b_p, sets the Fournier–Forand slope.
        size: Table length (uniform in sin(Θ/2)).
        particle_dop_max: P of the particle matrix, in [0, 1].
        depolarization_ratio: δ of the water molecules, in [0, 0.5).
    """
    if not (0.0 <= particle_dop_max <= 1.0):
        raise ValueError(f"particle_dop_max must lie in [0, 1], got {particle_dop_max!r}")
    if not (0.0 <= depolarization_ratio < 0.5):
        raise ValueError(f"depolarization_ratio must lie in [0, 0.5), got {depolarization_ratio!r}")
    u = np.linspace(0.0, 1.0, size)
    c = 1.0 - 2.0 * u * u
    s2 = 1.0 - c * c
    big_d, big_dp = _molecular_delta(depolarization_ratio)
    p11_m = 0.75 * big_d * (1.0 + c * c) + (1.0 - big_d)
    bm = b_molecular_per_m * p11_m / (4.0 * math.pi)
    mm = (
        -0.75 * big_d * s2 / p11_m,
        0.75 * big_d * (1.0 + c * c) / p11_m,
        1.5 * big_d * c / p11_m,
        1.5 * big_d * big_dp * c / p11_m,
    )
    slope = ff_slope_for_backscatter(float(particle_backscatter_ratio), FF_INDEX)
    if b_particle_per_m > 0:
        bp = b_particle_per_m * fournier_forand(c, FF_INDEX, slope)
    else:
        bp = np.zeros_like(c)
    r = 2.0 * c / (1.0 + c * c)
    mp = (-particle_dop_max * s2 / (1.0 + c * c), np.ones_like(c), r, r)
    beta = bm + bp
    safe = np.where(beta > 0, beta, 1.0)
    el = [(bm * a + bp * b) / safe for a, b in zip(mm, mp, strict=True)]
    return PhaseMatrix(
        u,
        beta,
        *el,
        float(b_molecular_per_m),
        float(b_particle_per_m),
        slope,
        float(particle_dop_max),
        float(depolarization_ratio),
    )


def inverse_cdf_cos(pm: PhaseMatrix, size: int = 65537) -> FloatArray:
    """The cos Θ at uniformly spaced probabilities of the scattering-angle distribution.

    The CDF is integrated on a grid fine enough for the forward peak (Θ log-spaced from
    Θ₁ = 1e-6 rad), and the particles' peak below Θ₁ analytically: there the Fournier–Forand
    function is the power law p ≈ A Θ^(μ−5), whose mass is 2π A Θ₁^(μ−3)/(μ − 3). The CDF is then
    b times the normalised distribution to within the quadrature (:func:`scattered_fraction`
    checks it), so the division by its end is a rounding step, not a renormalisation that would
    scatter more than b. Sampling ``np.interp(ξ (K − 1), arange(K), table)`` draws Θ from p(Θ) to
    the table's resolution (the largest step in probability is 1/(K − 1)).
    """
    theta, cdf = _cdf(pm)
    prob = np.linspace(0.0, 1.0, size)
    th = np.interp(prob, cdf / cdf[-1], theta)
    return np.cos(th)


_THETA_1 = 1e-6


def _cdf(pm: PhaseMatrix) -> tuple[FloatArray, FloatArray]:
    """(Θ, ∫₀^Θ β dΩ / b): the cumulative scattered fraction, Θ from 0 to π."""
    theta = np.concatenate([[0.0], np.geomspace(_THETA_1, math.pi, 200_000)])
    c = np.cos(theta[1:])
    dens = pm.beta_exact(c) * np.sin(theta[1:])
    # Below Θ₁: the molecules' share is β(0) π Θ₁² (smooth); the particles' the power law's mass.
    head = pm.b_molecular_per_m * float(molecular_phase(1.0, pm.depolarization_ratio))
    head *= math.pi * _THETA_1**2
    if pm.b_particle_per_m > 0:
        p1 = float(fournier_forand(math.cos(_THETA_1), FF_INDEX, pm.ff_slope, psi_min=_THETA_1))
        mu = pm.ff_slope
        head += pm.b_particle_per_m * 2.0 * math.pi * p1 * _THETA_1**2 / (mu - 3.0)
    body = 2.0 * math.pi * 0.5 * (dens[1:] + dens[:-1]) * np.diff(theta[1:])
    cdf = np.concatenate([[0.0, head], head + np.cumsum(body)])
    return theta, cdf / pm.b_per_m


def scattered_fraction(pm: PhaseMatrix) -> float:
    """∫ β dΩ / b over the sphere as the sampler integrates it (1 for an exact phase function)."""
    return float(_cdf(pm)[1][-1])
