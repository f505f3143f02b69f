"""A statistical gravity anomaly map: a stationary Gaussian random field of stated statistics.

World side. wang2023's map is a 1′ × 1′ region of Sandwell et al.'s marine gravity model that the
project cannot download; its only stated statistic is its range, −37.2 … 40.8 mGal (78 mGal,
wang2023 §4). The twin's physical map (``twin.world.gravity``: a seafloor forward-modelled at the
sea surface) has the range but not the texture that the paper's tables imply (issue 28: median
gradient 1.0 mGal/km, 34 km correlation length, and its "other maps" differ only in abyssal
hills). This module draws maps *by their statistics* instead, each seed an independent map:

* **Covariance**: isotropic Gaussian, C(r) = σ² exp(−r²/L²) [assumption: chosen because its
  gradient statistics are closed-form, below; a real anomaly spectrum falls off as a power law,
  which this smooth model does not have]. Drawn by filtering white noise with the root of its
  spectrum, S(k) ∝ exp(−k²L²/4), on a grid padded by 3 L so that the FFT's wrap-around does not
  correlate opposite edges (the same construction as the seafloor's abyssal hills).
* **Correlation length** L, 5 km by default [assumption: the value issue 28 filed, not a
  measurement; ``validation/gravity_path_planning.py`` shows the study at 3, 5, 10 and 20 km].
* **Amplitude**: each map is scaled so that its range (max − min over the map) is
  ``range_mgal``, the paper's 78 mGal by default (wang2023 §4). For context, not used: Wang H.
  et al. 2017 (Sensors 17(8):1851, Table 1) give the anomaly's standard deviation in 13 zones of
  the Western Pacific (105–145° E, 0–40° N) as 20.8–79.7 mGal; those zones are hundreds of km
  wide and include wavelengths a 100 km map does not hold.
* **Gradients** follow from σ and L: each horizontal component is N(0, 2σ²/L²), the magnitude
  Rayleigh with median √(2 ln 2)·√2 σ/L ≈ 1.665 σ/L (:func:`gradient_median_mgal_per_m`;
  ``tests/test_gravity_random.py`` checks drawn maps against it). With the 78 mGal range over
  100 × 100 km and L = 5 km, σ ≈ 12 mGal and the median gradient ≈ 4 mGal/km.

The anomaly has zero mean over the map (an anomaly map's zero is arbitrary for matching).
Randomness: only the Generator passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twin.core.gravity_map import GravityGrid

#: Padding of the drawn grid beyond the map, in correlation lengths: the Gaussian covariance is
#: e⁻⁹ ≈ 1e-4 at 3 L, so the FFT's periodic wrap adds no correlation across the map.
PAD_LENGTHS = 3.0


@dataclass(frozen=True, slots=True)
class RandomFieldSpec:
    """A statistical anomaly map (module docstring).

    Attributes:
        size_m: (East, North) extent of the map from its lower-left corner at (0, 0).
        spacing_m: Node spacing.
        correlation_m: Correlation length L of the Gaussian covariance exp(−r²/L²).
        range_mgal: The map's max − min, to which each drawn map is scaled.
    """

    size_m: tuple[float, float] = (100_000.0, 100_000.0)
    spacing_m: float = 1000.0
    correlation_m: float = 5000.0
    range_mgal: float = 78.0

    def __post_init__(self) -> None:
        if not (len(self.size_m) == 2 and all(s > 0 and math.isfinite(s) for s in self.size_m)):
            raise ValueError(f"random map size_m: {self.size_m!r}; allowed: two lengths > 0 m")
        if not (0 < self.spacing_m <= min(self.size_m) / 2):
            raise ValueError(
                f"random map spacing_m: {self.spacing_m!r}; allowed: "
                f"(0, {min(self.size_m) / 2:g}] m"
            )
        if not (self.correlation_m >= self.spacing_m and math.isfinite(self.correlation_m)):
            raise ValueError(
                f"random map correlation_m: {self.correlation_m!r}; allowed: at least the node "
                f"spacing ({self.spacing_m:g} m), finite"
            )
        if not (0 < self.range_mgal < 1e4):
            raise ValueError(f"random map range_mgal: {self.range_mgal!r}; allowed: (0, 1e4)")


def gaussian_filtered_noise(
    shape: tuple[int, int], spacing_m: float, width_m: float, rng: np.random.Generator
) -> np.ndarray:
    """White noise filtered to the Gaussian covariance exp(−r²/w²), not normalised.

    The spectrum of that covariance is ∝ exp(−k²w²/4); the filter is its root. Periodic (FFT):
    pad the grid where opposite edges must not correlate.
    """
    white = rng.standard_normal(shape)
    kx = 2 * math.pi * np.fft.fftfreq(shape[1], spacing_m)
    ky = 2 * math.pi * np.fft.fftfreq(shape[0], spacing_m)
    k2 = ky[:, None] ** 2 + kx[None, :] ** 2
    return np.fft.ifft2(np.fft.fft2(white) * np.exp(-k2 * width_m**2 / 8)).real


def random_anomaly_grid(spec: RandomFieldSpec, rng: np.random.Generator) -> GravityGrid:
    """One map drawn from the spec's statistics (zero mean, range ``spec.range_mgal``)."""
    d = spec.spacing_m
    e = np.arange(0.0, spec.size_m[0] + d / 2, d)
    n = np.arange(0.0, spec.size_m[1] + d / 2, d)
    pad = math.ceil(PAD_LENGTHS * spec.correlation_m / d)
    shape = (n.size + 2 * pad, e.size + 2 * pad)
    field = gaussian_filtered_noise(shape, d, spec.correlation_m, rng)
    v = field[pad : pad + n.size, pad : pad + e.size]
    v = v - v.mean()
    v *= spec.range_mgal / max(float(v.max() - v.min()), 1e-300)
    return GravityGrid(
        e, n, v,
        source=f"random field, L = {spec.correlation_m / 1e3:g} km, range {spec.range_mgal:g} mGal",
    )  # fmt: skip


def gradient_median_mgal_per_m(sigma_mgal: float, correlation_m: float) -> float:
    """The median |∇g| of a Gaussian-covariance field of standard deviation σ and length L.

    Each component of ∇g is N(0, s²) with s² = −∂²C/∂x²(0) = 2σ²/L²; |∇g| is Rayleigh(s), whose
    median is s √(2 ln 2).
    """
    return math.sqrt(2.0 * math.log(2.0)) * math.sqrt(2.0) * sigma_mgal / correlation_m


def map_statistics(grid: GravityGrid) -> dict[str, float]:
    """What a reader compares maps by: range, σ, gradients, correlation length.

    The gradient's median and 90th percentile from central differences at the nodes (mGal/km);
    the correlation length (m) where the map's autocorrelation along East and North, averaged,
    first falls below 1/e.
    """
    v = grid.values_mgal
    de, dn = (float(s) for s in grid.spacing_m)
    gn, ge = np.gradient(v, dn, de)
    mag = np.hypot(ge, gn)[1:-1, 1:-1] * 1e3
    a = v - v.mean()
    var = float((a * a).mean())
    lags = np.arange(1, max(2, min(a.shape) // 2))
    corr = np.array(
        [0.5 * ((a[:, k:] * a[:, :-k]).mean() + (a[k:, :] * a[:-k, :]).mean()) / var for k in lags]
    )
    below = np.flatnonzero(corr < math.exp(-1.0))
    if below.size:
        k = int(below[0])
        c0 = 1.0 if k == 0 else corr[k - 1]
        lag0 = 0.0 if k == 0 else float(lags[k - 1])
        # Linear between the last lag above 1/e and the first below it.
        frac = (c0 - math.exp(-1.0)) / (c0 - corr[k])
        corr_len = (lag0 + frac * (lags[k] - lag0)) * 0.5 * (de + dn)
    else:
        corr_len = math.inf
    return {
        "range_mgal": float(v.max() - v.min()),
        "sigma_mgal": math.sqrt(var),
        "gradient_median_mgal_per_km": float(np.median(mag)),
        "gradient_p90_mgal_per_km": float(np.percentile(mag, 90)),
        "correlation_length_m": float(corr_len),
    }


__all__ = [
    "RandomFieldSpec",
    "gaussian_filtered_noise",
    "gradient_median_mgal_per_m",
    "map_statistics",
    "random_anomaly_grid",
]
