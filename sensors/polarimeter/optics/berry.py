"""Berry's sky polarization (Berry, Dennis & Lee 2004): four neutral points, not two.

Rayleigh's sky has one neutral point pair (the sun and its antisun); real skies split each into
two, Babinet and Brewster above and below the sun, Arago and the fourth at their antipodes, δ
apart (:class:`~sensors.polarimeter.optics.sky.SkySpec` ``berry_delta_rad``). The model writes the
polarization as a complex function of the sky's stereographic coordinate ζ (optics.md §1.2);
:func:`berry_block` evaluates it for :func:`~sensors.polarimeter.optics.sky.sky_radiance`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sensors.polarimeter.optics.sun import SunPosition, sun_vector
from twin.core.arrays import FloatArray


@dataclass(frozen=True, slots=True)
class BerryPoints:
    """Berry's four neutral points as ENU unit vectors (some may lie below the horizon)."""

    babinet: NDArray[np.float64]
    brewster: NDArray[np.float64]
    arago: NDArray[np.float64]
    fourth: NDArray[np.float64]


def sun_angles(s: NDArray[np.float64]) -> tuple[float, float]:
    """(zenith angle, ENU azimuth counter-clockwise from East) of the sun vector."""
    return math.atan2(math.hypot(s[0], s[1]), s[2]), math.atan2(s[1], s[0])


def berry_neutral_points(sun_dir: SunPosition | ArrayLike, delta_rad: float) -> BerryPoints:
    """The four neutral points of Berry's model (optics.md §1.2).

    Babinet at zenith angle θ_s − δ/2 and Brewster at θ_s + δ/2 on the solar meridian; Arago and the
    fourth point are their antipodes.
    """
    s = sun_vector(sun_dir)
    theta_s, phi_s = sun_angles(s)

    def on_meridian(theta: float) -> NDArray[np.float64]:
        return np.array(
            [math.sin(theta) * math.cos(phi_s), math.sin(theta) * math.sin(phi_s), math.cos(theta)]
        )

    bab = on_meridian(theta_s - delta_rad / 2)
    bre = on_meridian(theta_s + delta_rad / 2)
    return BerryPoints(bab, bre, -bre, -bab)


@dataclass(frozen=True, slots=True)
class BerryFrame:
    """What Berry's polarization needs of one sun: its azimuth and the model's quartic.

    Attributes:
        cos_phi_s, sin_phi_s: The sun's ENU azimuth φ_s.
        k: −4 sgn(t_Bab) sgn(t_Bre) / ((1 + t_Bab²)(1 + t_Bre²)).
        poly: P(ξ)'s coefficients c4 … c0 (Horner order).
    """

    cos_phi_s: float
    sin_phi_s: float
    k: float
    poly: tuple[float, float, float, float, float]

    @classmethod
    def of(cls, s: NDArray[np.float64], delta_rad: float) -> BerryFrame:
        """For the unit sun vector ``s`` and the neutral points' separation δ."""
        theta_s, phi_s = sun_angles(s)
        t_bab = math.tan((theta_s - delta_rad / 2) / 2)
        t_bre = math.tan((theta_s + delta_rad / 2) / 2)
        sign = (1.0 if t_bab >= 0 else -1.0) * (1.0 if t_bre >= 0 else -1.0)
        # W = w e^{-2iφ_s}: the e^{iφ_s} of each finite-form factor cancels the e^{-2iφ_s}.
        k = -4.0 * sign / ((1.0 + t_bab**2) * (1.0 + t_bre**2))
        # In ξ = ζ e^{-iφ_s} (sun on the real axis) the four factors are the real quartic
        # P(ξ) = (ξ − t_Bab)(ξ − t_Bre)(1 + t_Bab ξ)(1 + t_Bre ξ) = Σ c_k ξ^k:
        s_sum, p_prod = t_bab + t_bre, t_bab * t_bre
        poly = (
            p_prod,
            s_sum * (1.0 - p_prod),
            1.0 - s_sum**2 + p_prod**2,
            -s_sum * (1.0 - p_prod),
            p_prod,
        )
        return cls(math.cos(phi_s), math.sin(phi_s), k, poly)


def berry_block(
    frame: BerryFrame,
    dop_max: float,
    x: FloatArray,
    y: FloatArray,
    z: FloatArray,
    rad: FloatArray,
    out: FloatArray,
) -> None:
    """Berry et al. 2004 Stokes (meridian frame) for one block (module docstring).

    With ξ = ζ e^{−iφ_s}, W = w e^{−2iφ_s} = K e^{2iφ_s} P(ξ) / (1 + |ξ|²)², K the constant
    −4 sgn(t_Bab) sgn(t_Bre) / ((1 + t_Bab²)(1 + t_Bre²)). The E-vector angle ψ from the meridian
    reference (towards d × ref) has e^{2iψ} = conj(W) ζ² / (|W| |ζ|²) (the ζ-plane is conformal,
    its radial direction is the meridian, and the reference points to the zenith, against the
    radial: ψ = φ − AoP_ζ), so Q + iU = I DoP_max · K P(ξ̄) ξ² / (|ξ|² (1+|ξ|²)² (2 − |W|)):
    the |W| of the DoP cancels and the e^{±2iφ_s} drop out.
    """
    cdt = np.complex64 if x.dtype == np.float32 else np.complex128
    inv = 1.0 / (1.0 + np.maximum(z, 0.0))
    cs, sn = frame.cos_phi_s, frame.sin_phi_s
    xi_c = np.empty(x.shape, dtype=cdt)  # ξ̄ = conj(ζ) e^{iφ_s}
    xi_c.real = (x * cs + y * sn) * inv
    xi_c.imag = (x * sn - y * cs) * inv
    c4, c3, c2, c1, c0 = frame.poly
    poly = xi_c * c4  # Horner: P(ξ̄) = conj(P(ξ)) (real coefficients)
    for c in (c3, c2, c1):
        poly += c
        poly *= xi_c
    poly += c0
    mod2 = xi_c.real * xi_c.real + xi_c.imag * xi_c.imag  # |ξ|²
    one_plus2 = (1.0 + mod2) ** 2
    abs_w = np.minimum(np.abs(poly) * (abs(frame.k) / one_plus2), 1.0)
    xi2 = np.conjugate(xi_c * xi_c)  # ξ²
    zen = mod2 == 0.0
    if np.any(zen):  # exact zenith, reference North: ζ²/|ζ|² → −1, i.e. ξ²/|ξ|² → −e^{−2iφ_s}
        xi2[zen] = -(complex(cs, -sn) ** 2)
        mod2[zen] = 1.0
    pol = poly * xi2
    amp = (dop_max * frame.k) * rad / (mod2 * one_plus2 * (2.0 - abs_w))
    np.multiply(amp, pol.real, out=out[1])
    np.multiply(amp, pol.imag, out=out[2])
