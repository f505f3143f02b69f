"""The recording's and the renderer's pictures: the colour maps as OpenCV draws them."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from twin.record import images


def _reference(idx: np.ndarray, colormap: int, mask: np.ndarray | None) -> np.ndarray:
    """The maps as they were drawn before the table was kept (applyColorMap on every call)."""
    rgb = cv2.cvtColor(cv2.applyColorMap(idx, colormap), cv2.COLOR_BGR2RGB)
    if mask is not None:
        rgb[~mask] = 0
    return rgb


@pytest.mark.parametrize("masked", [False, True])
def test_aop_and_dop_pictures_are_opencvs_colour_maps_byte_for_byte(masked: bool) -> None:
    rng = np.random.default_rng(3)
    aop = rng.uniform(-math.pi / 2 - 0.1, math.pi / 2 + 0.1, (256, 306)).astype(np.float32)
    dop = rng.uniform(-0.1, 1.1, (256, 306)).astype(np.float32)
    aop[0, :5] = np.nan  # a dark pixel's angle
    mask = rng.uniform(size=(256, 306)) > 0.3 if masked else None
    a_idx = np.clip(np.nan_to_num((aop + math.pi / 2) / math.pi * 255.0), 0, 255).astype(np.uint8)
    d_idx = np.clip(dop * 255.0, 0, 255).astype(np.uint8)
    dop[1, :3] = np.nan  # and a dark pixel's DoP: both draw in the map's first colour
    d_idx[1, :3] = 0
    aop_img = images.aop_rgb(aop, mask)
    dop_img = images.dop_rgb(dop, mask)
    assert aop_img.dtype == np.uint8 and aop_img.shape == (256, 306, 3)
    np.testing.assert_array_equal(aop_img, _reference(a_idx, cv2.COLORMAP_TWILIGHT_SHIFTED, mask))
    np.testing.assert_array_equal(dop_img, _reference(d_idx, cv2.COLORMAP_VIRIDIS, mask))
    if masked:
        assert not aop_img[~mask].any() and aop_img[mask].any()
    # A cyclic map: −90° and +90° are the same E-vector, one colour.
    ends = images.aop_rgb(np.array([[-math.pi / 2, math.pi / 2 - 1e-6]], dtype=np.float32))
    assert np.abs(ends[0, 0].astype(int) - ends[0, 1].astype(int)).max() <= 3


def _arrays(rng: np.random.Generator) -> list[np.ndarray]:
    """Arrays of the shapes a frame's S0 has, and the ones that break a shortcut."""
    frame = rng.uniform(0, 3000, (256, 306)).astype(np.float32)
    frame[100:110, 150:160] = 4095.0  # a saturated sun disc: ties at the top
    return [
        frame,
        np.exp(rng.normal(0, 3, 78_336)).astype(np.float32),  # a long bright tail
        rng.integers(0, 40, 20_000).astype(np.float32),  # many ties
        np.full(9_000, 7.0, np.float32),  # constant
        np.sort(rng.uniform(size=50_000)).astype(np.float32),  # sorted: a stride sees one end
        np.sort(rng.uniform(size=50_000))[::-1].astype(np.float32),
        rng.normal(size=30_000),  # float64
        rng.uniform(size=500).astype(np.float32),  # small: numpy's own path
        np.where(rng.uniform(size=10_000) < 0.01, np.nan, 1.0).astype(np.float32),  # NaN
    ]


@pytest.mark.parametrize("q", [0.0, 50.0, 95.0, 99.0, 99.5, 99.99, 100.0])
def test_percentile_of_is_numpys_percentile_bit_for_bit(q: float) -> None:
    rng = np.random.default_rng(11)
    for a in _arrays(rng):
        mine, numpys = images.percentile_of(a, q), float(np.percentile(a, q))
        assert mine == numpys or (math.isnan(mine) and math.isnan(numpys)), (a.dtype, a.size, q)


def test_intensity_picture_scales_to_the_percentile() -> None:
    rng = np.random.default_rng(5)
    s0 = rng.uniform(0, 3000, (256, 306)).astype(np.float32)
    s0[:, :100] = 0.0  # black outside a fisheye's circle (the power's slow path, skipped)
    top = float(np.percentile(s0, 99.5))
    img = images.intensity_u8(s0)
    expected = (np.clip(s0 / top, 0.0, 1.0) ** (1.0 / 2.2) * 255.0 + 0.5).astype(np.uint8)
    np.testing.assert_array_equal(img, expected)
    assert (img[s0 >= top] == 255).all() and img[s0 < 0.5 * top].max() < 255
