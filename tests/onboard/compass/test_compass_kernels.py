"""The compiled per-pixel chains of POL and LIG equal their numpy references (issue #31).

``twin.onboard.compass.kernels`` sums each pixel's constraint into Σ w v vᵀ in one compiled loop;
the numpy chains (``pol.pol_constraints``, ``lig._jacobian_normals``) are the slow paths they
replace. Same geometry, random AoP/DoP and gradients, tilted camera, both ports: the moments
agree to 1e-12 (relative), and so do the eigen-solutions the methods take from them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import sensors
from twin.core.frames import euler_to_dcm
from twin.onboard.compass import kernels
from twin.onboard.compass.analysis_grid import (
    analysis_geometry,
    eigen_from_moments,
    resolve_by_intensity,
    resolve_by_intensity_at,
    smallest_eigenvector,
)
from twin.onboard.compass.geometry import critical_angle
from twin.onboard.compass.lig import _jacobian_normals
from twin.onboard.compass.pol import pol_constraints

N_W = 1.338


def _setup(housing: str, seed: int):
    cam = sensors.create("polarimeter", "ideal_bin4", housing=housing)
    cal = cam.true_calibration()
    geo = analysis_geometry(cal, 2, N_W if housing == "flat" else 1.0)
    c_c_h = euler_to_dcm(0.12, -0.2, 0.0) @ cal.c_c_b
    cos_r = geo.rays @ c_c_h[2]
    idx = np.flatnonzero(geo.valid & (cos_r > math.cos(critical_angle(N_W))))
    return cal, geo, c_c_h, idx, np.random.default_rng(seed)


def _same_solution(mat, wsum, n, vecs, weights):
    ref = smallest_eigenvector(vecs, weights)
    got = eigen_from_moments(mat, wsum, n)
    np.testing.assert_allclose(got.eigenvalues, ref.eigenvalues, rtol=1e-9, atol=1e-14)
    assert abs(abs(float(got.s @ ref.s)) - 1.0) < 1e-12


@pytest.mark.parametrize(
    ("housing", "fresnel", "dop_weight"),
    [("dome", True, False), ("dome", False, True), ("flat", True, True)],
)
def test_pol_moments_equal_the_numpy_chain(housing, fresnel, dop_weight):
    cal, geo, c_c_h, idx, rng = _setup(housing, 1)
    assert idx.size > 1000
    aop = rng.uniform(-math.pi / 2, math.pi / 2, idx.size)
    dop = rng.uniform(0.0, 1.0, idx.size)
    dop[:5] = 0.0  # unpolarized pixels: ψ_a from −B alone
    vecs = pol_constraints(geo, cal, idx, aop, dop, c_c_h, N_W, fresnel)
    w = dop if dop_weight else np.ones(idx.size)
    r_s, t_s = geo.cal.sensor_axes("interpolate")
    mat, wsum = kernels.pol_moments(
        idx, aop, dop, geo.rays.reshape(-1, 3), r_s.reshape(-1, 3), t_s.reshape(-1, 3),
        geo.cal.rays("interpolate")[0].reshape(-1, 3), c_c_h, N_W, fresnel, housing == "flat",
        dop_weight,
    )  # fmt: skip
    np.testing.assert_allclose(mat, (vecs * w[:, None]).T @ vecs, rtol=0, atol=1e-12 * wsum)
    assert wsum == pytest.approx(w.sum(), rel=1e-12)
    _same_solution(mat, wsum, idx.size, vecs, w if dop_weight else None)


@pytest.mark.parametrize(
    ("housing", "sphere", "grad_weight"),
    [("dome", "air", False), ("dome", "water", True), ("flat", "air", True)],
)
def test_lig_moments_equal_the_numpy_chain(housing, sphere, grad_weight):
    _, geo, c_c_h, idx, rng = _setup(housing, 2)
    shape = geo.valid.shape
    gx = rng.normal(0.0, 5.0, shape).astype(np.float32)
    gy = rng.normal(0.0, 5.0, shape).astype(np.float32)
    flat_idx = idx[::7]
    gx.reshape(-1)[flat_idx] = 0.0  # no gradient: no normal, left out by both
    gy.reshape(-1)[flat_idx] = 0.0
    filt = rng.uniform(0.0, 100.0, shape).astype(np.float32)
    p_h = geo.rays.reshape(-1, 3)[idx] @ c_c_h.T
    normals, nn, ok = _jacobian_normals(geo, idx, c_c_h, p_h, gx, gy, N_W, sphere)
    w = (
        nn[ok] / np.maximum(filt.reshape(-1)[idx][ok].astype(np.float64), 1e-6)
        if grad_weight
        else np.ones(len(normals))
    )
    mat, wsum, count = kernels.lig_moments(
        idx, geo.rays.reshape(-1, 3), geo.du.reshape(-1, 3), geo.dv.reshape(-1, 3),
        gx.reshape(-1), gy.reshape(-1), filt.reshape(-1), c_c_h,
        N_W if sphere == "air" else 1.0, grad_weight,
    )  # fmt: skip
    assert count == len(normals) == idx.size - flat_idx.size
    np.testing.assert_allclose(mat, (normals * w[:, None]).T @ normals, rtol=0, atol=1e-12 * wsum)
    assert wsum == pytest.approx(w.sum(), rel=1e-12)
    _same_solution(mat, wsum, count, normals, w if grad_weight else None)


@pytest.mark.parametrize("housing", ["dome", "flat"])
def test_the_window_masks_are_numpys_but_within_rounding_of_the_threshold(housing):
    """``kernels.window_and_core`` against ``rays @ up > cos``: the same pixels, over many
    attitudes, except one whose cosine lies within 1e-15 of a threshold (none here)."""
    cam = sensors.create("polarimeter", "ideal_bin4", housing=housing)
    cal = cam.true_calibration()
    geo = analysis_geometry(cal, 2, N_W if housing == "flat" else 1.0)
    rng = np.random.default_rng(3)
    edge = math.cos(critical_angle(N_W))
    core_c = math.cos(critical_angle(N_W) - math.radians(3.0))
    near = 0
    for _ in range(200):
        roll, pitch, yaw = rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3)
        up = (euler_to_dcm(roll, pitch, yaw) @ cal.c_c_b)[2]
        cos_r = geo.rays @ up
        win, core = kernels.window_and_core(geo.rays, geo.valid, up, edge, core_c)
        for got, thr in ((win, edge), (core, core_c)):
            ref = geo.valid & (cos_r > thr)
            differ = got != ref
            assert np.all(np.abs(cos_r[differ] - thr) < 1e-15)
            near += int(differ.sum())
        assert win.sum() > 0 or not (geo.valid & (cos_r > edge)).any()
    assert near == 0
    # It reads the mask: an invalid pixel is never in the window.
    invalid = ~geo.valid
    up = cal.c_c_b[2]
    win, core = kernels.window_and_core(geo.rays, geo.valid, up, -2.0, -2.0)
    assert not win[invalid].any() and np.array_equal(win, geo.valid) and np.array_equal(core, win)


def test_the_sun_side_halves_are_the_level_frame_directions_but_at_the_dividing_plane():
    """``resolve_by_intensity_at`` (compiled sides) against ``resolve_by_intensity`` (p^h)."""
    cal, geo, _, _, rng = _setup("dome", 4)
    edge = math.cos(critical_angle(N_W))
    for _ in range(100):
        c_c_h = euler_to_dcm(*rng.uniform(-0.6, 0.6, 2), rng.uniform(-3, 3)) @ cal.c_c_b
        idx = np.flatnonzero(geo.valid & (geo.rays @ c_c_h[2] > edge))
        p_h = geo.rays.reshape(-1, 3)[idx] @ c_c_h.T
        s = rng.normal(size=3)
        s /= np.linalg.norm(s)
        intensity = rng.uniform(10.0, 20.0, idx.size) + 3.0 * (p_h[:, :2] @ s[:2])
        side = np.empty(idx.size, dtype=bool)
        kernels.window_sides(geo.rays.reshape(-1, 3), idx, c_c_h, s[0], s[1], side)
        ref = p_h[:, :2] @ s[:2] > 0
        assert np.all(np.abs((p_h[:, :2] @ s[:2])[side != ref]) < 1e-15)
        for min_contrast in (0.0, 0.05, 0.9):
            got = resolve_by_intensity_at(s, geo.rays, idx, c_c_h, intensity, min_contrast)
            want = resolve_by_intensity(s, p_h, intensity, min_contrast)
            assert np.array_equal(got[0], want[0]) and got[1:] == want[1:]
    # The zenith: nothing to compare, the upper hemisphere's sign.
    z = np.array([0.0, 0.0, -1.0])
    assert resolve_by_intensity_at(z, geo.rays, idx, c_c_h, intensity, 0.0)[1:] == (0.0, False)
