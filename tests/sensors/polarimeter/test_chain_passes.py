"""The exact chain's passes (sensors/polarimeter/chain_passes.py) against the scalar kernel.

The index pass finds each table's row by counting row cosines, not by ``column_kernel._row``'s
binary search: the rows and fractions must be the search's exactly, at the nodes too. The
chain, a block at a time, must not depend on where the blocks fall. And its polynomial e^x and
arccos must be libm's to 3e-13.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter import chain_passes as cp
from sensors.polarimeter.optics import column_kernel as colk
from sensors.polarimeter.render import OpticsConfig, Polarimeter
from sensors.polarimeter.unit import camera as camera_mod


def _camera() -> Polarimeter:
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    assert isinstance(cam, Polarimeter)
    cam.configure(OpticsConfig(jerlov_type="II"))
    return cam


SUN = np.array([math.sin(0.7) * 0.6, math.sin(0.7) * 0.8, math.cos(0.7)])


def _kernel_args(cam: Polarimeter):
    fc = cam._frame_constants(SUN, SUN, 10.0)
    assert cam._column is not None and fc.state is not None
    return cam._column._kernel_args(fc.state, True, True)


def _rays(k, seed: int) -> np.ndarray:
    """Random directions, and directions whose −v_z or v_z sits exactly on a table's nodes."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(3000, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    t_in, t_out = k[14], k[16]
    nodes = np.concatenate([-t_out, t_in, t_out, [1.0, -1.0, 0.0]]).astype(np.float32)
    az = rng.uniform(0.0, 2.0 * math.pi, nodes.size)
    h = np.sqrt(np.maximum(1.0 - nodes.astype(np.float64) ** 2, 0.0))
    on = np.stack([h * np.cos(az), h * np.sin(az), nodes.astype(np.float64)], -1)
    out = np.concatenate([v, on]).astype(np.float32)
    out[-len(nodes) :, 2] = nodes  # v_z exactly the node, as float32 holds it
    return out


def test_the_counts_give_the_binary_searchs_rows_and_fractions():
    k = _kernel_args(_camera())
    t_in, t_out, cos_c_frame = k[14], k[16], k[17]
    v = _rays(k, 1)
    w = np.empty(cp.SCRATCH_ROWS * cp.ROW)
    checked = 0
    for lo in range(0, len(v), cp.BLOCK):
        x, y, z = (np.ascontiguousarray(v[lo : lo + cp.BLOCK, i]) for i in range(3))
        cp._index_pass(x, y, z, w, k)
        for j, vz in enumerate(z.astype(np.float64)):
            inside = vz > cos_c_frame
            tc = t_in if inside else t_out
            czt = w[cp._CZT * cp.ROW + j]
            want = colk._row.py_func(czt, tc)
            got = cp._row.py_func(w[cp._CNT * cp.ROW + j], tc, czt)
            assert got == want, (vz, czt)
            want = colk._row.py_func(-vz, t_out)
            got = cp._row.py_func(w[cp._CUP * cp.ROW + j], t_out, -vz)
            assert got == want, vz
            checked += 1
    assert checked == len(v)
    # The table coordinate is scatter_pixels': this water's window edge on the table's.
    cos_c_table = k[18]
    vz = v[:, 2].astype(np.float64)[: cp.BLOCK]
    x, y, z = (np.ascontiguousarray(v[: cp.BLOCK, i]) for i in range(3))
    cp._index_pass(x, y, z, w, k)
    inside = vz > cos_c_frame
    want = np.where(
        inside,
        1.0 - (1.0 - vz) * (1.0 - cos_c_table) / (1.0 - cos_c_frame),
        np.where(vz > 0, vz * cos_c_table / cos_c_frame, vz),
    )
    np.testing.assert_allclose(w[cp._CZT * cp.ROW :][: cp.BLOCK], want, rtol=1e-14)


@pytest.mark.parametrize("m", [1, cp.BLOCK - 1, cp.BLOCK, cp.BLOCK + 1, 5 * cp.BLOCK + 17])
def test_a_chain_of_blocks_equals_the_chain_ray_by_ray(m):
    """The same rays in blocks or one at a time: the same Stokes bit for bit, whatever m."""
    from sensors.polarimeter import chain_kernel

    cam = _camera()
    fc = cam._frame_constants(SUN, SUN, 10.0)
    rng = np.random.default_rng(m)
    v = rng.normal(size=(m, 3))
    v[:, 2] = np.abs(v[:, 2])  # most of them in the window
    v[0] = (0.1, 0.2, 1.0)  # the first surely
    v = (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)
    axes = camera_mod.sensor_basis(v, np.float32)
    psf = np.full(m, 0.004, dtype=np.float32)
    whole, sees, scat = cam._render_points(v, axes, psf, np.eye(3), fc, None, "split")
    assert scat is not None and sees.any()
    for i in range(0, m, max(1, m // 7)):
        one, s1, sc1 = cam._render_points(
            v[i : i + 1], (axes, np.array([i])), psf[i : i + 1], np.eye(3), fc, None,
            "split",
        )  # fmt: skip
        assert np.array_equal(one[0], whole[i]) and s1[0] == sees[i]
        assert sc1 is not None and np.array_equal(sc1[0], scat[i])
    assert chain_kernel.applies(cam.optics.sky, SUN)


def test_the_polynomial_exponential_and_arc_cosine_are_libms_to_3e_13():
    """The arithmetic pass's e^x (x ≤ 0) and arccos, against numpy's, ends and branch points in."""
    import numba

    @numba.njit
    def both(x, xe, a, e):
        for i in range(x.shape[0]):
            a[i] = cp._acos(x[i])
        for i in range(xe.shape[0]):
            e[i] = cp._exp_neg(xe[i])

    x = np.concatenate([np.linspace(-1.0, 1.0, 100_001), [0.5, -0.5, np.nextafter(0.5, 1.0)]])
    xe = np.concatenate([-np.logspace(-14, np.log10(699.9), 100_001), [0.0, -1e-300, -700.0]])
    a, e = np.empty_like(x), np.empty_like(xe)
    both(x, xe, a, e)
    assert np.max(np.abs(a - np.arccos(x))) < 1e-15
    assert np.max(np.abs(e - np.exp(xe)) / np.exp(xe)) < 3e-13
    e2 = np.empty(3)
    both(x[:0], np.array([-700.5, -1e4, -np.inf]), a[:0], e2)
    assert np.all(e2 == 0.0)  # below e^−700 ≈ 1e−304: zero, as libm's underflow nearly is
