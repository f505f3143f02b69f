"""The lens polarization bench of the Snell-window paper (xin2024 §2.3), simulated.

World side: it measures a real unit (its lens, its sensor's fixed pattern and noise) and hands
the vehicle a table (:attr:`twin.core.calibration.CameraCalibration.lens_table`), as the paper's
bench hands its compensation curve to the navigation software.

The paper's procedure: a telecentric light source behind a polarizer is imaged at incidence
angles 0–90° in 10° steps (the camera on a precision turntable); at each, the polarizer is turned
0–170° in 10° steps and several frames are averaged. Here: the source's image is a small uniform
spot on the sensor's +u axis at the field angle θ (the turntable turns about the sensor's v axis;
the spot's radial direction is +u, so the polarizer angle χ is counted from the radial direction);
the spot's raw pixels are computed from the unit's own analysis vectors (lens, micro-polarizers,
PRNU, crosstalk, DSNU) with the temporal noise of ``frames`` averaged frames; the bench's software
inverts the spot's mean per analyser with the analyser layout the vehicle believes (its
calibration's: a least-squares inversion, the same convention as the vehicle's own
``twin.onboard.polarization``, which world-side code may not import); the spot's Stokes over all χ
give the lens's radial-frame Mueller matrix at θ by least squares.
"""

from __future__ import annotations

import math

import numpy as np

from sensors.polarimeter.unit.mosaic import DoFPSensor
from twin.core.calibration import CameraCalibration

#: The paper's bench: incidence 0–90° in 10° steps, polarizer 0–170° in 10° steps (xin2024 §2.3).
INCIDENCE_DEG: tuple[float, ...] = tuple(float(a) for a in range(0, 91, 10))
POLARIZER_DEG: tuple[float, ...] = tuple(float(a) for a in range(0, 180, 10))
FRAMES = 5  # "several frames, averaged" [uncertain: the paper does not say how many]
SPOT_PX = 16  # raw pixels across the measured spot (8×8 super-pixels)


def measure_lens(
    sensor: DoFPSensor,
    true: CameraCalibration,
    onboard: CameraCalibration,
    rng: np.random.Generator,
    *,
    incidence_deg: tuple[float, ...] = INCIDENCE_DEG,
    polarizer_deg: tuple[float, ...] = POLARIZER_DEG,
    frames: int = FRAMES,
) -> tuple[tuple[float, float, float, float, float], ...]:
    """The bench's table (θ rad, T̄, D, a, c), T̄ relative to the first (on-axis) angle.

    Args:
        sensor: The unit's sensor, lens folded in (``Polarimeter._dofp``).
        true: The world camera's exact geometry (where the spot really falls).
        onboard: The vehicle's calibration (its analyser layout and black level invert the raw).
        rng: Generator for the bench's frame noise.
        incidence_deg: Incidence (field) angles; those beyond the image circle or the sensor's
            edge are skipped.
        polarizer_deg: Polarizer angles from the radial direction.
        frames: Frames averaged per setting.
    """
    spec = sensor.spec
    h, w = sensor.shape
    cu, cv = true.principal_point_px
    t_s = spec.exposure_us * 1e-6
    # The brightest analyser near half the usable scale.
    s0 = 0.5 * spec.full_scale_e / max(spec.quantum_efficiency * t_s, 1e-30)
    chis = np.radians(np.asarray(polarizer_deg, dtype=np.float64))
    s_in = s0 * np.stack([np.ones_like(chis), np.cos(2 * chis), np.sin(2 * chis)], axis=1)
    # I_k = ½ (S0 + S1 cos 2α_k + S2 sin 2α_k) at the believed angle α_k of raw pixel (r, c).
    two_a = np.radians(2.0 * np.asarray(onboard.layout_deg, dtype=np.float64).ravel())
    inverse = np.linalg.pinv(0.5 * np.stack([np.ones(4), np.cos(two_a), np.sin(two_a)], axis=1))
    rows = []
    analysis = sensor.analysis.astype(np.float64)
    dsnu = sensor.dsnu_e.astype(np.float64)
    k = spec.conversion_gain_e_per_dn
    dark = spec.dark_current_at_temp_e_per_s * t_s
    for theta_deg in incidence_deg:
        theta = math.radians(theta_deg)
        if theta > true.max_field_angle_rad:
            continue
        u = cu + float(true.rho_of_theta(theta))
        v0 = round(cv) // 2 * 2 - SPOT_PX // 2
        u0 = round(u) // 2 * 2 - SPOT_PX // 2
        if not (0 <= u0 <= w - SPOT_PX and 0 <= v0 <= h - SPOT_PX):
            continue  # the spot's image falls off the sensor (a camera narrower than its circle)
        win = (slice(v0, v0 + SPOT_PX), slice(u0, u0 + SPOT_PX))
        a, offset = analysis[win], dsnu[win]
        measured = np.empty_like(s_in)
        for j, s in enumerate(s_in):
            lam = t_s * (a @ s) + dark
            sigma = np.sqrt(np.maximum(lam, 0.0) + spec.read_noise_e**2) / math.sqrt(frames)
            e = lam + sigma * rng.standard_normal(lam.shape) + offset
            dn = np.clip(e / k + spec.black_level_dn, 0.0, spec.saturation_dn)
            phases = (dn - onboard.black_level_dn).reshape(SPOT_PX // 2, 2, SPOT_PX // 2, 2)
            measured[j] = inverse @ phases.mean(axis=(0, 2)).ravel()
        m, *_ = np.linalg.lstsq(s_in, measured, rcond=None)
        m = m.T  # measured = M · s_in
        t = m[0, 0]
        rows.append((theta, t, 0.5 * (m[0, 1] + m[1, 0]) / t, m[1, 1] / t, m[2, 2] / t))
    t0 = rows[0][1]
    return tuple((th, t / t0, d, a_, c) for th, t, d, a_, c in rows)


__all__ = ["FRAMES", "INCIDENCE_DEG", "POLARIZER_DEG", "measure_lens"]
