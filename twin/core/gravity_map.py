"""A gravity-anomaly grid over the operating area: the one map type both sides use.

The world's true field (``twin.world.gravity``) and the vehicle's stored map (onboard, with its
map error) are both a :class:`GravityGrid`: anomaly values in mGal on a regular grid of local
East/North coordinates in metres. Interpolation is bilinear, as the PCRB paper's h(x) (wang2023
eq. 2), and so is its gradient (piecewise constant per cell, the derivative of the bilinear
surface), which is what the bound's H is.

Grids come from a synthetic model (world side) or from a file: :func:`load_grid` reads any
NetCDF/GeoTIFF that xarray opens (a region of the Sandwell–Smith marine gravity grid, say) and
converts longitude/latitude to East/North about the grid's centre with the paper's eqs. 31–32
(a local flat projection on the WGS84 radii of curvature at the centre), onto a regular grid of
the requested spacing.

Why a hand-written bilinear interpolator: scipy's RegularGridInterpolator gives values but not
the per-cell gradient, and the filter needs both at thousands of points per step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twin.core.arrays import Float64Array as FloatArray

# WGS84 (the paper's eq. 31–32 quote R_e = 6378137 m, f = 1/298.3).
_RE_M = 6378137.0
_F = 1.0 / 298.257223563


class OffMapError(ValueError):
    """A position outside the map's extent."""


@dataclass(frozen=True, eq=False)
class GravityGrid:
    """Gravity anomaly (mGal) on a regular East/North grid.

    Attributes:
        east_m: (nx,) strictly increasing, equally spaced East coordinates of the nodes.
        north_m: (ny,) the same for North.
        values_mgal: (ny, nx) anomaly at the nodes, ``values_mgal[j, i]`` at
            (``east_m[i]``, ``north_m[j]``). Finite everywhere.
        source: What the grid is (a model and its seed, or a file), for reports.
    """

    east_m: FloatArray
    north_m: FloatArray
    values_mgal: FloatArray
    source: str = ""
    _integral: FloatArray = field(init=False, repr=False)
    _node_grad: tuple[FloatArray, FloatArray] | None = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        e = np.asarray(self.east_m, dtype=np.float64)
        n = np.asarray(self.north_m, dtype=np.float64)
        v = np.asarray(self.values_mgal, dtype=np.float64)
        for name, axis in (("east_m", e), ("north_m", n)):
            if axis.ndim != 1 or axis.size < 2:
                raise ValueError(f"gravity map {name}: needs >= 2 nodes, got shape {axis.shape}")
            d = np.diff(axis)
            if not (np.all(np.isfinite(axis)) and np.all(d > 0)):
                raise ValueError(f"gravity map {name}: must be finite and strictly increasing")
            if np.ptp(d) > 1e-6 * d.mean():
                raise ValueError(f"gravity map {name}: nodes must be equally spaced")
        if v.shape != (n.size, e.size):
            raise ValueError(
                f"gravity map values: shape {v.shape}; allowed: (north, east) = "
                f"({n.size}, {e.size})"
            )
        bad = ~np.isfinite(v)
        if bad.any():
            j, i = np.argwhere(bad)[0]
            raise ValueError(
                f"gravity map values: {int(bad.sum())} NaN or infinite nodes (first at East "
                f"{e[i]:.0f} m, North {n[j]:.0f} m); allowed: finite everywhere (fill the holes, "
                "e.g. with verde or xarray's interpolate_na, before using the map)"
            )
        object.__setattr__(self, "east_m", e)
        object.__setattr__(self, "north_m", n)
        object.__setattr__(self, "values_mgal", v)
        # Summed-area table, for window sums in O(1) (SITAN's fit, eqs. 36–37).
        s = np.zeros((n.size + 1, e.size + 1))
        s[1:, 1:] = v.cumsum(0).cumsum(1)
        object.__setattr__(self, "_integral", s)

    # ---- geometry --------------------------------------------------------------------------
    @property
    def spacing_m(self) -> tuple[float, float]:
        """(East, North) node spacing δ."""
        return float(self.east_m[1] - self.east_m[0]), float(self.north_m[1] - self.north_m[0])

    @property
    def extent_m(self) -> tuple[float, float, float, float]:
        """(east min, east max, north min, north max)."""
        return (
            float(self.east_m[0]),
            float(self.east_m[-1]),
            float(self.north_m[0]),
            float(self.north_m[-1]),
        )

    def contains(self, east_m: ArrayLike, north_m: ArrayLike) -> NDArray[np.bool_]:
        """Whether points lie on the map (edges included)."""
        e0, e1, n0, n1 = self.extent_m
        e, n = np.asarray(east_m, dtype=np.float64), np.asarray(north_m, dtype=np.float64)
        return (e >= e0) & (e <= e1) & (n >= n0) & (n <= n1)

    def require_on_map(self, east_m: ArrayLike, north_m: ArrayLike, what: str) -> None:
        """Raise :class:`OffMapError` naming ``what`` if any point lies off the map."""
        e, n = np.asarray(east_m, dtype=np.float64), np.asarray(north_m, dtype=np.float64)
        inside = self.contains(e, n)
        if not np.all(inside):
            k = int(np.flatnonzero(~np.ravel(inside))[0])
            e0, e1, n0, n1 = self.extent_m
            raise OffMapError(
                f"{what}: (E {np.ravel(e)[k]:.0f} m, N {np.ravel(n)[k]:.0f} m) lies off the "
                f"gravity map; allowed: East {e0:.0f}…{e1:.0f} m, North {n0:.0f}…{n1:.0f} m"
            )

    # ---- interpolation ---------------------------------------------------------------------
    def _cell(self, east_m: ArrayLike, north_m: ArrayLike):
        de, dn = self.spacing_m
        fx = (np.asarray(east_m, dtype=np.float64) - self.east_m[0]) / de
        fy = (np.asarray(north_m, dtype=np.float64) - self.north_m[0]) / dn
        nx, ny = self.east_m.size, self.north_m.size
        # Points off the map take the nearest edge cell (callers that care check first).
        i = np.clip(np.floor(fx), 0, nx - 2).astype(np.int64)
        j = np.clip(np.floor(fy), 0, ny - 2).astype(np.int64)
        tx = np.clip(fx - i, 0.0, 1.0)
        ty = np.clip(fy - j, 0.0, 1.0)
        return i, j, tx, ty

    def value(self, east_m: ArrayLike, north_m: ArrayLike) -> FloatArray:
        """Bilinear anomaly (mGal) at points of any shape (clamped to the map's edge)."""
        i, j, tx, ty = self._cell(east_m, north_m)
        v = self.values_mgal
        return (
            v[j, i] * (1 - tx) * (1 - ty)
            + v[j, i + 1] * tx * (1 - ty)
            + v[j + 1, i] * (1 - tx) * ty
            + v[j + 1, i + 1] * tx * ty
        )

    def gradient(self, east_m: ArrayLike, north_m: ArrayLike) -> FloatArray:
        """(..., 2) gradient of the bilinear surface (mGal/m): (∂/∂East, ∂/∂North)."""
        i, j, tx, ty = self._cell(east_m, north_m)
        v = self.values_mgal
        de, dn = self.spacing_m
        ge = ((v[j, i + 1] - v[j, i]) * (1 - ty) + (v[j + 1, i + 1] - v[j + 1, i]) * ty) / de
        gn = ((v[j + 1, i] - v[j, i]) * (1 - tx) + (v[j + 1, i + 1] - v[j, i + 1]) * tx) / dn
        return np.stack([ge, gn], axis=-1)

    def node_gradient(self, east_m: ArrayLike, north_m: ArrayLike) -> FloatArray:
        """(..., 2) gradient (mGal/m) from central differences at the nodes, bilinear between.

        The bilinear surface's own derivative (:meth:`gradient`) jumps across cell edges and is
        undefined on them — where a path on the grid runs. The bound and the planner take this
        continuous one: the same slope at a node's neighbourhood scale δ.
        """
        if self._node_grad is None:
            de, dn = self.spacing_m
            gn, ge = np.gradient(self.values_mgal, dn, de)
            object.__setattr__(self, "_node_grad", (ge, gn))
        ge, gn = self._node_grad
        i, j, tx, ty = self._cell(east_m, north_m)
        out = []
        for g in (ge, gn):
            out.append(
                g[j, i] * (1 - tx) * (1 - ty)
                + g[j, i + 1] * tx * (1 - ty)
                + g[j + 1, i] * (1 - tx) * ty
                + g[j + 1, i + 1] * tx * ty
            )
        return np.stack(out, axis=-1)

    def window_sum(self, j0: ArrayLike, j1: ArrayLike, i0: ArrayLike, i1: ArrayLike) -> FloatArray:
        """Σ values[j0:j1, i0:i1] (half-open, clipped to the grid), vectorised."""
        ny, nx = self.values_mgal.shape
        a = np.clip(np.asarray(j0), 0, ny)
        b = np.clip(np.asarray(j1), 0, ny)
        c = np.clip(np.asarray(i0), 0, nx)
        d = np.clip(np.asarray(i1), 0, nx)
        s = self._integral
        return s[b, d] - s[a, d] - s[b, c] + s[a, c]

    def nearest_node(self, east_m: ArrayLike, north_m: ArrayLike) -> tuple[NDArray, NDArray]:
        """(column i, row j) of the nearest node, clipped to the grid."""
        de, dn = self.spacing_m
        i = np.rint((np.asarray(east_m, dtype=np.float64) - self.east_m[0]) / de)
        j = np.rint((np.asarray(north_m, dtype=np.float64) - self.north_m[0]) / dn)
        return (
            np.clip(i, 0, self.east_m.size - 1).astype(np.int64),
            np.clip(j, 0, self.north_m.size - 1).astype(np.int64),
        )

    def with_values(self, values_mgal: ArrayLike, source: str) -> GravityGrid:
        """The same grid with other values (a map with its map error, say)."""
        return GravityGrid(self.east_m, self.north_m, np.asarray(values_mgal), source)

    def to_dataarray(self) -> Any:
        """The grid as an ``xarray.DataArray`` (dims ``north``, ``east``; mGal)."""
        import xarray as xr

        return xr.DataArray(
            self.values_mgal,
            coords={"north": self.north_m, "east": self.east_m},
            dims=("north", "east"),
            name="gravity_anomaly",
            attrs={"units": "mGal", "source": self.source},
        )


def local_en_m(lon_deg: ArrayLike, lat_deg: ArrayLike, lon0_deg: float, lat0_deg: float):
    """wang2023 eqs. 31–32: East/North (m) from longitude/latitude about (lon0, lat0).

    R_m = R_e (1 − 2f + 3f sin²φ0) (meridian), R_n = R_e (1 + f sin²φ0) (prime vertical).
    """
    s2 = math.sin(math.radians(lat0_deg)) ** 2
    rm = _RE_M * (1 - 2 * _F + 3 * _F * s2)
    rn = _RE_M * (1 + _F * s2)
    e = (np.asarray(lon_deg, dtype=np.float64) - lon0_deg) * math.cos(math.radians(lat0_deg))
    return e * rn * math.pi / 180.0, (np.asarray(lat_deg) - lat0_deg) * rm * math.pi / 180.0


_LON_NAMES = ("lon", "longitude", "x")
_LAT_NAMES = ("lat", "latitude", "y")


def load_grid(path: str | Path, *, variable: str | None = None, spacing_m: float = 1000.0):
    """Read a gravity-anomaly grid (mGal) on longitude/latitude and resample it to East/North.

    Args:
        path: A file xarray opens (NetCDF; GeoTIFF with rioxarray installed).
        variable: The data variable; default the file's only one.
        spacing_m: Node spacing of the East/North grid (the paper's δ = 1 km).

    Returns:
        A :class:`GravityGrid` centred on the file's centre (East/North 0 there), covering the
        largest East/North rectangle inside the file's footprint.

    Raises:
        ValueError: Naming what is wrong (no such file, no lon/lat axes, NaN holes).
    """
    import xarray as xr
    from scipy.interpolate import RegularGridInterpolator

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"gravity map file: {str(p)!r} does not exist")
    try:
        ds = xr.open_dataset(p)
    except Exception as e:  # xarray raises many types for a file it cannot read
        raise ValueError(f"gravity map file: {str(p)!r} could not be read ({e})") from None
    with ds:
        names = list(ds.data_vars)
        if variable is None:
            if len(names) != 1:
                raise ValueError(
                    f"gravity map variable: the file has {names}; name one with variable="
                )
            variable = names[0]
        if variable not in ds:
            raise ValueError(f"gravity map variable: {variable!r}; allowed: {names}")
        da = ds[variable].squeeze()
        lon = next((c for c in _LON_NAMES if c in da.dims), None)
        lat = next((c for c in _LAT_NAMES if c in da.dims), None)
        if lon is None or lat is None or da.ndim != 2:
            raise ValueError(
                f"gravity map {variable!r}: dims {da.dims}; allowed: a 2-D grid on "
                f"{_LON_NAMES} × {_LAT_NAMES}"
            )
        da = da.sortby(lon).sortby(lat).transpose(lat, lon)
        lons = np.asarray(da[lon], dtype=np.float64)
        lats = np.asarray(da[lat], dtype=np.float64)
        vals = np.asarray(da.values, dtype=np.float64)
    bad = ~np.isfinite(vals)
    if bad.any():
        j, i = np.argwhere(bad)[0]
        raise ValueError(
            f"gravity map {variable!r}: {int(bad.sum())} NaN nodes (first at lon {lons[i]:.4f}, "
            f"lat {lats[j]:.4f}); allowed: finite everywhere (fill the holes first)"
        )
    lon0, lat0 = float(lons.mean()), float(lats.mean())
    # The East/North rectangle inside the footprint: the narrowest parallel bounds East.
    e_lo, _ = local_en_m(lons[0], lats, lon0, lat0)
    e_hi, _ = local_en_m(lons[-1], lats, lon0, lat0)
    _, n_lo = local_en_m(lon0, lats[0], lon0, lat0)
    _, n_hi = local_en_m(lon0, lats[-1], lon0, lat0)
    e_min, e_max = float(np.max(e_lo)), float(np.min(e_hi))
    east = np.arange(math.ceil(e_min / spacing_m), math.floor(e_max / spacing_m) + 1) * spacing_m
    north = np.arange(math.ceil(n_lo / spacing_m), math.floor(n_hi / spacing_m) + 1) * spacing_m
    if east.size < 2 or north.size < 2:
        raise ValueError(
            f"gravity map {variable!r}: the file spans less than two {spacing_m:g} m nodes"
        )
    s2 = math.sin(math.radians(lat0)) ** 2
    rm = _RE_M * (1 - 2 * _F + 3 * _F * s2)
    rn = _RE_M * (1 + _F * s2)
    ee, nn = np.meshgrid(east, north)
    lat_q = lat0 + nn / (rm * math.pi / 180.0)
    lon_q = lon0 + ee / (rn * math.pi / 180.0 * math.cos(math.radians(lat0)))
    interp = RegularGridInterpolator((lats, lons), vals, method="linear")
    values = interp(np.stack([lat_q, lon_q], axis=-1))
    return GravityGrid(east, north, values, source=f"{p.name}:{variable}")


__all__ = ["GravityGrid", "OffMapError", "load_grid", "local_en_m"]
