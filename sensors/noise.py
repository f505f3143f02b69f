"""Reusable sensor error processes: white noise, Gauss–Markov, random walk, quantization.

Each process is vectorised over an array ``shape`` (3 for an inertial triad, (2, 3) for an IMU's
two triads, 1 for a scalar gauge) and keeps its state in a preallocated array: sensors call them at
100 Hz inside the simulator's loop, so a step is a few in-place numpy operations and no allocation.
Randomness comes only from the ``numpy.random.Generator`` passed in, either directly
(:meth:`step`) or as standard normals the caller drew in one batch (:meth:`advance`), which is
cheaper and keeps a sensor's random stream aligned whatever its spec (see :class:`sensors.imu.Imu`).

The formulas are navigation.md §2.2:

* white noise of density N sampled at f_s: σ = N √f_s (N in units/√Hz);
* first-order Gauss–Markov, exact discretisation: b_k = e^{−Δt/τ} b_{k−1} + σ √(1 − e^{−2Δt/τ}) w_k;
* random walk of density K (units/√s): b_k = b_{k−1} + K √Δt w_k;

with w_k ~ N(0, 1). The arrays a process returns are its own state or scratch buffers: read them
or copy them before the next call.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from twin.core.arrays import Float64Array as FloatArray

# sqrt(2 ln 2 / pi): the Allan-deviation floor of flicker (1/f) bias noise is 0.664 B, where B is
# the IEEE Std 952 "bias instability" coefficient (navigation.md §1.6).
FLICKER_FLOOR_RATIO = math.sqrt(2.0 * math.log(2.0) / math.pi)

# The Allan deviation of a first-order Gauss–Markov process of standard deviation σ and correlation
# time τ_c peaks at 0.61736 σ at τ = 1.8926 τ_c (navigation.md §2.2 quotes ≈ 0.618 σ at ≈ 1.89 τ_c;
# these digits are the numerical maximum of :func:`gauss_markov_adev`).
GM_ADEV_PEAK_RATIO = 0.6173642831444408
GM_ADEV_PEAK_TAU_RATIO = 1.8926176808761919


Shape = int | tuple[int, ...]


def _filled(value: ArrayLike, shape: Shape, name: str) -> FloatArray:
    """A fresh float64 array of ``shape`` from a scalar or anything that broadcasts to it."""
    arr = np.asarray(value, dtype=np.float64)
    try:
        return np.array(np.broadcast_to(arr, shape), dtype=np.float64)
    except ValueError:
        raise ValueError(f"{name} of shape {arr.shape} does not broadcast to {shape}") from None


def white_sigma(density: ArrayLike, rate_hz: float) -> FloatArray:
    """Standard deviation of one sample of white noise of ``density`` (units/√Hz) at ``rate_hz``.

    σ = N √f_s (navigation.md §2.2): the noise is band-limited to the Nyquist band of the sampler,
    which is what a sensor that averages over its sample interval delivers.
    """
    return np.asarray(density, dtype=np.float64) * math.sqrt(rate_hz)


def gauss_markov_sigma_for_bias_instability(bias_instability: float) -> float:
    """The σ of a Gauss–Markov process whose Allan-deviation peak equals a flicker floor 0.664 B.

    σ_GM = 0.664 B / 0.6174 ≈ 1.0755 B (navigation.md §2.2 rounds it to 1.07 B). The floor is then
    reached at τ ≈ 1.89 τ_c, so pick τ_c near the τ where the datasheet's Allan curve bottoms out.
    """
    return FLICKER_FLOOR_RATIO * bias_instability / GM_ADEV_PEAK_RATIO


def gauss_markov_adev(tau_s: ArrayLike, sigma: float, tau_c_s: float) -> FloatArray:
    """Analytic Allan deviation of a first-order Gauss–Markov process.

    AVAR(τ) = (2 σ² τ_c / τ) [1 − τ_c / (2τ) (3 − 4 e^{−τ/τ_c} + e^{−2τ/τ_c})]
    (IEEE Std 952-1997, annex C; the exponentially correlated noise term).
    """
    t = np.asarray(tau_s, dtype=np.float64)
    x = t / tau_c_s
    avar = (
        2.0 * sigma**2 * tau_c_s / t * (1.0 - (3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)) / (2 * x))
    )
    return np.sqrt(np.maximum(avar, 0.0))


def quantize(x: ArrayLike, step: float, *, mode: str = "nearest") -> FloatArray:
    """Quantize to multiples of ``step``; ``step == 0`` returns the input unchanged.

    Args:
        x: Value(s) to quantize.
        step: The least significant bit, in the units of ``x``.
        mode: ``"nearest"`` (round half to even, an ideal ADC) or ``"floor"`` (truncation, what
            firmware integer division does for positive values).
    """
    if step == 0.0:
        return np.asarray(x, dtype=np.float64)
    scaled = np.asarray(x, dtype=np.float64) / step
    if mode == "nearest":
        return np.round(scaled) * step
    if mode == "floor":
        return np.floor(scaled) * step
    raise ValueError(f"mode = {mode!r}: must be 'nearest' or 'floor'")


class WhiteNoise:
    """Sampled white noise of a given density: n_k = σ w_k with σ = N √f_s.

    Args:
        density: Noise density N (units/√Hz): a scalar or an array that broadcasts to ``shape``.
        rate_hz: Sampling rate f_s (Hz).
        shape: Shape of one sample (3 for a triad).
    """

    __slots__ = ("sigma", "value")

    def __init__(self, density: ArrayLike, rate_hz: float, shape: Shape = 3):
        self.sigma = white_sigma(_filled(density, shape, "density"), rate_hz)
        self.value = np.zeros(shape)  # the last sample

    def advance(self, w: FloatArray) -> FloatArray:
        """Scale standard normals ``w`` to this noise; returns ``self.value``."""
        return np.multiply(self.sigma, w, out=self.value)

    def step(self, rng: np.random.Generator) -> FloatArray:
        """Draw one sample; returns ``self.value`` (overwritten by the next call)."""
        rng.standard_normal(out=self.value)
        return np.multiply(self.sigma, self.value, out=self.value)


class GaussMarkov:
    """First-order Gauss–Markov (Ornstein–Uhlenbeck) process, exactly discretised.

    b_k = φ b_{k−1} + q w_k, φ = e^{−Δt/τ}, q = σ √(1 − φ²), so the stationary variance is σ² for
    any step Δt, and a step of 2Δt is statistically the same as two steps of Δt. τ = 0 gives white
    noise of σ; τ = ∞ a random constant of σ.

    Args:
        sigma: Stationary standard deviation σ: a scalar or an array that broadcasts to ``shape``.
        tau_s: Correlation time τ (s): a scalar or an array that broadcasts to ``shape`` (e.g.
            shape (2, 1) for two triads with their own τ).
        shape: Shape of the state (3 for a triad).
    """

    __slots__ = ("_dt", "_phi", "_q", "_tmp", "_w", "sigma", "tau_s", "value")

    def __init__(self, sigma: ArrayLike, tau_s: ArrayLike, shape: Shape = 3):
        self.sigma = _filled(sigma, shape, "sigma")
        self.tau_s = _filled(tau_s, shape, "tau_s")
        if not np.all(self.tau_s >= 0.0):
            raise ValueError(f"tau_s = {tau_s!r}: must be >= 0")
        self.value = np.zeros(shape)
        self._phi = np.ones(shape)
        self._q = np.zeros(shape)
        self._tmp = np.zeros(shape)
        self._w = np.zeros(shape)
        self._dt = math.nan

    def _set_dt(self, dt: float) -> None:
        # Cached: at a fixed sample rate the coefficients are computed once per run.
        with np.errstate(divide="ignore", invalid="ignore"):
            phi = np.exp(-dt / self.tau_s)
        # τ = 0: white noise (φ = 0) for dt > 0, no change for dt = 0.
        phi[self.tau_s == 0.0] = 0.0 if dt > 0.0 else 1.0
        self._phi = phi
        self._q = self.sigma * np.sqrt(np.maximum(0.0, 1.0 - phi * phi))
        self._dt = dt

    def reset(self, rng: np.random.Generator, *, stationary: bool = True) -> FloatArray:
        """Start: b_0 ~ N(0, σ²) if ``stationary`` (the sensor has been running), else b_0 = 0.

        Always draws ``value.size`` normals, so a caller's random stream does not depend on the
        choice.
        """
        rng.standard_normal(out=self._tmp)
        if stationary:
            np.multiply(self.sigma, self._tmp, out=self.value)
        else:
            self.value.fill(0.0)
        return self.value

    def advance(self, w: FloatArray, dt: float) -> FloatArray:
        """Step by ``dt`` seconds with standard normals ``w``; returns the state (copy to keep)."""
        if dt != self._dt:
            self._set_dt(dt)
        self.value *= self._phi
        np.multiply(self._q, w, out=self._tmp)
        self.value += self._tmp
        return self.value

    def step(self, rng: np.random.Generator, dt: float) -> FloatArray:
        """Step by ``dt`` seconds drawing from ``rng``; returns the state (copy to keep)."""
        rng.standard_normal(out=self._w)
        return self.advance(self._w, dt)


class RandomWalk:
    """Random walk (integrated white noise) of density K: b_k = b_{k−1} + K √Δt w_k.

    For a gyro bias K is the rate random walk (rad/s/√s); for an accelerometer bias the
    acceleration random walk (m/s²/√s). Starts at 0: a turn-on offset is modelled separately.

    Args:
        density: K (units/√s): a scalar or an array that broadcasts to ``shape``.
        shape: Shape of the state (3 for a triad).
    """

    __slots__ = ("_tmp", "_w", "density", "value")

    def __init__(self, density: ArrayLike, shape: Shape = 3):
        self.density = _filled(density, shape, "density")
        self.value = np.zeros(shape)
        self._tmp = np.zeros(shape)
        self._w = np.zeros(shape)

    def reset(self) -> FloatArray:
        """Back to zero."""
        self.value.fill(0.0)
        return self.value

    def advance(self, w: FloatArray, dt: float) -> FloatArray:
        """Step by ``dt`` seconds with standard normals ``w``; returns the state (copy to keep)."""
        np.multiply(self.density, w, out=self._tmp)
        self._tmp *= math.sqrt(max(dt, 0.0))
        self.value += self._tmp
        return self.value

    def step(self, rng: np.random.Generator, dt: float) -> FloatArray:
        """Step by ``dt`` seconds drawing from ``rng``; returns the state (copy to keep)."""
        rng.standard_normal(out=self._w)
        return self.advance(self._w, dt)
