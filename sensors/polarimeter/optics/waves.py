"""Waves: Cox & Munk's slope statistics and a time-correlated slope field of the sea surface.

Cox & Munk (1954) JOSA 44:838 slope statistics (clean and slick surfaces, optics.md §2.3) and a
cheap, time-correlated random slope field (:class:`WaveSurface`) that perturbs the facet normals
of the air–water interface (:mod:`sensors.polarimeter.optics.surface`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sensors.polarimeter.optics.blocks import as_rotation
from sensors.polarimeter.optics.surface import _dtype
from twin.core.arrays import FloatArray


def cox_munk_variances(wind_speed_mps: float, slick: bool = False) -> tuple[float, float]:
    """Cross-wind and up-wind slope variances (σ_c², σ_u²) of Cox & Munk (1954).

    clean: σ_c² = 0.003 + 1.92e-3 W, σ_u² = 3.16e-3 W (their sum, 0.003 + 5.08e-3 W, is within
    1 % of Cox & Munk's separately fitted isotropic σ² = 0.003 + 5.12e-3 W);
    slick: σ_c² = 0.003 + 0.84e-3 W, σ_u² = 0.005 + 0.78e-3 W (optics.md §2.3). W is the wind
    speed at 12.5 m (41 ft) in m/s; Cox & Munk's data span about 1–14 m/s.

    Below 1 m/s there are no data, and the fits' intercepts (0.003, 0.005) are not a glassy sea:
    here the variances are scaled by W/(1 m/s) there, so W = 0 is exactly flat and the field
    grows continuously into Cox & Munk's range (our choice, not theirs).

    Args:
        wind_speed_mps: Wind speed W at 12.5 m in m/s, 0 to 30.
        slick: Use the slick-covered (oil film) fit instead of the clean-surface one.

    Returns:
        (σ_c², σ_u²).
    """
    w = float(wind_speed_mps)
    if not (math.isfinite(w) and 0.0 <= w <= 30.0):
        raise ValueError(f"wind_speed_mps must lie in [0, 30] m/s, got {wind_speed_mps!r}")
    if slick:
        var_c, var_u = 0.003 + 0.84e-3 * w, 0.005 + 0.78e-3 * w
    else:
        var_c, var_u = 0.003 + 1.92e-3 * w, 3.16e-3 * w
    taper = min(w / 1.0, 1.0)
    return var_c * taper, var_u * taper


def cox_munk_pdf(
    zx: ArrayLike, zy: ArrayLike, wind_speed_mps: float, slick: bool = False
) -> FloatArray:
    """Cox & Munk's Gram–Charlier slope density p(z_x, z_y) (cross-wind x, up-wind y).

    p = (2π σ_c σ_u)⁻¹ exp(−(ξ² + η²)/2) [1 − ½c21(ξ² − 1)η − ⅙c03(η³ − 3η) + (1/24)c40(ξ⁴ − 6ξ²
    + 3) + ¼c22(ξ² − 1)(η² − 1) + (1/24)c04(η⁴ − 6η² + 3)], ξ = z_x/σ_c, η = z_y/σ_u, with
    clean c21 = 0.01 − 0.0086 W, c03 = 0.04 − 0.033 W, c40 = 0.40, c22 = 0.12, c04 = 0.23 and slick
    c21 = 0, c03 = 0.02, c40 = 0.36, c22 = 0.10, c04 = 0.26 (optics.md §2.3; the c40 term uses ξ,
    correcting the η typo in Powell's ``p_wave_slope``). The density can dip slightly negative in
    the far tails, as the Gram–Charlier series does; :class:`WaveSurface` samples the Gaussian
    part only.

    Args:
        zx: Cross-wind slopes.
        zy: Up-wind slopes.
        wind_speed_mps: Wind speed at 12.5 m, > 0 (at 0 the surface is flat: no density).
        slick: Slick-surface coefficients.

    Returns:
        Density values, shape of the broadcast slopes.
    """
    if wind_speed_mps <= 0:
        raise ValueError(f"wind_speed_mps must be > 0 for a slope density, got {wind_speed_mps!r}")
    var_c, var_u = cox_munk_variances(wind_speed_mps, slick)
    w = float(wind_speed_mps)
    if slick:
        c21, c03, c40, c22, c04 = 0.0, 0.02, 0.36, 0.10, 0.26
    else:
        c21, c03, c40, c22, c04 = 0.01 - 0.0086 * w, 0.04 - 0.033 * w, 0.40, 0.12, 0.23
    sc, su = math.sqrt(var_c), math.sqrt(var_u)
    xi = np.asarray(zx, dtype=np.float64) / sc
    eta = np.asarray(zy, dtype=np.float64) / su
    x2, e2 = xi * xi, eta * eta
    series = (
        1.0
        - 0.5 * c21 * (x2 - 1.0) * eta
        - c03 / 6.0 * (eta * e2 - 3.0 * eta)
        + c40 / 24.0 * (x2 * x2 - 6.0 * x2 + 3.0)
        + 0.25 * c22 * (x2 - 1.0) * (e2 - 1.0)
        + c04 / 24.0 * (e2 * e2 - 6.0 * e2 + 3.0)
    )
    return np.exp(-0.5 * (x2 + e2)) / (2.0 * math.pi * sc * su) * series


@dataclass(frozen=True, slots=True)
class WindSea:
    """A wind-roughened sea surface's slope statistics and the random field that realises them.

    Attributes:
        wind_speed_mps: Wind speed at 12.5 m (Cox & Munk's anemometer height), m/s; 0 = flat.
        wind_dir_rad: ENU azimuth (counter-clockwise from East) the wind blows towards; the
            up-wind slope axis lies along it.
        slick: Slick-covered surface (Cox & Munk's oil-film fit).
        correlation_time_s: e-folding time of the slopes' temporal autocorrelation (AR(1)):
            ρ(Δt) = exp(−Δt/τ). Short gravity–capillary waves, which carry most slope variance,
            have periods of ~0.1–1 s, so ~0.5 s is a reasonable default (not a measured value).
        correlation_length_m: Spatial correlation length ℓ of the slope field: the covariance is
            exp(−r²/ℓ²). ~0.3 m (decimetre waves) by default (a modelling choice).
        grid_size: Cells per side of the periodic slope grid (power of two for the FFT).
        cell_m: Grid spacing; ℓ/4 or finer keeps the bilinear interpolation smooth.
    """

    wind_speed_mps: float = 0.0
    wind_dir_rad: float = 0.0
    slick: bool = False
    correlation_time_s: float = 0.5
    correlation_length_m: float = 0.3
    grid_size: int = 64
    cell_m: float = 0.075

    def __post_init__(self) -> None:
        cox_munk_variances(self.wind_speed_mps, self.slick)  # validates the wind speed
        if not (math.isfinite(self.wind_dir_rad)):
            raise ValueError(f"wind_dir_rad must be finite, got {self.wind_dir_rad!r}")
        if not (self.correlation_time_s > 0 and math.isfinite(self.correlation_time_s)):
            raise ValueError(f"correlation_time_s must be > 0 s, got {self.correlation_time_s!r}")
        if not (self.correlation_length_m > 0 and math.isfinite(self.correlation_length_m)):
            raise ValueError(
                f"correlation_length_m must be > 0 m, got {self.correlation_length_m!r}"
            )
        if not (8 <= self.grid_size <= 1024):
            raise ValueError(f"grid_size must lie in [8, 1024] cells, got {self.grid_size!r}")
        if not (0 < self.cell_m <= self.correlation_length_m):
            raise ValueError(
                f"cell_m must lie in (0, correlation_length_m={self.correlation_length_m}] m, "
                f"got {self.cell_m!r}"
            )

    @property
    def slope_variances(self) -> tuple[float, float]:
        """(σ_c², σ_u²) of :func:`cox_munk_variances`."""
        return cox_munk_variances(self.wind_speed_mps, self.slick)

    @property
    def flat(self) -> bool:
        """True for a glassy sea (W = 0)."""
        return self.wind_speed_mps == 0.0


class WaveSurface:
    """A periodic, spatially smooth, time-correlated field of Cox–Munk surface slopes.

    Model (cheap by design): two independent unit-variance Gaussian random fields ξ, η on a
    periodic ``grid_size``² grid with Gaussian covariance exp(−r²/ℓ²) (white noise filtered in
    Fourier space, the filter normalised so the expected variance is exactly 1), scaled to the
    cross-wind and up-wind slopes z_c = σ_c ξ, z_u = σ_u η, rotated into ENU. Time evolution is
    an exact AR(1) (discretised Ornstein–Uhlenbeck) update of the white noise,
    w ← ρ w + √(1 − ρ²) ε, ρ = exp(−Δt/τ), so every slope's lag-Δt autocorrelation is ρ and the
    marginal statistics stay stationary. Limits: Gaussian slopes (no Cox–Munk skewness/
    peakedness), no wave propagation (the field decorrelates in place rather than travelling), no
    surface elevation (rays meet the mean plane z = 0), one facet per ray (no multiple
    intersections or shadowing). Because rays sample the actual field, facets tilted towards a
    ray are met as often as geometry says, without an explicit Cox–Munk projected-area weight.

    Randomness comes only from the Generator passed in (same seed ⇒ same field).
    """

    def __init__(self, sea: WindSea, rng: np.random.Generator):
        """Draw the initial field.

        Args:
            sea: Slope statistics and field parameters.
            rng: The component's own Generator (DESIGN: SeedSequence.spawn per component).
        """
        self.sea = sea
        self._rng = rng
        g = sea.grid_size
        k = 2.0 * math.pi * np.fft.fftfreq(g, d=sea.cell_m)
        k2 = k[:, None] ** 2 + k[None, :] ** 2
        # Covariance exp(−r²/ℓ²) ⇔ spectrum ∝ exp(−k²ℓ²/4); the amplitude filter is its root.
        h = np.exp(-k2 * sea.correlation_length_m**2 / 8.0)
        h /= math.sqrt(float(np.mean(h * h)))  # white noise of var 1 → field of var 1
        self._filter = h
        self._noise = rng.standard_normal((2, g, g))
        var_c, var_u = sea.slope_variances
        self._sigma = (math.sqrt(var_c), math.sqrt(var_u))
        self._slopes = self._synthesise()

    def _synthesise(self) -> FloatArray:
        xi, eta = np.fft.ifft2(np.fft.fft2(self._noise) * self._filter).real
        z_c, z_u = self._sigma[0] * xi, self._sigma[1] * eta
        cw, sw = math.cos(self.sea.wind_dir_rad), math.sin(self.sea.wind_dir_rad)
        # up-wind unit (cw, sw), cross-wind unit (−sw, cw): slope vector z_u û + z_c ĉ in ENU.
        return np.stack([z_u * cw - z_c * sw, z_u * sw + z_c * cw], axis=-1)

    def step(self, dt_s: float) -> None:
        """Advance the field by ``dt_s`` seconds (exact AR(1) update)."""
        if not (dt_s >= 0 and math.isfinite(dt_s)):
            raise ValueError(f"dt_s must be >= 0 s, got {dt_s!r}")
        rho = math.exp(-dt_s / self.sea.correlation_time_s)
        eps = self._rng.standard_normal(self._noise.shape)
        self._noise = rho * self._noise + math.sqrt(max(1.0 - rho * rho, 0.0)) * eps
        self._slopes = self._synthesise()

    @property
    def slopes(self) -> FloatArray:
        """(G, G, 2) slopes (∂η/∂East, ∂η/∂North), indexed [East cell, North cell]."""
        return self._slopes

    def slopes_at(self, east_m: ArrayLike, north_m: ArrayLike) -> FloatArray:
        """Bilinearly interpolated slopes at surface points (periodic field), shape (..., 2).

        Args:
            east_m: East coordinates of the surface points, m.
            north_m: North coordinates, m (same shape).
        """
        g, h = self.sea.grid_size, self.sea.cell_m
        fx = np.asarray(east_m) / h
        fy = np.asarray(north_m) / h
        x0, y0 = np.floor(fx), np.floor(fy)
        tx, ty = (fx - x0)[..., None], (fy - y0)[..., None]
        i0 = x0.astype(np.int64) % g
        j0 = y0.astype(np.int64) % g
        i1, j1 = (i0 + 1) % g, (j0 + 1) % g
        f = self._slopes  # indexed [east index, north index]
        out = (f[i0, j0] * (1 - tx) + f[i1, j0] * tx) * (1 - ty) + (
            f[i0, j1] * (1 - tx) + f[i1, j1] * tx
        ) * ty
        return out.astype(np.result_type(fx, np.float32), copy=False)

    def normals_for_rays(
        self,
        look_dirs: ArrayLike,
        camera_east_north_m: ArrayLike,
        depth_m: float,
        *,
        rotation: ArrayLike | None = None,
    ) -> FloatArray:
        """ENU facet normals where camera rays meet the mean surface, shape of ``look_dirs``.

        A ray from a camera at ``depth_m`` below the surface along w (ENU) meets z = 0 at
        (x, y) + depth (w_x, w_y)/w_z. Rays at or below the horizon get the normal at a far point
        (they do not reach the surface; any normal is harmless there). A flat sea returns +z.

        Args:
            look_dirs: (..., 3) in-water look directions (frame F, or ENU).
            camera_east_north_m: (2,) camera position East, North in m.
            depth_m: Camera depth below the mean surface, m (>= 0).
            rotation: C_F^n when ``look_dirs`` are in frame F.
        """
        w = np.asarray(look_dirs)
        w = w.astype(_dtype(w), copy=False)
        if self.sea.flat:
            return np.broadcast_to(np.array([0.0, 0.0, 1.0], dtype=w.dtype), w.shape).copy()
        if not depth_m >= 0:
            raise ValueError(f"depth_m must be >= 0 m, got {depth_m!r}")
        r = as_rotation(rotation)
        if r is not None:
            w = w @ r.T.astype(w.dtype)
        x0, y0 = (float(v) for v in np.asarray(camera_east_north_m).reshape(2))
        # Clamp w_z so horizontal rays land far (1e3 depths) but finite.
        t = depth_m / np.maximum(w[..., 2], 1e-3)
        sl = self.slopes_at(x0 + t * w[..., 0], y0 + t * w[..., 1])
        return slopes_to_normals(sl)


def slopes_to_normals(slopes: ArrayLike) -> FloatArray:
    """Unit upward normals (−z_x, −z_y, 1)/√(1 + z_x² + z_y²) of surface slopes (..., 2)."""
    s = np.asarray(slopes)
    zx, zy = s[..., 0], s[..., 1]
    inv = 1.0 / np.sqrt(1.0 + zx * zx + zy * zy)
    return np.stack([-zx * inv, -zy * inv, inv], axis=-1)
