"""The per-pixel kernel's shortcuts equal the general chains they replace."""

from __future__ import annotations

import math

import numpy as np

from sensors.polarimeter.optics.column_kernel import fresnel_up_meridian
from sensors.polarimeter.optics.rt.surface_kernel import meridian, reflect_from_below

N_WATER = 1.339


def _general(dx, dy, dz, si, sq, su):
    """The reference's reflection: meridian → p-basis → Fresnel → the reflected light's meridian."""
    rx, ry, rz = meridian(dx, dy, dz)
    ni, nq, nu, nv, ndz, nrx, nry, nrz, _ = reflect_from_below(
        dx, dy, dz, rx, ry, rz, si, sq, su, 0.0, N_WATER
    )
    mx, my, mz = meridian(dx, dy, ndz)
    c1 = nrx * mx + nry * my + nrz * mz
    s1 = (nry * mz - nrz * my) * dx + (nrz * mx - nrx * mz) * dy + (nrx * my - nry * mx) * ndz
    chi = math.atan2(s1, c1)
    c2, s2 = math.cos(2 * chi), math.sin(2 * chi)
    return ni, c2 * nq + s2 * nu, -s2 * nq + c2 * nu, nv


def test_the_flat_sea_reflection_in_the_meridian_basis_is_the_reference_chain():
    rng = np.random.default_rng(3)
    cos_c = math.sqrt(1.0 - 1.0 / N_WATER**2)
    n_checked = 0
    for _ in range(2000):
        # Light coming up inside Snell's window (incidence cosine above the critical one),
        # any azimuth, including straight up.
        cz = rng.uniform(cos_c + 1e-6, 1.0)
        az = rng.uniform(-math.pi, math.pi)
        h = math.sqrt(1.0 - cz * cz)
        d = (h * math.cos(az), h * math.sin(az), cz)
        i = rng.uniform(0.1, 2.0)
        q, u = rng.uniform(-1, 1, 2) * i * 0.7
        want = _general(*d, i, q, u)
        got = fresnel_up_meridian(cz, N_WATER, i, q, u)
        assert abs(want[3]) < 1e-12  # no total reflection inside the window: V stays 0
        np.testing.assert_allclose(got, want[:3], rtol=1e-9, atol=1e-12 * i)
        n_checked += 1
    assert n_checked == 2000


def test_at_the_window_edge_the_reflection_is_total_and_at_the_zenith_fresnels():
    cos_c = math.sqrt(1.0 - 1.0 / N_WATER**2)
    i, q, u = fresnel_up_meridian(cos_c + 1e-12, N_WATER, 1.0, 0.3, 0.2)
    assert abs(i - 1.0) < 1e-4 and abs(q - 0.3) < 1e-4 and abs(u - 0.2) < 1e-4
    r = ((N_WATER - 1) / (N_WATER + 1)) ** 2
    i, q, u = fresnel_up_meridian(1.0, N_WATER, 1.0, 0.0, 0.0)
    assert abs(i - r) < 1e-12 and abs(q) < 1e-12
