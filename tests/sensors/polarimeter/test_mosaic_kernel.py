"""The sensor's compiled passes (mosaic_kernel) give the OpenCV chain's raw frames bit for bit."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sensors.polarimeter.unit.mosaic import DoFPSensor, preset


def _field(shape: tuple[int, int], seed: int) -> np.ndarray:
    """A fisheye-like Stokes field: a bright disc with a gradient and a dark surround, a sun.

    Spans the Gaussian and the photon-counting (Poisson) regimes, the dark-only pixels outside
    the disc, saturation at the sun, and partial polarization.
    """
    h, w = shape
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:h, 0:w]
    r = np.hypot(u - w / 2, v - h / 2) / (0.45 * min(h, w))
    s0 = np.where(r < 1.0, 2e7 * (1.2 - r) * (1 + 0.1 * rng.standard_normal((h, w))), 0.0)
    s0 = np.maximum(s0, 0.0)
    s0[h // 3, w // 3] = 5e11  # the sun: saturates every camera
    s0[np.abs(r - 0.98) < 0.02] = 2e4  # a dim ring: a few electrons, the Poisson path
    dop = 0.6 * (1.0 - np.minimum(r, 1.0))
    aop = np.arctan2(v - h / 2, u - w / 2)
    st = np.empty((h, w, 3), np.float32)
    st[..., 0] = s0
    st[..., 1] = s0 * dop * np.cos(2 * aop)
    st[..., 2] = s0 * dop * np.sin(2 * aop)
    return st


SPECS = {
    "phx050s_p": preset("phx050s_p"),  # DSNU, hot pixels, row noise, crosstalk, PRNU
    "no_dsnu": dataclasses.replace(preset("phx050s_p"), dsnu_e=0.0, row_noise_e=0.0),
    "read_only": dataclasses.replace(preset("imx250mzr"), shot_noise=False),
    "ideal": dataclasses.replace(preset("ideal"), auto_exposure=False, exposure_us=1000.0),
}


@pytest.mark.parametrize("name", list(SPECS))
@pytest.mark.parametrize("shape", [(96, 130), (210, 612)])
def test_the_compiled_passes_give_the_opencv_chains_raw_frame_bit_for_bit(name, shape):
    spec = SPECS[name]
    st = _field(shape, 3)
    # The sun pixel past 2³¹ DN is the one place the two differ (below): leave it out here.
    st[shape[0] // 3, shape[1] // 3] = (5e9, 0.0, 0.0)
    sensor = DoFPSensor(spec, shape, np.random.default_rng(1))
    frames, charges = [], []
    for kernels in (True, False):
        sensor._kernels = kernels
        frames.append(sensor.render_mosaic(st, spec.exposure_us, np.random.default_rng(7)))
        charges.append(sensor.expected_electrons(st, spec.exposure_us))
    np.testing.assert_array_equal(charges[0], charges[1])
    np.testing.assert_array_equal(frames[0], frames[1])
    # The field exercises what the passes branch on.
    assert (frames[0] == spec.saturation_dn).any()
    if spec.hot_pixel_fraction > 0:
        assert sensor._fp.hot.size > 0


def test_a_pixel_past_two_to_the_31_dn_reads_saturation_not_zero():
    """OpenCV rounds through int32, and a value past 2³¹ wrapped to 0: a black sun."""
    spec = SPECS["ideal"]
    st = np.zeros((4, 6, 3), np.float32)
    st[..., 0] = 1e13  # 1e13 photons/s × 1 ms = 1e10 e⁻ = 1e10 DN at K = 1
    sensor = DoFPSensor(spec, (4, 6), np.random.default_rng(0))
    raw = sensor.render_mosaic(st, spec.exposure_us, np.random.default_rng(0))
    assert (raw == spec.saturation_dn).all()
    sensor._kernels = False
    assert (sensor.render_mosaic(st, spec.exposure_us, np.random.default_rng(0)) == 0).all()


def test_fma32_rounds_once():
    from numba import njit

    from sensors.polarimeter.unit.mosaic_kernel import fma32

    @njit
    def f(a, b, c):
        return fma32(a, b, c)

    a = np.float32(1.0 + 2.0**-12)
    # a² = 1 + 2⁻¹¹ + 2⁻²⁴: rounded first, the 2⁻²⁴ is lost against −1; fused, it stays.
    assert f(a, a, np.float32(-1.0)) == np.float32(2.0**-11 + 2.0**-24)
    assert np.float32(a * a) - np.float32(1.0) == np.float32(2.0**-11)
    assert math.isnan(f(np.float32(np.nan), np.float32(1.0), np.float32(0.0)))
