"""The compiled exact chain (sensors/polarimeter/chain_kernel.py) equals the numpy chain.

The numpy chain (``FastPath.compiled_chain = False``) is the reference: the same formulas in
float32 numpy passes. The compiled chain computes them in float64 from the same float32 rays and
rounds once, so the two agree to float32 rounding (measured: S0 within 6e-5 relative, the
largest at grazing sky directions where the CIE sky's exp(b / cos Z) magnifies float32's
rounding of cos Z; Q and U within 4e-6 of S0), and Snell's window mask is identical. Within
~1e-7 rad of the world's zenith the meridian reference turns by large angles between
neighbouring float32 rays and both chains' Q, U there are float32 noise; those rays are left
out of the polarization check.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter import chain_kernel
from sensors.polarimeter.optics.sky import SkySpec
from sensors.polarimeter.render import OpticsConfig, Polarimeter
from sensors.polarimeter.unit import camera as camera_mod
from twin.core.frames import euler_to_dcm


def _sun(zenith_deg: float, azimuth_deg: float) -> np.ndarray:
    z, a = math.radians(zenith_deg), math.radians(azimuth_deg)
    return np.array([math.sin(z) * math.sin(a), math.sin(z) * math.cos(a), math.cos(z)])


def _camera(**optics: object) -> Polarimeter:
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    assert isinstance(cam, Polarimeter)
    cam.configure(OpticsConfig(**optics))  # type: ignore[arg-type]
    return cam


def _rays(cam: Polarimeter, c: np.ndarray, sun_look: np.ndarray | None, seed: int) -> np.ndarray:
    """Rays over the whole sphere, a cluster around the refracted sun, a band at the window edge."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(6000, 3))
    look = c.T @ (sun_look if sun_look is not None else np.array([0.0, 0.0, 1.0]))
    near = look + rng.normal(scale=0.01, size=(1500, 3))
    # Within ±0.5° of Snell's window edge, any azimuth (world frame, then into the camera's).
    edge = math.asin(1.0 / cam.n_water) + np.radians(rng.uniform(-0.5, 0.5, 1500))
    az = rng.uniform(0.0, 2.0 * math.pi, 1500)
    rim = np.stack([np.sin(edge) * np.cos(az), np.sin(edge) * np.sin(az), np.cos(edge)], -1) @ c
    v = np.concatenate([v, near, rim])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return v.astype(np.float32)


SCENES = [
    # jerlov type, depth (m), sun zenith (deg), attitude, sky
    ("II", 10.0, 40.0, np.eye(3), SkySpec()),
    ("3C", 1.0, 60.0, euler_to_dcm(0.3, -0.2, 1.0), SkySpec()),
    ("IB", 0.2, 75.0, euler_to_dcm(0.5, 0.1, 2.0), SkySpec()),
    ("II", 5.0, 60.0, euler_to_dcm(0.3, -0.2, 2.5), SkySpec(cie_type=3)),  # overcast
    ("I", 15.0, 20.0, euler_to_dcm(math.pi, 0.0, 0.0), SkySpec()),
]


def _both(cam: Polarimeter, *args, **kwargs):
    cam.compiled_chain = True
    a = cam._render_points(*args, **kwargs)
    cam.compiled_chain = False
    b = cam._render_points(*args, **kwargs)
    cam.compiled_chain = True
    return a, b


def _check(a: np.ndarray, b: np.ndarray, world: np.ndarray) -> None:
    assert a.dtype == np.float32 and np.all(np.isfinite(a)) and np.all(a[:, 0] >= 0)
    s0 = np.maximum(b[:, 0], 1e-30)
    assert np.max(np.abs(a[:, 0] - b[:, 0]) / s0) < 1e-4
    away = np.hypot(world[:, 0], world[:, 1]) > 1e-4  # not the zenith (module docstring)
    pol = np.hypot(a[:, 1] - b[:, 1], a[:, 2] - b[:, 2]) / s0
    assert np.max(pol[away]) < 2e-5


@pytest.mark.parametrize(("jerlov", "depth", "sun_zen", "c", "sky"), SCENES)
def test_the_compiled_chain_equals_the_numpy_chain(jerlov, depth, sun_zen, c, sky):
    cam = _camera(jerlov_type=jerlov, sky=sky)
    s = _sun(sun_zen, 37.0)
    fc = cam._frame_constants(s, s, depth)
    v = _rays(cam, c, fc.sun_look, seed=int(depth * 10))
    basis = camera_mod.sensor_basis(v, np.float32)
    psf = np.full(len(v), 0.004, dtype=np.float32)
    world = v.astype(np.float64) @ c.T
    (a, sees_a, _), (b, sees_b, _) = _both(cam, v, basis, psf, c, fc)
    assert np.array_equal(sees_a, sees_b)
    assert 0 < sees_a.sum() < len(v)
    _check(a, b, world)
    # The disc was found: the brightest ray is the sun's, many times the window's median.
    if fc.sun_look is not None and sun_zen < 70 and sky == SkySpec():  # a clear sky
        assert a[:, 0].max() > 1e3 * np.median(a[sees_a, 0])
    # Occluded rays keep only the scattered light; "split" returns that part too.
    occ = np.random.default_rng(1).random(len(v)) < 0.2
    (a, sees_a, sa), (b, _, sb) = _both(cam, v, basis, psf, c, fc, occ, "split")
    assert sa is not None and sb is not None
    _check(a, b, world)
    _check(sa, sb, world)
    assert np.array_equal(a[occ], sa[occ])  # no window light on an occluded ray


def test_a_fast_frame_with_the_compiled_chain_equals_one_without():
    cam = _camera()
    c = euler_to_dcm(math.radians(15), math.radians(-5), 0.7)
    s = _sun(35, 120)
    cam.compiled_chain = True
    a, win_a, _, _ = cam.render_stokes(None, np.zeros(3), c, 6.0, s)
    cam.compiled_chain = False
    b, win_b, _, _ = cam.render_stokes(None, np.zeros(3), c, 6.0, s)
    assert np.array_equal(win_a, win_b)
    world = cam.camera.rays.reshape(-1, 3).astype(np.float64) @ c.T
    valid = cam.camera.valid.reshape(-1)
    _check(a.reshape(-1, 3)[valid], b.reshape(-1, 3)[valid], world[valid])


@pytest.mark.parametrize(
    ("sky", "sun_zen"), [(SkySpec(polarization="berry"), 40.0), (SkySpec(), 100.0)]
)
def test_skies_the_kernel_does_not_cover_take_the_numpy_chain(sky, sun_zen):
    """Berry's sky and the night fall back: the frame is the numpy chain's bit for bit."""
    s = _sun(sun_zen, 10.0)
    assert not chain_kernel.applies(sky, s)
    cam = _camera(sky=sky)
    a = cam.render_stokes(None, np.zeros(3), np.eye(3), 5.0, s)[0]
    cam.compiled_chain = False
    b = cam.render_stokes(None, np.zeros(3), np.eye(3), 5.0, s)[0]
    assert np.array_equal(a, b)


def test_the_scattering_kernels_fourth_row_is_the_direct_lights_transmittance():
    """The chain reads e^(−c z / v_z) from the scattering kernel (column_kernel.scatter_pixels);
    its first three rows are the same with or without the fourth."""
    from sensors.polarimeter.optics import column_kernel, surface

    cam = _camera(jerlov_type="II")
    s = _sun(40.0, 30.0)
    beam = surface.refract_sun_beam(s, cam.n_water)
    fc = cam._frame_constants(s, s, 10.0)
    k = cam._column._kernel_args(fc.state, True, True)
    v = _rays(cam, np.eye(3), beam.look_dir, 3).astype(np.float64)
    x, y, z = (np.ascontiguousarray(v[:, i]) for i in range(3))
    three, four = np.empty((3, len(x))), np.empty((4, len(x)))
    column_kernel.scatter_pixels(x, y, z, three, *k)
    column_kernel.scatter_pixels(x, y, z, four, *k)
    assert np.array_equal(four[:3], three)
    cz = k[1]
    want = [math.exp(-cz / vz) if vz > 0 else 0.0 for vz in z]
    np.testing.assert_allclose(four[3], want, rtol=1e-15, atol=0.0)
    assert cz > 0 and (four[3][z <= 0] == 0).all() and (four[3][z > 0.2] > 0).all()
