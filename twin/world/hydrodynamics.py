"""Fossen's hydrodynamic model of a torpedo AUV, evaluated for MuJoCo every physics step.

Everything here is in Fossen's body frame f (x forward, y starboard, z down) at the CO (= CB = the
MuJoCo body origin), on the velocity relative to the water ν_r = ν − ν_c. The plant converts the
result to the body frame b with :data:`twin.core.frames.F_FROM_B`.

What MuJoCo does and what this module does (Fossen 2021, eq. 8.1 with relative velocity):

    M_RB ν̇ + C_RB(ν) ν                       ← MuJoCo's rigid-body dynamics and gravity at the CG
    + M_A ν̇_r + C_A(ν_r) ν_r                  ← added mass: C_A here, M_A ν̇_r solved in the plant
    + D(ν_r) ν_r − τ_liftdrag − τ_crossflow  ← damping, hull lift/drag, strip-theory cross-flow
    + buoyancy at the CB                      ← the plant (a world-frame force at the body origin)
    = τ_fins + τ_propeller                    ← control surfaces and propeller, here

Deliberate simplifications, all as in Fossen's remus100 model: the Munk moments (the destabilising
u·w and u·v terms of C_A in pitch and yaw) are left out, because the fins here produce lift from
their deflection only and could not cancel them; hull lift acts in the vertical plane only; the
linear damping in surge and sway fades as exp(−3 U_r) so that quadratic terms dominate at speed
(yaw's does not: Fossen's remus100 keeps it, and it is what damps the yaw rate in a turn).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from twin.world import hydrodynamics_kernel
from twin.world.vehicle import VehicleParams, hoerner_cd


def _crossflow(v: float, r: float, half_length: float) -> tuple[float, float]:
    """(∫ |s| s dx, ∫ x |s| s dx) over x ∈ [−h, h] with s = v + x r.

    With F(s) = |s|³/3 and G(s) = s³|s|/4 (antiderivatives of |s|s and s²|s|):
    ∫|s|s dx = ΔF / r and ∫x|s|s dx = (ΔG − v ΔF) / r². For |r| h ≪ |v| the first-order
    expansion in r is used instead, where the closed form loses precision.
    """
    h = half_length
    if abs(r) * h <= 1e-6 * max(abs(v), 1e-12) or abs(r) < 1e-12:
        return 2 * h * abs(v) * v, 4.0 / 3.0 * h**3 * abs(v) * r
    sa, sb = v - r * h, v + r * h
    df = (abs(sb) ** 3 - abs(sa) ** 3) / 3.0
    dg = (sb**3 * abs(sb) - sa**3 * abs(sa)) / 4.0
    return df / r, (dg - v * df) / (r * r)


def _crossflow_strips(v: float, r: float, half_length: float, n: int) -> tuple[float, float]:
    """Fossen's crossFlowDrag quadrature: n + 1 strips of width L/n at x = −h, −h + L/n, …, h."""
    dx = 2.0 * half_length / n
    fy = ny = 0.0
    for i in range(n + 1):
        x = -half_length + i * dx
        s = v + x * r
        fy += abs(s) * s * dx
        ny += x * abs(s) * s * dx
    return fy, ny


class Hydrodynamics:
    """Precomputed coefficients and the per-step force evaluation.

    Args:
        params: The vehicle.
        water_density_kg_m3: Density of the water the vehicle is in.
        gravity_mps2: Local gravity (for the damping ratios that are defined by the restoring
            stiffness).
    """

    def __init__(self, params: VehicleParams, water_density_kg_m3: float, gravity_mps2: float):
        params.validate()
        if not (math.isfinite(water_density_kg_m3) and 900.0 <= water_density_kg_m3 <= 1100.0):
            raise ValueError(
                f"water density {water_density_kg_m3!r} kg/m^3: allowed range [900, 1100]"
            )
        self.params = params
        self.rho = water_density_kg_m3
        self.added_mass = params.added_mass_f  # positive diagonal
        self._ma = tuple(float(x) for x in self.added_mass)
        self._d_lin = tuple(float(x) for x in params.linear_damping_f(gravity_mps2))
        # Hull as a low-aspect "wing" in the vertical plane (Beard & McLain 2012, used by Fossen).
        self._s_hull = params.hull_reference_area_m2
        self._ar = params.diameter_m**2 / self._s_hull
        self._cl_alpha = math.pi * self._ar / (1.0 + math.sqrt(1.0 + (self._ar / 2.0) ** 2))
        self._cd0 = params.hull_cd0
        # Strip theory: 2-D drag coefficient of a circular section, strips along the hull.
        self._half_length = params.length_m / 2
        cd2d = hoerner_cd(params.diameter_m, params.diameter_m)
        self._k_cross = 0.5 * self.rho * params.diameter_m * cd2d  # per unit length
        self._k_rudder = 0.5 * self.rho * params.rudder_area_m2 * params.rudder_cl_delta
        self._k_stern = 0.5 * self.rho * params.stern_area_m2 * params.stern_cl_delta
        d = params.prop_diameter_m
        self._kt_slope = (params.kt_max - params.kt0) / params.ja_max
        self._kq_slope = (params.kq_max - params.kq0) / params.ja_max
        self._rho_d4 = self.rho * d**4
        self._rho_d5 = self.rho * d**5
        p = params
        # hydrodynamics_kernel.wrench_f's constants, in its order.
        self.kernel_constants = (
            *self._ma, *self._d_lin, self._cl_alpha, self._cd0, p.oswald_e, self._ar, self.rho,
            self._s_hull, self._half_length, self._k_cross, self._k_rudder, self._k_stern,
            p.fin_x_m, p.thrust_deduction, p.prop_torque_on_hull, p.wake_fraction,
            p.prop_diameter_m, self._rho_d4, self._rho_d5, p.kt0, p.kq0, self._kt_slope,
            self._kq_slope, 2.0,  # the exponent of the fins' drag (hydrodynamics_kernel)
        )  # fmt: skip
        self._strips = int(p.crossflow_strips)

    # ---- components ----------------------------------------------------------------------
    def propeller(self, n_rps: float, u_r: float) -> tuple[float, float]:
        """(thrust X_prop, torque K_prop) at propeller speed n (rev/s) and surge speed u_r.

        Linearised Wageningen B-series K_T(J_a), K_Q(J_a) of Fossen's remus100; reverse thrust
        uses the bollard values. The advance speed is V_a = (1 − w) u_r.
        """
        p = self.params
        n_abs = abs(n_rps)
        if n_rps > 0:
            va_over_d = (1.0 - p.wake_fraction) * u_r / p.prop_diameter_m
            x = self._rho_d4 * (p.kt0 * n_abs * n_rps + self._kt_slope * va_over_d * n_abs)
            k = self._rho_d5 * (p.kq0 * n_abs * n_rps + self._kq_slope * va_over_d * n_abs)
        else:
            x = self._rho_d4 * p.kt0 * n_abs * n_rps
            k = self._rho_d5 * p.kq0 * n_abs * n_rps
        return x, k

    def wrench_f(
        self, nu_r: Sequence[float], rudder_rad: float, stern_rad: float, n_rps: float
    ) -> tuple[float, float, float, float, float, float]:
        """Hydrodynamic and control wrench [X, Y, Z, K, M, N] in f at the CO.

        Includes −C_A(ν_r)ν_r, −D(ν_r)ν_r, hull lift/drag, cross-flow drag, fins and propeller;
        excludes the added-mass inertia −M_A ν̇_r (solved implicitly by the plant) and
        gravity/buoyancy (applied by MuJoCo and the plant). Compiled
        (:mod:`twin.world.hydrodynamics_kernel`): :meth:`wrench_f_reference` bit for bit.
        """
        return hydrodynamics_kernel.wrench_f(
            tuple(nu_r), float(rudder_rad), float(stern_rad), float(n_rps),
            self.kernel_constants, self._strips,
        )  # fmt: skip

    def wrench_f_reference(
        self, nu_r: Sequence[float], rudder_rad: float, stern_rad: float, n_rps: float
    ) -> list[float]:
        """:meth:`wrench_f` in Python: the reference the compiled wrench is tested against."""
        u, v, w, p, q, r = nu_r
        xu, yv, zw, kp, mq, nr = self._ma
        par = self.params
        u_rel = math.sqrt(u * u + v * v + w * w)
        fade = math.exp(-3.0 * u_rel)

        # Added-mass Coriolis/centripetal C_A(ν_r)ν_r without the Munk moments (module docstring).
        ca = (
            zw * w * q - yv * v * r,
            xu * u * r - zw * w * p,
            yv * v * p - xu * u * q,
            (zw - yv) * v * w + (nr - mq) * q * r,
            (kp - nr) * r * p,
            (mq - kp) * p * q,
        )
        d = self._d_lin
        tau = [
            -ca[0] - d[0] * fade * u,
            -ca[1] - d[1] * fade * v,
            -ca[2] - d[2] * w,
            -ca[3] - d[3] * p,
            -ca[4] - d[4] * q,
            -ca[5] - d[5] * r,
        ]

        # Hull lift and drag in the vertical plane (angle of attack α = atan2(w, u)).
        if u_rel > 1e-9:
            alpha = math.atan2(w, u)
            cl = self._cl_alpha * alpha
            cd = self._cd0 + cl * cl / (math.pi * par.oswald_e * self._ar)
            qs = 0.5 * self.rho * u_rel * u_rel * self._s_hull
            f_drag, f_lift = qs * cd, qs * cl
            ca_, sa_ = math.cos(alpha), math.sin(alpha)
            tau[0] += -ca_ * f_drag + sa_ * f_lift
            tau[2] += -sa_ * f_drag - ca_ * f_lift

        # Strip-theory cross-flow drag (Fossen's crossFlowDrag, extended to heave/pitch for an
        # axisymmetric hull): a section at x sees v + x r sideways and w − x q vertically. The
        # strip sum is evaluated as its integral, in closed form (no per-step loop).
        if par.crossflow_strips:
            fy, ny = _crossflow_strips(v, r, self._half_length, par.crossflow_strips)
            fz, mz = _crossflow_strips(w, -q, self._half_length, par.crossflow_strips)
        else:
            fy, ny = _crossflow(v, r, self._half_length)
            fz, mz = _crossflow(w, -q, self._half_length)
        tau[1] -= self._k_cross * fy
        tau[5] -= self._k_cross * ny
        tau[2] -= self._k_cross * fz
        tau[4] += self._k_cross * mz

        # Fins: lift ∝ deflection, induced drag ∝ deflection² (Fossen's remus100). Both act at
        # x_fin aft of the CO, so their moments are those of a force there: N = x Y, M = −x Z.
        # Positive stern planes push the tail down (Z > 0 at x < 0), which pitches the nose up.
        u_h2 = u * u + v * v
        u_v2 = u * u + w * w
        y_r = -self._k_rudder * u_h2 * rudder_rad
        z_s = self._k_stern * u_v2 * stern_rad
        tau[0] += -self._k_rudder * u_h2 * rudder_rad**2 - self._k_stern * u_v2 * stern_rad**2
        tau[1] += y_r
        tau[2] += z_s
        tau[4] -= par.fin_x_m * z_s
        tau[5] += par.fin_x_m * y_r

        x_prop, k_prop = self.propeller(n_rps, u)
        tau[0] += (1.0 - par.thrust_deduction) * x_prop
        tau[3] += par.prop_torque_on_hull * k_prop
        return tau

    def steady_speed_mps(self, n_rps: float) -> float:
        """Forward speed at which thrust equals resistance in straight, level flight."""
        lo, hi = 0.0, 5.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            x = self.wrench_f((mid, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0, 0.0, n_rps)[0]
            lo, hi = (mid, hi) if x > 0 else (lo, mid)
        return 0.5 * (lo + hi)

    def rps_for_speed(self, speed_mps: float) -> float:
        """Propeller speed (rev/s) that holds ``speed_mps`` in steady straight flight."""
        n_max = self.params.prop_max_rpm / 60.0
        lo, hi = 0.0, n_max
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            x = self.wrench_f((speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0, 0.0, mid)[0]
            lo, hi = (mid, hi) if x < 0 else (lo, mid)
        return 0.5 * (lo + hi)
