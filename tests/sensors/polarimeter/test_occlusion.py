"""The occlusion mask's nearest-neighbour upsampling: each pixel takes its coarse sample."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sensors.polarimeter.occlusion import upsample_nearest


@pytest.mark.parametrize(
    ("shape", "k"), [((512, 612), 8), ((2048, 2448), 8), ((512, 612), 5), ((7, 9), 4), ((8, 8), 1)]
)
def test_each_pixel_takes_the_sample_of_its_cell_or_the_last(shape, k):
    h, w = shape
    rows, cols = len(range(k // 2, h, k)), len(range(k // 2, w, k))
    coarse = np.random.default_rng(k).random((rows, cols)) < 0.3
    up = upsample_nearest(coarse, k, shape)
    r, c = np.mgrid[0:h, 0:w]
    expect = coarse[np.minimum(r // k, rows - 1), np.minimum(c // k, cols - 1)]
    assert up.shape == shape and up.dtype == bool and up.flags.c_contiguous
    assert np.array_equal(up, expect)


@pytest.mark.parametrize(("shape", "s"), [((512, 612), 4), ((2048, 2448), 8), ((512, 612), 2)])
def test_where_the_stride_divides_the_frame_it_is_opencvs_nearest(shape, s):
    """The fast path's Snell-window mask (``FastPlan.nearest``) relies on it."""
    h, w = shape
    coarse = (np.random.default_rng(s).random((h // s, w // s)) < 0.5).astype(np.uint8)
    expect = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_NEAREST)
    assert np.array_equal(upsample_nearest(coarse, s, shape), expect)
