"""LIG and POL work on Snell's window's box, not the whole image: the same fixes (issue #31).

``LigCompass`` median-filters and differentiates only the rows and columns of the window, widened
by the filters' support; ``PolCompass`` makes its Stokes there only
(``analysis_grid.window_box``). The reference below takes the whole image (the box is the
image); every fix's numbers must be the same: for LIG's and POL's mappings, a noisy camera, the
window in the middle and near the image's edge.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import cv2
import numpy as np
import pytest

import sensors
from sensors.polarimeter.render import OpticsConfig
from twin.core.frames import euler_to_dcm
from twin.onboard.compass import analysis_grid, create, lig, pol
from twin.onboard.compass.base import CompassContext

UTC = dt.datetime(2021, 7, 31, 4, 0, tzinfo=dt.UTC)
SUN = np.array([0.5, 0.3, 0.81])


def _frame(cam, depth, roll, pitch, seed):
    c_b_n = euler_to_dcm(math.radians(roll), math.radians(pitch), 0.4)
    raw, _ = cam.render_offline(
        c_b_n, depth, SUN / np.linalg.norm(SUN), np.random.default_rng(seed)
    )
    ctx = CompassContext(
        UTC, 36.2, 120.5, roll_rad=math.radians(roll), pitch_rad=math.radians(pitch),
        depth_m=depth, water_index=cam.n_water, sun_enu=SUN / np.linalg.norm(SUN),
    )  # fmt: skip
    return raw, cam.calibration(), ctx


def _numbers(fix):
    d = dataclasses.asdict(fix)
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in d.items()}


@pytest.mark.parametrize(
    ("name", "params"),
    [
        ("lig", {}),
        ("lig", {"mapping": "paper", "weighting": "gradient"}),
        ("pol", {}),
        ("pol", {"analysis_max_width_px": 100}),
    ],
)
def test_the_box_gives_the_whole_images_fixes(monkeypatch, name, params):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type="II"))
    method = create(name, **params)
    scenes = [
        (10.0, 0.0, 0.0, 1),
        (3.0, 25.0, -10.0, 2),
        (1.0, 60.0, 5.0, 3),
        (15.0, -5.0, 40.0, 4),
    ]
    frames = [_frame(cam, *s) for s in scenes]
    boxed = [method.solve(*f) for f in frames]

    def whole(in_window, pad):
        return slice(0, in_window.shape[0]), slice(0, in_window.shape[1])

    monkeypatch.setattr(lig, "window_box", whole)
    monkeypatch.setattr(pol, "window_box", whole)
    for s, f, got in zip(scenes, frames, boxed, strict=True):
        ref = method.solve(*f)
        assert ref.ok, ref.reason
        assert _numbers(got) == _numbers(ref), s


def test_the_box_holds_the_window_and_the_filters_support():
    win = np.zeros((40, 50), dtype=bool)
    win[10:20, 30:49] = True
    rows, cols = analysis_grid.window_box(win, 4)
    assert (rows.start, rows.stop, cols.start, cols.stop) == (6, 24, 26, 50)


@pytest.mark.parametrize("ksize", [1, 3, 5])
@pytest.mark.parametrize("centre", [(128, 150), (20, 30), (250, 300)])
def test_the_filtered_box_is_the_whole_images_where_the_method_reads_it(ksize, centre):
    """Noise (every neighbour matters): the median at each in-window pixel, the gradient at each
    whose 3×3 neighbours are in the window, equal the whole image's; at the image's edge too."""
    rng = np.random.default_rng(ksize)
    intensity = rng.uniform(0.0, 100.0, (256, 306)).astype(np.float32)
    r, c = np.mgrid[0:256, 0:306]
    win = (r - centre[0]) ** 2 + (c - centre[1]) ** 2 < 50**2
    box, filt_b, gx_b, gy_b = lig._filtered_box(intensity, win, ksize)
    filt = cv2.medianBlur(intensity, ksize) if ksize > 1 else intensity
    gx = cv2.Sobel(filt, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)
    gy = cv2.Sobel(filt, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)
    inner = cv2.erode(win.view(np.uint8), np.ones((3, 3), np.uint8)).view(bool)
    for part, whole, mask in ((filt_b, filt, win), (gx_b, gx, inner), (gy_b, gy, inner)):
        assert np.array_equal(part[mask[box]], whole[mask])


@pytest.mark.parametrize("m", [2, 4])
def test_a_boxs_intensity_saturation_and_stokes_are_the_whole_grids_there(m):
    """Each analysis pixel is its own m × m raw block: any box of the grid gives its numbers."""
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cal = cam.calibration()
    geo = analysis_grid.analysis_geometry(cal, m)
    rng = np.random.default_rng(m)
    raw = rng.integers(0, 4096, (cal.height_px, cal.width_px)).astype(np.uint16)
    raw[rng.random(raw.shape) < 0.01] = cal.saturation_dn
    i_all, s_all = analysis_grid.block_intensity(raw, cal, geo)
    p_all = pol.binned_stokes(raw, cal, geo)
    h, w = i_all.shape
    for _ in range(20):
        r0, c0 = rng.integers(0, h - 1), rng.integers(0, w - 1)
        box = (slice(r0, rng.integers(r0 + 1, h + 1)), slice(c0, rng.integers(c0 + 1, w + 1)))
        i_b, s_b = analysis_grid.block_intensity(raw, cal, geo, box)
        assert np.array_equal(i_b, i_all[box]) and np.array_equal(s_b, s_all[box])
        p_b = pol.binned_stokes(raw, cal, geo, box)
        for name in ("s0", "s1", "s2"):
            assert np.array_equal(getattr(p_b, name), getattr(p_all, name)[box])
    assert s_all.any()
