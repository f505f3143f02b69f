"""REMUS-100-class vehicle parameters, with their sources.

Numbers follow Fossen's remus100 model (T. I. Fossen, Handbook of Marine Craft Hydrodynamics and
Motion Control, 2nd ed., Wiley 2021, §8.4.2; implemented in cybergalactic/PythonVehicleSimulator
``vehicles/remus100.py``) as surveyed in shared/reference/vehicle-and-peers.md §3.1, with the
derived values recomputed here from the geometry so that they cannot drift apart. Where that file's
versions differ (fin travel 15° vs 30°, servo time constant 0.1 s vs 1 s, yaw time constant 1 s vs
5 s) the choice is marked below. models/auv/README.md lists every number with its source.

All hydrodynamic quantities are in Fossen's body frame f (x forward, y starboard, z down) at the
centre of origin CO = centre of buoyancy; :mod:`twin.core.frames` converts to the body frame b.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Hoerner's 2-D cross-flow drag coefficient against B/2T (Fossen 2021, Hoerner 1965), digitised.
_HOERNER_B2T = (
    0.0109, 0.1766, 0.3530, 0.4519, 0.4728, 0.4929, 0.4933, 0.5585, 0.6464, 0.8336,
    0.9880, 1.3081, 1.6392, 1.8600, 2.3129, 2.6000, 3.0088, 3.4508, 3.7379, 4.0031,
)  # fmt: skip
_HOERNER_CD = (
    1.9661, 1.9657, 1.8976, 1.7872, 1.5837, 1.2786, 1.2108, 1.0836, 0.9986, 0.8796,
    0.8284, 0.7599, 0.6914, 0.6571, 0.6307, 0.5962, 0.5868, 0.5859, 0.5599, 0.5593,
)  # fmt: skip


def hoerner_cd(beam_m: float, draft_m: float) -> float:
    """2-D cross-flow drag coefficient of a section of beam B and draft T (Hoerner's curve)."""
    return float(np.interp(beam_m / (2.0 * draft_m), _HOERNER_B2T, _HOERNER_CD))


@dataclass(frozen=True, slots=True)
class VehicleParams:
    """Geometry, mass and hydrodynamic coefficients of a torpedo-shaped AUV.

    Defaults are the REMUS 100 (Fossen 2021 §8.4.2). Derived quantities (mass, inertia, added mass,
    linear damping) are properties computed from these fields.
    """

    length_m: float = 1.6  # Fossen remus100 `L`
    diameter_m: float = 0.19  # Fossen remus100 `diam`
    design_density_kg_m3: float = 1026.0  # Fossen's rho: mass = rho * V of the spheroid
    cg_below_cb_m: float = 0.02  # r_bg = [0, 0, 0.02] (z down): CG below CB
    # Hull drag: Cd = 0.42 on the frontal area (Allen et al. 2000), expressed on S = 0.7 L D.
    hull_cd_frontal: float = 0.42
    oswald_e: float = 0.7  # Oswald efficiency of the hull "wing" (Beard & McLain 2012)
    roll_added_inertia_ratio: float = 0.3  # A44 = 0.3 Ix (Fossen)
    # Low-speed linear damping (Fossen): time constants and damping ratios.
    t_surge_s: float = 20.0
    t_sway_s: float = 20.0
    zeta_roll: float = 0.3
    zeta_pitch: float = 0.8
    # Fossen remus100.py (PythonVehicleSimulator c717e07): T_yaw = 1 s, and the yaw damping does
    # not fade with speed (only surge and sway do). An earlier version of this file used 5 s.
    t_yaw_s: float = 1.0
    # Fins: each control pair (upper + lower rudder, port + starboard stern plane) is two fins of
    # S_fin = 0.00665 m², the REMUS fin planform area (Prestero 2001), which Fossen's remus100.py
    # uses as A_r = A_s = 2 S_fin; both pairs at x = -L/2 (Fossen). An earlier version of this file
    # used one 0.10 x 0.05 m rudder.
    rudder_area_m2: float = 2 * 0.00665
    rudder_cl_delta: float = 0.5
    stern_area_m2: float = 2 * 0.00665
    stern_cl_delta: float = 0.7
    fin_x_m: float = -0.8
    fin_max_rad: float = math.radians(15.0)  # vehicle-and-peers.md §3.1 (older remus100: 15 deg)
    fin_rate_max_rad_s: float = math.radians(60.0)  # assumption: a typical AUV fin servo, 60 deg/s
    # The lags act in auv.xml (filterexact dynprm); tests/models/test_models.py ties them here.
    fin_time_constant_s: float = 0.1  # vehicle-and-peers.md §3.1 (newer remus100.py: 1.0 s)
    # Propeller (Allen et al. 2000; Wageningen B3-0.718 fit in Fossen's remus100).
    prop_diameter_m: float = 0.14
    prop_max_rpm: float = 1525.0
    prop_time_constant_s: float = 1.0
    thrust_deduction: float = 0.1
    wake_fraction: float = 0.056  # Va = 0.944 U
    kt0: float = 0.4566
    kq0: float = 0.0700
    kt_max: float = 0.1798
    kq_max: float = 0.0312
    ja_max: float = 0.6632
    # Strip-theory cross-flow: number of strips along the hull. 0 (default) integrates exactly
    # over the hull; n > 0 reproduces Fossen's crossFlowDrag, which sums n + 1 strips of L/n (a
    # 5 % longer hull in sway, 15 % more yaw damping; used only to cross-check against PVS).
    crossflow_strips: int = 0
    # Fraction of the propeller's shaft torque that reacts on the hull in roll. 1.0: all of it (a
    # single open propeller, no stator or counter-rotation; Prestero 2001 measured K_prop = -0.543
    # N·m at cruise on the REMUS). Fossen's remus100.py scales it by 0.1 "to match exp. results"
    # without a source; set 0.1 only to cross-check against PVS.
    prop_torque_on_hull: float = 1.0

    def validate(self) -> None:
        """Raise ValueError naming the field if a parameter is impossible."""
        for name in (
            "length_m", "diameter_m", "design_density_kg_m3", "hull_cd_frontal", "oswald_e",
            "t_surge_s", "t_sway_s", "t_yaw_s", "prop_diameter_m", "prop_max_rpm",
            "prop_time_constant_s", "fin_time_constant_s", "fin_max_rad", "fin_rate_max_rad_s",
        ):  # fmt: skip
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"vehicle.{name} = {v!r}: must be a finite number > 0")
        if not (math.isfinite(self.prop_torque_on_hull) and 0 <= self.prop_torque_on_hull <= 1):
            raise ValueError(
                f"vehicle.prop_torque_on_hull = {self.prop_torque_on_hull!r}: allowed [0, 1]"
            )
        if self.crossflow_strips < 0:
            raise ValueError(f"vehicle.crossflow_strips = {self.crossflow_strips!r}: allowed >= 0")
        if not self.diameter_m < self.length_m:
            raise ValueError("vehicle.diameter_m must be smaller than vehicle.length_m")
        if not 0 <= self.cg_below_cb_m < self.diameter_m / 2:
            raise ValueError(
                f"vehicle.cg_below_cb_m = {self.cg_below_cb_m!r}: "
                f"allowed [0, {self.diameter_m / 2})"
            )

    # ---- derived quantities (Fossen 2021 §8.4.2) -------------------------------------------
    @property
    def semi_axes_m(self) -> tuple[float, float]:
        """(a, b): spheroid semi-axes along and across the hull."""
        return self.length_m / 2, self.diameter_m / 2

    @property
    def volume_m3(self) -> float:
        a, b = self.semi_axes_m
        return 4.0 / 3.0 * math.pi * a * b * b

    @property
    def mass_kg(self) -> float:
        """Rigid-body mass: neutrally buoyant spheroid at the design density."""
        return self.design_density_kg_m3 * self.volume_m3

    @property
    def inertia_f(self) -> tuple[float, float, float]:
        """(Ix, Iy, Iz) of the spheroid at the CG, Fossen axes."""
        a, b = self.semi_axes_m
        m = self.mass_kg
        ix = 0.4 * m * b * b
        iy = 0.2 * m * (a * a + b * b)
        return ix, iy, iy

    @property
    def added_mass_f(self) -> np.ndarray:
        """Diagonal added mass [X_u', Y_v', Z_w', K_p', M_q', N_r'] (positive), Lamb's k-factors."""
        a, b = self.semi_axes_m
        m = self.mass_kg
        ix, iy, _ = self.inertia_f
        e = math.sqrt(1.0 - (b / a) ** 2)
        log_term = math.log((1 + e) / (1 - e))
        alpha0 = 2.0 * (1 - e * e) / e**3 * (0.5 * log_term - e)
        beta0 = 1.0 / e**2 - (1 - e * e) / (2 * e**3) * log_term
        k1 = alpha0 / (2 - alpha0)
        k2 = beta0 / (2 - beta0)
        k_prime = (
            e**4 * (beta0 - alpha0) / ((2 - e * e) * (2 * e * e - (2 - e * e) * (beta0 - alpha0)))
        )
        return np.array(
            [m * k1, m * k2, m * k2, self.roll_added_inertia_ratio * ix, k_prime * iy, k_prime * iy]
        )

    @property
    def rigid_mass_matrix_diag_f(self) -> np.ndarray:
        """diag(M_RB) expressed at the CO (parallel-axis terms on the diagonal included)."""
        m = self.mass_kg
        ix, iy, iz = self.inertia_f
        zg = self.cg_below_cb_m
        return np.array([m, m, m, ix + m * zg * zg, iy + m * zg * zg, iz])

    @property
    def hull_reference_area_m2(self) -> float:
        """S = 0.7 L D (Fossen: 70 % of the rectangle L x D)."""
        return 0.7 * self.length_m * self.diameter_m

    @property
    def hull_cd0(self) -> float:
        """Parasitic drag coefficient on S: Cd * pi b^2 / S."""
        _, b = self.semi_axes_m
        return self.hull_cd_frontal * math.pi * b * b / self.hull_reference_area_m2

    def linear_damping_f(self, g: float = 9.81) -> np.ndarray:
        """Low-speed linear damping diag at zero speed [Xu, Yv, Zw, Kp, Mq, Nr] (positive).

        Surge and sway fade as exp(-3 U_r) in :mod:`twin.world.hydrodynamics` (Fossen).
        """
        m_total = self.rigid_mass_matrix_diag_f + self.added_mass_f
        w = self.mass_kg * g
        w_roll = math.sqrt(w * self.cg_below_cb_m / m_total[3])
        w_pitch = math.sqrt(w * self.cg_below_cb_m / m_total[4])
        return np.array(
            [
                m_total[0] / self.t_surge_s,
                m_total[1] / self.t_sway_s,
                m_total[2] / self.t_sway_s,
                m_total[3] * 2 * self.zeta_roll * w_roll,
                m_total[4] * 2 * self.zeta_pitch * w_pitch,
                m_total[5] / self.t_yaw_s,
            ]
        )


REMUS100 = VehicleParams()
