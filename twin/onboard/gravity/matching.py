"""Gravity matching in the navigation filter: a gravimeter reading as a position update.

Onboard side. The vehicle carries a stored anomaly map (:class:`StoredMap`: what a survey or
Sandwell's grid gives it, with the map's declared error) and reads a marine gravimeter
(``sensors.gravimeter``), which measures specific force, not the anomaly. Each reading is

1. **reduced** to an anomaly with the vehicle's own estimates: a_m = g̃ − γ(L̂, d̂) + E(v̂), with
   γ the normal gravity the map is referred to
   (:func:`twin.core.earth.normal_gravity_in_water_mgal`)
   and E the Eötvös effect of the estimated velocity (:func:`twin.core.earth.eotvos_mgal`);
2. **matched** by SITAN (wang2023 §4, eqs. 34–37; :func:`twin.onboard.gravity.sitan.sitan_slope`):
   the predicted anomaly is the stored map at the estimated position, the measurement matrix the
   map's slope fitted over the INS's confidence region (half-width L = ⌈σ_max/δ⌉ nodes);
3. **averaged** over ``window_s`` (the vertical accelerations of depth keeping: ``GravityMatcher``)
   and **fused** as a scalar update of the 15-state ESKF (``Eskf.update_scalar``),
   innovation-gated.

With errors defined as estimate − truth, the innovation z = Δg_M(x̂) − a_m is linear in

    z ≈ h_E δE + h_N δN + ∂γ/∂L δL − ∂γ/∂d δh... − ∂E/∂v_E δv_E − ∂E/∂v_N δv_N + noise

(δE = (R_N + h) cos L δλ, δN = (R_M + h) δL; the depth term enters through h = −d as −∂γ/∂d δh
with the sign of d̂ − d = −δh), so the filter learns velocity from the Eötvös term too, as a real
GAINS does. The noise variance is wang2023's eq. 3: R = σ_m² + C₀β²δ⁴/4 + σ_g², with the map's
variance C₀ and correlation distance (β = 1/ℓ²) measured on the stored map itself, δ its node
spacing, σ_g the gravimeter's declared noise — plus SITAN's own linearization error, the map's
spread about the fitted plane over the window (Hostetler & Andreas 1983; without it the filter
trusted a slope where the map curves and walked off at metres per second).

An estimate off the stored map, or a reading that is not finite (the world's field ends), is
skipped with its reason; nothing non-finite reaches the filter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from twin.core import earth
from twin.core.gravity_map import GravityGrid
from twin.onboard.eskf import Eskf, UpdateResult
from twin.onboard.eskf_dynamics import DIM, DV, I_H, I_LAT, I_LON
from twin.onboard.gravity.pcrb import observation_variance
from twin.onboard.gravity.sitan import sitan_slope

I_VE, I_VN = DV.start, DV.start + 1  # δv_E, δv_N in the ESKF's state


def correlation_distance_m(grid: GravityGrid) -> float:
    """Where the map's isotropic autocorrelation falls to 1/e (m), from its power spectrum."""
    v = grid.values_mgal - grid.values_mgal.mean()
    ny, nx = v.shape
    # Zero-padded FFT autocorrelation (no wrap-around), averaged over the two axes.
    f = np.fft.rfft2(v, s=(2 * ny, 2 * nx))
    acf = np.fft.irfft2(np.abs(f) ** 2, s=(2 * ny, 2 * nx))
    counts = np.fft.irfft2(
        np.abs(np.fft.rfft2(np.ones_like(v), s=(2 * ny, 2 * nx))) ** 2, s=(2 * ny, 2 * nx)
    )
    acf = acf / np.maximum(counts, 1.0)
    if not acf[0, 0] > 0.0:
        return math.inf  # a flat map: no variance to correlate (β = 0)
    de, dn = grid.spacing_m
    ax_e, ax_n = acf[0, :nx] / acf[0, 0], acf[:ny, 0] / acf[0, 0]
    lengths = []
    for ax, d in ((ax_e, de), (ax_n, dn)):
        below = np.nonzero(ax < math.exp(-1.0))[0]
        if below.size == 0:
            lengths.append(d * (ax.size - 1))  # correlated over the whole map
            continue
        k = int(below[0])
        a0, a1 = ax[k - 1], ax[k]
        lengths.append(d * (k - 1 + (a0 - math.exp(-1.0)) / max(a0 - a1, 1e-12)))
    return float(np.mean(lengths))


@dataclass(frozen=True, eq=False)
class StoredMap:
    """The anomaly map the vehicle carries, and what it is told about its errors.

    Attributes:
        grid: The stored anomaly grid (mGal) in map coordinates (m).
        launch_m: Where the launch point (the navigation origin) lies on the map (E, N) (m).
        sigma_map_mgal: Declared 1σ error of the map's nodes (σ_m of eq. 3).
        sigma_gravimeter_mgal: Declared 1σ noise of the gravimeter's readings (σ_g).
        max_half_window: Largest half-width L of the SITAN slope fit (nodes).
        variance_mgal2: Eq. 3's R for one reading (derived: σ_m², C₀β²δ⁴/4 with the map's own
            variance and correlation distance, σ_g²).
        map_variance_mgal2: Its map part alone (σ_m² and the resolution term), which averaging
            readings does not reduce.
    """

    grid: GravityGrid
    launch_m: tuple[float, float]
    sigma_map_mgal: float = 1.7
    sigma_gravimeter_mgal: float = 0.5
    max_half_window: int = 10
    variance_mgal2: float = field(init=False)
    map_variance_mgal2: float = field(init=False)

    def __post_init__(self) -> None:
        for name in ("sigma_map_mgal", "sigma_gravimeter_mgal"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"StoredMap.{name}: {v!r}; allowed: >= 0 mGal")
        if not (isinstance(self.max_half_window, int) and self.max_half_window >= 1):
            raise ValueError(f"StoredMap.max_half_window: {self.max_half_window!r}; allowed: >= 1")
        e, n = self.launch_m
        if not bool(self.grid.contains(e, n)):
            x0, x1, y0, y1 = self.grid.extent_m
            raise ValueError(
                f"gravity map launch point ({e:.0f}, {n:.0f}) m is off the stored map "
                f"[{x0:.0f}, {x1:.0f}] × [{y0:.0f}, {y1:.0f}] m"
            )
        c0 = float(np.var(self.grid.values_mgal))
        ell = correlation_distance_m(self.grid)
        delta = float(min(self.grid.spacing_m))
        r = observation_variance(
            self.sigma_map_mgal, c0, 1.0 / ell**2, delta, self.sigma_gravimeter_mgal
        )
        # Eq. 3 for one reading, and its map part (error + resolution) alone.
        object.__setattr__(self, "variance_mgal2", max(r, 1e-6))
        object.__setattr__(self, "map_variance_mgal2", r - self.sigma_gravimeter_mgal**2)


@dataclass(frozen=True, slots=True)
class MatchResult:
    """One gravimeter reading's fate: the update, or why there was none."""

    t: float
    applied: bool
    innovation_mgal: float = math.nan
    half_window: int = 0
    reason: str = ""
    update: UpdateResult | None = None
    variance_mgal2: float = math.nan


def linearization_variance(
    grid: GravityGrid, east_m: float, north_m: float, half: int, h_e: float, h_n: float
) -> float:
    """What the fitted plane misses over SITAN's window (mGal²): the map's spread about it.

    Hostetler & Andreas (1983) add this residual to R: where the map curves within the INS's
    confidence region, one slope does not say where the vehicle is, and a filter that took it at
    its word would trust a wrong direction (navigation.md §3.3).
    """
    i, j = (int(x) for x in grid.nearest_node(east_m, north_m))
    j0, j1 = max(j - half, 0), min(j + half + 1, grid.north_m.size)
    i0, i1 = max(i - half, 0), min(i + half + 1, grid.east_m.size)
    v = grid.values_mgal[j0:j1, i0:i1]
    de = grid.east_m[i0:i1] - grid.east_m[i]
    dn = grid.north_m[j0:j1] - grid.north_m[j]
    plane = h_e * de[None, :] + h_n * dn[:, None]
    r = v - plane
    return float(np.var(r))


class GravityMatcher:
    """Turns gravimeter readings into ESKF updates against a :class:`StoredMap`.

    A marine gravimeter's reading carries the vehicle's vertical acceleration: a few mm/s² of
    depth-keeping are hundreds of mGal. Like every marine gravity processing chain (the AT1M's
    own filters, and the 1–4 min Gaussian filters of survey processing), the vehicle averages:
    each reading is reduced (normal gravity, Eötvös with the estimated velocity, and the vertical
    acceleration the filter itself estimates from its vertical velocity), then ``window_s`` of
    reduced readings are fused as one update against the mean of the map along the estimated
    track over the same window [ours: 60 s, the short end of survey filters]. The white noise
    averages down (σ_g²/N); the map's error and resolution terms of eq. 3 do not (they are
    correlated along a few hundred metres of track).

    Args:
        stored: The map and its declared errors.
        origin_lat_rad: Latitude of the navigation origin (the launch point).
        origin_lon_rad: Its longitude.
        window_s: Averaging window (s).
    """

    def __init__(
        self,
        stored: StoredMap,
        origin_lat_rad: float,
        origin_lon_rad: float,
        window_s: float = 60.0,
    ):
        if not (math.isfinite(window_s) and window_s > 0):
            raise ValueError(f"GravityMatcher window_s: {window_s!r}; allowed: > 0 s")
        self.stored = stored
        self.lat0 = origin_lat_rad
        self.lon0 = origin_lon_rad
        self.window_s = float(window_s)
        r_m, r_n = earth.principal_radii(origin_lat_rad)
        self._m_per_rad = (r_m, r_n * math.cos(origin_lat_rad))
        self.results: list[MatchResult] = []
        self._buf: list[tuple[float, float, float]] = []  # (reduced anomaly, map E, map N)
        self._t0: float | None = None
        self._last_vu: tuple[float, float] | None = None  # (t, estimated v_U) of the last reading

    def map_position(self, lat_rad: float, lon_rad: float) -> tuple[float, float]:
        """Map coordinates (m) of an estimated position."""
        e0, n0 = self.stored.launch_m
        return (
            e0 + (lon_rad - self.lon0) * self._m_per_rad[1],
            n0 + (lat_rad - self.lat0) * self._m_per_rad[0],
        )

    def update(self, f: Eskf, t: float, gravity_mgal: float) -> MatchResult | None:
        """Reduce one reading; fuse the window when it is full. The result, or None meanwhile."""
        res = self._add(f, t, gravity_mgal)
        if res is not None:
            self.results.append(res)
        return res

    def _add(self, f: Eskf, t: float, gravity_mgal: float) -> MatchResult | None:
        if not math.isfinite(gravity_mgal):
            return MatchResult(t, False, reason="gravimeter reading not finite")
        ins = f.ins
        lat, h = ins.lat, ins.h
        v_e, v_n, v_u = (float(x) for x in ins.v)
        depth = max(-h, 0.0)
        e, n = self.map_position(lat, ins.lon)
        if not bool(self.stored.grid.contains(e, n)):
            self._buf.clear()
            self._t0 = None
            return MatchResult(t, False, reason="estimate off the stored map")
        a_up = 0.0
        if self._last_vu is not None and t > self._last_vu[0]:
            a_up = (v_u - self._last_vu[1]) / (t - self._last_vu[0])
        self._last_vu = (t, v_u)
        anomaly = gravity_mgal - earth.normal_gravity_in_water_mgal(lat, depth)
        anomaly += earth.eotvos_mgal(v_e, v_n, lat) - a_up / earth.MGAL_MPS2
        if self._t0 is None:
            self._t0 = t
        self._buf.append((anomaly, e, n))
        if t - self._t0 < self.window_s - 1e-9:
            return None
        res = self._fuse(f, t)
        self._buf.clear()
        self._t0 = None
        return res

    def _fuse(self, f: Eskf, t: float) -> MatchResult:
        grid = self.stored.grid
        buf = np.asarray(self._buf)
        ee, nn = buf[:, 1], buf[:, 2]
        ins = f.ins
        lat, h = ins.lat, ins.h
        v_e, v_n = float(ins.v[0]), float(ins.v[1])
        depth = max(-h, 0.0)
        r_m, r_n = earth.principal_radii(lat)
        m_n, m_e = r_m + h, (r_n + h) * math.cos(lat)
        # SITAN's window from the filter's horizontal position covariance (m²).
        jac = np.diag([m_n, m_e])
        p_pos = jac @ f.P[I_LAT : I_LON + 1, I_LAT : I_LON + 1] @ jac
        sig = math.sqrt(max(float(np.linalg.eigvalsh(p_pos)[-1]), 0.0))
        half = int(min(max(math.ceil(sig / min(grid.spacing_m)), 1), self.stored.max_half_window))
        slopes = sitan_slope(grid, ee, nn, np.full(ee.size, half))
        h_e, h_n = (float(x) for x in slopes.mean(axis=0))
        z = float(np.mean(grid.value(ee, nn))) - float(buf[:, 0].mean())
        # The map's error is drawn per node and interpolated between them: windows closer than
        # a node spacing δ share it. Each window is fused as if independent, so it carries
        # δ/d times the map variance (d: the track it covered) — one independent look per node,
        # the information the map really holds (and the spacing the bound assumes).
        track = float(np.sum(np.hypot(np.diff(ee), np.diff(nn))))
        shared = max(1.0, min(grid.spacing_m) / max(track, 1e-9))
        var = (
            self.stored.map_variance_mgal2 * shared
            + self.stored.sigma_gravimeter_mgal**2 / len(buf)
            + linearization_variance(grid, float(ee[-1]), float(nn[-1]), half, h_e, h_n)
        )
        row = np.zeros(DIM)
        eps = 1e-6
        dgamma_dlat = (
            earth.normal_gravity_in_water_mgal(lat + eps, depth)
            - earth.normal_gravity_in_water_mgal(lat - eps, depth)
        ) / (2 * eps)
        row[I_LAT] = h_n * m_n + dgamma_dlat
        row[I_LON] = h_e * m_e
        row[I_H] = -earth.POINCARE_PREY_MGAL_PER_M if depth > 0 else 0.0
        # −∂E/∂v of the Eötvös effect (mGal per m/s).
        row[I_VE] = -(2.0 * earth.OMEGA_IE * math.cos(lat) + 2.0 * v_e / earth.A_M)
        row[I_VE] /= earth.MGAL_MPS2
        row[I_VN] = -(2.0 * v_n / earth.A_M) / earth.MGAL_MPS2
        upd = f.update_scalar("map", z, row, max(var, 1e-6))
        reason = "" if upd.applied else upd.reason
        return MatchResult(t, upd.applied, z, half, reason, upd, max(var, 1e-6))


__all__ = [
    "GravityMatcher",
    "MatchResult",
    "StoredMap",
    "correlation_distance_m",
    "linearization_variance",
]
