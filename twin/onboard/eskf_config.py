"""The ESKF's configuration: the LIG paper's tuning, and the tuning from an IMU datasheet.

Onboard side. :class:`EskfConfig` holds P0, Q, R, the gates and the INS's options of
:class:`twin.onboard.eskf.Eskf`; :meth:`EskfConfig.for_imu` derives P0 and Q from the declared
datasheet (:class:`ImuGrade`), either floored at the paper's values (``tuning = "imu"``) or from
the datasheet alone with a rate allowance that follows the measured turn rate (``tuning =
"datasheet"``; docs/navigation.md). Split from the filter because it is a concept of its own:
what the vehicle's integrator declares, not how the filter runs.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from twin.core import earth
from twin.onboard.ins import InsConfig

__all__ = ["GM_SIGMA_PER_BIAS_INSTABILITY", "EskfConfig", "ImuGrade", "Triple"]

_DEG = math.pi / 180.0
_DEG_PER_H = _DEG / 3600.0
_DEG_PER_RT_H = _DEG / 60.0
_UG = 1e-6 * earth.G0_MPS2

Triple = tuple[float, float, float]


def _triple(name: str, value: Any, *, positive: bool = False) -> Triple:
    try:
        t = tuple(float(v) for v in value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"EskfConfig.{name} = {value!r}: must be 3 finite numbers >= 0") from exc
    bad = len(t) != 3 or not all(math.isfinite(v) and (v > 0 if positive else v >= 0) for v in t)
    if bad:
        kind = "> 0" if positive else ">= 0"
        raise ValueError(f"EskfConfig.{name} = {value!r}: must be 3 finite numbers {kind}")
    return t  # type: ignore[return-value]


def _scalar(name: str, value: Any, lo: float, hi: float, *, lo_open: bool = False) -> None:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value > hi or value < lo or (lo_open and value == lo):
        lo_b = "(" if lo_open else "["
        raise ValueError(
            f"EskfConfig.{name} = {value!r}: must be a finite number in {lo_b}{lo:g}, {hi:g}]"
        )


# A first-order Gauss–Markov process of variance σ² has its Allan-deviation peak 0.6174 σ (at an
# averaging time of 1.89 τ); equating it to the flicker floor 0.664 B of an IEEE-952 bias
# instability B gives σ = 1.0755 B — the same mapping as the simulated IMU (sensors.noise),
# restated here because onboard code does not import the world side.
GM_SIGMA_PER_BIAS_INSTABILITY = 0.664 / 0.6174


@dataclass(frozen=True, slots=True)
class ImuGrade:
    """The declared IMU datasheet, SI units (what the vehicle's integrator knows of its IMU).

    Densities are one-sided root PSDs; sigmas are 1σ over turn-ons; a per-axis datasheet value is
    given here as its worst axis.

    Attributes:
        gyro_noise_density: Angle random walk N_g (rad/√s ≡ rad/s/√Hz).
        gyro_bias_instability: IEEE-952 bias instability B_g (rad/s).
        gyro_bias_corr_time_s: Correlation time of the Gauss–Markov bias model (s).
        gyro_turn_on_bias: Turn-on (run-to-run) bias σ (rad/s), the residual after any at-rest
            calibration the vehicle does.
        gyro_scale_factor: Scale-factor error σ (fraction).
        gyro_misalignment: Axis misalignment σ (rad).
        accel_noise_density: Velocity random walk N_a (m/s²/√Hz).
        accel_bias_instability: Bias instability B_a (m/s²).
        accel_bias_corr_time_s: Correlation time of the accelerometer bias (s).
        accel_turn_on_bias: Turn-on bias σ (m/s²).
        accel_scale_factor: Scale-factor error σ (fraction).
        accel_misalignment: Axis misalignment σ (rad).
    """

    gyro_noise_density: float
    gyro_bias_instability: float
    gyro_bias_corr_time_s: float
    gyro_turn_on_bias: float
    gyro_scale_factor: float = 0.0
    gyro_misalignment: float = 0.0
    accel_noise_density: float = 0.0
    accel_bias_instability: float = 0.0
    accel_bias_corr_time_s: float = 300.0
    accel_turn_on_bias: float = 0.0
    accel_scale_factor: float = 0.0
    accel_misalignment: float = 0.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if not (ok and math.isfinite(value) and value >= 0.0):
                raise ValueError(f"ImuGrade.{f.name} = {value!r}: must be a finite number >= 0")
            if f.name.endswith("_corr_time_s") and not value > 0.0:
                raise ValueError(f"ImuGrade.{f.name} = {value!r}: must be a finite number > 0")
            if f.name.endswith(("_scale_factor", "_misalignment")) and value > 0.1:
                raise ValueError(f"ImuGrade.{f.name} = {value!r}: must be in [0, 0.1]")

    @property
    def gyro_gm_sigma(self) -> float:
        """σ of the Gauss–Markov gyro bias equivalent to the bias instability (rad/s)."""
        return GM_SIGMA_PER_BIAS_INSTABILITY * self.gyro_bias_instability

    @property
    def accel_gm_sigma(self) -> float:
        """σ of the Gauss–Markov accelerometer bias (m/s²)."""
        return GM_SIGMA_PER_BIAS_INSTABILITY * self.accel_bias_instability


@dataclass(frozen=True, slots=True)
class EskfConfig:
    """Filter parameters; defaults from the LIG paper §3.3 unless marked as assumptions.

    Sigmas are 1σ per axis (E, N, U for the navigation errors; body x, y, z for the biases).

    Attributes:
        p0_attitude_rad: Initial φ σ (paper: 0.5° each).
        p0_velocity_mps: Initial δv σ (ASSUMPTION 0.1 m/s; the paper's entry is unreadable).
        p0_position_m: Initial position σ E, N, U in metres (ASSUMPTION 1 m), converted to δL, δλ
            at the initial latitude.
        p0_gyro_bias_rad_s: Initial ε σ (paper: 2 °/h).
        p0_accel_bias_mps2: Initial ∇ σ (paper: 10 µg).
        q_attitude: Attitude process-noise density (rad/√s) on φ (paper: 0.01, 0.01, 0.16 °/√h).
        q_velocity: Velocity process-noise density (m/s²/√Hz) on δv (paper: 5 µg/√Hz).
        q_gyro_bias: Gyro-bias driving density (rad/s/√s) (paper: 0, a random constant).
        q_accel_bias: Accelerometer-bias driving density (m/s²/√s) (paper: 0).
        gyro_bias_tau_s: Gauss–Markov correlation time of ε (s); None: random walk/constant.
        accel_bias_tau_s: Same for ∇.
        r_gravity_mps2: Gravity-vector noise σ per axis (paper R_g: 0.1 g).
        r_sun: Solar-vector noise σ per axis, unitless (paper R_s: 0.05), used when a fix has no
            covariance.
        r_depth_m: Depth noise σ (m) (ASSUMPTION 0.05 m: gauge noise plus offset residual).
        gravity_models_accel_bias: Include −C_b^n for ∇ in H_g (the paper omits it).
        static_accel_tol_mps2: Gravity update only when | ‖f̄‖ − γ | is below this (ASSUMPTION).
        static_rate_tol_rad_s: ... and ‖ω̄ − ω_ie^b‖ below this (ASSUMPTION 0.02 rad/s).
        gate_probability: Chi-square gate: accept when NIS < χ²_dof⁻¹(p); 1.0 disables gating.
        q_rate_gain: Attitude process noise per unit of the measured turn rate (rad/√s per
            rad/s): the covariance step adds (q_rate_gain · ‖ω̄‖)² to each attitude axis, with ω̄
            the bias-compensated gyro rate over the step — the allowance for the rate-proportional
            gyro errors (scale factor, misalignment) that follows what the vehicle does. 0: none
            (``for_imu`` folds a fixed allowance into ``q_attitude`` instead).
        cov_step_s: Covariance propagation interval (s), at most; also before every update.
        ins: The INS's :class:`~twin.onboard.ins.InsConfig`.
    """

    p0_attitude_rad: Triple = (0.5 * _DEG, 0.5 * _DEG, 0.5 * _DEG)
    p0_velocity_mps: Triple = (0.1, 0.1, 0.1)
    p0_position_m: Triple = (1.0, 1.0, 1.0)
    p0_gyro_bias_rad_s: Triple = (2.0 * _DEG_PER_H,) * 3
    p0_accel_bias_mps2: Triple = (10.0 * _UG,) * 3
    q_attitude: Triple = (0.01 * _DEG_PER_RT_H, 0.01 * _DEG_PER_RT_H, 0.16 * _DEG_PER_RT_H)
    q_velocity: Triple = (5.0 * _UG,) * 3
    q_gyro_bias: Triple = (0.0, 0.0, 0.0)
    q_accel_bias: Triple = (0.0, 0.0, 0.0)
    gyro_bias_tau_s: float | None = None
    accel_bias_tau_s: float | None = None
    r_gravity_mps2: Triple = (0.1 * earth.G0_MPS2,) * 3
    r_sun: Triple = (0.05, 0.05, 0.05)
    r_depth_m: float = 0.05
    gravity_models_accel_bias: bool = True
    static_accel_tol_mps2: float = 0.1
    static_rate_tol_rad_s: float = 0.02
    gate_probability: float = 0.999
    q_rate_gain: float = 0.0
    cov_step_s: float = 0.1
    ins: InsConfig = field(default_factory=InsConfig)

    def __post_init__(self) -> None:
        for name in ("p0_attitude_rad", "p0_velocity_mps", "p0_position_m"):
            object.__setattr__(self, name, _triple(name, getattr(self, name), positive=True))
        for name in (
            "p0_gyro_bias_rad_s",
            "p0_accel_bias_mps2",
            "q_attitude",
            "q_velocity",
            "q_gyro_bias",
            "q_accel_bias",
        ):
            object.__setattr__(self, name, _triple(name, getattr(self, name)))
        for name in ("r_gravity_mps2", "r_sun"):
            object.__setattr__(self, name, _triple(name, getattr(self, name), positive=True))
        for name in ("gyro_bias_tau_s", "accel_bias_tau_s"):
            if getattr(self, name) is not None:
                _scalar(name, getattr(self, name), 0.0, 1e9, lo_open=True)
        _scalar("r_depth_m", self.r_depth_m, 0.0, 1e3, lo_open=True)
        _scalar("static_accel_tol_mps2", self.static_accel_tol_mps2, 0.0, 100.0, lo_open=True)
        _scalar("static_rate_tol_rad_s", self.static_rate_tol_rad_s, 0.0, 100.0, lo_open=True)
        _scalar("gate_probability", self.gate_probability, 0.0, 1.0, lo_open=True)
        _scalar("cov_step_s", self.cov_step_s, 0.0, 10.0, lo_open=True)
        _scalar("q_rate_gain", self.q_rate_gain, 0.0, 1.0)
        if not isinstance(self.gravity_models_accel_bias, bool):
            raise ValueError(
                f"EskfConfig.gravity_models_accel_bias = {self.gravity_models_accel_bias!r}: "
                f"must be True or False"
            )
        if not isinstance(self.ins, InsConfig):
            raise ValueError(f"EskfConfig.ins = {self.ins!r}: must be an InsConfig")

    @classmethod
    def for_imu(
        cls,
        grade: ImuGrade,
        *,
        typical_rate_rad_s: float = 0.05,
        manoeuvre_time_s: float = 60.0,
        datasheet_only: bool = False,
        **overrides: Any,
    ) -> EskfConfig:
        """P0 and Q from the IMU's datasheet; every other field the paper's default.

        * P0 of the biases: turn-on ⊕ the Gauss–Markov σ of the bias instability (the bias is
          running when the filter starts; σ_GM = 1.0755 B, :data:`GM_SIGMA_PER_BIAS_INSTABILITY`).
          For the accelerometer also ⊕ (scale factor × g) ⊕ (misalignment × g): at rest, and
          while roll and pitch stay small, those errors act on gravity as constant biases that
          the ∇ state absorbs (an allowance, not a model: they change with attitude).
        * Q of φ and δv: the angle / velocity random-walk densities, never below the paper's
          values (those are kept as the floor the paper found necessary for its own unit).
        * Bias driving noise: a random walk with q = σ_GM √(2/τ), the driving density of the
          datasheet's Gauss–Markov process (σ̇² = q² − 2σ²/τ = 0 at σ_GM). A Gauss–Markov error
          state with that τ would pull the estimate of the *constant* turn-on part towards zero;
          the random walk has the GM's short-term increments and over-bounds its long-term
          variance (σ√(2t/τ) > σ for t > τ/2): conservative, never overconfident.
        * Rate-proportional gyro errors (scale factor s, misalignment m: δω = (S + M) ω) are not
          states. Allowance: white attitude noise whose variance over one manoeuvre of duration
          T at rate ω̄ matches the coherent error of that manoeuvre, q² T = (k ω̄ T)², i.e.
          q = k ω̄ √T with k = √(s² + 2m²) (rotation axis plus the two cross axes), added in
          quadrature to the ARW. It is ``typical_rate_rad_s`` (ω̄, default 0.05 rad/s ≈ 3 °/s)
          and ``manoeuvre_time_s`` (T, default 60 s): ASSUMPTIONS about the mission, not the
          IMU. Limitations: it is the same whether the vehicle turns or not (conservative at
          rest, pass ``typical_rate_rad_s=0`` for a vehicle known to hold still) and a steady
          turn much longer than T accumulates more than it allows. Accelerometer scale factor
          and misalignment on manoeuvre accelerations (≲ 0.1 m/s² for an AUV: ≲ 0.1 mm/s²
          of error) are neglected.

        ``datasheet_only=True`` (the scenario's ``navigation.tuning = "datasheet"``) is for an IMU
        far better than the paper's, whose floors and fixed allowance would swamp it: a
        navigation-grade unit's ARW (0.002 °/√h) is a fifth of the paper's east/north floor and
        1/80 of its vertical one, and the fixed allowance (0.09 °/√h for 0.05 mrad of
        misalignment) is 47 times its ARW — a filter told its level drifts that fast lets weak
        couplings (depth through Coriolis, the map's Eötvös term) walk its tilt by hundredths of
        a degree, each a Schuler velocity error of 0.1–1 m/s (docs/gravity.md). So:

        * Q of φ and δv: the datasheet's ARW and VRW alone, no floor;
        * the rate-proportional allowance follows the *measured* rate: ``q_rate_gain = k √T``,
          added as (k √T ‖ω̄‖)² over each covariance step (zero on a straight leg, the fixed
          value above while turning at ω̄);
        * P0 of ∇ per axis: a scale-factor error acts on the axis's own specific force and a
          misalignment on the others', so in level flight the horizontal axes (x, y) see
          misalignment × g and the vertical axis (z) scale factor × g.

        Args:
            grade: The declared IMU datasheet.
            typical_rate_rad_s: ω̄ above (rad/s, ≥ 0).
            manoeuvre_time_s: T above (s, > 0).
            datasheet_only: The datasheet tuning above instead of the paper-floored one.
            **overrides: Any :class:`EskfConfig` field, applied last (e.g. ``ins=...``).

        Raises:
            ValueError: naming the field, for a bad grade, rate, time or override.
        """
        if not isinstance(grade, ImuGrade):
            raise ValueError(f"EskfConfig.for_imu grade = {grade!r}: must be an ImuGrade")
        for name, value, lo_open in (
            ("typical_rate_rad_s", typical_rate_rad_s, False),
            ("manoeuvre_time_s", manoeuvre_time_s, True),
        ):
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if not (ok and math.isfinite(value) and (value > 0 if lo_open else value >= 0)):
                kind = "> 0" if lo_open else ">= 0"
                raise ValueError(
                    f"EskfConfig.for_imu {name} = {value!r}: must be a finite number {kind}"
                )
        if not isinstance(datasheet_only, bool):
            raise ValueError(
                f"EskfConfig.for_imu datasheet_only = {datasheet_only!r}: must be True or False"
            )
        paper = cls()
        g = earth.G0_MPS2

        def rss(*terms: float) -> float:
            return math.sqrt(sum(t * t for t in terms))

        k_rate = rss(grade.gyro_scale_factor, math.sqrt(2.0) * grade.gyro_misalignment)
        q_rate = k_rate * typical_rate_rad_s * math.sqrt(manoeuvre_time_s)
        q_att = tuple(max(p, rss(grade.gyro_noise_density, q_rate)) for p in paper.q_attitude)
        q_vel = tuple(max(p, grade.accel_noise_density) for p in paper.q_velocity)
        p0_g = rss(grade.gyro_turn_on_bias, grade.gyro_gm_sigma)
        p0_a = rss(
            grade.accel_turn_on_bias,
            grade.accel_gm_sigma,
            grade.accel_scale_factor * g,
            grade.accel_misalignment * g,
        )
        q_g = grade.gyro_gm_sigma * math.sqrt(2.0 / grade.gyro_bias_corr_time_s)
        q_a = grade.accel_gm_sigma * math.sqrt(2.0 / grade.accel_bias_corr_time_s)
        fields: dict[str, Any] = {
            "p0_gyro_bias_rad_s": (p0_g,) * 3,
            "p0_accel_bias_mps2": (p0_a,) * 3,
            "q_attitude": q_att,
            "q_velocity": q_vel,
            "q_gyro_bias": (q_g,) * 3,
            "q_accel_bias": (q_a,) * 3,
        }
        if datasheet_only:
            a_xy = rss(grade.accel_turn_on_bias, grade.accel_gm_sigma, grade.accel_misalignment * g)
            a_z = rss(grade.accel_turn_on_bias, grade.accel_gm_sigma, grade.accel_scale_factor * g)
            fields |= {
                "p0_accel_bias_mps2": (a_xy, a_xy, a_z),
                "q_attitude": (grade.gyro_noise_density,) * 3,
                "q_velocity": (grade.accel_noise_density,) * 3,
                "q_rate_gain": k_rate * math.sqrt(manoeuvre_time_s),
            }
        names = {f.name for f in dataclasses.fields(cls)}
        for name in overrides:
            if name not in names:
                raise ValueError(f"EskfConfig.for_imu {name}=...: not an EskfConfig field")
        return cls(**{**fields, **overrides})
