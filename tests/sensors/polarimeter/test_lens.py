"""The lens's own polarization, the simulated bench that measures it, and the onboard correction."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter.unit.bench import measure_lens
from sensors.polarimeter.unit.hardware import CalibrationUncertainty, HardwareErrors, MountingError
from sensors.polarimeter.unit.lens import LensPolarization, fold_radial, radial_mueller
from twin.onboard.lens import compensate, compensate_at, compensate_grid, grid_uv
from twin.onboard.polarization import stokes_from_mosaic

LENS_ONLY = HardwareErrors(CalibrationUncertainty.ideal(), MountingError.ideal())


def test_one_interface_follows_fresnel():
    # Uncoated (coating index 1 = no layer) at 45° into n = 1.52: the textbook Fresnel values.
    bare = LensPolarization(coating_index=1.0)
    i = np.radians([45.0])
    ts, tp, _, _ = bare._interface(i, 500.0)
    ci, n = math.cos(i[0]), 1.52
    ct = math.sqrt(1 - (math.sin(i[0]) / n) ** 2)
    rs = (ci - n * ct) / (ci + n * ct)
    rp = (n * ci - ct) / (n * ci + ct)
    assert ts[0] == pytest.approx(1 - rs**2, rel=1e-9)
    assert tp[0] == pytest.approx(1 - rp**2, rel=1e-9)
    # A quarter-wave MgF₂ layer at its design wavelength, normal incidence:
    # R = ((n_g − n_c²)/(n_g + n_c²))² (Macleod §3.2.1) = 1.26 %.
    coated = LensPolarization()
    ts0, tp0, _, _ = coated._interface(np.zeros(1), 550.0)
    r = ((1.52 - 1.38**2) / (1.52 + 1.38**2)) ** 2
    assert ts0[0] == pytest.approx(1 - r, rel=1e-9) and tp0[0] == pytest.approx(1 - r, rel=1e-9)


def test_the_lens_diattenuation_grows_with_field_angle_and_is_zero_on_axis():
    lens = LensPolarization()
    theta = np.radians(np.arange(0.0, 92.6, 2.5))
    t, d, delta = lens.transfer(theta, 500.0)
    assert t[0] == 1.0 and d[0] == 0.0 and delta[0] == 0.0
    assert np.all(np.diff(d) > 0)
    assert d[-1] == pytest.approx(0.040, abs=0.002)  # 92.5°: the value the docs quote
    assert np.all(np.abs(delta) < 0.01) and np.all(t > 0.98)
    one, zero, _ = LensPolarization.ideal().transfer(theta, 500.0)
    assert np.all(one == 1.0) and np.all(zero == 0.0)


def test_fold_radial_is_a_times_the_radial_mueller_matrix():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(4, 5, 3))
    t, d, delta, phi = (rng.uniform(0.8, 1.0, (4, 5)), rng.uniform(0, 0.1, (4, 5)),
                        rng.uniform(-0.1, 0.1, (4, 5)), rng.uniform(-3, 3, (4, 5)))  # fmt: skip
    m = radial_mueller(t, d, delta, phi)
    np.testing.assert_allclose(
        fold_radial(a, t, d, delta, phi), np.einsum("hwi,hwij->hwj", a, m), rtol=1e-5, atol=1e-6
    )
    # Along the radial axis (φ = 0): T [[1, D, 0], [D, 1, 0], [0, 0, √(1 − D²) cos δ]].
    m0 = radial_mueller(0.9, 0.1, 0.2, 0.0)
    np.testing.assert_allclose(
        m0, 0.9 * np.array([[1, 0.1, 0], [0.1, 1, 0], [0, 0, math.sqrt(0.99) * math.cos(0.2)]])
    )


def _uniform_frame(cam, dop: float):
    """A uniform polarized field on the sensor, AoP 45° from each pixel's radial direction."""
    h, w = cam.camera.shape
    cu, cv = cam.true_calibration().principal_point_px
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    phi = np.arctan2(v - cv, u - cu)
    aop = phi + math.pi / 4
    s0 = 4e6
    st = np.stack(
        [np.full_like(phi, s0), s0 * dop * np.cos(2 * aop), s0 * dop * np.sin(2 * aop)], -1
    )
    return st.astype(np.float32), aop


def _aop_error(cam, st, aop, cal):
    raw = cam._dofp.render_mosaic(st, 1000.0, np.random.default_rng(1))
    img = stokes_from_mosaic(raw, cal.layout_deg, black_level_dn=cal.black_level_dn)
    u, v = grid_uv(img.shape, "superpixel")
    fixed = compensate(img, cal, u, v)
    truth = aop[::2, ::2]  # the field is smooth: its value at a super-pixel's corner pixel
    err = lambda a: np.degrees(np.angle(np.exp(2j * (a.astype(np.float64) - truth))) / 2)  # noqa: E731
    return err(img.aop), err(fixed.aop)


def test_the_lens_turns_the_aop_at_the_edge_and_the_bench_correction_undoes_it():
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure_hardware(LENS_ONLY)
    unit = cam.draw_unit(np.random.default_rng(3))
    cal = unit.calibration
    assert len(cal.lens_table) == 10  # 0–90° in 10° steps, all inside the 92.5° circle
    # The bench measured the lens it was given: D within 0.001 of the model at every angle.
    theta = np.array([r[0] for r in cal.lens_table])
    _, d_model, _ = cam.hardware.lens.transfer(theta, cam.optics.wavelength_nm)
    np.testing.assert_allclose([r[2] for r in cal.lens_table], d_model, atol=1e-3)
    dop = 0.3
    st, aop = _uniform_frame(cam, dop)
    raw_err, fixed_err = _aop_error(cam, st, aop, cal)
    th = cam.true_calibration().theta_of_rho(
        np.hypot(*(x - c for x, c in zip(grid_uv(raw_err.shape, "superpixel"),
                                           cam.true_calibration().principal_point_px, strict=True)))
    )  # fmt: skip
    edge = (th > math.radians(80)) & (th < math.radians(90))
    centre = th < math.radians(20)
    # A radial diattenuator turns an AoP 45° off radial by ≈ −D/(2p) rad: 3°–4° at 80–90°.
    _, d_edge, _ = cam.hardware.lens.transfer(np.radians([85.0]), 500.0)
    expected = -math.degrees(d_edge[0] / (2 * dop))
    assert np.median(raw_err[edge]) == pytest.approx(expected, rel=0.2)
    assert abs(np.median(raw_err[centre])) < 0.1
    # The bench's correction takes it out.
    assert abs(np.median(fixed_err[edge])) < 0.1 * abs(expected)


def _bench_frame():
    """A drawn unit's calibration and a frame of uniform light through its lens (DoP 0.3)."""
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure_hardware(LENS_ONLY)
    cal = cam.draw_unit(np.random.default_rng(3)).calibration
    st, _ = _uniform_frame(cam, 0.3)
    raw = cam._dofp.render_mosaic(st, 1000.0, np.random.default_rng(1))
    img = stokes_from_mosaic(raw, cal.layout_deg, black_level_dn=cal.black_level_dn)
    return cal, img


def test_the_cached_grid_compensation_equals_the_per_call_one_bit_for_bit():
    # compensate_grid keeps a grid's factors in the calibration (issue #31): the same numbers.
    cal, img = _bench_frame()
    for kind, block in (("superpixel", 2), ("block", 2)):
        want = compensate(img, cal, *grid_uv(img.shape, kind, block=block))
        for _ in range(2):  # computed, then from the cache
            got = compensate_grid(img, cal, kind, block=block)
            for name in ("s0", "s1", "s2", "aop", "dop"):
                np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    assert sum(1 for k in cal._cache if k[0] == "lens_inverse") == 2
    # A crop elsewhere in the frame is another grid: its own factors, not the first one's.
    crop = compensate_grid(img, cal, "superpixel", origin=(2, 0))
    assert not np.array_equal(crop.aop, want.aop)


def test_the_compiled_compensation_at_some_pixels_is_the_grids_bit_for_bit():
    # compensate_at / compensate_gathered (POL's window pixels, lens_kernel.undo_at) against
    # compensate_grid (numpy's apply_inverse on the whole grid) at the same pixels (issue #31).
    cal, img = _bench_frame()
    want = compensate_grid(img, cal, "block", block=2)
    idx = np.flatnonzero(np.random.default_rng(2).random(img.s0.size) < 0.3)
    got = compensate_at(img, cal, idx, "block", block=2)
    for name in ("s0", "s1", "s2", "aop", "dop", "saturated"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name).reshape(-1)[idx])


def test_without_compensation_the_vehicle_gets_no_table_and_an_ideal_lens_changes_nothing():
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure_hardware(dataclasses.replace(LENS_ONLY, lens_compensation=False))
    assert not cam.hardware.drawn
    assert cam.calibration().lens_table == ()
    st, _ = _uniform_frame(cam, 0.5)
    cam.render_offline(np.eye(3), 2.0, np.array([0.0, 0.0, 1.0]), np.random.default_rng(0))
    with_lens = cam._dofp.expected_dn(st, 1000.0)
    plain = sensors.create("polarimeter", "ideal_bin4")
    plain.render_offline(np.eye(3), 2.0, np.array([0.0, 0.0, 1.0]), np.random.default_rng(0))
    without = plain._dofp.expected_dn(st, 1000.0)
    assert not np.array_equal(with_lens, without)
    cu, cv = (round(x) for x in plain.true_calibration().principal_point_px)
    centre = (slice(cv - 4, cv + 4), slice(cu - 4, cu + 4))
    np.testing.assert_allclose(with_lens[centre], without[centre], rtol=1e-4)
    # An ideal budget builds the sensor without optics: the analysis vectors are the sensor's.
    ideal = sensors.create("polarimeter", "ideal_bin4")
    ideal.configure_hardware(HardwareErrors.ideal())
    ideal.render_offline(np.eye(3), 2.0, np.array([0.0, 0.0, 1.0]), np.random.default_rng(0))
    np.testing.assert_array_equal(ideal._dofp.analysis, plain._dofp.analysis)


def test_the_bench_skips_angles_whose_spot_leaves_the_sensor():
    cam = sensors.create("polarimeter", "moi_pinhole")  # a 60° perspective camera
    cam.configure_hardware(LENS_ONLY)
    unit = cam.draw_unit(np.random.default_rng(0))
    # f = 2319 px, 1024 px from the centre to the edge: the spot leaves the sensor past 23.8°.
    assert [round(math.degrees(r[0])) for r in unit.calibration.lens_table] == [0, 10, 20]


def test_a_bad_lens_table_or_lens_is_a_clear_error():
    cal = sensors.create("polarimeter", "ideal_bin4").true_calibration()
    with pytest.raises(ValueError, match="lens_table"):
        dataclasses.replace(cal, lens_table=((0.1, 1.0, 0.0, 1.0, 1.0), (0.0, 1.0, 0.0, 1.0, 1.0)))
    with pytest.raises(ValueError, match=r"lens\.surfaces"):
        LensPolarization(surfaces=-1)
    with pytest.raises(ValueError, match=r"lens\.model"):
        LensPolarization(model="zeiss")  # type: ignore[arg-type]
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.render_offline(np.eye(3), 2.0, np.array([0.0, 0.0, 1.0]), np.random.default_rng(0))
    c = cam.true_calibration()
    rows = measure_lens(cam._dofp, c, c, np.random.default_rng(0), incidence_deg=(0.0, 45.0))
    assert len(rows) == 2 and rows[0][1] == 1.0 and abs(rows[1][2]) < 1e-3  # a neutral lens
