"""The gravity map (twin.core.gravity_map) and the world's field (twin.world.gravity)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from twin.core.gravity_map import GravityGrid, OffMapError, load_grid, local_en_m
from twin.world.gravity import (
    POINCARE_PREY_MGAL_PER_M,
    Flat,
    SeafloorSpec,
    Slope,
    anomaly_grid,
    normal_gravity_mgal,
    seafloor_depth,
    wang2023_seafloor,
)


def _plane(nx=21, ny=11, d=1000.0, ge=2e-3, gn=-1e-3) -> GravityGrid:
    e, n = np.arange(nx) * d, np.arange(ny) * d
    ee, nn = np.meshgrid(e, n)
    return GravityGrid(e, n, 5.0 + ge * ee + gn * nn, source="plane")


def test_bilinear_values_and_gradients_are_exact_on_a_plane():
    g = _plane()
    pts = np.random.default_rng(0).uniform([0, 0], [20_000, 10_000], (200, 2))
    np.testing.assert_allclose(
        g.value(pts[:, 0], pts[:, 1]), 5 + 2e-3 * pts[:, 0] - 1e-3 * pts[:, 1]
    )
    np.testing.assert_allclose(g.gradient(pts[:, 0], pts[:, 1]), np.tile([2e-3, -1e-3], (200, 1)))
    np.testing.assert_allclose(
        g.node_gradient(pts[:, 0], pts[:, 1]), np.tile([2e-3, -1e-3], (200, 1)), atol=1e-12
    )


def test_window_sums_match_brute_force():
    rng = np.random.default_rng(1)
    e, n = np.arange(17) * 500.0, np.arange(13) * 500.0
    v = rng.normal(size=(13, 17))
    g = GravityGrid(e, n, v)
    for _ in range(50):
        j0, i0 = rng.integers(-3, 10), rng.integers(-3, 14)
        j1, i1 = j0 + rng.integers(0, 8), i0 + rng.integers(0, 8)
        want = v[max(j0, 0) : max(j1, 0), max(i0, 0) : max(i1, 0)].sum()
        assert g.window_sum(j0, j1, i0, i1) == pytest.approx(want, abs=1e-9)


@pytest.mark.parametrize(
    ("make", "needle"),
    [
        (lambda: GravityGrid(np.arange(3.0), np.arange(2.0), np.full((2, 3), np.nan)), "6 NaN"),
        (lambda: GravityGrid(np.array([0.0, 1.0, 3.0]), np.arange(2.0), np.zeros((2, 3))),
         "equally spaced"),
        (lambda: GravityGrid(np.arange(3.0), np.arange(2.0), np.zeros((3, 2))), "shape"),
        (lambda: GravityGrid(np.arange(3.0)[::-1], np.arange(2.0), np.zeros((2, 3))),
         "increasing"),
    ],
)  # fmt: skip
def test_impossible_maps_are_clear_errors(make, needle):
    with pytest.raises(ValueError, match=needle):
        make()


def test_a_position_off_the_map_is_named():
    g = _plane()
    g.require_on_map(20_000.0, 0.0, "start")  # the edge is on the map
    with pytest.raises(OffMapError, match=r"goal: \(E 25000 m, N 5000 m\).*East 0…20000 m"):
        g.require_on_map([1000.0, 25_000.0], [0.0, 5000.0], "goal")


def test_a_netcdf_grid_on_longitude_latitude_loads_onto_east_north(tmp_path):
    lon = np.linspace(120.0, 121.0, 61)
    lat = np.linspace(36.0, 36.8, 49)
    # A field linear in East/North about the centre: the loader must undo the projection.
    ee, nn = local_en_m(*np.meshgrid(lon, lat), lon.mean(), lat.mean())
    field = 3e-3 * ee + 1e-3 * nn
    path = tmp_path / "faa.nc"
    xr.Dataset({"faa": (("lat", "lon"), field)}, coords={"lat": lat, "lon": lon}).to_netcdf(path)
    g = load_grid(path, spacing_m=2000.0)
    assert g.spacing_m == (2000.0, 2000.0)
    e0, e1, n0, n1 = g.extent_m
    assert e0 < -40_000 and e1 > 40_000 and n0 < -40_000 and n1 > 40_000
    ge, gn = np.meshgrid(g.east_m, g.north_m)
    np.testing.assert_allclose(g.values_mgal, 3e-3 * ge + 1e-3 * gn, atol=0.05)
    back = g.to_dataarray()
    assert back.dims == ("north", "east") and back.attrs["units"] == "mGal"
    # Bad files: holes, missing, ambiguous variable.
    holed = field.copy()
    holed[3, 4] = np.nan
    bad = tmp_path / "holes.nc"
    xr.Dataset({"faa": (("lat", "lon"), holed)}, coords={"lat": lat, "lon": lon}).to_netcdf(bad)
    with pytest.raises(ValueError, match=r"1 NaN nodes \(first at lon 120.0667, lat 36.0500\)"):
        load_grid(bad)
    with pytest.raises(ValueError, match="does not exist"):
        load_grid(tmp_path / "none.nc")
    two = tmp_path / "two.nc"
    xr.Dataset(
        {"a": (("lat", "lon"), field), "b": (("lat", "lon"), field)},
        coords={"lat": lat, "lon": lon},
    ).to_netcdf(two)
    with pytest.raises(ValueError, match="name one with variable="):
        load_grid(two)
    assert load_grid(two, variable="b", spacing_m=5000.0).values_mgal.shape[0] > 2


def test_a_netcdf4_hdf5_grid_like_sandwell_smith_loads(tmp_path):
    """The global marine gravity grids are NetCDF-4 (HDF5) on (lat, lon), lat descending."""
    lon = np.linspace(10.0, 10.5, 31)
    lat = np.linspace(-20.0, -20.4, 25)  # descending, as GMT writes some grids
    _, nn = local_en_m(*np.meshgrid(lon, lat), lon.mean(), lat.mean())
    path = tmp_path / "grav.nc"
    xr.Dataset({"z": (("lat", "lon"), 2e-3 * nn)}, coords={"lat": lat, "lon": lon}).to_netcdf(
        path, engine="h5netcdf"
    )
    assert path.read_bytes()[:4] == b"\x89HDF"  # really HDF5, not NetCDF-3
    g = load_grid(path, spacing_m=1000.0)
    _, gn = np.meshgrid(g.east_m, g.north_m)
    np.testing.assert_allclose(g.values_mgal, 2e-3 * gn, atol=0.05)


def test_a_plateau_flank_gives_the_bouguer_step():
    """Far from a 400 m step the anomaly differs by 2πGΔρh = 27.5 mGal (infinite slab)."""
    spec = SeafloorSpec(
        size_m=(80_000.0, 20_000.0),
        hill_rms_m=0.0,
        slopes=(Slope(40_000.0, 10_000.0, azimuth_deg=0.0, height_m=400.0, width_m=2000.0),),
        pad_m=60_000.0,
    )
    g = anomaly_grid(spec, np.random.default_rng(0))
    # Plateau to the left (West) of a northward line.
    step = float(g.value(10_000.0, 10_000.0) - g.value(70_000.0, 10_000.0))
    slab = 2 * math.pi * 6.674e-11 * 1640.0 * 400.0 * 1e5
    assert step == pytest.approx(slab, rel=0.1)
    assert abs(float(g.values_mgal.mean())) < 1e-9  # an anomaly map about its mean


def test_the_seafloor_is_deterministic_and_has_its_declared_hills():
    spec = SeafloorSpec(size_m=(60_000.0, 60_000.0), flats=(Flat(30_000.0, 30_000.0),), pad_m=0)
    _, _, a = seafloor_depth(spec, np.random.default_rng(3))
    _, _, b = seafloor_depth(spec, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    hills = a - spec.mean_depth_m
    # The rms is declared before the flat's taper, which removes some of it.
    assert 0.5 * spec.hill_rms_m < hills.std() < 1.05 * spec.hill_rms_m
    assert np.abs(hills[28:33, 28:33]).max() < 0.1 * spec.hill_rms_m  # the plain is flat


def test_the_wang2023_map_puts_test_1_on_a_slope_and_test_2_on_a_flat():
    spec = wang2023_seafloor()
    e, n, depth = seafloor_depth(spec, np.random.default_rng(0))
    gn, ge = np.gradient(depth, n, e)
    slope = np.hypot(ge, gn)

    def at(x, y):
        return slope[np.argmin(np.abs(n - y)), np.argmin(np.abs(e - x))]

    assert at(58_000.0, 73_000.0) > np.percentile(slope, 95)
    assert at(30_000.0, 58_000.0) < np.percentile(slope, 10)


def test_normal_gravity_is_wgs84s_and_grows_downwards_by_poincare_prey():
    assert normal_gravity_mgal(45.0) == pytest.approx(980619.78, abs=0.05)  # Moritz 1980
    assert normal_gravity_mgal(0.0) == pytest.approx(978032.53, abs=0.05)
    assert POINCARE_PREY_MGAL_PER_M == pytest.approx(0.2222, abs=1e-4)
    assert normal_gravity_mgal(45.0, 100.0) - normal_gravity_mgal(45.0) == pytest.approx(
        22.22, 0.01
    )
