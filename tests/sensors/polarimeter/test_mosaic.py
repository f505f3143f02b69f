"""The DoFP sensor model: analysers, noise statistics, ADC, fixed pattern, exposure."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from sensors.polarimeter.unit.mosaic import (
    IMX250MZR_LAYOUT_DEG,
    PRESETS,
    DoFPSensor,
    PolarizationSensorSpec,
    photon_rate_per_pixel,
    preset,
)
from twin.onboard import polarization as onboard
from twin.onboard.polarization import stokes_from_mosaic

EXPOSURE_US = 1000.0
# Pixel temporal noise only: no fixed pattern, no crosstalk, no defects, no row noise (the
# AoP-noise law is about shot and read noise).
TEMPORAL = dataclasses.replace(
    preset("imx250mzr"),
    orientation_error_deg=0.0,
    prnu=0.0,
    dsnu_e=0.0,
    crosstalk=0.0,
    hot_pixel_fraction=0.0,
    row_noise_e=0.0,
)
NOISELESS = dataclasses.replace(
    preset("ideal"), auto_exposure=False, exposure_us=EXPOSURE_US, extinction_ratio=math.inf
)


def uniform_stokes(shape, s0_photons_s, dop=0.0, aop=0.0) -> np.ndarray:
    st = np.empty((*shape, 3), np.float32)
    st[..., 0] = s0_photons_s
    st[..., 1] = s0_photons_s * dop * math.cos(2 * aop)
    st[..., 2] = s0_photons_s * dop * math.sin(2 * aop)
    return st


def photons_for_s0_electrons(spec: PolarizationSensorSpec, s0_e: float) -> float:
    """Photon rate whose Stokes S0, as the onboard estimator ½ΣI sees it, is ``s0_e`` electrons.

    An unpolarized S0 gives each pixel η·S0·t/2 electrons, and ½ΣI of four such pixels is η·S0·t.
    """
    return s0_e / (spec.quantum_efficiency * EXPOSURE_US * 1e-6)


def axis_error(measured: np.ndarray, truth: float) -> np.ndarray:
    return np.angle(np.exp(2j * (measured.astype(np.float64) - truth))) / 2


# --- spec and presets ---------------------------------------------------------------------------
def test_presets_validate_and_state_the_datasheet_numbers():
    for spec in PRESETS.values():
        spec.validate()
    imx = preset("imx250mzr")
    assert imx.layout_deg == IMX250MZR_LAYOUT_DEG == onboard.IMX250MZR_LAYOUT_DEG
    assert imx.full_well_e == pytest.approx(10_700.0)
    assert imx.read_noise_e == pytest.approx(2.9)
    assert imx.adc_bits == 12
    assert imx.saturation_dn == 4095
    assert imx.diattenuation == pytest.approx(249.0 / 251.0)
    assert preset("phx050s_p").exposure_us == 700.0  # the LIG sea trial
    assert preset("imx264mzr").auto_exposure
    ideal = preset("ideal")
    assert ideal.diattenuation == 1.0
    assert ideal.saturation_dn == 65535
    with pytest.raises(KeyError, match="imx250mzr"):
        preset("nope")


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("quantum_efficiency", 0.0),
        ("quantum_efficiency", 1.5),
        ("full_well_e", -1.0),
        ("conversion_gain_e_per_dn", 0.0),
        ("read_noise_e", -0.1),
        ("read_noise_e", float("nan")),
        ("exposure_us", 0.0),
        ("extinction_ratio", 1.0),
        ("orientation_error_deg", -1.0),
        ("crosstalk", 0.25),
        ("prnu", 0.6),
        ("dsnu_e", -1.0),
        ("ae_percentile", 0.0),
        ("ae_target_fraction", 1.2),
        ("black_level_dn", 4095.0),
        ("adc_bits", 17),
        ("adc_bits", 12.0),
        ("shot_noise", 1),
        ("max_exposure_us", 10.0),
        ("layout_deg", ((0.0, 90.0), (0.0, 90.0))),
    ],
)
def test_impossible_specs_name_the_field(field, value):
    spec = dataclasses.replace(preset("imx250mzr"), **{field: value})
    with pytest.raises(ValueError, match=field):
        spec.validate()
    with pytest.raises(ValueError, match=field):
        DoFPSensor(spec, (4, 4), np.random.default_rng(0))


def test_shape_and_stokes_input_are_checked():
    with pytest.raises(ValueError, match="shape"):
        DoFPSensor(preset("ideal"), (5, 4), np.random.default_rng(0))
    cam = DoFPSensor(preset("ideal"), (4, 6), np.random.default_rng(0))
    rng = np.random.default_rng(1)
    with pytest.raises(ValueError, match=r"stokes\.shape"):
        cam.render_mosaic(np.zeros((6, 4, 3), np.float32), EXPOSURE_US, rng)
    with pytest.raises(TypeError, match="dtype"):
        cam.render_mosaic(np.zeros((4, 6, 3), np.int32), EXPOSURE_US, rng)
    with pytest.raises(ValueError, match="exposure_us"):
        cam.render_mosaic(np.zeros((4, 6, 3), np.float32), -1.0, rng)


def test_photon_rate_from_radiance_follows_the_camera_equation():
    # π·T·L/(4N²)·p²·λ/(hc) with L = 1 W m⁻² sr⁻¹, N = 2, T = 1, p = 3.45 µm, λ = 530 nm.
    expected = math.pi / 16 * (3.45e-6) ** 2 * 530e-9 / (6.62607015e-34 * 299_792_458.0)
    assert photon_rate_per_pixel(1.0, f_number=2.0) == pytest.approx(expected, rel=1e-12)
    st = np.array([2.0, 0.5, -0.3])
    np.testing.assert_allclose(photon_rate_per_pixel(st, f_number=2.0), st * expected)


# --- the ideal camera ---------------------------------------------------------------------------
def test_ideal_sensor_round_trips_known_stokes_up_to_quantization():
    rng = np.random.default_rng(10)
    h, w = 64, 96
    # One random (physical) Stokes vector per super-pixel, at 5e6–5e7 photons/s.
    s0 = rng.uniform(5e6, 5e7, (h // 2, w // 2))
    dop, aop = rng.uniform(0, 1, s0.shape), rng.uniform(-np.pi / 2, np.pi / 2, s0.shape)
    sp = np.stack([s0, s0 * dop * np.cos(2 * aop), s0 * dop * np.sin(2 * aop)], axis=-1)
    stokes = np.repeat(np.repeat(sp, 2, axis=0), 2, axis=1).astype(np.float32)
    cam = DoFPSensor(NOISELESS, (h, w), np.random.default_rng(0))
    raw = cam.render_mosaic(stokes, EXPOSURE_US, np.random.default_rng(1))
    assert raw.dtype == np.uint16
    truth_dn = sp * EXPOSURE_US * 1e-6  # η = 1, K = 1: one photon = one DN
    img = stokes_from_mosaic(raw)
    # Each raw value is rounded (≤ ½ DN): S0 = ½Σ4 and S1, S2 = differences of 2 ⇒ ≤ 1 DN.
    for j, layer in enumerate((img.s0, img.s1, img.s2)):
        assert np.abs(layer - truth_dn[..., j]).max() <= 1.0 + 1e-3
    # The float path is exact: no quantization at all.
    exact = stokes_from_mosaic(cam.expected_dn(stokes, EXPOSURE_US))
    for j, layer in enumerate((exact.s0, exact.s1, exact.s2)):
        np.testing.assert_allclose(layer, truth_dn[..., j], rtol=2e-6, atol=0.02)
    np.testing.assert_allclose(
        axis_error(exact.aop[dop > 0.01], 0.0), axis_error(aop, 0.0)[dop > 0.01], atol=1e-4
    )
    # And the ideal camera is deterministic: the generator is not even consumed.
    g = np.random.default_rng(5)
    state = g.bit_generator.state
    np.testing.assert_array_equal(cam.render_mosaic(stokes, EXPOSURE_US, g), raw)
    assert g.bit_generator.state == state


def test_aop_follows_the_chain_convention_from_evector_to_onboard_aop():
    # Camera frame (camera.py): u along +x, v along −y, light reaches the sensor along −z, and the
    # sensor-plane Stokes are referenced to +x. An E-vector along (1, −1, 0) points to +u and +v
    # in the image, 45° from +u towards +v: the onboard AoP must read +45°.
    from sensors.polarimeter import stokes as stokes_mod
    from sensors.polarimeter.unit.camera import SENSOR_PROPAGATION, SENSOR_REFERENCE

    d, ref = SENSOR_PROPAGATION, SENSOR_REFERENCE
    np.testing.assert_array_equal(d, [0.0, 0.0, -1.0])
    np.testing.assert_array_equal(ref, [1.0, 0.0, 0.0])
    for e_vec, aop_deg in (
        ((1.0, -1.0, 0.0), 45.0),
        ((1.0, 0.0, 0.0), 0.0),
        ((1.0, 1.0, 0.0), -45.0),
    ):
        sv = stokes_mod.from_evector(4e7, 0.7, np.array(e_vec), d, ref)
        st = np.broadcast_to(sv, (4, 4, 3)).astype(np.float32)
        cam = DoFPSensor(NOISELESS, (4, 4), np.random.default_rng(0))
        img = stokes_from_mosaic(cam.render_mosaic(st, EXPOSURE_US, np.random.default_rng(1)))
        np.testing.assert_allclose(np.degrees(img.aop), aop_deg, atol=0.01)
        np.testing.assert_allclose(img.dop, 0.7, atol=1e-3)


# --- analyser imperfections ---------------------------------------------------------------------
@pytest.mark.parametrize("er", [10.0, 50.0, 300.0])
def test_extinction_ratio_scales_measured_dop_by_the_diattenuation(er):
    spec = dataclasses.replace(NOISELESS, extinction_ratio=er)
    d = (er - 1) / (er + 1)
    cam = DoFPSensor(spec, (8, 8), np.random.default_rng(0))
    for dop in (0.1, 0.5, 1.0):
        st = uniform_stokes((8, 8), 4e7, dop=dop, aop=0.4)
        img = stokes_from_mosaic(cam.expected_dn(st, EXPOSURE_US))
        np.testing.assert_allclose(img.dop, d * dop, rtol=1e-5)
        np.testing.assert_allclose(img.aop, 0.4, atol=1e-5)  # ER does not rotate the AoP


def test_crosstalk_scales_dop_by_one_minus_four_c_and_conserves_light():
    c = 0.02
    spec = dataclasses.replace(NOISELESS, crosstalk=c)
    cam = DoFPSensor(spec, (8, 8), np.random.default_rng(0))
    st = uniform_stokes((8, 8), 4e7, dop=0.6, aop=-0.7)
    img = stokes_from_mosaic(cam.expected_dn(st, EXPOSURE_US))
    np.testing.assert_allclose(img.dop, 0.6 * (1 - 4 * c), rtol=1e-5)
    np.testing.assert_allclose(img.s0, 4e7 * EXPOSURE_US * 1e-6, rtol=1e-6)
    np.testing.assert_allclose(img.aop, -0.7, atol=1e-5)


def test_orientation_error_is_a_fixed_per_pixel_pattern_of_the_stated_sigma():
    spec = dataclasses.replace(NOISELESS, orientation_error_deg=1.0)
    cam = DoFPSensor(spec, (256, 256), np.random.default_rng(0))
    nominal = np.tile(np.deg2rad(np.asarray(IMX250MZR_LAYOUT_DEG)), (128, 128))
    err = cam.analyzer_angle_rad - nominal
    assert np.degrees(err.std()) == pytest.approx(1.0, rel=0.02)
    # Perfectly polarized light along the x-axis: the AoP errors of a super-pixel are a
    # combination of its four analysers' errors, small and centred.
    img = stokes_from_mosaic(cam.expected_dn(uniform_stokes((256, 256), 4e7, 1.0), EXPOSURE_US))
    assert abs(np.degrees(img.aop.mean())) < 0.02
    assert 0.2 < np.degrees(img.aop.std()) < 1.0


# --- noise --------------------------------------------------------------------------------------
@pytest.mark.parametrize(("s0_e", "dop", "aop"), [(4000.0, 0.3, 0.3), (10_000.0, 0.2, -1.0)])
@pytest.mark.measures
def test_aop_noise_matches_one_over_two_p_sqrt_s0(s0_e, dop, aop, record_property):
    """σ_AoP ≈ 1/(2P√S0), S0 in electrons (optics.md §3.3), over 128×128 super-pixels.

    At these counts read noise (2σ_r² = 17 e⁻²) and quantization (K²/6 = 1.3 e⁻²) add < 0.5 %
    to the variance, so the bare law must hold within 10 %; with them, P·d and S0 included, the
    first-order prediction √(S0 + 2σ_r² + K²/6)/(2·d·P·S0) within 3 %.
    """
    spec = TEMPORAL
    n = 256
    cam = DoFPSensor(spec, (n, n), np.random.default_rng(0))
    st = uniform_stokes((n, n), photons_for_s0_electrons(spec, s0_e), dop, aop)
    raw = cam.render_mosaic(st, EXPOSURE_US, np.random.default_rng(1))
    img = stokes_from_mosaic(raw, black_level_dn=spec.black_level_dn)
    k, sr, d = spec.conversion_gain_e_per_dn, spec.read_noise_e, spec.diattenuation
    assert img.s0.mean() * k == pytest.approx(s0_e, rel=2e-3)
    sigma = axis_error(img.aop, aop).std()
    record_property("aop_noise_vs_bare_law_rel", float(sigma * 2 * dop * math.sqrt(s0_e) - 1.0))
    full = math.sqrt(s0_e + 2 * sr**2 + k**2 / 6) / (2 * d * dop * s0_e)
    record_property("aop_noise_vs_full_law_rel", float(sigma / full - 1.0))
    assert sigma == pytest.approx(1.0 / (2 * dop * math.sqrt(s0_e)), rel=0.10)
    assert sigma == pytest.approx(full, rel=0.03)


def test_aop_noise_in_the_photon_counting_regime_includes_read_noise():
    # ~15 e⁻ a pixel: exact Poisson shot noise, read noise no longer negligible.
    spec, s0_e, dop = TEMPORAL, 60.0, 0.8
    cam = DoFPSensor(spec, (256, 256), np.random.default_rng(0))
    st = uniform_stokes((256, 256), photons_for_s0_electrons(spec, s0_e), dop, 0.3)
    raw = cam.render_mosaic(st, EXPOSURE_US, np.random.default_rng(2))
    img = stokes_from_mosaic(raw, black_level_dn=spec.black_level_dn)
    k, sr = spec.conversion_gain_e_per_dn, spec.read_noise_e
    full = math.sqrt(s0_e + 2 * sr**2 + k**2 / 6) / (2 * spec.diattenuation * dop * s0_e)
    assert axis_error(img.aop, 0.3).std() == pytest.approx(full, rel=0.10)


def test_shot_noise_is_exact_poisson_at_low_counts():
    # No read noise, 1 e⁻/DN, no offset: raw values are the electron counts themselves.
    spec = dataclasses.replace(
        TEMPORAL, read_noise_e=0.0, conversion_gain_e_per_dn=1.0, black_level_dn=0.0
    )
    cam = DoFPSensor(spec, (256, 256), np.random.default_rng(0))
    lam = 5.0  # electrons a pixel: unpolarized, η·S0·t/2
    st = uniform_stokes((256, 256), 2 * lam / (spec.quantum_efficiency * EXPOSURE_US * 1e-6))
    dark = spec.dark_current_at_temp_e_per_s * EXPOSURE_US * 1e-6
    raw = cam.render_mosaic(st, EXPOSURE_US, np.random.default_rng(3)).astype(float)
    assert raw.mean() == pytest.approx(lam + dark, rel=0.01)
    assert raw.var() == pytest.approx(lam + dark, rel=0.03)
    assert np.mean(raw == 0) == pytest.approx(math.exp(-(lam + dark)), rel=0.1)
    # The Gaussian approximation, forced, gets P(0) wrong by a factor ~3: the exact path matters.
    gauss = cam.render_mosaic(st, EXPOSURE_US, np.random.default_rng(3), poisson_below_e=0.0)
    assert np.mean(gauss == 0) > 2 * math.exp(-lam)


def test_pixel_noise_variance_is_shot_plus_read_plus_quantization():
    spec = TEMPORAL
    cam = DoFPSensor(spec, (256, 256), np.random.default_rng(0))
    st = uniform_stokes((256, 256), photons_for_s0_electrons(spec, 5000.0))
    raw = cam.render_mosaic(st, EXPOSURE_US, np.random.default_rng(4)).astype(float)
    k = spec.conversion_gain_e_per_dn
    e = (raw - spec.black_level_dn) * k
    mean = 2500.0 + spec.dark_current_at_temp_e_per_s * EXPOSURE_US * 1e-6
    assert e.mean() == pytest.approx(mean, rel=1e-3)
    assert e.var() == pytest.approx(mean + spec.read_noise_e**2 + k**2 / 12, rel=0.03)


# --- ADC, saturation, darkness ------------------------------------------------------------------
def test_saturation_clips_at_4095_and_is_flagged():
    spec = preset("imx250mzr")
    cam = DoFPSensor(spec, (16, 16), np.random.default_rng(0))
    bright = uniform_stokes((16, 16), 1e9, dop=0.5)  # ~10⁵ e⁻ a pixel ≫ full well
    raw = cam.render_mosaic(bright, EXPOSURE_US, np.random.default_rng(1))
    assert raw.max() == 4095
    assert np.all(raw == 4095)
    img = stokes_from_mosaic(raw, black_level_dn=spec.black_level_dn, saturation_dn=4095)
    assert img.saturated.all()
    assert np.all(img.dop == 0.0)  # documented: clipped channels read unpolarized
    # Strong polarization: only the 0° analysers clip (~15 ke⁻ > 10.7 ke⁻ full well); flagged,
    # and the DoP is biased low (unclipped it would be 0.9·d·(1 − 4c) = 0.875).
    s0 = photons_for_s0_electrons(spec, 16_000.0)
    st = uniform_stokes((16, 16), s0, dop=0.9, aop=0.0)
    raw = cam.render_mosaic(st, EXPOSURE_US, np.random.default_rng(2))
    assert np.all(raw[1::2, 1::2] == 4095)
    assert raw[0::2].max() < 4095 and raw[1::2, 0::2].max() < 4095
    img = stokes_from_mosaic(raw, black_level_dn=spec.black_level_dn, saturation_dn=4095)
    assert img.saturated.all()
    assert img.dop.max() < 0.8
    assert abs(img.aop.mean()) < 0.01  # the axis survives this clipping


def test_dark_frame_is_black_level_plus_dark_noise_without_nan():
    spec = preset("imx250mzr")
    cam = DoFPSensor(spec, (256, 256), np.random.default_rng(0))
    dark = np.zeros((256, 256, 3), np.float32)
    raw = cam.render_mosaic(dark, EXPOSURE_US, np.random.default_rng(1)).astype(float)
    k = spec.conversion_gain_e_per_dn
    assert raw.mean() == pytest.approx(spec.black_level_dn, abs=0.05)
    sigma_dn = math.sqrt(spec.read_noise_e**2 + spec.dsnu_e**2 + spec.row_noise_e**2 + k**2 / 12)
    assert raw.std() == pytest.approx(sigma_dn / k, rel=0.05)
    # A long exposure at night: dark current adds its mean (and shot noise), the hot pixels
    # their own.
    night = cam.render_mosaic(dark, 1e6, np.random.default_rng(2)).astype(float)
    hot = cam._fp.hot.size / raw.size
    dark_e = spec.dark_current_at_temp_e_per_s * (1 - hot) + spec.hot_pixel_dark_e_per_s * hot
    assert night.mean() == pytest.approx(spec.black_level_dn + dark_e / k, abs=0.05)
    for method in ("superpixel", "interpolate"):
        img = stokes_from_mosaic(raw.astype(np.uint16), method=method, black_level_dn=240.0)
        for layer in (img.s0, img.s1, img.s2, img.aop, img.dop):
            assert np.all(np.isfinite(layer))
        assert 0.0 <= img.dop.min() and img.dop.max() <= 1.0


def test_dark_current_doubles_with_the_doubling_temperature():
    spec = dataclasses.replace(preset("imx250mzr"), sensor_temp_c=25.0 + 7.0)
    assert spec.dark_current_at_temp_e_per_s == pytest.approx(2 * spec.dark_current_e_per_s)


# --- randomness ---------------------------------------------------------------------------------
def test_same_seed_gives_an_identical_frame_and_another_seed_does_not():
    spec = preset("imx250mzr")
    st = uniform_stokes((64, 64), photons_for_s0_electrons(spec, 3000.0), 0.4, 0.2)
    st[:8] *= 1e-3  # a dim band through the exact-Poisson path too
    a = DoFPSensor(spec, (64, 64), np.random.default_rng(7))
    b = DoFPSensor(spec, (64, 64), np.random.default_rng(7))
    fa = a.render_mosaic(st, EXPOSURE_US, np.random.default_rng(11))
    fb = b.render_mosaic(st, EXPOSURE_US, np.random.default_rng(11))
    np.testing.assert_array_equal(fa, fb)
    fc = a.render_mosaic(st, EXPOSURE_US, np.random.default_rng(12))
    assert np.mean(fa != fc) > 0.5
    # OpenCV's thread count does not change the noise (its RNG is reseeded per band).
    threads = cv2.getNumThreads()
    try:
        cv2.setNumThreads(1 if threads != 1 else 2)
        fd = a.render_mosaic(st, EXPOSURE_US, np.random.default_rng(11))
    finally:
        cv2.setNumThreads(threads)
    np.testing.assert_array_equal(fa, fd)


def test_frame_does_not_depend_on_the_memory_alignment_of_the_input():
    spec = preset("imx250mzr")
    cam = DoFPSensor(spec, (34, 262), np.random.default_rng(0))
    st = uniform_stokes((34, 262), photons_for_s0_electrons(spec, 3000.0), 0.4, 0.2)
    st *= np.random.default_rng(1).uniform(0.5, 1.5, (34, 262, 1)).astype(np.float32)
    ref = cam.render_mosaic(st, EXPOSURE_US, np.random.default_rng(2))
    buf = np.empty(st.size + 16, np.float32)
    for offset in range(1, 9):
        shifted = buf[offset : offset + st.size].reshape(st.shape)
        shifted[...] = st
        frame = cam.render_mosaic(shifted, EXPOSURE_US, np.random.default_rng(2))
        np.testing.assert_array_equal(frame, ref)


def test_fixed_pattern_stays_fixed_across_frames_and_temporal_noise_changes():
    spec = dataclasses.replace(TEMPORAL, prnu=0.05)
    cam = DoFPSensor(spec, (128, 128), np.random.default_rng(0))
    gain_before = cam.gain.copy()
    st = uniform_stokes((128, 128), photons_for_s0_electrons(spec, 8000.0))
    rng = np.random.default_rng(1)
    frames = np.array([cam.render_mosaic(st, EXPOSURE_US, rng) for _ in range(8)], float)
    np.testing.assert_array_equal(cam.gain, gain_before)
    assert not cam.gain.flags.writeable
    signal = frames - spec.black_level_dn
    # The frame average follows the PRNU map; the difference of two frames does not.
    assert np.corrcoef(signal.mean(0).ravel(), cam.gain.ravel())[0, 1] > 0.9
    diff = signal[0] - signal[1]
    assert abs(np.corrcoef(diff.ravel(), cam.gain.ravel())[0, 1]) < 0.05
    k = spec.conversion_gain_e_per_dn
    temporal_dn = math.sqrt(4000.0 + spec.read_noise_e**2 + k**2 / 12) / k
    assert diff.std() == pytest.approx(math.sqrt(2) * temporal_dn, rel=0.05)
    # Another sensor from another seed has another pattern.
    other = DoFPSensor(spec, (128, 128), np.random.default_rng(1))
    assert not np.array_equal(other.gain, cam.gain)


# --- exposure -----------------------------------------------------------------------------------
def test_signal_is_linear_in_exposure():
    cam = DoFPSensor(preset("imx250mzr"), (8, 8), np.random.default_rng(0))
    st = uniform_stokes((8, 8), 1e6, 0.3)
    e1 = cam.expected_electrons(st, 500.0)
    e2 = cam.expected_electrons(st, 1000.0)
    np.testing.assert_allclose(e2, 2 * e1, rtol=1e-6)


def test_auto_exposure_puts_the_percentile_at_the_target_fraction():
    spec = preset("imx264mzr")
    cam = DoFPSensor(spec, (128, 128), np.random.default_rng(0))
    yy, xx = np.mgrid[0:128, 0:128]
    st = uniform_stokes((128, 128), 1.0, 0.4, 0.3)
    st *= (2e5 * (1 + xx / 64.0 + yy / 128.0))[..., None].astype(np.float32)
    t_us = cam.exposure_for(st)
    assert spec.min_exposure_us <= t_us <= spec.max_exposure_us
    dn = cam.expected_dn(st, t_us) - spec.black_level_dn
    level = np.percentile(dn, spec.ae_percentile) / (spec.saturation_dn - spec.black_level_dn)
    assert level == pytest.approx(spec.ae_target_fraction, rel=0.03)
    # From a raw frame, one firmware step lands close to the same exposure.
    raw = cam.render_mosaic(st, 0.3 * t_us, np.random.default_rng(1))
    assert cam.next_exposure_us(raw, 0.3 * t_us) == pytest.approx(t_us, rel=0.05)
    # Saturated: halve. Darkness: the longest exposure. Fixed-exposure presets ignore the scene.
    saturated = np.full((128, 128), spec.saturation_dn, np.uint16)
    assert cam.next_exposure_us(saturated, 2000.0) == pytest.approx(1000.0)
    assert cam.auto_exposure_us(np.zeros_like(st)) == spec.max_exposure_us
    fixed = DoFPSensor(preset("phx050s_p"), (128, 128), np.random.default_rng(0))
    assert fixed.exposure_for(st) == 700.0
