"""Strapdown IMU: a gyro triad and an accelerometer triad with datasheet-grade errors.

Measurement model (navigation.md §2.2), per triad:

    ω̃ = (I + S_g + M_g) ω + b_g + n_g,     f̃ = (I + S_a + M_a) f + b_a + n_a,

* S = diag(s), s ~ N(0, σ_s²): scale-factor errors, drawn at turn-on (:meth:`Imu.reset`);
* M: the six off-diagonal axis misalignments (non-orthogonality plus mounting), each ~ N(0, σ_m²),
  drawn at turn-on; zero diagonal;
* b = turn-on bias (a random constant, drawn at turn-on) + bias instability (a first-order
  Gauss–Markov process with σ_GM = 0.664 B / 0.6174 ≈ 1.0755 B and correlation time τ_c, so its
  Allan-deviation peak equals the flicker floor 0.664 B of the datasheet's bias instability B;
  navigation.md §2.2) + a random walk (rate random walk for the gyro);
* n: white noise of the angle/velocity random walk density N, σ = N √f_s per sample.

True values. MuJoCo's world is the local-level ENU navigation frame n, but MuJoCo integrates
Newton's law in that frame as if it were inertial. The ``accelerometer`` at the IMU site gives the
specific force of the site in site axes relative to MuJoCo's world, with the world's gravity
``opt.gravity`` (which the plant sets to [0, 0, −γ(lat)], local normal gravity); the ``gyro``
gives the site's angular velocity relative to the world, without the Earth's rotation
(navigation.md §2.4). A real IMU on a vehicle following the same trajectory over the rotating,
curved Earth measures more. For an Earth-referenced ENU strapdown INS,

    Ċ_b^n = C_b^n [ω_ib^b ×] − [ω_in^n ×] C_b^n,
    v̇^n  = C_b^n f^b − (2 ω_ie^n + ω_en^n) × v^n + g^n,

to reproduce MuJoCo's Ċ = C [ω_mj ×] and v̇ = C f_mj + g, the sensor must read

    ω^b = ω_mj + C_n^b (ω_ie^n + ω_en^n),
    f^b = f_mj + C_n^b ((2 ω_ie^n + ω_en^n) × v^n),

with ω_ie^n = [0, Ω cos L, Ω sin L], ω_en^n the transport rate (:mod:`twin.core.earth`), v^n the
site's world velocity (MJCF ``framelinvel``) and C_n^b the transpose of the site's rotation. These
terms are added when ``ImuSpec.earth_kinematics`` is true (the default). Gravity needs no term: the
world's gravity is normal gravity, which already contains the centrifugal part of the Earth's
rotation. An INS that models γ(L, h) with its free-air height gradient sees the world's
depth-independent gravity differ by 3.1e-6 m/s² per metre of depth (31 µg at 100 m); the world's
gravity is the truth, so an INS that wants zero model error uses the scenario's declared gravity.

MJCF sensors. An IMU mounted at site ``S`` reads the MJCF sensors ``S/accelerometer``,
``S/gyro`` and ``S/linvel`` (``models/auv/auv.xml`` declares them for the site ``imu``). Axes are
the site's axes, which for ``imu`` are the body axes (x right, y forward, z up).

Random stream. Each sample draws the same 18 standard normals in one call (white, Gauss–Markov and
random-walk drivers of both triads), and each reset the same 30, whatever the spec: changing one
error magnitude (say the ARW in a Monte Carlo sweep) leaves every other error's realisation
unchanged, and an ideal IMU consumes its stream exactly as a noisy one does.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

import dm_env
import numpy as np

from sensors import imu_kernel
from sensors.base import Sensor, SensorSpec, WorldView
from sensors.noise import (
    GaussMarkov,
    RandomWalk,
    WhiteNoise,
    gauss_markov_sigma_for_bias_instability,
)
from sensors.registry import register
from twin.core import earth
from twin.core.arrays import Float64Array as FloatArray

# --- datasheet units to SI (navigation.md §1.1: pyins DH_TO_RS, DRH_TO_RRS) -------------------
DEG = math.pi / 180.0
DEG_PER_H = DEG / 3600.0
"""°/h → rad/s (gyro bias)."""
DEG_PER_RT_H = DEG / 60.0
"""°/√h → rad/√s ≡ rad/s/√Hz (angle random walk)."""
DEG_PER_H_PER_RT_H = DEG_PER_H / 60.0
"""°/h/√h → rad/s/√s (rate random walk)."""
MICRO_G = 1e-6 * earth.G0_MPS2
"""µg → m/s² (datasheets use standard gravity g₀ = 9.80665)."""
MICRO_G_PER_RT_HZ = MICRO_G
"""µg/√Hz → m/s²/√Hz (velocity random walk density)."""
MICRO_G_PER_RT_H = MICRO_G / 60.0
"""µg/√h → m/s²/√s (acceleration random walk)."""
PPM = 1e-6
MRAD = 1e-3

Axes3 = float | tuple[float, float, float]

# Fields that may hold one value for all axes or a per-axis triple.
_PER_AXIS_FIELDS = ("gyro_noise_density", "accel_noise_density")


@dataclass(frozen=True, slots=True)
class ImuSpec(SensorSpec):
    """What an IMU datasheet says, in SI units. All errors default to zero (an ideal IMU).

    Sigmas are 1σ over the population of turn-ons; densities are one-sided root PSDs.

    Attributes:
        rate_hz: Output data rate (Hz).
        delay_s: Latency from the sampling instant to delivery (s).
        gyro_noise_density: Angle random walk N_g (rad/s/√Hz ≡ rad/√s), scalar or per axis.
        gyro_bias_instability: IEEE-952 bias instability B_g (rad/s): the Allan floor is 0.664 B.
        gyro_bias_corr_time_s: Correlation time τ_c of the Gauss–Markov bias (s).
        gyro_turn_on_bias: Turn-on (run-to-run) bias σ (rad/s).
        gyro_rate_random_walk: Rate random walk K_g (rad/s/√s).
        gyro_scale_factor: Scale-factor error σ (fraction; 1e-6 = 1 ppm).
        gyro_misalignment: Axis misalignment σ of each off-diagonal element (rad).
        accel_noise_density: Velocity random walk N_a (m/s²/√Hz), scalar or per axis.
        accel_bias_instability: Bias instability B_a (m/s²).
        accel_bias_corr_time_s: Correlation time of the accelerometer Gauss–Markov bias (s).
        accel_turn_on_bias: Turn-on bias σ (m/s²).
        accel_random_walk: Bias (acceleration) random walk K_a (m/s²/√s).
        accel_scale_factor: Scale-factor error σ (fraction).
        accel_misalignment: Axis misalignment σ (rad).
        earth_kinematics: Add the Earth-rate, transport-rate and Coriolis terms an ENU INS expects
            (see the module docstring); false gives MuJoCo's inertial-world kinematics.
    """

    rate_hz: float = 100.0
    delay_s: float = 0.0
    gyro_noise_density: Axes3 = 0.0
    gyro_bias_instability: float = 0.0
    gyro_bias_corr_time_s: float = 300.0
    gyro_turn_on_bias: float = 0.0
    gyro_rate_random_walk: float = 0.0
    gyro_scale_factor: float = 0.0
    gyro_misalignment: float = 0.0
    accel_noise_density: Axes3 = 0.0
    accel_bias_instability: float = 0.0
    accel_bias_corr_time_s: float = 300.0
    accel_turn_on_bias: float = 0.0
    accel_random_walk: float = 0.0
    accel_scale_factor: float = 0.0
    accel_misalignment: float = 0.0
    earth_kinematics: bool = True

    def __post_init__(self) -> None:
        # Lists (from TOML or JSON) become tuples so the spec stays immutable and hashable.
        for name in _PER_AXIS_FIELDS:
            value = getattr(self, name)
            if isinstance(value, list | np.ndarray):
                object.__setattr__(self, name, tuple(float(v) for v in value))

    def validate(self) -> None:
        """Raise ValueError naming the field, value and allowed range if the spec is impossible."""
        SensorSpec.validate(self)
        for f in dataclasses.fields(self):
            if f.name in ("rate_hz", "delay_s"):
                continue
            value = getattr(self, f.name)
            if f.name == "earth_kinematics":
                if not isinstance(value, bool | np.bool_):
                    raise ValueError(f"earth_kinematics = {value!r}: must be true or false")
                continue
            if f.name in _PER_AXIS_FIELDS and isinstance(value, tuple):
                if len(value) != 3:
                    raise ValueError(
                        f"{f.name} = {value!r}: must be one number or three (x, y, z), "
                        f"each finite and >= 0"
                    )
                items = value
            else:
                items = (value,)
            for v in items:
                if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
                    raise ValueError(f"{f.name} = {value!r}: must be a finite number >= 0")
                if not (math.isfinite(v) and v >= 0):
                    raise ValueError(f"{f.name} = {value!r}: must be a finite number >= 0")

    @classmethod
    def from_datasheet(
        cls,
        *,
        rate_hz: float = 100.0,
        delay_s: float = 0.0,
        gyro_arw_deg_rt_h: Axes3 = 0.0,
        gyro_bias_instability_deg_h: float = 0.0,
        gyro_bias_corr_time_s: float = 300.0,
        gyro_turn_on_bias_deg_h: float = 0.0,
        gyro_rrw_deg_h_rt_h: float = 0.0,
        gyro_scale_factor_ppm: float = 0.0,
        gyro_misalignment_mrad: float = 0.0,
        accel_vrw_ug_rt_hz: Axes3 = 0.0,
        accel_bias_instability_ug: float = 0.0,
        accel_bias_corr_time_s: float = 300.0,
        accel_turn_on_bias_ug: float = 0.0,
        accel_bias_rw_ug_rt_h: float = 0.0,
        accel_scale_factor_ppm: float = 0.0,
        accel_misalignment_mrad: float = 0.0,
        earth_kinematics: bool = True,
    ) -> ImuSpec:
        """Build a spec from datasheet units, so that presets read like the datasheets.

        Args:
            rate_hz: Output data rate (Hz).
            delay_s: Latency (s).
            gyro_arw_deg_rt_h: Angle random walk (°/√h), scalar or per axis.
            gyro_bias_instability_deg_h: Bias instability / in-run bias stability (°/h).
            gyro_bias_corr_time_s: Correlation time of the Gauss–Markov bias (s).
            gyro_turn_on_bias_deg_h: Turn-on bias σ (°/h).
            gyro_rrw_deg_h_rt_h: Rate random walk (°/h/√h).
            gyro_scale_factor_ppm: Scale-factor error σ (ppm).
            gyro_misalignment_mrad: Axis misalignment σ (mrad).
            accel_vrw_ug_rt_hz: Velocity random walk density (µg/√Hz), scalar or per axis.
            accel_bias_instability_ug: Bias instability (µg).
            accel_bias_corr_time_s: Correlation time of the Gauss–Markov bias (s).
            accel_turn_on_bias_ug: Turn-on bias σ (µg).
            accel_bias_rw_ug_rt_h: Bias random walk (µg/√h).
            accel_scale_factor_ppm: Scale-factor error σ (ppm).
            accel_misalignment_mrad: Axis misalignment σ (mrad).
            earth_kinematics: See :class:`ImuSpec`.
        """

        def scaled(value: Axes3, unit: float) -> Axes3:
            if isinstance(value, tuple | list | np.ndarray):
                return tuple(float(v) * unit for v in value)
            return float(value) * unit

        return cls(
            rate_hz=rate_hz,
            delay_s=delay_s,
            gyro_noise_density=scaled(gyro_arw_deg_rt_h, DEG_PER_RT_H),
            gyro_bias_instability=gyro_bias_instability_deg_h * DEG_PER_H,
            gyro_bias_corr_time_s=gyro_bias_corr_time_s,
            gyro_turn_on_bias=gyro_turn_on_bias_deg_h * DEG_PER_H,
            gyro_rate_random_walk=gyro_rrw_deg_h_rt_h * DEG_PER_H_PER_RT_H,
            gyro_scale_factor=gyro_scale_factor_ppm * PPM,
            gyro_misalignment=gyro_misalignment_mrad * MRAD,
            accel_noise_density=scaled(accel_vrw_ug_rt_hz, MICRO_G_PER_RT_HZ),
            accel_bias_instability=accel_bias_instability_ug * MICRO_G,
            accel_bias_corr_time_s=accel_bias_corr_time_s,
            accel_turn_on_bias=accel_turn_on_bias_ug * MICRO_G,
            accel_random_walk=accel_bias_rw_ug_rt_h * MICRO_G_PER_RT_H,
            accel_scale_factor=accel_scale_factor_ppm * PPM,
            accel_misalignment=accel_misalignment_mrad * MRAD,
            earth_kinematics=earth_kinematics,
        )


IMU_PRESETS: MappingProxyType[str, ImuSpec] = MappingProxyType(
    {
        # Hu et al. 2024 (LIG paper), Table 1 (navigation.md §2.1): gyro ARW 0.15 °/√h, bias
        # stability 8 °/h; accelerometer "random walk" 45 (x, y) / 65 (z) µg/√Hz (the table prints
        # µg/Hz, a typo for µg/√Hz; x, y vs z is our reading, navigation.md §6), bias stability
        # 20 µg; 100 Hz. The paper states nothing else, so the following are ASSUMPTIONS for an
        # industrial MEMS unit of that class (SBG Ellipse2-like, navigation.md §2.1): turn-on bias
        # 20 °/h and 200 µg (the residual after the at-rest bias calibration a vehicle does before
        # a dive, 2.5x and 10x the in-run stability; raw MEMS turn-on repeatability is much
        # larger), scale factor 500 ppm, misalignment 1 mrad (≈ 0.06°), no rate random walk
        # (the Gauss–Markov bias carries the low-frequency wander), τ_c = 300 s (MEMS Allan floors
        # typically sit at 10^2–10^3 s).
        "lig2024": ImuSpec.from_datasheet(
            rate_hz=100.0,
            gyro_arw_deg_rt_h=0.15,
            gyro_bias_instability_deg_h=8.0,
            gyro_bias_corr_time_s=300.0,
            gyro_turn_on_bias_deg_h=20.0,
            gyro_scale_factor_ppm=500.0,
            gyro_misalignment_mrad=1.0,
            accel_vrw_ug_rt_hz=(45.0, 45.0, 65.0),
            accel_bias_instability_ug=20.0,
            accel_bias_corr_time_s=300.0,
            accel_turn_on_bias_ug=200.0,
            accel_scale_factor_ppm=500.0,
            accel_misalignment_mrad=1.0,
        ),
        # A TYPICAL tactical-grade FOG IMU, not a specific product. navigation.md §2.1 gives the
        # typical ranges, itself marked [U] (from memory): ARW 0.005–0.05 °/√h, bias instability
        # 0.01–1 °/h, accel bias 10–100 µg, VRW 0.01–0.05 m/s/√h. Chosen inside them: ARW 0.02 °/√h,
        # 0.1 °/h, 50 µg, VRW 30 µg/√Hz (= 0.018 m/s/√h). ASSUMPTIONS: turn-on bias 0.3 °/h and
        # 100 µg, scale factor 50 ppm (gyro) / 100 ppm (accel), misalignment 0.1 mrad, τ_c = 600 s.
        "tactical_fog": ImuSpec.from_datasheet(
            rate_hz=100.0,
            gyro_arw_deg_rt_h=0.02,
            gyro_bias_instability_deg_h=0.1,
            gyro_bias_corr_time_s=600.0,
            gyro_turn_on_bias_deg_h=0.3,
            gyro_scale_factor_ppm=50.0,
            gyro_misalignment_mrad=0.1,
            accel_vrw_ug_rt_hz=30.0,
            accel_bias_instability_ug=50.0,
            accel_bias_corr_time_s=600.0,
            accel_turn_on_bias_ug=100.0,
            accel_scale_factor_ppm=100.0,
            accel_misalignment_mrad=0.1,
        ),
        # Honeywell HG9900, a navigation-grade ring-laser-gyro IMU, from its brochure
        # (N61-1638-000-000) as transcribed by IS4S NavToolkit's ``hg9900_model`` (1σ): gyro bias
        # 0.0035 °/h, ARW 0.002 °/√h (max), scale factor 5 ppm; accelerometer bias 25 µg, scale
        # factor 100 ppm; no velocity random walk listed (0 here). The brochure's bias figures
        # are taken as run-to-run (turn-on) constants; ASSUMPTIONS: an in-run instability of a
        # tenth of them with τ_c = 3600 s (NavToolkit assumes its τ too), misalignment 0.05 mrad
        # (10″, a calibrated navigation-grade cluster), and 100 Hz (the unit's own output is
        # faster; the twin's INS integrates at 100 Hz for every preset).
        "hg9900": ImuSpec.from_datasheet(
            rate_hz=100.0,
            gyro_arw_deg_rt_h=0.002,
            gyro_bias_instability_deg_h=0.00035,
            gyro_bias_corr_time_s=3600.0,
            gyro_turn_on_bias_deg_h=0.0035,
            gyro_scale_factor_ppm=5.0,
            gyro_misalignment_mrad=0.05,
            accel_vrw_ug_rt_hz=0.0,
            accel_bias_instability_ug=2.5,
            accel_bias_corr_time_s=3600.0,
            accel_turn_on_bias_ug=25.0,
            accel_scale_factor_ppm=100.0,
            accel_misalignment_mrad=0.05,
        ),
        # Every error zero: the readings are the true kinematics (Earth terms included).
        "ideal": ImuSpec(),
    }
)


@dataclass(frozen=True, slots=True)
class TriadErrorState:
    """The true error state of one sensor triad (copies; safe to keep).

    Attributes:
        bias: Total bias now, turn_on + instability + random_walk (3,).
        turn_on: Turn-on bias, constant over a run (3,).
        instability: Gauss–Markov bias-instability state (3,).
        random_walk: Random-walk bias state (3,).
        matrix: I + S + M, the scale-factor and misalignment matrix (3, 3).
        noise: The white noise added to the last sample (3,).
    """

    bias: FloatArray
    turn_on: FloatArray
    instability: FloatArray
    random_walk: FloatArray
    matrix: FloatArray
    noise: FloatArray


@dataclass(frozen=True, slots=True)
class ImuErrors:
    """The IMU's true error state after its last sample (world-side truth, never onboard)."""

    gyro: TriadErrorState
    accel: TriadErrorState


# imu_kernel.sample's constants: WGS84 a and e², the Earth's rate, and the exponent of sin²L.
_EARTH_CONSTANTS = (earth.A_M, earth.E2, earth.OMEGA_IE, 2.0)


class _ErrorModel:
    """Both triads' errors as (2, 3) arrays, row 0 the gyro and row 1 the accelerometer.

    One set of numpy operations serves both triads: at 100 Hz the per-call overhead of numpy,
    not the arithmetic, is what costs.
    """

    __slots__ = (
        "_block",
        "_draw",
        "_flat",
        "_has_rw",
        "gm",
        "matrix",
        "misalignment_sigma",
        "rw",
        "scale_sigma",
        "turn_on",
        "turn_on_sigma",
        "white",
    )

    def __init__(self, s: ImuSpec):
        def rows(g: Axes3, a: Axes3) -> FloatArray:
            return np.array([np.broadcast_to(g, 3), np.broadcast_to(a, 3)], dtype=np.float64)

        self.white = WhiteNoise(
            rows(s.gyro_noise_density, s.accel_noise_density), s.rate_hz, (2, 3)
        )
        gm_sigma = [
            gauss_markov_sigma_for_bias_instability(s.gyro_bias_instability),
            gauss_markov_sigma_for_bias_instability(s.accel_bias_instability),
        ]
        self.gm = GaussMarkov(
            np.array(gm_sigma)[:, None],
            np.array([[s.gyro_bias_corr_time_s], [s.accel_bias_corr_time_s]]),
            (2, 3),
        )
        self.rw = RandomWalk(np.array([[s.gyro_rate_random_walk], [s.accel_random_walk]]), (2, 3))
        self._has_rw = bool(s.gyro_rate_random_walk or s.accel_random_walk)
        self.turn_on_sigma = np.array([[s.gyro_turn_on_bias], [s.accel_turn_on_bias]])
        self.scale_sigma = np.array([[s.gyro_scale_factor], [s.accel_scale_factor]])
        self.misalignment_sigma = np.array([[s.gyro_misalignment], [s.accel_misalignment]])
        self.turn_on = np.zeros((2, 3))
        self.matrix = np.broadcast_to(np.eye(3), (2, 3, 3)).copy()
        # The two 3 x 3 matrices as one block-diagonal 6 x 6: one mat-vec for both triads.
        self._block = np.eye(6)
        # Flat (6,) views of the (2, 3) states; the processes update them in place.
        self._flat = (
            self.turn_on.reshape(6),
            self.gm.value.reshape(6),
            self.rw.value.reshape(6),
            self.white.value.reshape(6),
        )
        self._draw = np.zeros((4, 2, 3))

    def reset(self, rng: np.random.Generator) -> None:
        """Draw the turn-on errors: always 30 normals (module docstring, "Random stream")."""
        rng.standard_normal(out=self._draw)  # turn-on bias, scale, misalignment (2 blocks)
        np.multiply(self.turn_on_sigma, self._draw[0], out=self.turn_on)
        scale = 1.0 + self.scale_sigma * self._draw[1]
        mis = self.misalignment_sigma * np.concatenate((self._draw[2], self._draw[3]), axis=1)
        for i in range(2):
            m = self.matrix[i]
            m[0, 0], m[1, 1], m[2, 2] = scale[i]
            m[0, 1], m[0, 2], m[1, 2], m[1, 0], m[2, 0], m[2, 1] = mis[i]
        self._block[0:3, 0:3] = self.matrix[0]
        self._block[3:6, 3:6] = self.matrix[1]
        self.gm.reset(rng, stationary=True)  # the sensor was running before the episode
        self.rw.reset()
        self.white.value.fill(0.0)

    def measure(self, true: FloatArray, w: FloatArray, dt: float) -> FloatArray:
        """(I + S + M) true + bias + noise for both rows of ``true`` (2, 3); ``w`` is (3, 2, 3).

        Returns a new (6,) array [gyro, accel]: it leaves the sensor inside a Reading.
        """
        turn_on, gm, rw, white = self._flat
        out = np.dot(self._block, true.reshape(6))
        self.gm.advance(w[1], dt)
        if self._has_rw:  # its normals are drawn either way; only the arithmetic is skipped
            self.rw.advance(w[2], dt)
            out += rw
        self.white.advance(w[0])
        out += turn_on
        out += gm
        out += white
        return out

    def measure_compiled(
        self,
        gyro: FloatArray,
        accel: FloatArray,
        linvel: FloatArray,
        c_sn: FloatArray,
        h: float,
        lat: float,
        earth_terms: bool,
        w: FloatArray,
        dt: float,
    ) -> FloatArray:
        """:meth:`measure` of :meth:`Imu._ideal`'s values, in one compiled call (imu_kernel)."""
        gm = self.gm
        if dt != gm._dt:
            gm._set_dt(dt)
        turn_on, gm_value, rw_value, white_value = self._flat
        return imu_kernel.sample(
            gyro, accel, linvel, c_sn, h, lat, earth_terms, _EARTH_CONSTANTS, self._block,
            turn_on, gm_value, gm._phi.reshape(6), gm._q.reshape(6), rw_value,
            self.rw.density.reshape(6), dt, self._has_rw, self.white.sigma.reshape(6),
            white_value, w.reshape(3, 6),
        )  # fmt: skip

    def state(self, row: int) -> TriadErrorState:
        return TriadErrorState(
            bias=self.turn_on[row] + self.gm.value[row] + self.rw.value[row],
            turn_on=self.turn_on[row].copy(),
            instability=self.gm.value[row].copy(),
            random_walk=self.rw.value[row].copy(),
            matrix=self.matrix[row].copy(),
            noise=self.white.value[row].copy(),
        )


@register
class Imu(Sensor):
    """A strapdown IMU at an MJCF site: channels ``angular_rate`` and ``specific_force``.

    Both channels are float64 arrays of shape (3,) in the site's axes (the body axes x right,
    y forward, z up for the default site ``imu``): ``angular_rate`` in rad/s, ``specific_force``
    in m/s² (a level vehicle at rest reads about [0, 0, +g]). See the module docstring for the
    measurement model and the Earth-rate terms.

    Args:
        spec: An :class:`ImuSpec`.
        name: Unique name in the run (default ``"imu"``).
        site: MJCF site (default ``"imu"``); the MJCF sensors ``{site}/accelerometer``,
            ``{site}/gyro`` and ``{site}/linvel`` must exist.
    """

    kind: ClassVar[str] = "imu"
    spec_type: ClassVar[type[SensorSpec]] = ImuSpec
    default_site: ClassVar[str] = "imu"
    PRESETS: ClassVar[MappingProxyType[str, ImuSpec]] = IMU_PRESETS
    #: Sample through :mod:`sensors.imu_kernel` (one compiled call, the same numbers bit for
    #: bit); False: :meth:`_ideal` and the error model's numpy steps, the reference.
    compiled: ClassVar[bool] = True
    spec: ImuSpec

    def __init__(self, spec: ImuSpec, *, name: str | None = None, site: str | None = None):
        super().__init__(spec, name=name, site=site)
        self._errors = _ErrorModel(self.spec)
        self._gyro_sensor = f"{self.site}/gyro"
        self._accel_sensor = f"{self.site}/accelerometer"
        self._linvel_sensor = f"{self.site}/linvel"
        self._w = np.zeros((3, 2, 3))  # [white, GM, RW] x [gyro, accel] x axes
        # The kernel is Imu._ideal and _ErrorModel.measure: a subclass that overrides either
        # keeps its own by the Python path.
        self._kernel_applies = type(self)._ideal is Imu._ideal and (
            type(self._errors).measure is _ErrorModel.measure
        )
        self._t_last: float | None = None

    def channel_specs(self) -> dict[str, dm_env.specs.Array]:
        """``angular_rate`` (3,) rad/s and ``specific_force`` (3,) m/s², float64."""
        return {
            "angular_rate": dm_env.specs.Array((3,), np.float64, "angular_rate"),
            "specific_force": dm_env.specs.Array((3,), np.float64, "specific_force"),
        }

    def reset(self, world: WorldView, rng: np.random.Generator) -> None:
        """Turn on: draw turn-on biases, scale factors, misalignments and the initial GM biases."""
        for needed in (self._gyro_sensor, self._accel_sensor, self._linvel_sensor):
            try:
                world.mj_sensor(needed)
            except (KeyError, ValueError) as exc:
                raise KeyError(
                    f"IMU {self.name!r} at site {self.site!r} needs the MJCF sensor {needed!r}"
                ) from exc
        self._errors.reset(rng)
        self._t_last = world.t

    def _ideal(self, world: WorldView) -> FloatArray:
        """Error-free [angular_rate, specific_force] as one new (2, 3) array."""
        out = np.empty((2, 3))
        out[0] = world.mj_sensor(self._gyro_sensor)
        out[1] = world.mj_sensor(self._accel_sensor)
        if not self.spec.earth_kinematics:
            return out
        pos, c_sn = world.site_pose(self.site)
        v_e, v_n, v_u = world.mj_sensor(self._linvel_sensor).tolist()
        lat = world.latitude_rad
        h = float(pos[2]) - world.surface_z_m
        r_m, r_n = earth.principal_radii(lat)
        # Plain float math: this runs at 100 Hz and each small numpy call costs about 1 µs.
        ie_n = earth.OMEGA_IE * math.cos(lat)
        ie_u = earth.OMEGA_IE * math.sin(lat)
        en_e = -v_n / (r_m + h)
        en_n = v_e / (r_n + h)
        en_u = v_e * math.tan(lat) / (r_n + h)
        a_e, a_n, a_u = en_e, 2.0 * ie_n + en_n, 2.0 * ie_u + en_u  # 2 ω_ie + ω_en
        terms_n = np.array(
            [
                [en_e, ie_n + en_n, ie_u + en_u],  # ω_in = ω_ie + ω_en
                [a_n * v_u - a_u * v_n, a_u * v_e - a_e * v_u, a_e * v_n - a_n * v_e],  # (…) × v
            ]
        )
        out += terms_n @ c_sn  # row-vector form of C_n^s x = (C_s^n)^T x
        return out

    def ideal_outputs(self, world: WorldView) -> tuple[FloatArray, FloatArray]:
        """The error-free (angular_rate, specific_force) now, Earth terms included; new arrays."""
        out = self._ideal(world)
        return out[0].copy(), out[1].copy()

    def sample(self, world: WorldView, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Measure now: ``angular_rate`` and ``specific_force`` with all errors applied."""
        if self._t_last is None:
            raise RuntimeError(f"IMU {self.name!r}: call reset() before sample()")
        t = world.t
        dt = t - self._t_last
        self._t_last = t
        rng.standard_normal(out=self._w)  # always 18 normals, whatever the spec
        if self.compiled and self._kernel_applies:
            pos, c_sn = world.site_pose(self.site)
            out = self._errors.measure_compiled(
                world.mj_sensor(self._gyro_sensor),
                world.mj_sensor(self._accel_sensor),
                world.mj_sensor(self._linvel_sensor),
                c_sn,
                float(pos[2]) - world.surface_z_m,
                world.latitude_rad,
                self.spec.earth_kinematics,
                self._w,
                dt,
            )
        else:
            out = self._errors.measure(self._ideal(world), self._w, dt)
        return {"angular_rate": out[0:3], "specific_force": out[3:6]}

    def current_errors(self) -> ImuErrors:
        """The true error state after the last sample (for the truth channel and tests)."""
        return ImuErrors(gyro=self._errors.state(0), accel=self._errors.state(1))

    def describe(self) -> dict[str, Any]:
        """A JSON-able summary, with the Gauss–Markov sigmas the bias instabilities map to."""
        out = super().describe()
        out["gauss_markov_sigma"] = {
            "gyro": gauss_markov_sigma_for_bias_instability(self.spec.gyro_bias_instability),
            "accel": gauss_markov_sigma_for_bias_instability(self.spec.accel_bias_instability),
        }
        return out
