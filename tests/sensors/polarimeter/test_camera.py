from __future__ import annotations

import math

import numpy as np
import pytest

from sensors.polarimeter import stokes
from sensors.polarimeter.optics.sky import SkySpec, sky_radiance
from sensors.polarimeter.unit.camera import SENSOR_PROPAGATION, SENSOR_REFERENCE, Camera
from sensors.polarimeter.unit.fisheye import PRESETS, TUM_VI_CAM0_KB, FisheyeSpec, preset
from sensors.polarimeter.unit.port import flat_port_inverse, flat_port_refraction
from twin.core.frames import euler_to_dcm

F_FE185_MM = 1.8
PITCH_MM = 3.45e-3


def _grid(cam: Camera, step: int) -> tuple[np.ndarray, np.ndarray]:
    """A sub-sampled pixel grid including the last row and column."""
    us = np.unique(np.r_[np.arange(0, cam.width, step), cam.width - 1])
    vs = np.unique(np.r_[np.arange(0, cam.height, step), cam.height - 1])
    v, u = np.meshgrid(vs, us, indexing="ij")
    return u.astype(float), v.astype(float)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# --- presets and the image circle ---------------------------------------------------------------


def test_the_snell_papers_lens_is_a_smaller_circle():
    # FE185C046HA-1 (xin2024 §4.1): f = 1.4 mm, r = f·θ(1 + k1θ² + … + k4θ⁸) at θ = 92.5° with the
    # TUM VI fisheye's departure from equidistant: 1.3 % inside the ideal 655.1 full-res px.
    cam = Camera(preset("phx050s_fe185c046"))
    t = math.radians(92.5)
    k1, k2, k3, k4 = TUM_VI_CAM0_KB
    shape = 1 + k1 * t**2 + k2 * t**4 + k3 * t**6 + k4 * t**8
    assert cam.image_circle_radius_px == pytest.approx(1.4 * t * shape / PITCH_MM)
    assert 0.98 < shape < 0.99


@pytest.mark.parametrize("name", ["phx050s_fe185", "imx264_185"])
@pytest.mark.parametrize("binning", [1, 2, 4])
def test_fisheye_presets_185_degree_image_circle(name: str, binning: int) -> None:
    cam = Camera(preset(name, binning=binning))
    assert cam.shape == (2048 // binning, 2448 // binning)
    # Equidistant: r = f θ_max = 1.8 mm · 92.5° = 842.3 full-res px (optics.md §3.5: "842 px").
    r_full = F_FE185_MM * math.radians(92.5) / PITCH_MM
    assert cam.image_circle_radius_px == pytest.approx(r_full / binning, rel=1e-12)
    assert 2 * cam.image_circle_radius_px < cam.height  # the whole 185° circle is on the sensor


def test_valid_mask_is_the_image_circle() -> None:
    cam = Camera(preset("phx050s_fe185", binning=4))
    v, u = np.mgrid[0 : cam.height, 0 : cam.width]
    cu, cv = (cam.width - 1) / 2, (cam.height - 1) / 2
    r = np.hypot(u - cu, v - cv)
    rc = cam.image_circle_radius_px
    assert np.all(cam.valid[r < rc - 1e-6])
    assert not np.any(cam.valid[r > rc + 1e-6])
    assert cam.valid[int(cv), int(cu)] and not cam.valid[0, 0]
    assert np.all(cam.theta[cam.valid] <= math.radians(92.5) + 1e-6)
    assert np.isfinite(cam.rays).all() and np.isfinite(cam.theta).all()


def test_moi_pinhole_rays_are_the_papers_eq_16_18() -> None:
    cam = Camera(preset("moi_pinhole"), dtype=np.float64)  # (per-pixel arrays are not built)
    assert cam.shape == (2448, 2048) and cam.spec.polarization_mapping == "orthographic"
    mx = np.array([1, 2048, 1, 2048, 1024, 1025, 300])  # 1-based, as in the paper
    my = np.array([1, 1, 2448, 2448, 1224, 1225, 2000])
    d = 3.45e-3
    v_b = np.stack([d * (mx - (2048 + 1) / 2), d * (-my + (2448 + 1) / 2), 8.0 + 0 * mx], -1)
    ray, valid = cam.pixel_to_ray(mx - 1, my - 1)
    assert np.all(valid)
    np.testing.assert_allclose(ray, _unit(v_b), atol=1e-14)
    assert Camera(preset("moi_pinhole", binning=4)).valid.all()


# --- round trips, θ ≥ 90° ---------------------------------------------------------------------


def _specs_for_round_trip() -> list[FisheyeSpec]:
    f_px = F_FE185_MM / PITCH_MM
    # An OCamCalib-style polynomial that looks past 90°: g(ρ) = a0 + a2 ρ² (+ a3 ρ³), a0 < 0.
    a0 = -f_px
    ocam = (a0, 0.0, 0.55 / f_px, 2e-5 / f_px**2)
    return [
        preset("phx050s_fe185"),
        preset("phx050s_fe185", binning=2, principal_point_px=(1230.3, 1017.8)),
        preset("imx264_185", binning=4),
        preset("phx050s_fe185", kb_coeffs=(-0.012, 0.0015, -2e-4, 1e-5), focal_length_mm=1.85),
        preset(
            "phx050s_fe185",
            projection="scaramuzza",
            ocam_poly=ocam,
            ocam_affine=(1.0005, 0.0003, -0.0002),
        ),
        preset("moi_pinhole"),
        preset("moi_pinhole", binning=4, principal_point_px=(1000.0, 1250.0)),
    ]


@pytest.mark.parametrize("spec", _specs_for_round_trip(), ids=lambda s: s.projection)
def test_pixel_ray_pixel_round_trip(spec: FisheyeSpec) -> None:
    cam = Camera(spec, dtype=np.float64)
    u, v = _grid(cam, 7 if spec.binning > 1 else 23)
    ray, valid = cam.pixel_to_ray(u, v)
    np.testing.assert_allclose(np.linalg.norm(ray, axis=-1), 1.0, atol=1e-12)
    u2, v2, ok = cam.project(ray)
    assert np.array_equal(ok, valid)
    err = np.hypot(u2 - u, v2 - v)[valid]
    assert err.max() < 1e-3
    if spec.projection != "perspective":
        theta = np.arctan2(np.hypot(ray[..., 0], ray[..., 1]), ray[..., 2])
        beyond = valid & (theta > math.pi / 2)
        assert beyond.sum() > 10  # the round trip covers the ring beyond 90°
        assert np.hypot(u2 - u, v2 - v)[beyond].max() < 1e-3


def test_cached_rays_match_pixel_to_ray_and_binning_centres() -> None:
    full = Camera(preset("phx050s_fe185"), dtype=np.float64)
    b4 = Camera(preset("phx050s_fe185", binning=4), dtype=np.float64)
    k = np.array([0, 5, 100, 305, 611])
    j = np.array([0, 7, 200, 255, 511])
    # Binned pixel k is centred at full-resolution coordinate 4k + 1.5.
    ray_full, _ = full.pixel_to_ray(4 * k + 1.5, 4 * j + 1.5)
    np.testing.assert_allclose(b4.rays[j, k], ray_full, atol=1e-12)
    ray_b4, _ = b4.pixel_to_ray(k, j)
    np.testing.assert_allclose(b4.rays[j, k], ray_b4, atol=1e-12)
    f32 = Camera(preset("phx050s_fe185", binning=4))
    assert f32.rays.dtype == np.float32
    np.testing.assert_allclose(f32.rays, b4.rays, atol=2e-7)


def test_project_beyond_90_degrees_lands_on_the_right_side() -> None:
    # OpenCV's fisheye model maps θ = 91° to the opposite side (optics.md §3.5); ours must not.
    cam = Camera(preset("phx050s_fe185"), dtype=np.float64)
    cu, cv = (cam.width - 1) / 2, (cam.height - 1) / 2
    f_px = F_FE185_MM / PITCH_MM
    for theta_deg in (89.0, 90.0, 91.0, 92.4):
        t = math.radians(theta_deg)
        u, v, ok = cam.project(np.array([math.sin(t), 0.0, math.cos(t)]))
        assert ok and u == pytest.approx(cu + f_px * t, abs=1e-6) and v == pytest.approx(cv)
    _, _, ok = cam.project(np.array([[math.sin(1.62), 0, math.cos(1.62)], [0, 0, -1], [0, 0, 0]]))
    assert not ok.any()  # beyond 92.5°, straight back, and the zero vector


def test_image_axes_north_up_east_right_when_heading_north() -> None:
    cam = Camera(preset("phx050s_fe185"), dtype=np.float64)
    cu, cv = (cam.width - 1) / 2, (cam.height - 1) / 2
    c_b_n = euler_to_dcm(0.0, 0.0, 0.0)  # level, heading North: body y = North, x = East
    north, east = np.array([0.0, 0.6, 0.8]), np.array([0.6, 0.0, 0.8])
    un, vn, _ = cam.project(c_b_n.T @ north)
    ue, ve, _ = cam.project(c_b_n.T @ east)
    assert vn < cv and un == pytest.approx(cu)  # North at the top
    assert ue > cu and ve == pytest.approx(cv)  # East on the right
    # Heading East (yaw = −90°, ENU counter-clockwise): North is now on the left.
    c_b_n = euler_to_dcm(0.0, 0.0, -math.pi / 2)
    un, vn, _ = cam.project(c_b_n.T @ north)
    assert un < cu and vn == pytest.approx(cv)


def test_pixel_solid_angles_sum_to_the_field_of_view() -> None:
    cam = Camera(preset("phx050s_fe185", binning=4), dtype=np.float64)
    total = cam.pixel_solid_angle_sr[cam.valid].sum()
    assert total == pytest.approx(2 * math.pi * (1 - math.cos(math.radians(92.5))), rel=5e-3)
    pin = Camera(preset("moi_pinhole", binning=4), dtype=np.float64)
    # A pinhole pixel at the axis subtends (pitch/f)² sr.
    centre = pin.pixel_solid_angle_sr[pin.height // 2, pin.width // 2]
    assert centre == pytest.approx((4 * PITCH_MM / 8.0) ** 2, rel=1e-4)


def test_rotated_rays() -> None:
    cam = Camera(preset("phx050s_fe185", binning=4))
    r = euler_to_dcm(0.2, -0.1, 1.0)
    w = cam.rotated_rays(r)
    np.testing.assert_allclose(w, cam.rays @ r.T, atol=2e-6)
    with pytest.raises(ValueError, match="orthonormal"):
        cam.rotated_rays(2 * np.eye(3))


# --- housing -------------------------------------------------------------------------------------


def test_flat_port_snell_twice_and_inverse() -> None:
    rng = np.random.default_rng(1)
    d = _unit(rng.normal(size=(500, 3)))
    d[:, 2] = np.abs(d[:, 2])
    n_w, n_g = 1.333, 1.49
    out, ok, ci, cg, co = flat_port_refraction(d, n_w, n_g)
    assert ok.all()
    s_in = np.hypot(d[:, 0], d[:, 1])
    s_out = np.hypot(out[:, 0], out[:, 1])
    np.testing.assert_allclose(n_w * s_out, s_in, atol=1e-12)  # n_a sin θ_a = n_w sin θ_w
    np.testing.assert_allclose(np.sqrt(1 - cg**2) * n_g, s_in, atol=1e-12)  # … = n_g sin θ_g
    np.testing.assert_allclose(ci, d[:, 2], atol=1e-12)
    np.testing.assert_allclose(co, out[:, 2], atol=1e-12)
    # Azimuth kept, unit length, and the whole hemisphere squeezed into Snell's window.
    np.testing.assert_allclose(d[:, 0] * out[:, 1] - d[:, 1] * out[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, atol=1e-12)
    assert np.degrees(np.arccos(out[:, 2].min())) < math.degrees(math.asin(1 / n_w)) + 1e-9
    back, ok2 = flat_port_inverse(out, n_w)
    assert ok2.all()
    np.testing.assert_allclose(back, d, atol=1e-9)
    # Behind the port / beyond the critical angle: invalid, finite.
    bad_in, ok3, *_ = flat_port_refraction(np.array([[1.0, 0.0, -0.1]]), n_w, n_g)
    t = math.asin(1 / n_w) + 1e-3
    bad_out, ok4 = flat_port_inverse(np.array([[math.sin(t), 0.0, math.cos(t)]]), n_w)
    assert not ok3.any() and not ok4.any()
    assert np.isfinite(bad_in).all() and np.isfinite(bad_out).all()
    with pytest.raises(ValueError, match="n_outside"):
        flat_port_refraction(d, 0.5, 1.5)


def test_flat_port_camera_sees_snells_window_only() -> None:
    spec = preset("phx050s_fe185", binning=4, housing="flat")
    cam = Camera(spec)
    port = cam.outside(1.333)
    assert port.housing == "flat" and len(port.interfaces()) == 2
    # Lens rays at θ ≥ 90° never leave the housing.
    assert not np.any(port.valid & (cam.theta >= math.pi / 2))
    assert np.all(port.valid == (cam.valid & (cam.theta < math.pi / 2)))
    theta_w = np.arccos(np.clip(port.directions[..., 2][port.valid], -1, 1))
    assert theta_w.max() <= math.asin(1 / 1.333) + 1e-6
    assert np.isfinite(port.directions).all()
    # Round trip through project_outside.
    u, v, ok = cam.project_outside(port.directions[::17, ::17], 1.333)
    vv, uu = np.mgrid[0 : cam.height : 17, 0 : cam.width : 17]
    sel = port.valid[::17, ::17]
    assert ok[sel].all()  # (invalid pixels carry the port normal, which projects anywhere)
    assert np.abs(u[sel] - uu[sel]).max() < 1e-2 and np.abs(v[sel] - vv[sel]).max() < 1e-2
    dome = Camera(preset("phx050s_fe185", binning=4)).outside(1.333)
    assert dome.interfaces() == () and np.array_equal(dome.valid, cam.valid)


# --- polarization through the lens ----------------------------------------------------------------


def test_meridional_sensor_reference() -> None:
    cam = Camera(preset("phx050s_fe185", binning=4), dtype=np.float64)
    ref = cam.sensor_reference
    np.testing.assert_allclose(np.sum(ref * cam.rays, axis=-1), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(ref, axis=-1), 1.0, atol=1e-12)
    # Radial E-vectors (in the ray's meridional plane) land radial on the sensor.
    p = cam.rays
    radial = _unit(np.stack([p[..., 0], p[..., 1], np.zeros_like(p[..., 0])], -1) + 1e-300)
    e3d = _unit(radial - np.sum(radial * p, -1, keepdims=True) * p)
    s_in = stokes.from_evector(np.ones(cam.shape), np.ones(cam.shape), e3d, -p, ref)
    s_sens = cam.to_sensor_stokes(s_in, ref)
    e_img = stokes.to_evector(s_sens, SENSOR_PROPAGATION, SENSOR_REFERENCE)
    sel = cam.valid & (cam.theta > 0.05)
    cos_to_radial = np.abs(np.sum(e_img * radial, axis=-1))[sel]
    np.testing.assert_allclose(cos_to_radial, 1.0, atol=1e-9)


def test_sensor_stokes_orientation_convention() -> None:
    # On the axis both mappings agree: an E-vector along camera y is at ψ = −90° ≡ 90° from +x
    # (ψ turns from +x towards d × ref = −y), i.e. Q = −I·P, U = 0.
    for mapping in ("meridional", "orthographic"):
        cam = Camera(preset("phx050s_fe185", polarization_mapping=mapping), dtype=np.float64)
        p = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
        ref = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        s_in = np.array([[1.0, -0.5, 0.0], [1.0, 0.0, 0.5]])  # y-polarized, then +45° from y
        s_out = cam.to_sensor_stokes(s_in, ref, rays=p)
        np.testing.assert_allclose(s_out[0], [1.0, -0.5, 0.0], atol=1e-12)
        # From ref y about d = −z, +45° turns towards d × y = x: the axis (x + y)/√2, whose angle
        # from +x about −z is −45°: Q = 0, U = −0.5.
        np.testing.assert_allclose(s_out[1], [1.0, 0.0, -0.5], atol=1e-12)


# --- validation --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"binning": 3}, "binning"),
        ({"width_px": 2447}, "width_px"),
        ({"height_px": -8}, "height_px"),
        ({"width_px": 2448 * 1.0}, "width_px"),
        ({"pixel_pitch_um": -3.45}, "pixel_pitch_um"),
        ({"focal_length_mm": float("nan")}, "focal_length_mm"),
        ({"projection": "fisheye"}, "projection"),
        ({"max_field_angle_deg": 185.0}, "max_field_angle_deg"),
        ({"kb_coeffs": (-0.3, 0.0, 0.0, 0.0)}, "kb_coeffs"),
        ({"projection": "scaramuzza", "ocam_poly": (500.0, 0.0, 1e-3)}, "ocam_poly"),
        ({"ocam_affine": (0.0, 0.0, 0.0)}, "ocam_affine"),
        ({"principal_point_px": (float("inf"), 0.0)}, "principal_point_px"),
        ({"housing": "glass"}, "housing"),
        ({"port_glass_index": 0.9}, "port_glass_index"),
        ({"polarization_mapping": "none"}, "polarization_mapping"),
    ],
)
def test_spec_validation(overrides: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        preset("phx050s_fe185", **overrides)


def test_perspective_field_angle_limit_and_unknown_preset() -> None:
    with pytest.raises(ValueError, match="max_field_angle_deg"):
        preset("moi_pinhole", max_field_angle_deg=90.0)
    with pytest.raises(ValueError, match="preset"):
        preset("gopro")
    assert set(PRESETS) == {"phx050s_fe185", "phx050s_fe185c046", "imx264_185", "moi_pinhole"}


@pytest.mark.parametrize("mapping", ["meridional", "orthographic"])
def test_sensor_stokes_from_meridian_fast_path(mapping: str) -> None:
    cam = Camera(preset("phx050s_fe185", binning=4, polarization_mapping=mapping), dtype=np.float64)
    r = euler_to_dcm(0.3, -0.2, 1.0)
    s = np.array([0.3, -0.5, math.sqrt(1 - 0.34)])
    sky = sky_radiance(cam.rays, s, SkySpec(**{"sun_relative_radiance": 0.0}), rotation=r)
    fast = cam.sensor_stokes_from_meridian(sky.stokes, r)
    slow = cam.to_sensor_stokes(sky.stokes, sky.reference())
    np.testing.assert_allclose(fast, slow, atol=1e-12 * sky.stokes[..., 0].max())
    # Level camera, world zenith on a pixel centre (principal point at an integer pixel): North.
    spec = preset("phx050s_fe185", binning=4, principal_point_px=(1225.5, 1021.5))
    cam = Camera(spec, dtype=np.float64)
    assert np.any(np.all(cam.rays == [0.0, 0.0, 1.0], axis=-1))
    sky = sky_radiance(cam.rays, s, SkySpec(), rotation=np.eye(3))
    buf = np.empty((3, *cam.shape))
    fast = cam.sensor_stokes_from_meridian(sky.stokes, np.eye(3), out=buf)
    np.testing.assert_allclose(fast, cam.to_sensor_stokes(sky.stokes, sky.reference()), atol=1e-12)
    assert np.shares_memory(fast, buf)
