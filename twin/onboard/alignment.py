"""The INS's initial attitude error after a stationary fine alignment (gyrocompassing).

Onboard side: what the vehicle's integrator knows of its own alignment, from the declared IMU
datasheet (:class:`twin.onboard.eskf.ImuGrade`). Before a dive the INS levels on its
accelerometers and finds north on its gyros by sensing the Earth's rotation. The classic
steady-state limits (Titterton & Weston 2004, *Strapdown Inertial Navigation Technology*, §10.2.2;
Groves 2013, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation*, §5.6.2):

* tilt: σ_θ = σ_∇ / g — the level is found to within the horizontal accelerometer bias;
* heading: σ_ψ = σ_ε / (Ω cos L) — north is found to within the ratio of the east gyro's error to
  the horizontal Earth rate, with σ_ε the gyro bias ⊕ the angle random walk averaged over the
  alignment, N / √T. (The accelerometer term ∇ tan L / g is below 1e-4 rad for any unit that can
  gyrocompass at all, and is neglected.)

The same formulas say who cannot: a MEMS gyro of 20 °/h against the 11.9 °/h of horizontal Earth
rate at 37.5° N has no north to find. :func:`gyrocompass_sigma` refuses what would leave a heading
σ above :data:`MAX_HEADING_SIGMA_DEG` (the filter's error model is small-angle).
"""

from __future__ import annotations

import math

from twin.core import earth
from twin.onboard.eskf_config import ImuGrade

#: ASSUMPTION: a 10-minute stationary fine alignment at the quay before launch.
ALIGNMENT_TIME_S = 600.0
#: The largest heading σ a gyrocompass alignment may leave (the ESKF's small-angle limit).
MAX_HEADING_SIGMA_DEG = 5.0


class AlignmentError(ValueError):
    """The IMU cannot gyrocompass at this latitude (message names the numbers)."""


def gyrocompass_sigma(
    grade: ImuGrade, latitude_rad: float, duration_s: float = ALIGNMENT_TIME_S
) -> tuple[float, float]:
    """(tilt σ, heading σ) in radians after a stationary fine alignment of ``duration_s``.

    Raises:
        AlignmentError: when the heading σ would exceed :data:`MAX_HEADING_SIGMA_DEG`.
    """
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"gyrocompass_sigma duration_s = {duration_s!r}: must be > 0 s")
    accel = math.hypot(grade.accel_turn_on_bias, grade.accel_gm_sigma)
    tilt = accel / earth.G0_MPS2
    gyro = math.sqrt(
        grade.gyro_turn_on_bias**2
        + grade.gyro_gm_sigma**2
        + grade.gyro_noise_density**2 / duration_s
    )
    horizontal_rate = earth.OMEGA_IE * math.cos(latitude_rad)
    heading = gyro / horizontal_rate if horizontal_rate > 0 else math.inf
    if not heading <= math.radians(MAX_HEADING_SIGMA_DEG):
        deg_h = math.degrees(1.0) * 3600.0
        raise AlignmentError(
            f"a gyro error of {gyro * deg_h:.3g} °/h cannot find north at latitude "
            f"{math.degrees(latitude_rad):.1f}° (Earth rate there {horizontal_rate * deg_h:.3g} "
            f"°/h): heading σ {math.degrees(heading):.3g}°, allowed ≤ {MAX_HEADING_SIGMA_DEG:g}°"
        )
    return tilt, heading


__all__ = ["ALIGNMENT_TIME_S", "MAX_HEADING_SIGMA_DEG", "AlignmentError", "gyrocompass_sigma"]
