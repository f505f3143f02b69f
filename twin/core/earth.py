"""The Earth model: WGS84 ellipsoid, normal gravity, radii of curvature, Earth and transport rates.

Pure math, shared by the world (sensor synthesis) and the vehicle computer (strapdown INS): it
imports nothing from the world side, only the standard library and numpy.

Frames follow :mod:`twin.core.frames`: the navigation frame n is local-level ENU, so vectors
here are [East, North, Up]. Heights ``h_m`` are above the ellipsoid, taken equal to the height
above the sea surface (the geoid undulation is ignored); a submerged vehicle has h < 0.

Sources:
    * WGS84 defining constants and the Somigliana closed form: NIMA TR8350.2 (3rd ed., 2000),
      §3 and eq. 4-1; the free-air height correction is its eq. 4-3.
    * Numerical values as in pyins.earth (navigation.md §1.1), which they reproduce to the last
      digit: RATE, A, E2, GE, GP.
    * Radii of curvature and the ENU transport rate: Titterton & Weston, *Strapdown Inertial
      Navigation Technology* (2nd ed.), §3.5; Groves, *Principles of GNSS, Inertial, and
      Multisensor Integrated Navigation Systems* (2nd ed.), eqs. 2.105-2.106 and 5.44 (there NED;
      here permuted to ENU).
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.arrays import Float64Array as FloatArray

# --- WGS84 (NIMA TR8350.2 §3; pyins.earth, navigation.md §1.1) --------------------------------
A_M = 6378137.0
"""Semi-major axis a (m)."""
F = 1.0 / 298.257223563
"""Flattening f."""
B_M = A_M * (1.0 - F)
"""Semi-minor axis b (m), 6356752.3142."""
E2 = 6.69437999014e-3
"""First eccentricity squared e² = f (2 − f)."""
OMEGA_IE = 7.292115e-5
"""Earth rotation rate Ω (rad/s)."""
GM_M3_S2 = 3.986004418e14
"""Earth's gravitational constant GM including the atmosphere (m³/s²)."""
GAMMA_E = 9.7803253359
"""Normal gravity at the equator γ_e (m/s²)."""
GAMMA_P = 9.8321849378
"""Normal gravity at the poles γ_p (m/s²)."""
K_SOMIGLIANA = (B_M * GAMMA_P) / (A_M * GAMMA_E) - 1.0
"""Somigliana's constant k = b γ_p / (a γ_e) − 1 = 0.00193185265241."""
M_RATIO = OMEGA_IE**2 * A_M**2 * B_M / GM_M3_S2
"""m = Ω² a² b / GM, the ratio in the free-air correction (TR8350.2 eq. 4-3)."""
G0_MPS2 = 9.80665
"""Standard gravity g₀ (m/s²): the 'g' of datasheet units (mg, µg), not a physical gravity."""


def normal_gravity(lat_rad: float, h_m: float = 0.0) -> float:
    """Magnitude of WGS84 normal gravity γ(L, h) in m/s².

    Somigliana's closed form on the ellipsoid, γ₀ = γ_e (1 + k sin²L) / √(1 − e² sin²L), with the
    second-order free-air correction of TR8350.2 eq. 4-3:
    γ = γ₀ [1 − 2/a (1 + f + m − 2 f sin²L) h + 3 h²/a²].

    Normal gravity includes the centrifugal acceleration of the Earth's rotation (it is plumb-line
    gravity, what a level accelerometer at rest reads), so an Earth-referenced mechanization adds
    no separate centrifugal term. Below the sea surface (h < 0) the free-air formula is an
    extrapolation: inside the water the real gradient is smaller by 4πGρ (the Bouguer term,
    ≈ 0.086 mGal/m for sea water); at AUV depths the difference is a few mGal, below the IMU
    accelerometer's bias instability.

    Args:
        lat_rad: Geodetic latitude (rad).
        h_m: Height above the ellipsoid (m); negative under water.

    Returns:
        γ in m/s² (9.780325 at the equator, 9.806198 at 45°, 9.832185 at the poles, h = 0).
    """
    s2 = math.sin(lat_rad) ** 2
    g0 = GAMMA_E * (1.0 + K_SOMIGLIANA * s2) / math.sqrt(1.0 - E2 * s2)
    if h_m == 0.0:
        return g0
    return g0 * (
        1.0 - 2.0 / A_M * (1.0 + F + M_RATIO - 2.0 * F * s2) * h_m + 3.0 * (h_m / A_M) ** 2
    )


MGAL_MPS2 = 1e-5
"""1 mGal in m/s²."""
#: Newton's constant (CODATA 2018) and sea water's density, for the water layer's attraction.
G_NEWTON = 6.674e-11
RHO_SEAWATER_KG_M3 = 1030.0
FREE_AIR_MGAL_PER_M = 0.3086
#: Poincaré–Prey: the vertical gradient of gravity inside a water layer, mGal/m (positive down):
#: down through water gravity grows by the free-air gradient less twice the layer's attraction.
POINCARE_PREY_MGAL_PER_M = (
    FREE_AIR_MGAL_PER_M - 4 * math.pi * G_NEWTON * RHO_SEAWATER_KG_M3 / MGAL_MPS2
)


def normal_gravity_in_water_mgal(lat_rad: float, depth_m: float = 0.0) -> float:
    """Normal gravity (mGal) at the sea surface, continued down through the water.

    The anomaly a gravimeter's reading is reduced to is relative to this: Somigliana's closed form
    at the surface (:func:`normal_gravity`) plus the Poincaré–Prey gradient below it.
    """
    return normal_gravity(lat_rad) / MGAL_MPS2 + POINCARE_PREY_MGAL_PER_M * max(float(depth_m), 0.0)


def eotvos_mgal(v_east_mps: float, v_north_mps: float, lat_rad: float) -> float:
    """The Eötvös effect (mGal): what moving over the rotating Earth takes off measured gravity.

    2Ω v_E cos L + (v_E² + v_N²)/a (Harlan 1968, Geophysics 33(3)): 14.6 mGal per m/s of eastward
    speed at the equator.
    """
    centrifugal = 2.0 * OMEGA_IE * v_east_mps * math.cos(lat_rad)
    return (centrifugal + (v_east_mps**2 + v_north_mps**2) / A_M) / MGAL_MPS2


def gravity_enu(lat_rad: float, h_m: float = 0.0) -> FloatArray:
    """Normal gravity vector g^n = [0, 0, −γ(L, h)] in ENU (m/s²)."""
    return np.array([0.0, 0.0, -normal_gravity(lat_rad, h_m)])


def principal_radii(lat_rad: float) -> tuple[float, float]:
    """Principal radii of curvature of the WGS84 ellipsoid at latitude L.

    Returns:
        (R_M, R_N) in metres: R_M = a (1 − e²) / (1 − e² sin²L)^{3/2}, the meridian radius (north
        -south curvature), and R_N = a / √(1 − e² sin²L), the prime-vertical radius (east-west).
    """
    d = 1.0 - E2 * math.sin(lat_rad) ** 2
    r_n = A_M / math.sqrt(d)
    return r_n * (1.0 - E2) / d, r_n


def earth_rate_enu(lat_rad: float) -> FloatArray:
    """Earth rotation rate ω_ie^n = [0, Ω cos L, Ω sin L] in ENU (rad/s)."""
    return np.array([0.0, OMEGA_IE * math.cos(lat_rad), OMEGA_IE * math.sin(lat_rad)])


def transport_rate_enu(lat_rad: float, h_m: float, v_enu: FloatArray) -> FloatArray:
    """Transport rate ω_en^n: the rotation of the local-level frame as the vehicle moves (rad/s).

    ω_en^n = [−v_N / (R_M + h), v_E / (R_N + h), v_E tan L / (R_N + h)] (Titterton & Weston §3.5,
    ENU form). Singular at the poles (tan L), as any local-level north-pointing mechanization is.

    Args:
        lat_rad: Geodetic latitude (rad).
        h_m: Height above the ellipsoid (m).
        v_enu: Velocity over ground [v_E, v_N, v_U] (m/s).
    """
    r_m, r_n = principal_radii(lat_rad)
    v_e, v_n = float(v_enu[0]), float(v_enu[1])
    return np.array([-v_n / (r_m + h_m), v_e / (r_n + h_m), v_e * math.tan(lat_rad) / (r_n + h_m)])


def latlon_rates(lat_rad: float, h_m: float, v_enu: FloatArray) -> tuple[float, float, float]:
    """Geodetic position rates (L̇, λ̇, ḣ) from the ENU velocity (rad/s, rad/s, m/s).

    L̇ = v_N / (R_M + h), λ̇ = v_E / ((R_N + h) cos L), ḣ = v_U: the position equation of the
    ENU mechanization, here so that the world and an INS move over the ellipsoid the same way.
    """
    r_m, r_n = principal_radii(lat_rad)
    v_e, v_n, v_u = (float(v) for v in v_enu)
    return v_n / (r_m + h_m), v_e / ((r_n + h_m) * math.cos(lat_rad)), v_u
