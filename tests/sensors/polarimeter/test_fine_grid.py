"""The fast path's fine level (sensors/polarimeter/fine_grid.py) against its references.

The compiled bilinear interpolation is the coarse grid's numpy interpolation
(``FastPlan.interpolate``, ``cv2.resize``'s convention); each cell's stencil holds every fine
point its pixels read; the level engages where it should, renders fewer rays, and keeps the
pixels it interpolates near the exact chain (docs/polarimeter.md; the ten scenes' bounds are
``test_render_fast.py``'s).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_render_fast import _pair, _pier_frames, _sun

import sensors
from sensors.polarimeter import fast_path, fast_plan
from sensors.polarimeter.fine_grid import bilinear_into
from sensors.polarimeter.render import Polarimeter
from twin.core.frames import euler_to_dcm


def _plan(preset: str = "phx050s_p_bin4", **kw: object) -> fast_plan.FastPlan:
    cam = sensors.create("polarimeter", preset, **kw)
    assert isinstance(cam, Polarimeter)
    plan = cam._fast_plan(cam.camera.outside(cam.n_water))
    assert plan is not None
    return plan


@pytest.mark.parametrize("stride", [2, 4])
def test_the_compiled_bilinear_is_the_coarse_grids_numpy_interpolation(stride):
    plan = _plan(smooth_stride_px=stride)
    h, w = plan._shape
    rng = np.random.default_rng(3)
    grid = rng.uniform(-1.0, 2.0, (h // stride, w // stride, 3)).astype(np.float32)
    # Every pixel of the frame, the border's clamped ones included.
    idx = np.arange(h * w, dtype=np.intp)
    want = plan.interpolate(grid, idx)
    got = np.zeros((h * w, 3), dtype=np.float32)
    bilinear_into(grid.reshape(-1, 3), h // stride, w // stride, stride, w, idx, got, False)
    np.testing.assert_allclose(got, want, rtol=2e-6, atol=2e-6)
    # Subtracting: the same values taken off what is there.
    base = rng.uniform(0.0, 1.0, (h * w, 3)).astype(np.float32)
    sub = base.copy()
    bilinear_into(grid.reshape(-1, 3), h // stride, w // stride, stride, w, idx[::7], sub, True)
    np.testing.assert_allclose(sub[::7], base[::7] - want[::7], rtol=2e-6, atol=4e-6)
    np.testing.assert_array_equal(np.delete(sub, np.s_[::7], 0), np.delete(base, np.s_[::7], 0))


def test_the_fine_level_is_used_from_a_coarse_stride_of_8():
    assert _plan().fine is None  # 612×512: stride 4, where it does not pay (fast_path.py)
    assert _plan(smooth_stride_px=2).fine is None
    full = _plan("phx050s_p")
    assert full.stride == 8 and full.fine is not None and full.fine.stride == 4


def test_each_cells_stencil_holds_every_fine_point_its_pixels_read():
    plan = _plan("phx050s_p")
    fine = plan.fine
    assert fine is not None and fine.stride == plan.stride // 2
    _, w = plan._shape
    hf, wf = fine.shape
    f = fine.stride
    cells = np.flatnonzero(plan.cell_valid.reshape(-1))
    for cell in cells[:: max(len(cells) // 400, 1)]:
        px = plan.pixels(np.array([cell]))
        if px.size == 0:
            continue
        fy = (px // w - (f - 1) / 2.0) / f
        fx = (px % w - (f - 1) / 2.0) / f
        y0, x0 = np.floor(fy).astype(int), np.floor(fx).astype(int)
        need = set()
        for dy in (0, 1):
            for dx in (0, 1):
                yy = np.clip(y0 + dy, 0, hf - 1)
                xx = np.clip(x0 + dx, 0, wf - 1)
                need |= set((yy * wf + xx).tolist())
        assert need <= set(fine.cell_points[cell].tolist()), cell


def test_the_fine_level_renders_fewer_rays_and_stays_near_the_exact_chain():
    # validation/fast_path_error.py's full-resolution scene
    c, depth, sun = euler_to_dcm(0.35, -0.17, 0.4), 1.0, _sun(30, 60)
    fast, exact = _pair("phx050s_p")
    rays = [0]
    orig = fast_path.FastPath._render_points

    def counted(self, r, *a, **k):  # type: ignore[no-untyped-def]
        rays[0] += len(r)
        return orig(self, r, *a, **k)

    frames = {}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fast_path.FastPath, "_render_points", counted)
        # The fine level alone (the window grid would give much of the band either way).
        mp.setattr(fast_path.FastPath, "window_grid", False)
        for on in (False, True):
            mp.setattr(fast_path.FastPath, "fine_level", on)
            rays[0] = 0
            frames[on] = (fast.render_stokes(None, np.zeros(3), c, depth, sun), rays[0])
    (before, win_before, *_), n_off = frames[False]
    (after, win_after, *_), n_on = frames[True]
    b, win_b, *_ = exact.render_stokes(None, np.zeros(3), c, depth, sun)
    np.testing.assert_array_equal(win_after, win_b)  # Snell's window mask stays exact
    np.testing.assert_array_equal(win_before, win_b)
    assert n_on < 0.8 * n_off, (n_on, n_off)  # measured 136 070 against 190 238
    fine = np.any(after != before, axis=-1) & (b[..., 0] > 0)
    assert fine.sum() > 40_000  # the level engaged (59 776 pixels)
    rel = np.abs(after[..., 0] - b[..., 0])[fine] / b[..., 0][fine]
    assert rel.max() < 0.015, rel.max()  # measured 0.7 % (the frame's worst: 1.9 %)


def test_occluded_pixels_of_fine_cells_lose_the_interpolated_direct_light():
    """The pier scene: some occluded pixels lie in fine cells; fast and exact still agree."""
    from sensors.polarimeter import fast_path as fp

    subtracted = []

    def recording(grid, hf, wf, f, w, idx, flat, subtract):  # type: ignore[no-untyped-def]
        if subtract:
            subtracted.append(len(idx))
        bilinear_into(grid, hf, wf, f, w, idx, flat, subtract)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fp, "bilinear_into", recording)
        a, b = _pier_frames("ideal")
    assert subtracted and sum(subtracted) > 0
    lit = b.stokes[..., 0] > 0
    rel = np.abs(a.stokes[..., 0] - b.stokes[..., 0])[lit] / b.stokes[..., 0][lit]
    assert rel.max() < 0.05
