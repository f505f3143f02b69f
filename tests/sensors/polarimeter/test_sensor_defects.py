"""Sensor error sources beyond the pixel noise: hot pixels, row noise, and the datasheet's AoP."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sensors.polarimeter.unit.mosaic import DoFPSensor, preset
from twin.onboard.polarization import stokes_from_mosaic

# The LIG paper's Table 1 (hu2024): the PHX050S-P polarimeter's "AoP perception accuracy 0.61°
# (1σ)". Its test condition is not stated; the usual one is a uniform, fully polarized target (a
# polarizer before an integrating sphere) exposed to half the full scale, read per super-pixel.
PAPER_AOP_SIGMA_DEG = 0.61


def _uniform(n: int, s0: float, dop: float, aop: float) -> np.ndarray:
    st = np.empty((n, n, 3), np.float32)
    st[..., 0] = s0
    st[..., 1] = s0 * dop * math.cos(2 * aop)
    st[..., 2] = s0 * dop * math.sin(2 * aop)
    return st


def test_the_phx050s_p_preset_reaches_its_datasheet_aop_accuracy_on_a_uniform_target():
    """Orientation errors, crosstalk, PRNU and the noise together, none fitted to this figure."""
    spec = preset("phx050s_p")
    n, aop, dop = 512, 0.3, 1.0
    t = spec.exposure_us * 1e-6
    # The brightest analyser (along the AoP) at half the usable full scale.
    s0 = 0.5 * spec.full_scale_e / (spec.quantum_efficiency * t * (1 + spec.diattenuation) / 2)
    sigmas = []
    for seed in range(3):  # three units: the fixed pattern is part of the figure
        cam = DoFPSensor(spec, (n, n), np.random.default_rng(seed))
        raw = cam.render_mosaic(
            _uniform(n, s0, dop, aop), spec.exposure_us, np.random.default_rng(9)
        )
        img = stokes_from_mosaic(raw, black_level_dn=spec.black_level_dn)
        err = np.angle(np.exp(2j * (img.aop.astype(np.float64) - aop))) / 2
        assert abs(math.degrees(err.mean())) < 0.02  # no bias: the errors are zero-mean
        sigmas.append(math.degrees(err.std()))
    # Measured 0.54° (the three units agree to 0.01°): within 15 % of the datasheet's 0.61°.
    assert np.ptp(sigmas) < 0.03
    assert np.mean(sigmas) == pytest.approx(PAPER_AOP_SIGMA_DEG, rel=0.2)


def test_hot_pixels_are_a_fixed_pattern_with_their_own_dark_current():
    spec = dataclasses.replace(preset("imx250mzr"), hot_pixel_fraction=1e-3)
    n = 512
    cam = DoFPSensor(spec, (n, n), np.random.default_rng(0))
    hot = cam._fp.hot
    # Binomial(n², 1e-3): mean 262, σ 16.
    assert abs(hot.size - 1e-3 * n * n) < 5 * math.sqrt(1e-3 * n * n)
    assert np.all(np.diff(hot) > 0)
    again = DoFPSensor(spec, (n, n), np.random.default_rng(0))
    np.testing.assert_array_equal(again._fp.hot, hot)
    # The other fixed patterns do not depend on whether there are hot pixels.
    none = DoFPSensor(
        dataclasses.replace(spec, hot_pixel_fraction=0.0), (n, n), np.random.default_rng(0)
    )
    np.testing.assert_array_equal(none.gain, cam.gain)
    np.testing.assert_array_equal(none.dsnu_e, cam.dsnu_e)
    dark = np.zeros((n, n, 3), np.float32)
    exposure_us = 100_000.0  # 0.1 s: 500 e⁻ in a hot pixel, 0.5 e⁻ in the others
    e = cam.expected_electrons(dark, exposure_us).ravel()
    assert e[hot] == pytest.approx(spec.hot_pixel_dark_e_per_s * 0.1, rel=1e-5)
    cold = np.delete(e, hot)
    assert np.all(cold == pytest.approx(spec.dark_current_e_per_s * 0.1, rel=1e-5))
    raw = cam.render_mosaic(dark, exposure_us, np.random.default_rng(1)).astype(float).ravel()
    k = spec.conversion_gain_e_per_dn
    assert np.median(raw[hot]) == pytest.approx(spec.black_level_dn + 500.0 / k, abs=3.0)
    # Warmer sensor, hotter pixels: the same doubling as the mean dark current.
    warm = dataclasses.replace(spec, sensor_temp_c=spec.dark_current_ref_temp_c + 7.0)
    assert warm.hot_pixel_dark_at_temp_e_per_s == pytest.approx(2 * spec.hot_pixel_dark_e_per_s)


def test_row_noise_is_common_to_a_row_and_leaves_the_pixel_noise_alone():
    base = dataclasses.replace(preset("imx250mzr"), hot_pixel_fraction=0.0)
    rows = dataclasses.replace(base, row_noise_e=3.0)
    shape = (256, 2048)
    dark = np.zeros((*shape, 3), np.float32)
    a = DoFPSensor(base, shape, np.random.default_rng(0))
    b = DoFPSensor(rows, shape, np.random.default_rng(0))
    ra = a.render_mosaic(dark, 1000.0, np.random.default_rng(5)).astype(float)
    rb = b.render_mosaic(dark, 1000.0, np.random.default_rng(5)).astype(float)
    diff = rb - ra
    # Same pixel noise: the difference is one offset per row (± the quantization step).
    assert np.max(np.ptp(diff, axis=1)) <= 2.0
    k = rows.conversion_gain_e_per_dn
    assert diff.mean(axis=1).std() == pytest.approx(3.0 / k, rel=0.15)
    assert rows.row_noise_e > 0 and preset("phx050s_p").row_noise_e == 0.5


@pytest.mark.parametrize(("field", "value"), [("hot_pixel_fraction", 0.2), ("row_noise_e", -1.0)])
def test_impossible_defects_name_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(preset("imx250mzr"), **{field: value}).validate()


def test_the_ideal_sensor_has_no_defects():
    ideal = preset("ideal")
    assert ideal.hot_pixel_fraction == 0.0 and ideal.row_noise_e == 0.0


def test_binning_carries_the_defects():
    import sensors

    full = sensors.create("polarimeter", "phx050s_p").spec
    s1 = full.sensor_spec()
    s4 = dataclasses.replace(full, binning=4).sensor_spec()
    # One hot pixel in 16 makes a hot binned pixel; 4 rows' offsets, each summed 4 times.
    assert s4.hot_pixel_fraction == pytest.approx(1 - (1 - s1.hot_pixel_fraction) ** 16)
    assert s4.hot_pixel_dark_e_per_s == s1.hot_pixel_dark_e_per_s
    assert s4.row_noise_e == pytest.approx(8 * s1.row_noise_e)
