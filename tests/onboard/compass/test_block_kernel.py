"""The analysis grid's compiled block intensity and mask equal the OpenCV resizes bit for bit.

``analysis_grid.COMPILED_BLOCKS`` switches between :mod:`twin.onboard.compass.block_kernel` (one
pass, exact arithmetic on integer mosaics) and the resizes it replaced, kept as the reference:
every value and every sign of zero the same, for whole grids and boxes, dark, flat, clipped and
noisy mosaics; the resizes wherever the kernel's exactness does not hold; and the same fixes
from LIG and POL on rendered frames.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import numpy as np
import pytest

import sensors
from sensors.polarimeter.render import OpticsConfig
from twin.core.frames import euler_to_dcm
from twin.onboard.compass import analysis_grid, block_kernel, create
from twin.onboard.compass.base import CompassContext


def _bits(a: np.ndarray) -> bytes:
    """An array's exact content (−0 differs from +0) with its shape and type."""
    a = np.ascontiguousarray(a)
    return repr((a.shape, a.dtype.str)).encode() + a.view(np.uint8).tobytes()


def _both(monkeypatch, fn, *args):
    """fn's result with the kernel, then with the resizes."""
    monkeypatch.setattr(analysis_grid, "COMPILED_BLOCKS", True)
    fast = fn(*args)
    monkeypatch.setattr(analysis_grid, "COMPILED_BLOCKS", False)
    return fast, fn(*args)


def _mosaic(rng, shape, dtype, cal):
    hi = 256 if dtype == np.uint8 else cal.saturation_dn + 1
    raw = rng.integers(0, hi, shape).astype(dtype)
    h, w = shape
    raw[: h // 3, : w // 4] = 0  # dark: 0 − black, and 0 − 0 where the black level is 0
    raw[h // 3 : h // 2, : w // 4] = int(cal.black_level_dn) % hi  # flat at the black level
    raw[rng.random(shape) < 0.01] = hi - 1  # clipped pixels for the mask
    return raw


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("black", [0.0, 240.0, 7.0])
def test_the_compiled_blocks_are_the_resizes_bit_for_bit(monkeypatch, dtype, black):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cal = dataclasses.replace(cam.calibration(), black_level_dn=black)
    if dtype == np.uint8:
        cal = dataclasses.replace(cal, saturation_dn=255)
    geo = analysis_grid.analysis_geometry(cal, 2)
    rng = np.random.default_rng(int(black) + dtype().itemsize)
    raw = _mosaic(rng, (cal.height_px, cal.width_px), dtype, cal)
    h, w = geo.cal.height_px, geo.cal.width_px
    boxes = [None, (slice(0, h), slice(0, w)), (slice(h - 1, h), slice(0, 1))]
    for _ in range(12):
        r0, c0 = rng.integers(0, h - 1), rng.integers(0, w - 1)
        boxes.append(
            (slice(r0, rng.integers(r0 + 1, h + 1)), slice(c0, rng.integers(c0 + 1, w + 1)))
        )
    calls = []
    kernel = block_kernel.s0_and_mask
    monkeypatch.setattr(analysis_grid, "s0_and_mask", lambda *a: calls.append(1) or kernel(*a))
    for box in boxes:
        (i_k, s_k), (i_r, s_r) = _both(
            monkeypatch, analysis_grid.block_intensity, raw, cal, geo, box
        )
        assert _bits(i_k) == _bits(i_r) and _bits(s_k) == _bits(s_r), box
        sat_k, sat_r = _both(monkeypatch, analysis_grid.block_saturation, raw, cal, geo, box)
        assert _bits(sat_k) == _bits(sat_r), box
    assert len(calls) == 2 * len(boxes)  # the kernel ran: nothing fell back
    whole = analysis_grid.block_intensity(raw, cal, geo)
    assert whole[1].any() and not whole[1].all()  # clipped blocks and clear ones
    assert (whole[0] == 0).any()  # zeros, whose sign must match too (0 − 0 is +0)


@pytest.mark.parametrize(
    ("change", "m"),
    [
        ({"black_level_dn": 240.5}, 2),  # the black level not an integer: not exact
        ({}, 4),  # 4×4 blocks: the resize's own grid
        ("float32", 2),  # a float mosaic: not exact
    ],
)
def test_where_the_kernel_is_not_exact_the_resizes_run(monkeypatch, change, m):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cal = cam.calibration()
    if isinstance(change, dict):
        cal = dataclasses.replace(cal, **change)
    geo = analysis_grid.analysis_geometry(cal, m)
    raw = _mosaic(np.random.default_rng(m), (cal.height_px, cal.width_px), np.uint16, cal)
    if change == "float32":
        raw = raw.astype(np.float32) + np.float32(0.25)

    def refuse(*args):
        raise AssertionError("the kernel ran where its arithmetic is not exact")

    monkeypatch.setattr(analysis_grid, "s0_and_mask", refuse)
    i_a, s_a = analysis_grid.block_intensity(raw, cal, geo)
    monkeypatch.setattr(analysis_grid, "COMPILED_BLOCKS", False)
    i_b, s_b = analysis_grid.block_intensity(raw, cal, geo)
    assert _bits(i_a) == _bits(i_b) and _bits(s_a) == _bits(s_b)


def test_a_box_past_the_mosaic_falls_back_rather_than_reading_outside_it(monkeypatch):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cal = cam.calibration()
    geo = analysis_grid.analysis_geometry(cal, 2)
    small = np.zeros((cal.height_px // 2, cal.width_px), np.uint16)  # half the rows it claims
    assert analysis_grid._compiled_blocks(small, cal, geo, None, True) is None


UTC = dt.datetime(2021, 7, 31, 4, 0, tzinfo=dt.UTC)
SUN = np.array([0.5, 0.3, 0.81]) / np.linalg.norm([0.5, 0.3, 0.81])


@pytest.mark.parametrize("name", ["lig", "pol", "lig_paper"])  # (pol_paper reads no block)
def test_lig_and_pol_give_the_same_fixes_with_the_compiled_blocks(monkeypatch, name):
    cam = sensors.create("polarimeter", "phx050s_p_bin4")
    cam.configure(OpticsConfig(jerlov_type="II"))
    method = create(name)
    calls = []
    kernel = block_kernel.s0_and_mask
    monkeypatch.setattr(analysis_grid, "s0_and_mask", lambda *a: calls.append(1) or kernel(*a))
    fixes = []
    for depth, roll, pitch, seed in ((10.0, 0.0, 0.0, 1), (3.0, 25.0, -10.0, 2)):
        c_b_n = euler_to_dcm(math.radians(roll), math.radians(pitch), 0.4)
        raw, _ = cam.render_offline(c_b_n, depth, SUN, np.random.default_rng(seed))
        ctx = CompassContext(
            UTC, 36.2, 120.5, roll_rad=math.radians(roll), pitch_rad=math.radians(pitch),
            depth_m=depth, water_index=cam.n_water, sun_enu=SUN,
        )  # fmt: skip
        fast, ref = _both(monkeypatch, method.solve, raw, cam.calibration(), ctx)
        assert ref.ok, ref.reason
        assert repr(dataclasses.asdict(fast)) == repr(dataclasses.asdict(ref))
        fixes.append(fast)
    assert fixes[0].heading_deg != fixes[1].heading_deg
    assert calls  # the compiled blocks served the method
