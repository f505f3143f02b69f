from __future__ import annotations

import math

import numpy as np
import pytest

from sensors.polarimeter import stokes
from sensors.polarimeter.unit.calibration import calibration_from_spec
from sensors.polarimeter.unit.camera import SENSOR_PROPAGATION, SENSOR_REFERENCE, Camera
from sensors.polarimeter.unit.fisheye import preset
from sensors.polarimeter.unit.mosaic import preset as sensor_preset


@pytest.mark.parametrize(
    ("name", "binning"),
    [
        ("phx050s_fe185", 1),
        ("phx050s_fe185", 2),
        ("phx050s_fe185", 4),
        ("moi_pinhole", 1),
        ("moi_pinhole", 2),
        ("moi_pinhole", 4),
    ],
)
def test_onboard_rays_equal_world_rays(name: str, binning: int) -> None:
    spec = preset(name, binning=binning)
    cam = Camera(spec, dtype=np.float64)
    cal = calibration_from_spec(spec)
    assert (cal.width_px, cal.height_px) == (cam.width, cam.height)
    # A sub-sample of the frame including its four edges (the full frame at binning 1 is 5 MP).
    v, u = np.meshgrid(
        np.r_[0 : cam.height : 7, cam.height - 1], np.r_[0 : cam.width : 5, cam.width - 1],
        indexing="ij",
    )  # fmt: skip
    ours, ok = cal.pixel_to_ray(u.astype(float), v.astype(float))
    world, ok_w = cam.pixel_to_ray(u, v)
    inside = ok_w  # beyond the image circle both only extrapolate
    np.testing.assert_array_equal(ok, ok_w)
    np.testing.assert_allclose(ours[inside], world[inside], atol=1e-12)
    if name == "phx050s_fe185":
        theta = np.arccos(np.clip(world[..., 2], -1, 1))
        assert (theta[inside] > math.radians(90.5)).any()  # θ > 90° is covered
    # The cached per-pixel rays of the Stokes grid equal the world's rays at the same points.
    rays, valid = cal.rays("interpolate")
    np.testing.assert_allclose(rays[valid], cam.rays[cam.valid], atol=1e-12)
    # And projection is the inverse of the world's back-projection.
    pu, pv, pvalid = cal.project(world[inside])
    np.testing.assert_allclose(pu, u[inside], atol=1e-6)
    np.testing.assert_allclose(pv, v[inside], atol=1e-6)
    assert pvalid.all()


@pytest.mark.parametrize("name", ["phx050s_fe185", "moi_pinhole"])
def test_evectors_match_the_world_lens_mapping(name: str) -> None:
    """An AoP read off the world's sensor-plane Stokes lifts back to the E-vector that made it."""
    spec = preset(name, binning=4)
    cam = Camera(spec, dtype=np.float64)
    cal = calibration_from_spec(spec)
    rng = np.random.default_rng(3)
    p = cam.rays
    # Random E-vectors ⟂ each ray, as Stokes referenced to an arbitrary axis ⟂ the ray.
    a = rng.normal(size=p.shape)
    e = a - np.sum(a * p, axis=-1, keepdims=True) * p
    e /= np.linalg.norm(e, axis=-1, keepdims=True)
    ref = np.cross(p, [0.3, 0.5, 0.8])
    ref /= np.linalg.norm(ref, axis=-1, keepdims=True)
    s = stokes.from_evector(np.ones(p.shape[:2]), np.ones(p.shape[:2]), e, -p, ref)
    s_sensor = cam.to_sensor_stokes(s, ref)
    aop, _ = stokes.to_aop_dop(s_sensor)
    lifted = cal.evectors(aop, "interpolate")
    valid = cam.valid & (p[..., 2] > 0.05)
    # Lines, not arrows: |cos| of the angle between them is 1.
    dots = np.abs(np.sum(lifted * e, axis=-1))[valid]
    assert dots.min() > 1 - 1e-9
    # The world's own sensor-plane axes agree with the calibration's meridional ones.
    if spec.polarization_mapping == "meridional":
        r_s, _ = cal.sensor_axes("interpolate")
        np.testing.assert_allclose(r_s[valid], cam.sensor_reference[valid], atol=1e-12)
    e_img = stokes.to_evector(s_sensor, SENSOR_PROPAGATION, SENSOR_REFERENCE)
    assert np.isfinite(e_img).all()


def test_sensor_spec_carries_layout_and_saturation() -> None:
    cal = calibration_from_spec(preset("phx050s_fe185"), sensor_preset("imx250mzr"))
    assert cal.layout_deg == sensor_preset("imx250mzr").layout_deg
    assert cal.saturation_dn == sensor_preset("imx250mzr").saturation_dn


def test_scaramuzza_is_refused() -> None:
    spec = preset("phx050s_fe185", projection="scaramuzza", ocam_poly=(-600.0, 0.0, 1e-4))
    with pytest.raises(ValueError, match="scaramuzza"):
        calibration_from_spec(spec)
