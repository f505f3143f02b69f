"""Strapdown inertial navigation in the local-level ENU frame over the WGS84 ellipsoid.

The vehicle computer's dead reckoning: attitude C_b^n, ENU velocity v^n and geodetic position
(latitude L, longitude λ, height h) integrated from the IMU's angular rate and specific force (or
their increments). Frames and Euler angles follow :mod:`twin.core.frames` (n = ENU; b = x starboard,
y forward, z up); the Earth model is :mod:`twin.core.earth` (WGS84 normal gravity, radii, Earth and
transport rates), reused here and never duplicated.

Mechanization (Titterton & Weston §3.5; Savage 1998; the same discrete algorithm as pyins'
``strapdown.Integrator``, permuted from NED to ENU)::

    Ċ_b^n = C_b^n [ω_ib^b ×] − [ω_in^n ×] C_b^n,          ω_in^n = ω_ie^n + ω_en^n
    v̇^n  = C_b^n f^b − (2 ω_ie^n + ω_en^n) × v^n + g^n,   g^n = [0, 0, −γ(L, h)]
    L̇ = v_N / (R_M + h),  λ̇ = v_E / ((R_N + h) cos L),  ḣ = v_U

One step over [t, t + Δt] with the rotation vector θ (body) and velocity increment Δv (body,
sculling and rotation-compensated):

* velocity: v⁺ = v + C Δv − ½ ζ × (C Δv) + (g(L, h − ½ v_U Δt) − (2ω_ie + ω_en) × v) Δt,
  with ζ = ω_in Δt the navigation frame's rotation over the step;
* position: trapezoid rule with the mean velocity ½ (v + v⁺) and the radii at the step's start;
* attitude: C⁺ = exp(−[ζ̄×]) C exp([θ×]), ζ̄ from the mean velocity.

Rate inputs (what :mod:`sensors.imu` delivers: ``angular_rate`` rad/s and ``specific_force``
m/s²) are taken as constant over the interval that ends at the sample's time (zero-order hold):
θ = ω Δt, Δv = f Δt + ½ θ × f Δt. Increment inputs (pyins' ``compute_increments_from_imu``
output, coning and sculling already applied) are used as they are.

Sensor compensation: the INS subtracts its current bias estimates (``gyro_bias``,
``accel_bias``, body axes; measured = true + bias) from every sample. The error-state filter
(:mod:`twin.onboard.eskf`) owns those estimates and feeds its corrections back with
:meth:`StrapdownIns.correct`.

Bad input: a reading with a NaN or infinity raises ``ValueError`` naming the channel
(``InsConfig.on_nonfinite = "raise"``, the default) or is skipped and counted in
``StrapdownIns.skipped`` (``"skip"``); it never propagates into the state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from twin.core import earth
from twin.core.arrays import Float64Array as FloatArray
from twin.core.frames import dcm_to_euler, dcm_to_quat, euler_to_dcm, yaw_to_heading_deg
from twin.core.messages import Reading
from twin.onboard import mechanization

__all__ = ["InsConfig", "NavState", "StrapdownIns", "rotvec_to_dcm"]

Vec3 = tuple[float, float, float]
Mat9 = tuple[float, float, float, float, float, float, float, float, float]
# The Earth model's constants in mechanization.advance's order (and the exponent 2 it needs).
EARTH_CONSTANTS = (
    earth.A_M, earth.E2, earth.OMEGA_IE, earth.GAMMA_E, earth.K_SOMIGLIANA, earth.F,
    earth.M_RATIO, 2.0,
)  # fmt: skip


def _check_finite_range(owner: str, name: str, value: float, lo: float, hi: float) -> None:
    """Raise ValueError naming ``owner.name`` unless ``lo <= value <= hi`` and finite."""
    ok = isinstance(value, int | float | np.floating | np.integer) and not isinstance(value, bool)
    if not (ok and math.isfinite(value) and lo <= value <= hi):
        raise ValueError(f"{owner}.{name} = {value!r}: must be a finite number in [{lo:g}, {hi:g}]")


def _vec3(owner: str, name: str, value: object) -> FloatArray:
    """A finite float (3,) array, or ValueError naming the field."""
    try:
        arr = np.array(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{owner}.{name} = {value!r}: must be 3 finite numbers") from exc
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{owner}.{name} = {value!r}: must be 3 finite numbers (no NaN/inf)")
    return arr


def _rotvec_exp(x: float, y: float, z: float) -> Mat9:
    """exp([r×]) for the rotation vector r = (x, y, z) as 9 floats, row-major (Rodrigues)."""
    n2 = x * x + y * y + z * z
    if n2 > 1e-6:
        n = math.sqrt(n2)
        c = math.cos(n)
        k1 = math.sin(n) / n
        k2 = (1.0 - c) / n2
    else:  # Taylor series: exact to double precision for |r| < 1e-3
        n4 = n2 * n2
        c = 1.0 - n2 / 2.0 + n4 / 24.0
        k1 = 1.0 - n2 / 6.0 + n4 / 120.0
        k2 = 0.5 - n2 / 24.0 + n4 / 720.0
    return (
        k2 * x * x + c, k2 * x * y - k1 * z, k2 * x * z + k1 * y,
        k2 * y * x + k1 * z, k2 * y * y + c, k2 * y * z - k1 * x,
        k2 * z * x - k1 * y, k2 * z * y + k1 * x, k2 * z * z + c,
    )  # fmt: skip


def _mul33(a: Mat9, b: Mat9) -> Mat9:
    """The product of two 3×3 matrices held as 9 floats, row-major."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = a
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = b
    return (
        a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8,
        a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8,
        a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8,
    )  # fmt: skip


def _frozen(values: tuple[float, ...], shape: tuple[int, ...]) -> FloatArray:
    """A read-only float array of ``values`` (the INS hands out views of its float state)."""
    arr = np.array(values).reshape(shape)
    arr.flags.writeable = False
    return arr


def rotvec_to_dcm(x: float, y: float, z: float) -> FloatArray:
    """exp([r×]) for the rotation vector r = (x, y, z) (Rodrigues; series near zero)."""
    return np.array(_rotvec_exp(x, y, z)).reshape(3, 3)


@dataclass(frozen=True, slots=True)
class InsConfig:
    """Mechanization options.

    Attributes:
        free_air_gravity: True: γ(L, h) with the free-air height gradient (:func:`twin.core.earth.
            normal_gravity`). False: γ(L, 0) whatever the height — the depth-independent
            gravity the simulated world uses (``sensors.imu`` module docstring), so the INS has
            zero gravity-model error against the twin.
        max_dt_s: Largest accepted step (s); a larger gap is a ValueError (a dropped stream
            should not be silently bridged by one huge Euler step). Allowed (0, 10].
        on_nonfinite: ``"raise"``: a NaN/inf in a reading is a ValueError naming the channel;
            ``"skip"``: the sample is dropped (the state does not advance) and counted.
        orthonormalize_every: Re-orthonormalize C_b^n every this many steps (≥ 1).
    """

    free_air_gravity: bool = True
    max_dt_s: float = 1.0
    on_nonfinite: Literal["raise", "skip"] = "raise"
    orthonormalize_every: int = 100

    def __post_init__(self) -> None:
        if not isinstance(self.free_air_gravity, bool):
            raise ValueError(
                f"InsConfig.free_air_gravity = {self.free_air_gravity!r}: must be True or False"
            )
        _check_finite_range("InsConfig", "max_dt_s", self.max_dt_s, 1e-9, 10.0)
        if self.on_nonfinite not in ("raise", "skip"):
            raise ValueError(
                f"InsConfig.on_nonfinite = {self.on_nonfinite!r}: must be 'raise' or 'skip'"
            )
        if not (isinstance(self.orthonormalize_every, int) and self.orthonormalize_every >= 1):
            raise ValueError(
                f"InsConfig.orthonormalize_every = {self.orthonormalize_every!r}: must be an "
                f"integer >= 1"
            )


@dataclass(frozen=True, slots=True)
class NavState:
    """A navigation solution at one instant (a snapshot: arrays are copies).

    Attributes:
        t: Time (s).
        lat_rad: Geodetic latitude (rad), in [−π/2, π/2] (exclusive of the poles in practice).
        lon_rad: Longitude (rad).
        h_m: Height above the ellipsoid = the sea surface (m); negative under water (h = −depth).
        v_enu: Velocity over ground [v_E, v_N, v_U] (m/s).
        c_bn: Attitude C_b^n (body → ENU), 3×3.
    """

    t: float
    lat_rad: float
    lon_rad: float
    h_m: float
    v_enu: FloatArray = field(default_factory=lambda: np.zeros(3))
    c_bn: FloatArray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self) -> None:
        _check_finite_range("NavState", "t", self.t, -1e12, 1e12)
        _check_finite_range(
            "NavState", "lat_rad", self.lat_rad, -math.pi / 2 + 1e-6, math.pi / 2 - 1e-6
        )
        _check_finite_range("NavState", "lon_rad", self.lon_rad, -4 * math.pi, 4 * math.pi)
        _check_finite_range("NavState", "h_m", self.h_m, -12000.0, 1e5)
        object.__setattr__(self, "v_enu", _vec3("NavState", "v_enu", self.v_enu))
        c = np.array(self.c_bn, dtype=np.float64)
        if c.shape != (3, 3) or not np.all(np.isfinite(c)):
            raise ValueError(f"NavState.c_bn: must be a finite 3x3 matrix, got {self.c_bn!r}")
        if np.abs(c @ c.T - np.eye(3)).max() > 1e-6 or np.linalg.det(c) < 0:
            raise ValueError("NavState.c_bn: must be a proper rotation (C Cᵀ = I, det = +1)")
        object.__setattr__(self, "c_bn", c)

    @classmethod
    def from_euler(
        cls,
        *,
        t: float = 0.0,
        lat_rad: float,
        lon_rad: float,
        h_m: float = 0.0,
        v_enu: FloatArray | tuple[float, float, float] = (0.0, 0.0, 0.0),
        roll: float = 0.0,
        pitch: float = 0.0,
        yaw: float = 0.0,
    ) -> NavState:
        """Build from (roll, pitch, yaw) in radians, :mod:`twin.core.frames` convention."""
        for name, v in (("roll", roll), ("pitch", pitch), ("yaw", yaw)):
            _check_finite_range("NavState", name, v, -2 * math.pi, 2 * math.pi)
        return cls(
            t, lat_rad, lon_rad, h_m, np.asarray(v_enu, float), euler_to_dcm(roll, pitch, yaw)
        )

    @property
    def euler(self) -> tuple[float, float, float]:
        """(roll, pitch, yaw) in radians."""
        return dcm_to_euler(self.c_bn)

    @property
    def heading_deg(self) -> float:
        """Compass heading, degrees clockwise from North in [0, 360)."""
        return yaw_to_heading_deg(self.euler[2])

    @property
    def quat_wxyz(self) -> FloatArray:
        """Attitude as a unit quaternion (w, x, y, z)."""
        return dcm_to_quat(self.c_bn)

    @property
    def depth_m(self) -> float:
        """Depth below the sea surface (m): −h."""
        return -self.h_m


class StrapdownIns:
    """The ENU strapdown mechanization (module docstring), stepping at the IMU's rate.

    Args:
        init: Initial solution (attitude, velocity, position, time).
        config: :class:`InsConfig`.
        gyro_bias: Initial gyro bias estimate (rad/s, body), subtracted from every sample.
        accel_bias: Initial accelerometer bias estimate (m/s², body).

    The state is public for the filter (read it; change it through :meth:`correct` or
    :meth:`reset`, or by assigning a whole new value): ``t``, ``lat``, ``lon``, ``h``, ``v``
    (ENU, (3,)), ``c_bn`` (3×3),
    ``gyro_bias``, ``accel_bias``; plus the last compensated ``omega_ib_b`` and ``f_b``.

    Speed: at 100 Hz the per-call overhead of small numpy operations (≈ 1 µs each), not the
    arithmetic, dominates a step, so the state lives in plain floats (``c_bn`` as 9 floats,
    row-major) and one step is scalar Python math (≈ 10 µs). The array attributes are built on
    first access after a change and are **read-only** views of that state (assign a new array
    to replace one; in-place writes raise). The filter reads the float state directly
    (package-internal): ``_c`` (C_b^n row-major), ``_v``, ``_w`` and ``_f`` (the last
    compensated ω_ib^b and f^b), ``_bg``, ``_ba``.
    """

    def __init__(
        self,
        init: NavState,
        config: InsConfig | None = None,
        *,
        gyro_bias: FloatArray | None = None,
        accel_bias: FloatArray | None = None,
    ):
        self.config = config if config is not None else InsConfig()
        self.skipped = 0
        self.reset(init, gyro_bias=gyro_bias, accel_bias=accel_bias)

    def reset(
        self,
        init: NavState,
        *,
        gyro_bias: FloatArray | None = None,
        accel_bias: FloatArray | None = None,
    ) -> None:
        """Re-initialize from ``init`` (attitude, velocity, position, time) and bias estimates."""
        if not isinstance(init, NavState):
            raise ValueError(f"StrapdownIns init: must be a NavState, got {type(init).__name__}")
        self.t = float(init.t)
        self.lat = float(init.lat_rad)
        self.lon = float(init.lon_rad)
        self.h = float(init.h_m)
        self._v: Vec3 = tuple(init.v_enu.tolist())  # type: ignore[assignment]
        self._c: Mat9 = tuple(init.c_bn.ravel().tolist())  # type: ignore[assignment]
        zero = (0.0, 0.0, 0.0)
        self._bg: Vec3 = (
            zero if gyro_bias is None else _tuple3(_vec3("StrapdownIns", "gyro_bias", gyro_bias))
        )
        self._ba: Vec3 = (
            zero if accel_bias is None else _tuple3(_vec3("StrapdownIns", "accel_bias", accel_bias))
        )
        self._w: Vec3 = zero
        self._f: Vec3 = zero
        self._cache: dict[str, FloatArray] = {}
        self._steps = 0
        self._max_dt = self.config.max_dt_s

    # --- the state as arrays (read-only, built on demand) --------------------------------------
    def _array(self, key: str, values: tuple[float, ...], shape: tuple[int, ...]) -> FloatArray:
        arr = self._cache.get(key)
        if arr is None:
            arr = self._cache[key] = _frozen(values, shape)
        return arr

    @property
    def c_bn(self) -> FloatArray:
        """Attitude C_b^n (3×3, read-only)."""
        return self._array("c_bn", self._c, (3, 3))

    @c_bn.setter
    def c_bn(self, value: FloatArray) -> None:
        c = np.asarray(value, dtype=np.float64)
        if c.shape != (3, 3) or not np.all(np.isfinite(c)):
            raise ValueError(f"StrapdownIns c_bn: must be a finite 3x3 matrix, got {value!r}")
        self._c = tuple(c.ravel().tolist())  # type: ignore[assignment]
        self._cache.pop("c_bn", None)

    @property
    def v(self) -> FloatArray:
        """Velocity [v_E, v_N, v_U] (m/s, read-only)."""
        return self._array("v", self._v, (3,))

    @v.setter
    def v(self, value: FloatArray) -> None:
        self._v = _tuple3(_vec3("StrapdownIns", "v", value))
        self._cache.pop("v", None)

    @property
    def gyro_bias(self) -> FloatArray:
        """Gyro bias estimate (rad/s, body; read-only)."""
        return self._array("gyro_bias", self._bg, (3,))

    @gyro_bias.setter
    def gyro_bias(self, value: FloatArray) -> None:
        self._bg = _tuple3(_vec3("StrapdownIns", "gyro_bias", value))
        self._cache.pop("gyro_bias", None)

    @property
    def accel_bias(self) -> FloatArray:
        """Accelerometer bias estimate (m/s², body; read-only)."""
        return self._array("accel_bias", self._ba, (3,))

    @accel_bias.setter
    def accel_bias(self, value: FloatArray) -> None:
        self._ba = _tuple3(_vec3("StrapdownIns", "accel_bias", value))
        self._cache.pop("accel_bias", None)

    @property
    def omega_ib_b(self) -> FloatArray:
        """The last bias-compensated angular rate (rad/s, body; read-only)."""
        return self._array("omega_ib_b", self._w, (3,))

    @omega_ib_b.setter
    def omega_ib_b(self, value: FloatArray) -> None:
        self._w = _tuple3(_vec3("StrapdownIns", "omega_ib_b", value))
        self._cache.pop("omega_ib_b", None)

    @property
    def f_b(self) -> FloatArray:
        """The last bias-compensated specific force (m/s², body; read-only)."""
        return self._array("f_b", self._f, (3,))

    @f_b.setter
    def f_b(self, value: FloatArray) -> None:
        self._f = _tuple3(_vec3("StrapdownIns", "f_b", value))
        self._cache.pop("f_b", None)

    # --- inputs --------------------------------------------------------------------------------
    def step(self, dt: float, angular_rate: FloatArray, specific_force: FloatArray) -> bool:
        """Advance by ``dt`` with rate samples (rad/s, m/s², body axes), held over the step.

        Returns:
            True if the state advanced, False if the sample was skipped (non-finite input with
            ``on_nonfinite="skip"``).
        """
        self._check_dt(dt)
        w = _floats3("angular_rate", angular_rate)
        f = _floats3("specific_force", specific_force)
        if not self._finite(w, f, ("angular_rate", "specific_force")):
            return False
        bg, ba = self._bg, self._ba
        wx, wy, wz = w[0] - bg[0], w[1] - bg[1], w[2] - bg[2]
        fx, fy, fz = f[0] - ba[0], f[1] - ba[1], f[2] - ba[2]
        self._w = (wx, wy, wz)
        self._f = (fx, fy, fz)
        # Rotation compensation for rates held over the step: ½ θ × Δv (Savage 1998 Part 2).
        h2 = 0.5 * dt * dt
        dv = (
            fx * dt + h2 * (wy * fz - wz * fy),
            fy * dt + h2 * (wz * fx - wx * fz),
            fz * dt + h2 * (wx * fy - wy * fx),
        )
        self._advance(dt, (wx * dt, wy * dt, wz * dt), dv)
        return True

    def step_increments(self, dt: float, dtheta: FloatArray, dvel: FloatArray) -> bool:
        """Advance by ``dt`` with increments: rotation vector (rad) and Δv (m/s), body axes.

        The increments are expected coning- and sculling-corrected (pyins
        ``compute_increments_from_imu``); the bias estimates are removed as ``b Δt``.
        """
        self._check_dt(dt)
        th = _floats3("dtheta", dtheta)
        dvb = _floats3("dvel", dvel)
        if not self._finite(th, dvb, ("dtheta", "dvel")):
            return False
        bg, ba = self._bg, self._ba
        th = (th[0] - bg[0] * dt, th[1] - bg[1] * dt, th[2] - bg[2] * dt)
        dvb = (dvb[0] - ba[0] * dt, dvb[1] - ba[1] * dt, dvb[2] - ba[2] * dt)
        self._w = (th[0] / dt, th[1] / dt, th[2] / dt)
        self._f = (dvb[0] / dt, dvb[1] / dt, dvb[2] / dt)
        self._advance(dt, th, dvb)
        return True

    def step_reading(self, reading: Reading, dt: float | None = None) -> bool:
        """Advance with an IMU :class:`~twin.core.messages.Reading`.

        Channels ``angular_rate`` and ``specific_force``; ``dt`` defaults to ``reading.t − t``.
        """
        step = reading.t - self.t if dt is None else dt
        ok = self.step(step, reading["angular_rate"], reading["specific_force"])
        if ok and dt is None:
            self.t = float(reading.t)  # no drift of the clock by summing steps
        return ok

    def _check_dt(self, dt: float) -> None:
        if isinstance(dt, int | float | np.floating) and 0.0 < dt <= self._max_dt:
            return
        if not (isinstance(dt, int | float | np.floating) and math.isfinite(dt)):
            raise ValueError(f"StrapdownIns dt = {dt!r}: must be a finite number of seconds")
        raise ValueError(
            f"StrapdownIns dt = {dt!r}: must be in (0, {self._max_dt:g}] s (InsConfig.max_dt_s)"
        )

    def _finite(self, a: Vec3, b: Vec3, names: tuple[str, str]) -> bool:
        """True if all six values are finite; else skip (counted) or raise naming the channel."""
        s = a[0] + a[1] + a[2] + b[0] + b[1] + b[2]
        if math.isfinite(s):  # one test for the common case (a NaN or inf poisons the sum)
            return True
        for name, arr in zip(names, (a, b), strict=True):
            if not (math.isfinite(arr[0]) and math.isfinite(arr[1]) and math.isfinite(arr[2])):
                if self.config.on_nonfinite == "skip":
                    self.skipped += 1
                    return False
                raise ValueError(
                    f"StrapdownIns {name} = {list(arr)!r}: non-finite sample at t = {self.t:.6f}"
                    f" s (InsConfig.on_nonfinite='skip' drops such samples instead)"
                )
        return True  # all finite; only their sum overflowed

    # --- the mechanization ---------------------------------------------------------------------
    def gravity(self, lat: float, h: float) -> float:
        """γ used by the mechanization (see ``InsConfig.free_air_gravity``)."""
        return earth.normal_gravity(lat, h if self.config.free_air_gravity else 0.0)

    def _advance(self, dt: float, theta: Vec3, dv_b: Vec3) -> None:
        # The compiled step (twin.onboard.mechanization): _advance_reference's arithmetic, bit
        # for bit, at a quarter of its cost. A subclass with its own gravity model steps in
        # Python (the compiled step knows only earth.normal_gravity).
        if not self.standard_gravity:
            self._advance_reference(dt, theta, dv_b)
            return
        self.lat, self.lon, self.h, self._v, c = mechanization.advance(
            dt, theta, dv_b, self.lat, self.lon, self.h, self._v, self._c,
            self.config.free_air_gravity, EARTH_CONSTANTS,
        )  # fmt: skip
        self._end_step(dt, c)

    def _end_step(self, dt: float, c: Mat9) -> None:
        """A step's end: the clock, the periodic re-orthonormalization, the new attitude."""
        self.t += dt
        self._steps += 1
        if self._steps % self.config.orthonormalize_every == 0:
            c = mechanization.orthonormalize(c)
        self._c = c
        self._cache.clear()

    def _advance_reference(self, dt: float, theta: Vec3, dv_b: Vec3) -> None:
        """:meth:`_advance` in Python: the reference the compiled step is tested against."""
        lat, h = self.lat, self.h
        v_e, v_n, v_u = self._v
        sl, cl = math.sin(lat), math.cos(lat)
        tl = sl / cl
        d = 1.0 - earth.E2 * sl * sl
        r_n = earth.A_M / math.sqrt(d)
        r_m = r_n * (1.0 - earth.E2) / d
        rm_h, rn_h = r_m + h, r_n + h
        ie_n, ie_u = earth.OMEGA_IE * cl, earth.OMEGA_IE * sl
        # ω_in = ω_ie + ω_en (twin.core.earth.transport_rate_enu)
        chi_e = -v_n / rm_h
        chi_n = ie_n + v_e / rn_h
        chi_u = ie_u + v_e * tl / rn_h
        c = self._c
        bx, by, bz = dv_b
        dvn0 = c[0] * bx + c[1] * by + c[2] * bz  # C Δv
        dvn1 = c[3] * bx + c[4] * by + c[5] * bz
        dvn2 = c[6] * bx + c[7] * by + c[8] * bz
        # (2 ω_ie + ω_en) = ω_in + ω_ie
        a_e, a_n, a_u = chi_e, chi_n + ie_n, chi_u + ie_u
        g = self.gravity(lat, h + 0.5 * v_u * dt)  # gravity at the step's mid height
        ve1 = v_e + dvn0 + (-(a_n * v_u - a_u * v_n) - 0.5 * (chi_n * dvn2 - chi_u * dvn1)) * dt
        vn1 = v_n + dvn1 + (-(a_u * v_e - a_e * v_u) - 0.5 * (chi_u * dvn0 - chi_e * dvn2)) * dt
        vu1 = v_u + dvn2 + (-(a_e * v_n - a_n * v_e) - 0.5 * (chi_e * dvn1 - chi_n * dvn0) - g) * dt
        # Mean velocity over the step: position by the trapezoid rule, frame rate at mid-step.
        me, mn, mu = 0.5 * (v_e + ve1), 0.5 * (v_n + vn1), 0.5 * (v_u + vu1)
        self.lat = lat + mn / rm_h * dt
        self.lon = self.lon + me / (rn_h * cl) * dt
        self.h = h + mu * dt
        self._v = (ve1, vn1, vu1)
        # exp(−[ζ×]): the n-frame turns by ζ over the step; C⁺ = exp(−[ζ×]) C exp([θ×]).
        c_nav = _rotvec_exp(mn / rm_h * dt, -(ie_n + me / rn_h) * dt, -(ie_u + me * tl / rn_h) * dt)
        self._end_step(dt, _mul33(c_nav, _mul33(c, _rotvec_exp(*theta))))

    # --- corrections and output ----------------------------------------------------------------

    @property
    def standard_gravity(self) -> bool:
        """Whether :meth:`gravity` is this class's (the compiled paths know only that one)."""
        return type(self).gravity is StrapdownIns.gravity

    def correct_vector(self, e: FloatArray) -> None:
        """:meth:`correct_floats` from the filter's 15 error estimates, compiled.

        ``e`` = (φ, δv, δL, δλ, δh, δb_g, δb_a) as the filter orders them;
        :func:`twin.onboard.mechanization.correct` does :meth:`correct_floats`'s arithmetic.
        """
        self.set_corrected(
            mechanization.correct(
                self._c, self._v, self.lat, self.lon, self.h, self._bg, self._ba, e
            )
        )

    def set_corrected(self, state: tuple[Any, ...]) -> None:
        """Take a corrected state (C, v, L, λ, h, b_g, b_a), as the compiled corrections give it."""
        (self._c, self._v, self.lat, self.lon, self.h, self._bg, self._ba) = state
        self._cache.clear()

    def correct_floats(
        self, phi: Vec3, dv: Vec3, dlat: float, dlon: float, dh: float, dbg: Vec3, dba: Vec3
    ) -> None:
        """:meth:`correct` with plain floats (the filter's feedback path; no conversions)."""
        self._c = _mul33(_rotvec_exp(*phi), self._c)
        v, bg, ba = self._v, self._bg, self._ba
        self._v = (v[0] - dv[0], v[1] - dv[1], v[2] - dv[2])
        self.lat -= dlat
        self.lon -= dlon
        self.h -= dh
        self._bg = (bg[0] + dbg[0], bg[1] + dbg[1], bg[2] + dbg[2])
        self._ba = (ba[0] + dba[0], ba[1] + dba[1], ba[2] + dba[2])
        self._cache.clear()

    def state(self) -> NavState:
        """The current solution as a :class:`NavState` snapshot."""
        return NavState(
            self.t, self.lat, self.lon, self.h, np.array(self._v), np.array(self._c).reshape(3, 3)
        )


def _tuple3(arr: FloatArray) -> Vec3:
    x, y, z = arr.tolist()
    return (x, y, z)


def _floats3(name: str, value: object) -> Vec3:
    """Three Python floats from a (3,) array-like, or ValueError naming ``name`` (no NaN check)."""
    arr = value if type(value) is np.ndarray else np.asarray(value, dtype=np.float64)
    if arr.shape != (3,):
        raise ValueError(f"StrapdownIns {name}: must have shape (3,), got {arr.shape}")
    x, y, z = arr.tolist()
    return (float(x), float(y), float(z))
