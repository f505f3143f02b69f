"""WGS84 Earth model: normal gravity, radii, Earth and transport rates."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from twin.core import earth

# navigation.md §2.4 table (pyins.earth.gravity at h = 0).
SOMIGLIANA_TABLE = [(0.0, 9.780325), (30.0, 9.793247), (45.0, 9.806198)]


@pytest.mark.parametrize(("lat_deg", "expected"), SOMIGLIANA_TABLE)
def test_somigliana_matches_reference_table(lat_deg: float, expected: float) -> None:
    assert earth.normal_gravity(math.radians(lat_deg)) == pytest.approx(expected, abs=5e-7)


def test_normal_gravity_at_equator_and_poles_is_the_defining_constants() -> None:
    assert earth.normal_gravity(0.0) == pytest.approx(earth.GAMMA_E, abs=1e-12)
    assert earth.normal_gravity(math.pi / 2) == pytest.approx(earth.GAMMA_P, abs=1e-10)
    assert earth.normal_gravity(-math.pi / 2) == pytest.approx(earth.GAMMA_P, abs=1e-10)


def test_free_air_gradient_is_0_3086_mgal_per_metre() -> None:
    lat = math.radians(45.0)
    # Under water (h < 0) gravity is larger: 0.3086 mGal/m = 3.086e-6 m/s² per metre.
    dg = earth.normal_gravity(lat, -100.0) - earth.normal_gravity(lat, 0.0)
    assert dg / 100.0 == pytest.approx(3.086e-6, rel=5e-3)
    assert earth.gravity_enu(lat, -100.0)[2] == -earth.normal_gravity(lat, -100.0)


def test_principal_radii() -> None:
    r_m, r_n = earth.principal_radii(0.0)
    assert r_n == pytest.approx(earth.A_M)
    assert r_m == pytest.approx(earth.A_M * (1 - earth.E2))
    r_m, r_n = earth.principal_radii(math.pi / 2)
    polar = earth.A_M / math.sqrt(1 - earth.E2)  # = a² / b
    assert r_m == pytest.approx(polar) and r_n == pytest.approx(polar)
    assert polar == pytest.approx(earth.A_M**2 / earth.B_M)
    # Meridian radius below prime-vertical radius everywhere but at the poles.
    r_m, r_n = earth.principal_radii(math.radians(45.0))
    assert r_m < r_n


@pytest.mark.parametrize("lat_deg", [-60.0, 0.0, 36.175, 45.0, 80.0])
def test_earth_rate_enu(lat_deg: float) -> None:
    lat = math.radians(lat_deg)
    w = earth.earth_rate_enu(lat)
    assert np.linalg.norm(w) == pytest.approx(earth.OMEGA_IE, rel=1e-15)
    assert w[0] == 0.0
    # The rotation axis points to the celestial pole: elevation = latitude, due north.
    assert math.atan2(w[2], w[1]) == pytest.approx(lat)


def test_transport_rate_equals_frame_rotation_from_position_rates() -> None:
    """ω_en^n = [−L̇, λ̇ cos L, λ̇ sin L]: the rotation of the ENU frame moved over the ellipsoid."""
    lat, h = math.radians(36.175), -25.0
    v = np.array([1.3, -0.7, 0.2])
    lat_dot, lon_dot, h_dot = earth.latlon_rates(lat, h, v)
    expected = np.array([-lat_dot, lon_dot * math.cos(lat), lon_dot * math.sin(lat)])
    np.testing.assert_allclose(earth.transport_rate_enu(lat, h, v), expected, rtol=1e-14)
    assert h_dot == 0.2


def test_transport_rate_moving_east_on_equator() -> None:
    w = earth.transport_rate_enu(0.0, 0.0, np.array([10.0, 0.0, 0.0]))
    np.testing.assert_allclose(w, [0.0, 10.0 / earth.A_M, 0.0], atol=1e-20)


def test_earth_module_imports_nothing_from_the_world_side() -> None:
    """twin.core.earth is shared with onboard code: only stdlib math, numpy and twin.core."""
    tree = ast.parse(Path(earth.__file__).read_text())
    imported: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module)
    allowed = {"__future__", "math", "numpy", "twin.core.frames", "twin.core.arrays"}
    assert imported <= allowed, imported
