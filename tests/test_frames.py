from __future__ import annotations

import math

import numpy as np
import pytest

from twin.core import frames


def test_euler_round_trip() -> None:
    rng = np.random.default_rng(1)
    for _ in range(200):
        r, y = rng.uniform(-math.pi, math.pi, 2)
        p = rng.uniform(-1.5, 1.5)
        c = frames.euler_to_dcm(r, p, y)
        np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(frames.dcm_to_euler(c), (r, p, y), atol=1e-9)
        q = frames.dcm_to_quat(c)
        np.testing.assert_allclose(frames.quat_to_dcm(q), c, atol=1e-12)


def test_angle_senses() -> None:
    fwd = np.array([0.0, 1.0, 0.0])
    # Positive pitch raises the nose; positive roll lowers the starboard side (body +x).
    assert frames.euler_to_dcm(0, 0.1, 0)[:, 1] @ [0, 0, 1] > 0
    assert frames.euler_to_dcm(0.1, 0, 0)[:, 0] @ [0, 0, 1] < 0
    # Heading 90 deg (East): the nose points along ENU +x.
    c = frames.euler_to_dcm(0, 0, frames.heading_deg_to_yaw(90.0))
    np.testing.assert_allclose(c @ fwd, [1, 0, 0], atol=1e-12)
    assert frames.yaw_to_heading_deg(frames.heading_deg_to_yaw(271.5)) == pytest.approx(271.5)


def test_fossen_permutation_is_a_proper_rotation() -> None:
    assert np.linalg.det(frames.F_FROM_B) == pytest.approx(1.0)
    # Body forward (y) is Fossen x; body up (z) is Fossen -z (down).
    np.testing.assert_array_equal(frames.F_FROM_B @ [0, 1, 0], [1, 0, 0])
    np.testing.assert_array_equal(frames.F_FROM_B @ [0, 0, 1], [0, 0, -1])


def test_quaternion_order_boundary() -> None:
    q = np.array([0.9, 0.1, 0.2, 0.3])
    np.testing.assert_array_equal(frames.wxyz_to_xyzw(q), [0.1, 0.2, 0.3, 0.9])
    np.testing.assert_array_equal(frames.xyzw_to_wxyz(frames.wxyz_to_xyzw(q)), q)


def test_wraps() -> None:
    assert frames.wrap_pi(3 * math.pi) == pytest.approx(math.pi)
    assert frames.wrap_pi(-math.pi) == pytest.approx(math.pi)
    assert float(frames.wrap_deg180(350.0)) == pytest.approx(-10.0)
