"""15-state error-state Kalman filter (ESKF) for the INS, aided by gravity, sun and depth.

The LIG paper's integrated navigation (Hu et al. 2024, §3): a strapdown INS
(:mod:`twin.onboard.ins`) carries the full nonlinear solution; the filter estimates its errors,
feeds them back into the INS after every accepted measurement and resets its error state to zero.

State and error dynamics: :mod:`twin.onboard.eskf_dynamics` (paper eq. 16, errors as
*estimate − truth*; φ's sign convention there).

Measurements (z = predicted − measured, the paper's sign):

* gravity vector (eqs. 18–19), only when quasi-static (‖f‖ ≈ g, ‖ω‖ small): with the mean
  bias-compensated specific force f̄^b, Z_g = −C_b^n_est f̄^b − g^n = [g^n×] φ − C_b^n ∇ + v.
  The paper's H_g keeps only [g^n×]; ``EskfConfig.gravity_models_accel_bias`` (default True) adds
  the −C_b^n column for ∇ (static tilt and horizontal accelerometer bias remain inseparable:
  φ_level ≈ ∇_h / g).
* solar vector (eqs. 20–24), from any compass method: Z_s = C_b^n_est ŝ^b − s^n = [s^n×] φ + v,
  R = C_b^n_est Σ_b C_b^n_estᵀ (or the configured R_s). Both vectors are unit vectors, so Z_s has
  no information along s^n; the update uses the two components on the plane normal to s^n (a
  3-D update would have a singular innovation covariance when Σ_b is rank 2, as compass fixes'
  tangent-plane covariances are).
* depth: Z_d = h_est − (−depth) = δh + v. Height is relative to the scenario's sea surface,
  which the Earth model takes as the ellipsoid (:mod:`twin.core.earth`): h = −depth.
* gravity map (:meth:`Eskf.update_scalar`, built by :mod:`twin.onboard.gravity.matching`): the
  stored anomaly at the estimated position minus the reduced gravimeter reading, with SITAN's
  fitted slope on δL, δλ and the Eötvös and normal-gravity partials on δv and δL, δh.

Gating: every innovation's NIS = yᵀ S⁻¹ y is tested against the chi-square quantile
``EskfConfig.gate_probability`` for its dimension; a rejected measurement is recorded in
:attr:`Eskf.rejections` (time, kind, NIS) and not applied.

Covariance propagation runs every ``cov_step_s`` (default 0.1 s, and before every update) with
Φ = I + FΔt + ½(FΔt)² and Q_d = ½(Φ Q_c Φᵀ + Q_c)Δt — the error dynamics' time constants
(Schuler 84 min, Earth rate) are long, and this keeps the filter far faster than real time. After
an update the error state is fed back and zeroed; the reset Jacobian I − ½[δφ×] on the attitude
block is taken as the identity (the corrections are small).

The Kalman algebra is filterpy's (>= 2.0): :func:`filterpy.kalman.predict` (P ← ΦPΦᵀ + Q) and
:func:`filterpy.kalman.update` (gain and Joseph-form covariance update), written out here with the
same formulas because their general versions cost ≈ 30 and ≈ 70 µs a call at 10 Hz per variant
(the budget for 200x real time is 50 µs per 100 Hz IMU step); the tests check both against
filterpy. F is refilled in place (:mod:`twin.onboard.eskf_dynamics`), the INS steps in plain floats.

Tuning: :meth:`EskfConfig.for_imu` derives P0 and Q from the IMU's datasheet (:class:`ImuGrade`);
with the paper's defaults the lig2024 seed IMU gives attitude NEES of 10–500 (docs/navigation.md).

Defaults (paper §3.3, "determined by trial-and-error"): P0 = diag(0.5°, 0.5°, 0.5°; …; 2 °/h ×3;
10 µg ×3)², Q = diag(0.01, 0.01, 0.16 °/√h; 5 µg/√Hz ×3; 0 …)², R_g = diag(0.1 g)², R_s =
diag(0.05)². The printed P0 has 9 entries for 15 states; its "1 m/hr" is unreadable, so the
velocity (0.1 m/s) and position (1 m) entries of P0 are our assumptions. Q's φ and δv densities
are taken as continuous-time densities on the ENU error states (the paper lists them by E, N, U).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from twin.core import earth
from twin.core.arrays import Float64Array as FloatArray
from twin.core.frames import dcm_to_euler, yaw_to_heading_deg
from twin.core.messages import Reading
from twin.onboard import eskf_kernels, mechanization
from twin.onboard.eskf_algebra import (
    chi2_threshold,
    cross3,
    dot3,
    given3,
    tangent_basis,
    unit3,
)
from twin.onboard.eskf_config import GM_SIGMA_PER_BIAS_INSTABILITY, EskfConfig, ImuGrade, Triple
from twin.onboard.eskf_dynamics import (
    _F_VARYING,
    DIM,
    I_H,
    PHI,
    _f_constant_part,
    attitude_error,
    error_dynamics,
)
from twin.onboard.eskf_references import EskfReferences
from twin.onboard.eskf_results import MeasurementKind, NavEstimate, Rejection, UpdateResult
from twin.onboard.ins import EARTH_CONSTANTS, NavState, StrapdownIns

__all__ = [
    "DIM",
    "GM_SIGMA_PER_BIAS_INSTABILITY",
    "Eskf",
    "EskfConfig",
    "ImuGrade",
    "NavEstimate",
    "Rejection",
    "UpdateResult",
    "attitude_error",
    "chi2_threshold",
    "error_dynamics",
]


# The depth update's H: the height error's row (read only by the update).
_H_DEPTH = np.zeros((1, DIM))
_H_DEPTH[0, I_H] = 1.0
_H_DEPTH.setflags(write=False)


class Eskf(EskfReferences):
    """INS + 15-state error-state Kalman filter (module docstring).

    Args:
        config: :class:`EskfConfig`.
        init: Initial navigation solution (attitude, velocity, position, time).
        gyro_bias: Initial gyro bias estimate (rad/s, body), e.g. from an at-rest calibration.
        accel_bias: Initial accelerometer bias estimate (m/s², body).

    Typical loop::

        nav = Eskf(EskfConfig(), NavState.from_euler(lat_rad=..., lon_rad=..., h_m=-depth, ...))
        for reading in readings:
            if reading.sensor == "imu":
                nav.predict_reading(reading)
            elif reading.sensor == "depth":
                nav.update_depth(float(reading["depth_m"][0]))
        nav.update_gravity()          # at 10 Hz, from the IMU samples since the last call
        nav.update_sun(fix)           # a CompassFix (or sun_body=..., sun_enu=...)
        est = nav.estimate()
    """

    def __init__(
        self,
        config: EskfConfig | None = None,
        init: NavState | None = None,
        *,
        gyro_bias: FloatArray | None = None,
        accel_bias: FloatArray | None = None,
    ):
        if init is None:
            raise ValueError("Eskf init: an initial NavState is required")
        self.config = config if config is not None else EskfConfig()
        cfg = self.config
        self.ins = StrapdownIns(init, cfg.ins, gyro_bias=gyro_bias, accel_bias=accel_bias)
        r_m, r_n = earth.principal_radii(init.lat_rad)
        pe, pn, pu = cfg.p0_position_m
        sig = np.array(
            [
                *cfg.p0_attitude_rad,
                *cfg.p0_velocity_mps,
                pn / (r_m + init.h_m),
                pe / ((r_n + init.h_m) * math.cos(init.lat_rad)),
                pu,
                *cfg.p0_gyro_bias_rad_s,
                *cfg.p0_accel_bias_mps2,
            ]
        )
        self.P = np.diag(sig**2)
        self.x = np.zeros(DIM)  # the error state: zero between updates (fed back at once)
        self._q_diag = (
            np.array(
                [
                    *cfg.q_attitude,
                    *cfg.q_velocity,
                    0.0,
                    0.0,
                    0.0,
                    *cfg.q_gyro_bias,
                    *cfg.q_accel_bias,
                ]
            )
            ** 2
        )
        self._qc = np.diag(self._q_diag)
        self._f = _f_constant_part(cfg.gyro_bias_tau_s, cfg.accel_bias_tau_s)
        self._f_flat = self._f.reshape(-1)  # a view: F is refilled in place
        self._eye = np.eye(DIM)
        self._r_gravity = np.diag(np.array(cfg.r_gravity_mps2) ** 2)
        self._r_depth = np.array([[cfg.r_depth_m * cfg.r_depth_m]])
        self._r_sun = np.diag(np.array(cfg.r_sun) ** 2)
        self._gate = {d: chi2_threshold(cfg.gate_probability, d) for d in (1, 2, 3)}
        self._pending_dt = 0.0
        self._cov_step = cfg.cov_step_s - 1e-9
        self._f_sum = [0.0, 0.0, 0.0]
        self._w_sum = [0.0, 0.0, 0.0]
        self._n_sum = 0
        self._w2_dt = 0.0  # ∫‖ω‖² dt since the last covariance step (the rate allowance)
        self.rejections: list[Rejection] = []
        self.counts: dict[str, int] = {
            "gravity": 0,
            "sun": 0,
            "depth": 0,
            "map": 0,
            "not_static": 0,
        }

    # --- time update ---------------------------------------------------------------------------
    @property
    def t(self) -> float:
        return self.ins.t

    def predict_imu(self, dt: float, angular_rate: FloatArray, specific_force: FloatArray) -> bool:
        """One INS step with rate samples (rad/s, m/s², body); the covariance follows lazily.

        Returns False when the sample was skipped (non-finite with ``on_nonfinite="skip"``).
        """
        if not self.ins.step(dt, angular_rate, specific_force):
            return False
        self._after_step(dt)
        return True

    def predict_reading(self, reading: Reading) -> bool:
        """One INS step with an IMU reading (dt from the time stamps)."""
        dt = reading.t - self.ins.t
        if not self.ins.step_reading(reading):
            return False
        self._after_step(dt)
        return True

    def _after_step(self, dt: float) -> None:
        f, w = self.ins._f, self.ins._w  # the compensated sample, plain floats
        fs, ws = self._f_sum, self._w_sum
        fs[0] += f[0]
        fs[1] += f[1]
        fs[2] += f[2]
        ws[0] += w[0]
        ws[1] += w[1]
        ws[2] += w[2]
        self._n_sum += 1
        self._w2_dt += (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * dt
        self._pending_dt += dt
        if self._pending_dt >= self._cov_step:
            self.propagate_covariance()

    def gravity_partials(self) -> tuple[float, float]:
        """(∂γ/∂L, ∂γ/∂h) of the INS's gravity model at the current position (central diff.)."""
        lat, h, g = self.ins.lat, self.ins.h, self.ins.gravity
        dl, dh = 1e-5, 1.0
        return (
            (g(lat + dl, h) - g(lat - dl, h)) / (2 * dl),
            (g(lat, h + dh) - g(lat, h - dh)) / (2 * dh),
        )

    def system_matrix(self) -> FloatArray:
        """F at the INS's current state and last compensated specific force (a new array)."""
        return self._system_matrix().copy()

    def _system_matrix(self) -> FloatArray:
        """F refilled in place (the filter's own preallocated array).

        Compiled (:func:`twin.onboard.mechanization.fill_f`, :meth:`_system_matrix_reference`'s
        values bit for bit) unless the INS has a gravity model of its own.
        """
        ins = self.ins
        if not ins.standard_gravity:
            return self._system_matrix_reference()
        fa = ins.config.free_air_gravity
        dgl, dgh = mechanization.gravity_partials(ins.lat, ins.h, fa, EARTH_CONSTANTS)
        mechanization.fill_f(
            self._f_flat, _F_VARYING, ins.lat, ins.h, ins._v, ins._c, ins._f, dgl, dgh,
            EARTH_CONSTANTS,
        )  # fmt: skip
        return self._f

    def propagate_covariance(self) -> None:
        """Bring P to the INS's time (Φ = I + FΔt + ½(FΔt)², Q_d trapezoidal).

        P ← Φ P Φᵀ + Q_d written out rather than through filterpy's ``kalman.predict``: that also
        propagates x (zero here), handles a control input and a fading-memory factor, and costs
        ≈ 30 µs against ≈ 8 µs for the two products; the algebra is the same (a test checks).
        Compiled (:func:`twin.onboard.eskf_kernels.propagate`): :meth:`_propagate_reference`'s
        arithmetic bit for bit, a third of its cost.
        """
        dt = self._pending_dt
        if dt <= 0.0:
            return
        q_diag, qc = self._rate_q(dt)
        ins = self.ins
        if ins.standard_gravity:  # F's fill and the step in one dispatch (the same calls)
            self.P = eskf_kernels.propagate_at(
                self.P, self._f, _F_VARYING, ins.lat, ins.h, ins._v, ins._c, ins._f,
                ins.config.free_air_gravity, EARTH_CONSTANTS, dt, q_diag, qc, self._eye,
            )  # fmt: skip
        else:
            self.P = eskf_kernels.propagate(
                self.P, self._system_matrix(), dt, q_diag, qc, self._eye
            )
        self._pending_dt = 0.0

    def _rate_q(self, dt: float) -> tuple[FloatArray, FloatArray]:
        """Q_c's diagonal and Q_c for this step (the rate-proportional allowance added)."""
        q_diag, qc = self._q_diag, self._qc
        gain = self.config.q_rate_gain
        if gain > 0.0:
            # The rate-proportional allowance over this step: (k √T)² times the mean ‖ω‖².
            q_diag = q_diag.copy()
            q_diag[PHI] += gain * gain * self._w2_dt / dt
            qc = np.diag(q_diag)
        self._w2_dt = 0.0
        return q_diag, qc

    # --- measurement updates -------------------------------------------------------------------
    def update_gravity(
        self,
        specific_force: FloatArray | None = None,
        angular_rate: FloatArray | None = None,
        *,
        r: FloatArray | None = None,
    ) -> UpdateResult:
        """Gravity-vector update (eqs. 18–19) if the vehicle is quasi-static.

        Args:
            specific_force: Bias-compensated specific force (m/s², body). None: the mean of the
                INS's compensated samples since the last gravity update (noise averaged down).
            angular_rate: Compensated angular rate (rad/s, body), for the static test; None: the
                mean since the last gravity update.
            r: 3×3 measurement covariance; None: the configured R_g.
        """
        cfg = self.config
        n = self._n_sum
        if specific_force is None or angular_rate is None:
            if n == 0:
                return UpdateResult("gravity", self.t, False, reason="no IMU samples")
        mean_f = (self._f_sum[0] / n, self._f_sum[1] / n, self._f_sum[2] / n) if n else None
        mean_w = (self._w_sum[0] / n, self._w_sum[1] / n, self._w_sum[2] / n) if n else None
        self._f_sum = [0.0, 0.0, 0.0]
        self._w_sum = [0.0, 0.0, 0.0]
        self._n_sum = 0
        fx, fy, fz = mean_f if specific_force is None else given3(specific_force)
        wx, wy, wz = mean_w if angular_rate is None else given3(angular_rate)
        if not math.isfinite(fx + fy + fz + wx + wy + wz):
            raise ValueError(
                f"Eskf.update_gravity specific_force/angular_rate: non-finite input "
                f"({[fx, fy, fz]}, {[wx, wy, wz]})"
            )
        ins = self.ins
        c0, c1, c2, c3, c4, c5, c6, c7, c8 = ins._c
        g = ins.gravity(ins.lat, ins.h)
        ie_n, ie_u = earth.OMEGA_IE * math.cos(ins.lat), earth.OMEGA_IE * math.sin(ins.lat)
        # ω − C_n^b ω_ie^n, ω_ie^n = [0, Ω cos L, Ω sin L]
        rx, ry, rz = (
            wx - c3 * ie_n - c6 * ie_u,
            wy - c4 * ie_n - c7 * ie_u,
            wz - c5 * ie_n - c8 * ie_u,
        )
        if (
            abs(math.sqrt(fx * fx + fy * fy + fz * fz) - g) > cfg.static_accel_tol_mps2
            or math.sqrt(rx * rx + ry * ry + rz * rz) > cfg.static_rate_tol_rad_s
        ):
            self.counts["not_static"] += 1
            return UpdateResult("gravity", self.t, False, reason="not quasi-static")
        # z = −C f̄ − g^n, g^n = [0, 0, −γ]; H = [[g^n×] 0 0 0 −C]
        z = np.array(
            [
                -(c0 * fx + c1 * fy + c2 * fz),
                -(c3 * fx + c4 * fy + c5 * fz),
                g - (c6 * fx + c7 * fy + c8 * fz),
            ]
        )
        h = eskf_kernels.gravity_rows(g, ins._c, cfg.gravity_models_accel_bias)
        rr = self._r_gravity if r is None else self._covariance("r", r, 3)
        return self._propagate_and_update("gravity", z, h, rr)

    def update_sun(
        self,
        fix: Any = None,
        *,
        sun_body: FloatArray | None = None,
        sun_enu: FloatArray | None = None,
        covariance_body: FloatArray | None = None,
        azimuth_only: bool = False,
    ) -> UpdateResult:
        """Solar-vector update (eqs. 20–24) from a compass fix or explicit vectors.

        ``azimuth_only=True`` keeps only the component of the residual along the horizontal
        tangent of s^n (the sun's azimuth, i.e. the heading): a 1-D update that leaves roll and
        pitch to gravity. Use it when the compass's elevation is biased (under water, the
        refracted and multiply scattered light moves the apparent sun's elevation more than its
        azimuth: validation/results/campaigns/compass_underwater/report.md). A sun within 5° of
        the zenith has no usable azimuth: the update is skipped with that reason.

        Args:
            fix: A :class:`~twin.onboard.compass.base.CompassFix` (anything with ``ok``,
                ``sun_body``, ``sun_enu``, ``covariance_body``); a fix with ``ok=False`` is
                skipped. Keyword arguments override its fields.
            sun_body: Unit solar vector measured in the body frame.
            sun_enu: Unit solar vector from the ephemeris (ENU).
            covariance_body: 3×3 covariance of ``sun_body``; None: the configured R_s.
            azimuth_only: Use only the azimuth (heading) component (see above).
        """
        if fix is not None:
            if not getattr(fix, "ok", False):
                return UpdateResult("sun", self.t, False, reason="no fix")
            sun_body = fix.sun_body if sun_body is None else sun_body
            sun_enu = fix.sun_enu if sun_enu is None else sun_enu
            if covariance_body is None:
                covariance_body = getattr(fix, "covariance_body", None)
        if sun_body is None or sun_enu is None:
            raise ValueError("Eskf.update_sun: sun_body and sun_enu are required")
        s_b = unit3("sun_body", sun_body)
        s_n = unit3("sun_enu", sun_enu)
        r_b = (
            self._r_sun
            if covariance_body is None
            else self._covariance("covariance_body", covariance_body, 3, psd_only=True)
        )
        if azimuth_only:
            rho = math.hypot(s_n[0], s_n[1])
            if rho < math.sin(math.radians(5.0)):
                return UpdateResult("sun", self.t, False, reason="sun near the zenith")
            basis: tuple[Triple, ...] = ((s_n[1] / rho, -s_n[0] / rho, 0.0),)
        else:
            basis = tangent_basis(s_n)
        self.propagate_covariance()
        c0, c1, c2, c3, c4, c5, c6, c7, c8 = self.ins._c
        # Predicted minus measured: C ŝ^b − s^n, on the plane normal to s^n (basis e1, e2).
        bx, by, bz = s_b
        d = (
            c0 * bx + c1 * by + c2 * bz - s_n[0],
            c3 * bx + c4 * by + c5 * bz - s_n[1],
            c6 * bx + c7 * by + c8 * bz - s_n[2],
        )
        z = np.array([dot3(e, d) for e in basis])
        # H = Eᵀ [s^n×]: row i is (e_i × s^n)ᵀ on φ.
        h = np.zeros((len(basis), DIM))
        for i, e in enumerate(basis):
            h[i, PHI] = cross3(e, s_n)
        # R = Eᵀ C Σ_b Cᵀ E = G Σ_b Gᵀ with the rows of G = Eᵀ C = (Cᵀ e_i)ᵀ.
        g = np.array(
            [
                [c0 * e[0] + c3 * e[1] + c6 * e[2], c1 * e[0] + c4 * e[1] + c7 * e[2],
                 c2 * e[0] + c5 * e[1] + c8 * e[2]]
                for e in basis
            ]
        )  # fmt: skip
        r2 = g @ r_b @ g.T
        if not np.all(np.linalg.eigvalsh(r2) > 0.0):
            raise ValueError(
                "Eskf.update_sun covariance_body: singular on the plane normal to the sun "
                "(must be positive definite there)"
            )
        return self._update("sun", z, h, r2)

    def update_depth(self, depth_m: float, *, sigma_m: float | None = None) -> UpdateResult:
        """Depth-gauge update: z = h_est + depth (h = −depth below the scenario's surface)."""
        d = float(np.asarray(depth_m, dtype=np.float64).reshape(-1)[0])
        if not math.isfinite(d):
            raise ValueError(f"Eskf.update_depth depth_m = {depth_m!r}: must be finite")
        if sigma_m is None:
            r = self._r_depth
        else:
            s = float(sigma_m)
            if not (math.isfinite(s) and s > 0):
                raise ValueError(f"Eskf.update_depth sigma_m = {sigma_m!r}: must be finite and > 0")
            r = np.array([[s * s]])
        return self._propagate_and_update("depth", np.array([self.ins.h + d]), _H_DEPTH, r)

    def update_scalar(
        self, kind: MeasurementKind, z: float, h: FloatArray, variance: float
    ) -> UpdateResult:
        """A scalar update with a given innovation z (predicted − measured) and row H (15,).

        For measurements modelled outside the filter (the gravity-map match of
        :mod:`twin.onboard.gravity.matching`); gated like the others.
        """
        row = np.asarray(h, dtype=np.float64).reshape(1, DIM)
        if not (math.isfinite(z) and np.all(np.isfinite(row))):
            raise ValueError(f"Eskf.update_scalar {kind}: non-finite innovation or H")
        if not (math.isfinite(variance) and variance > 0):
            raise ValueError(f"Eskf.update_scalar {kind}: variance {variance!r}; allowed: > 0")
        self.propagate_covariance()
        return self._update(kind, np.array([z]), row, np.array([[variance]]))

    def update_vector(self, kind: str, z: FloatArray, h: FloatArray, r: FloatArray) -> UpdateResult:
        """An m-dimensional update with innovation z (predicted − measured), H (m×15) and R.

        For measurements modelled outside the filter (a navigation aid's:
        :mod:`twin.onboard.aids`); gated against the χ² quantile of its dimension like the
        others, and counted under ``kind``.

        Raises:
            ValueError: Shapes that do not agree, non-finite values, or an R that is not
                symmetric positive definite.
        """
        zz = np.asarray(z, dtype=np.float64).reshape(-1)
        m = len(zz)
        hh = np.asarray(h, dtype=np.float64)
        rr = np.asarray(r, dtype=np.float64)
        if not (1 <= m <= 6 and hh.shape == (m, DIM) and rr.shape == (m, m)):
            raise ValueError(
                f"Eskf.update_vector {kind}: z {zz.shape}, H {hh.shape}, R {rr.shape}; allowed: "
                f"z (m,), H (m, {DIM}), R (m, m) with 1 <= m <= 6"
            )
        if not (np.all(np.isfinite(zz)) and np.all(np.isfinite(hh)) and np.all(np.isfinite(rr))):
            raise ValueError(f"Eskf.update_vector {kind}: non-finite z, H or R")
        if not np.allclose(rr, rr.T) or np.any(np.linalg.eigvalsh(rr) <= 0.0):
            raise ValueError(f"Eskf.update_vector {kind}: R must be symmetric positive definite")
        if m not in self._gate:
            self._gate[m] = chi2_threshold(self.config.gate_probability, m)
        self.propagate_covariance()
        return self._update(kind, zz, hh, rr)

    @staticmethod
    def _covariance(name: str, value: Any, n: int, *, psd_only: bool = False) -> FloatArray:
        m = np.asarray(value, dtype=np.float64)
        if m.shape != (n, n) or not np.all(np.isfinite(m)):
            raise ValueError(f"Eskf {name}: must be a finite {n}x{n} matrix, got shape {m.shape}")
        m = 0.5 * (m + m.T)
        lo = np.linalg.eigvalsh(m)[0]
        if lo < (-1e-12 if psd_only else 1e-300):
            kind = "positive semi-definite" if psd_only else "positive definite"
            raise ValueError(f"Eskf {name}: must be {kind} (smallest eigenvalue {lo:.3g})")
        return m

    def _update(
        self, kind: MeasurementKind, z: FloatArray, h: FloatArray, r: FloatArray
    ) -> UpdateResult:
        """Gate, then the Kalman update in Joseph form, then feedback.

        The algebra is filterpy's ``kalman.update`` (K = P Hᵀ S⁻¹, x ← x + K y, Joseph-form
        P ← (I − KH) P (I − KH)ᵀ + K R Kᵀ), written out: filterpy's general version (reshapes,
        np.linalg.inv of S, three dense 15×15 products with I − KH) costs ≈ 70 µs a call, and the
        run loop makes up to three calls every 0.1 s per filter variant. Here (I − KH) P is
        P − K (P Hᵀ)ᵀ and the right factor is applied as ((I − KH) P) − ((I − KH) P Hᵀ) Kᵀ: the
        same Joseph form, with m-column products only (m ≤ 3): (I − KH)P − ((I − KH)PHᵀ − KR)Kᵀ.
        A test checks it against filterpy.
        """
        # Compiled (eskf_kernels.update): _update_reference's arithmetic bit for bit; an S
        # without a closed-form inverse (m > 3, or not positive definite) takes the numpy path.
        # The INS's correction (_feedback's) in the same dispatch when it applies.
        ins = self.ins
        status, nis, p1, state = eskf_kernels.update_at(
            self.P, h, r, z, self._gate[len(z)], ins._c, ins._v, ins.lat, ins.lon, ins.h,
            ins._bg, ins._ba,
        )  # fmt: skip
        return self._applied(kind, status, nis, self.P, p1, state, z, h, r)

    def _propagate_and_update(
        self, kind: MeasurementKind, z: FloatArray, h: FloatArray, r: FloatArray
    ) -> UpdateResult:
        """:meth:`propagate_covariance`, then :meth:`_update`: one compiled dispatch for both.

        (:func:`eskf_kernels.propagate_update_at`, the same calls in the same order), where the
        INS's gravity is the one the compiled F knows; else the two methods.
        """
        ins = self.ins
        if not ins.standard_gravity:
            self.propagate_covariance()
            return self._update(kind, z, h, r)
        dt = self._pending_dt
        q_diag, qc = self._rate_q(dt) if dt > 0.0 else (self._q_diag, self._qc)
        status, nis, p, p1, state = eskf_kernels.propagate_update_at(
            dt, self.P, self._f, _F_VARYING, ins.lat, ins.lon, ins.h, ins._v, ins._c, ins._f,
            ins._bg, ins._ba, ins.config.free_air_gravity, EARTH_CONSTANTS, q_diag, qc,
            self._eye, h, r, z, self._gate[len(z)],
        )  # fmt: skip
        if dt > 0.0:
            self._pending_dt = 0.0
        return self._applied(kind, status, nis, p, p1, state, z, h, r)

    def _applied(
        self,
        kind: MeasurementKind,
        status: int,
        nis: float,
        p: FloatArray,
        p1: FloatArray,
        state: tuple[Any, ...],
        z: FloatArray,
        h: FloatArray,
        r: FloatArray,
    ) -> UpdateResult:
        """A compiled update's outcome taken.

        P before the update, and when it applied, P⁺ and the corrected state; the numpy path
        for status 0 (no closed-form S⁻¹).
        """
        self.P = p
        if status == 0:
            return self._update_reference(kind, z, h, r)
        if status == 1:
            self.rejections.append(Rejection(self.t, kind, nis, self._gate[len(z)]))
            return UpdateResult(kind, self.t, False, nis, "gate")
        self.P = p1
        self.ins.set_corrected(state)
        self.counts[kind] = self.counts.get(kind, 0) + 1
        return UpdateResult(kind, self.t, True, nis)

    def _feedback(self, x: FloatArray) -> None:
        """Apply the estimated errors to the INS and reset the error state (ESKF reset)."""
        self.ins.correct_vector(x)

    # --- output --------------------------------------------------------------------------------
    def nav_state(self) -> NavState:
        """The INS solution now (cheap; no covariance)."""
        return self.ins.state()

    def estimate(self) -> NavEstimate:
        """Attitude, heading, velocity, position, biases and the covariance (copies)."""
        ins = self.ins
        c_bn = np.array(ins._c).reshape(3, 3)
        roll, pitch, yaw = dcm_to_euler(c_bn)
        return NavEstimate(
            t=ins.t,
            roll=roll,
            pitch=pitch,
            yaw=yaw,
            heading_deg=yaw_to_heading_deg(yaw),
            heading_sigma_deg=math.degrees(math.sqrt(max(self.P[2, 2], 0.0))),
            c_bn=c_bn,
            v_enu=np.array(ins._v),
            lat_rad=ins.lat,
            lon_rad=ins.lon,
            h_m=ins.h,
            gyro_bias=np.array(ins._bg),
            accel_bias=np.array(ins._ba),
            covariance=self.P.copy(),
        )
