"""The assembled polarimeter: Snell's window where it belongs, valid frames in odd situations."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scene_world import WIDE_PIER, SceneWorld

import sensors
from sensors.polarimeter.optics.surface import snell_window_half_angle
from sensors.polarimeter.render import OpticsConfig, Polarimeter, PolarimeterSpec
from twin.core.frames import euler_to_dcm
from twin.onboard.polarization import stokes_from_mosaic


def _sun(zenith_deg: float, azimuth_deg: float) -> np.ndarray:
    z, a = math.radians(zenith_deg), math.radians(azimuth_deg)
    return np.array([math.sin(z) * math.sin(a), math.sin(z) * math.cos(a), math.cos(z)])


def _camera(preset: str = "ideal_bin4", **optics: object) -> Polarimeter:
    cam = sensors.create("polarimeter", preset)
    assert isinstance(cam, Polarimeter)
    cam.configure(OpticsConfig(**optics))  # type: ignore[arg-type]
    return cam


def _angle_to_zenith_deg(cam: Polarimeter, c_cn: np.ndarray) -> np.ndarray:
    up = cam.camera.rays.astype(np.float64) @ c_cn[2]
    return np.degrees(np.arccos(np.clip(up, -1.0, 1.0)))


# --- Snell's window ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("salinity", "temperature", "wavelength", "lo", "hi"),
    [(0.0, 20.0, 589.0, 48.55, 48.65), (35.0, 15.0, 500.0, 48.0, 48.25)],
)
def test_snell_window_half_angle_and_image_radius_for_a_level_camera(
    salinity, temperature, wavelength, lo, hi
):
    cam = _camera(salinity_psu=salinity, temperature_c=temperature, wavelength_nm=wavelength)
    theta_c = math.degrees(float(snell_window_half_angle(cam.n_water)))
    assert lo <= theta_c <= hi
    _, truth = cam.render_offline(np.eye(3), 3.0, _sun(30, 100), np.random.default_rng(0))
    ang = _angle_to_zenith_deg(cam, np.eye(3))
    win = truth.snell_window
    # Every window pixel lies inside θ_c, every pixel well inside it is in the window.
    px_deg = math.degrees(1.0 / cam.camera.spec.focal_length_px * cam.camera.spec.binning)
    assert ang[win].max() <= theta_c + 1e-6
    assert np.all(win[ang < theta_c - px_deg])
    # Image radius of the window edge: f·θ_c of the equidistant lens (binned pixels).
    v, u = np.nonzero(win)
    cu, cv = cam.camera.spec.principal_point_full_px
    b = cam.camera.spec.binning
    r = np.hypot(u * b + (b - 1) / 2 - cu, v * b + (b - 1) / 2 - cv).max() / b
    expected = cam.camera.spec.focal_length_px * math.radians(theta_c) / b
    assert abs(r - expected) < 1.0


def test_the_rendered_intensity_drops_at_the_window_edge():
    cam = _camera(jerlov_type="IB")
    raw, _truth = cam.render_offline(np.eye(3), 2.0, _sun(35, 40), np.random.default_rng(1))
    s0 = stokes_from_mosaic(raw, method="interpolate").s0
    ang = _angle_to_zenith_deg(cam, np.eye(3))
    theta_c = math.degrees(float(snell_window_half_angle(cam.n_water)))
    inside = s0[(ang > theta_c - 6) & (ang < theta_c - 2)].mean()
    outside = s0[(ang > theta_c + 2) & (ang < theta_c + 6)].mean()
    assert inside > 3.0 * outside


@pytest.mark.parametrize(("roll", "pitch"), [(20.0, 0.0), (0.0, -25.0), (30.0, 15.0)])
def test_the_window_follows_the_world_zenith_when_the_camera_tilts(roll, pitch):
    cam = _camera()
    c = euler_to_dcm(math.radians(roll), math.radians(pitch), 0.4)
    _, truth = cam.render_offline(c, 5.0, _sun(40, 200), np.random.default_rng(2))
    ang = _angle_to_zenith_deg(cam, c)
    theta_c = math.degrees(float(snell_window_half_angle(cam.n_water)))
    px_deg = math.degrees(cam.camera.spec.binning / cam.camera.spec.focal_length_px)
    win = truth.snell_window
    assert win.any()
    assert ang[win].max() <= theta_c + 1e-6
    assert np.all(win[(ang < theta_c - px_deg) & cam.camera.valid])
    # The window's centroid moved away from the image centre, towards the zenith's pixel.
    u_z, v_z, ok = cam.camera.project(c[2])
    assert ok
    v, u = np.nonzero(win)
    h, w = cam.camera.shape
    shift = np.hypot(u.mean() - (w - 1) / 2, v.mean() - (h - 1) / 2)
    assert shift > 0.5 * np.hypot(u_z - (w - 1) / 2, v_z - (h - 1) / 2)
    assert np.hypot(u.mean() - u_z, v.mean() - v_z) < 0.2 * shift + 3


def test_the_sun_pixel_is_the_brightest_spot_of_a_shallow_frame():
    cam = _camera()
    _raw, truth = cam.render_offline(np.eye(3), 1.0, _sun(30, 60), np.random.default_rng(3))
    assert truth.sun_pixel is not None
    s0 = truth.stokes[..., 0]
    v, u = np.unravel_index(np.argmax(s0), s0.shape)
    assert math.hypot(u - truth.sun_pixel[0], v - truth.sun_pixel[1]) < 2.0


# --- odd situations: valid frames, no NaN, no exception ------------------------------------------
def _check_valid(raw: np.ndarray, cam: Polarimeter) -> None:
    assert raw.dtype == np.uint16
    assert raw.shape == cam.camera.shape
    assert int(raw.max()) <= cam.pspec.sensor_spec().saturation_dn


def test_a_night_frame_is_dark_and_valid():
    cam = _camera("phx050s_p_bin4")
    raw, truth = cam.render_offline(np.eye(3), 5.0, _sun(100, 80), np.random.default_rng(4))
    _check_valid(raw, cam)
    assert truth.night
    assert truth.sun_pixel is None
    black = cam.pspec.sensor_spec().black_level_dn
    assert float(np.mean(raw)) < black + 2.0
    assert np.all(np.isfinite(truth.stokes)) and float(truth.stokes.max()) == 0.0


def test_a_camera_pointing_down_sees_no_window_and_stays_finite():
    cam = _camera("phx050s_p_bin4")
    raw, truth = cam.render_offline(
        euler_to_dcm(math.pi, 0.0, 0.0), 5.0, _sun(30, 0), np.random.default_rng(5)
    )
    _check_valid(raw, cam)
    assert not truth.snell_window.any()
    assert np.all(np.isfinite(truth.stokes))
    assert float(truth.stokes[..., 0].min()) >= 0.0


def test_a_30_degree_tilted_frame_in_air_and_in_water_is_valid():
    cam = _camera("phx050s_p_bin4")
    c = euler_to_dcm(math.radians(30), 0.0, 1.0)
    for depth in (-0.5, 0.2, 12.0):
        raw, truth = cam.render_offline(c, depth, _sun(50, 300), np.random.default_rng(6))
        _check_valid(raw, cam)
        assert np.all(np.isfinite(truth.stokes))
        assert truth.snell_window.any()


# --- occlusion in a real MuJoCo scene ------------------------------------------------------------
def test_a_pier_above_the_camera_blocks_the_sky_but_not_the_scattered_light():
    frames = {}
    for pier in (False, True):
        world = SceneWorld(WIDE_PIER if pier else "")
        cam = _camera("ideal_bin4", jerlov_type="IB")
        rng = np.random.default_rng(7)
        cam.reset(world, rng)
        cam.sample(world, rng)
        frames[pier] = cam.truth
    open_sky, covered = frames[False], frames[True]
    up = (open_sky.snell_window | ~open_sky.occluded) & _camera().camera.valid
    assert open_sky.snell_window.any() and not open_sky.occluded[open_sky.snell_window].any()
    assert not covered.snell_window.any()
    assert covered.occluded[up & open_sky.snell_window].all()
    s_open = open_sky.stokes[..., 0][open_sky.snell_window].mean()
    s_cov = covered.stokes[..., 0][open_sky.snell_window].mean()
    # Only scattered light is left (about 30 % of the window here; the pier does not shade the
    # scattering volume: not modelled).
    assert 0.0 < s_cov < 0.5 * s_open
    assert np.all(np.isfinite(covered.stokes))


def test_the_vehicle_hull_does_not_occlude_the_sky_above_the_camera():
    world = SceneWorld()
    cam = _camera("ideal_bin4")
    rng = np.random.default_rng(8)
    cam.reset(world, rng)
    cam.sample(world, rng)
    ang = _angle_to_zenith_deg(cam, np.eye(3))
    assert not cam.truth.occluded[(ang < 80) & cam.camera.valid].any()


# --- determinism and bad input -------------------------------------------------------------------
def test_same_seed_same_frame_other_seed_other_frame():
    def frame(seed: int) -> np.ndarray:
        cam = _camera("phx050s_p_bin4")
        return cam.render_offline(np.eye(3), 8.0, _sun(45, 10), np.random.default_rng(seed))[0]

    a, b, c = frame(11), frame(11), frame(12)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_binning_keeps_the_signal_to_noise_physics():
    full = sensors.create("polarimeter", "phx050s_p").spec
    assert isinstance(full, PolarimeterSpec)
    binned = dataclasses.replace(full, binning=4)
    s1, s4 = full.sensor_spec(), binned.sensor_spec()
    assert s4.full_well_e == pytest.approx(16 * s1.full_well_e)
    assert s4.read_noise_e == pytest.approx(4 * s1.read_noise_e)
    assert s4.saturation_dn == s1.saturation_dn


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"binning": 3}, "binning"),
        ({"camera": "nope"}, "camera"),
        ({"f_number": -2.0}, "f_number"),
        ({"exposure_us": float("nan")}, "exposure_us"),
        ({"occlusion_stride_px": 0}, "occlusion_stride_px"),
    ],
)
def test_bad_polarimeter_specs_name_the_field(overrides, field):
    with pytest.raises(ValueError, match=field):
        sensors.create("polarimeter", "phx050s_p", **overrides)


def test_bad_optics_and_bad_offline_input_name_the_field():
    with pytest.raises(ValueError, match="jerlov_type"):
        OpticsConfig(jerlov_type="XX")
    cam = _camera()
    with pytest.raises(ValueError, match="depth_m"):
        cam.render_offline(np.eye(3), float("nan"), _sun(30, 0), np.random.default_rng(0))
    with pytest.raises(ValueError, match="sun"):
        cam.render_offline(np.eye(3), 3.0, np.array([0.0, 0.0, 2.0]), np.random.default_rng(0))
    with pytest.raises(ValueError, match="c_cn"):
        cam.render_offline(2 * np.eye(3), 3.0, _sun(30, 0), np.random.default_rng(0))


def test_a_flat_port_sees_only_the_water_within_its_own_critical_cone():
    cam = sensors.create("polarimeter", "ideal_bin4", housing="flat")
    assert isinstance(cam, Polarimeter)
    cam.configure(OpticsConfig())
    raw, truth = cam.render_offline(np.eye(3), 3.0, _sun(30, 100), np.random.default_rng(9))
    _check_valid(raw, cam)
    assert np.all(np.isfinite(truth.stokes))
    # Lens rays at or beyond 90° never leave the housing: dark there (only the black level).
    lens_theta = np.degrees(cam.camera.theta.astype(np.float64))
    assert float(truth.stokes[..., 0][lens_theta > 90.5].max()) == 0.0
    # Through a flat port the in-water field is the cone asin(1/n) ≈ 48° about the axis, so
    # Snell's window (also 48°) fills what the lens can see: the window covers most lit pixels.
    lit = truth.stokes[..., 0] > 0
    assert truth.snell_window[lit].mean() > 0.9
    dome = _camera()
    _, t_dome = dome.render_offline(np.eye(3), 3.0, _sun(30, 100), np.random.default_rng(9))
    assert truth.snell_window.sum() > 1.5 * t_dome.snell_window.sum()  # the window is magnified


def test_render_offline_sees_the_wavy_sea_and_its_waves_evolve_with_t():
    """Offline frames get the scenario's sea state, time-correlated, as a run's frames do."""
    sun = _sun(40, 120)

    def frames(wind: float, ts: tuple[float, ...], seed: int = 9) -> list:
        cam = _camera("ideal_bin4", wind_speed_mps=wind)
        rng = np.random.default_rng(seed)
        return [cam.render_offline(np.eye(3), 1.0, sun, rng, t=t)[1] for t in ts]

    flat = frames(0.0, (0.0,))[0]
    a0, a1, a5 = frames(5.0, (0.0, 0.05, 5.0))  # 5 m/s: a table node (computed once)
    b0 = frames(5.0, (0.0,))[0]
    assert np.array_equal(a0.stokes, b0.stokes)  # same seed, same sea
    # The waves move the window's rim: its mask differs from the flat sea's ...
    assert 0.002 < np.mean(a0.snell_window != flat.snell_window) < 0.2
    # ... and the sea evolves: 50 ms later it has changed a little, 5 s later much more.
    d_short = np.mean(a1.snell_window != a0.snell_window)
    d_long = np.mean(a5.snell_window != a0.snell_window)
    assert 0.0 < d_short < d_long
    with pytest.raises(ValueError, match="t:"):
        _camera("ideal_bin4").render_offline(
            np.eye(3), 1.0, sun, np.random.default_rng(0), t=math.nan
        )
