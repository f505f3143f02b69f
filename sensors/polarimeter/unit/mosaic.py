"""The sensor: micro-polarizer analysers, pixel response, noise and ADC of a DoFP camera.

Stage 7 of the polarimeter chain. Input: the linear Stokes irradiance on every pixel; output: the
raw uint16 mosaic the camera delivers. The onboard side turns that mosaic back into Stokes images
with :func:`twin.onboard.polarization.stokes_from_mosaic`.

Input contract (``stokes``, shape (H, W, 3), float32 preferred):

* Units: photons per pixel per second arriving at the pixel (after the lens, before the
  micro-polarizer), integrated over the sensor's passband. :func:`photon_rate_per_pixel` converts
  band radiance (W m⁻² sr⁻¹) with the camera equation.
* Reference: the CAMERA IMAGE +u axis (the direction of increasing column); angles turn from it
  towards +v (increasing row), clockwise on a display with row 0 on top. That is exactly the
  sensor-plane Stokes of :mod:`sensors.polarimeter.unit.camera` (reference +x = +u, light travelling
  along −z, the :mod:`sensors.polarimeter.stokes` convention; e.g.
  ``Camera.sensor_stokes_from_meridian``): the caller must rotate each pixel's Stokes vector into
  that reference. The analyser angles of ``layout_deg`` are counted in the same sense, and so is
  the AoP that :func:`twin.onboard.polarization.stokes_from_mosaic` reports. (The twin's image is
  the sky as a map seen from above, the mirror of a physical camera's frame; see camera.py and
  the onboard module for what that means for a real sensor's layout.)
* Physical light: S0 ≥ √(S1² + S2²) ≥ 0, finite. (Negative expected counts are clamped to 0.)

Measurement model (optics.md §3.2–3.3), per pixel p with analyser angle α_p from the layout:

    λ_p = t · η · g_p · ½ [S0 + d (S1 cos 2α'_p + S2 sin 2α'_p)]  (+ crosstalk)  + t · i_dark,p(T)
    e_p ~ Poisson(λ_p) + N(0, σ_read²) + DSNU_p + r_row(p)
    DN_p = clip(round(e_p / K + black level), 0, min(2^bits − 1, FW / K + black level))

* ``d = (ER − 1)/(ER + 1)``: diattenuation from the extinction ratio ER (ER = ∞ ⇒ d = 1).
* ``α'_p = α_p + ε_p``: per-pixel orientation error ε ~ N(0, σ_ε²), a manufacturing fixed pattern.
* ``g_p = 1 + PRNU_p``, PRNU ~ N(0, σ_PRNU²); DSNU_p ~ N(0, σ_DSNU²) e⁻: fixed patterns.
* ``i_dark,p``: the mean dark current, or a hot pixel's (a fraction ``hot_pixel_fraction`` of
  the pixels, a fixed pattern), both doubling every ``dark_current_doubling_k``.
* ``r_row ~ N(0, σ_row²)``: a temporal offset shared by every pixel of a row, drawn per frame.
* η (``quantum_efficiency``): electrons per photon along the analyser's transmission axis,
  polarizer transmittance and fill factor included. An unpolarised beam of S0 photons/s gives
  η·S0/2 e⁻/s, so an EMVA 1288 QE measured with unpolarised light is η/2.
* Crosstalk c: each pixel receives a fraction c of the light its four edge neighbours' analysers
  pass and loses 4c of its own (energy conserving). It is lumped into each pixel's effective
  analysis vector — ``(1 − 4c)·a_p + c·Σ_n a_n`` evaluated on the pixel's own Stokes, the usual
  calibration model (optics.md §3.2) — which is exact where the Stokes field is smooth over a
  pixel and ignores the ≤ c blur of sharp edges (Snell's window's rim, the sun's disc). In a
  standard layout the edge neighbours of a pixel are its ±45° analysers, so crosstalk scales the
  measured DoP by (1 − 4c). Real crosstalk grows with incidence angle and lens speed; one c is used.
* Full-well clipping is applied to the total (signal + noise) charge together with the ADC clip:
  one saturation level ``min(2^bits − 1, round(FW/K + black level))``. Saturated pixels read exactly
  that value.

Noise generation. Measured for a 2448×2048 frame on one thread of the (shared, 2-core Xeon) dev
VM: numpy's ``Generator.poisson`` takes 47 ns a sample at λ = 1000 and 91 ns at λ = 10
(240–460 ms a frame), ``Generator.standard_normal(dtype=float32)`` 15 ns (75 ms), OpenCV's
``cv2.randn`` 3.5 ns (18 ms). So:

* Where λ ≥ ``poisson_below_e`` (default 20 e⁻) shot and read noise are drawn together as one
  Gaussian, e = λ + √(λ + σ_read²)·z: mean and variance exact, skewness 1/√λ ≤ 0.22 missing
  (≤ 0.13 once read noise is added; invisible after quantization at K ≈ 2.8 e⁻/DN).
* Where the dark-only count < λ < ``poisson_below_e`` (dim pixels, the photon-counting regime)
  the shot noise is exact Poisson from the frame's Generator, plus Gaussian read noise. Pixels
  that receive no light at all (λ = dark count: outside the fisheye's image circle) take the
  Gaussian path: their dark count is ≪ 1 e⁻ at millisecond exposures and buried in read noise.
* The standard normals z come from OpenCV's RNG (multiply-with-carry + ziggurat) reseeded for
  every band of rows from integers drawn from the Generator passed to :meth:`render_mosaic`:
  same Generator state ⇒ same frame (with the same OpenCV version; the thread count does not
  matter, checked), and a 4–5× speed-up over numpy. Side effect: it reseeds OpenCV's
  (thread-local) RNG.
* Fixed-pattern maps are drawn once per :class:`DoFPSensor` from the Generator given to its
  constructor (numpy); temporal noise per frame from the Generator given to the frame call.

Work is done in bands of rows so the temporaries stay in cache; the per-pixel arithmetic runs in
two compiled passes (:mod:`sensors.polarimeter.unit.mosaic_kernel`: the OpenCV chain's raw frames
bit
for bit). Measured on one core of the shared dev VM, 2026-12-07
(``benchmarks/results/polarimeter_frame.md``, median of 3 rounds): 22.9 ms a 2448×2048 frame,
of which 11.6 ms ``cv2.randn``'s 5 M normals (line profile); 1.3 ms a 612×512 frame. (With the
OpenCV chain, 2026-12-06: 30.8 and 1.9 ms.)

Sources: Sony IMX250MZR/IMX264MZR facts and the noise model: ../shared/reference/optics.md §3.1–3.3
(EMVA 1288 figures of the mono IMX250 via MATRIX VISION mvBlueFOX3-2051); PHX050S-P: extinction
ratio > 100:1 (up to 425:1), QE ≈ 50 % at 530 nm, 12-bit, gain 0 dB, exposure 500–2500 µs
(xin2024 §4.1, the same camera), exposure 700 µs in the LIG sea trial (hu2024 §4.3); IMX264MZR with
auto exposure (fang2024 §2.1). EMVA 1288 (release 4.0) for the linear camera model and the dark
current doubling temperature.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import NDArray

# The spec and presets live in sensor_spec.py; re-exported here, where users import them.
from sensors.polarimeter.unit import mosaic_kernel as mk
from sensors.polarimeter.unit.sensor_spec import (
    IMX250MZR_LAYOUT_DEG,
    PRESETS,
    PolarizationSensorSpec,
    _finite,
    preset,
)

#: Below this expected count (e⁻) shot noise is drawn exactly (Poisson); above it, Gaussian.
POISSON_BELOW_E = 20.0

_BAND_PIXELS = 1 << 16  # ~64 k pixels a band: a few 256 kB float32 temporaries stay in L2
_H_PLANCK = 6.62607015e-34  # J s (SI, exact)
_C_LIGHT = 299_792_458.0  # m/s (SI, exact)


def photon_rate_per_pixel(
    radiance_w_m2_sr: NDArray[np.floating] | float,
    *,
    f_number: float,
    pixel_pitch_um: float = 3.45,
    wavelength_nm: float = 530.0,
    lens_transmission: float = 1.0,
) -> NDArray[np.floating] | float:
    """Photons per pixel per second from band radiance: the camera equation.

    Image-plane irradiance for an object at infinity, on axis: E = π·T·L / (4 N²); a pixel of
    pitch p collects E·p², i.e. E·p²·λ/(h c) photons/s at the effective wavelength λ. Linear, so it
    applies to each Stokes component. Off-axis fall-off (relative illumination) of the fisheye is
    the camera stage's business.

    Args:
        radiance_w_m2_sr: Radiance integrated over the sensor's passband (W m⁻² sr⁻¹).
        f_number: The lens's working f-number N.
        pixel_pitch_um: Pixel pitch (µm); 3.45 for the IMX250/264.
        wavelength_nm: Effective wavelength of the band (nm).
        lens_transmission: T of the lens (and dome), in (0, 1].

    Returns:
        Photons per pixel per second (same shape as ``radiance_w_m2_sr``).
    """
    _finite("f_number", f_number, 0.0, math.inf, True, True)
    _finite("pixel_pitch_um", pixel_pitch_um, 0.0, math.inf, True, True)
    _finite("wavelength_nm", wavelength_nm, 0.0, math.inf, True, True)
    _finite("lens_transmission", lens_transmission, 0.0, 1.0, True, False)
    area = (pixel_pitch_um * 1e-6) ** 2
    photon_j = _H_PLANCK * _C_LIGHT / (wavelength_nm * 1e-9)
    return radiance_w_m2_sr * (math.pi * lens_transmission / (4.0 * f_number**2) * area / photon_j)


@dataclass(frozen=True, slots=True)
class _FixedPattern:
    orientation_error_rad: NDArray[np.float32]
    gain: NDArray[np.float32]
    dsnu_e: NDArray[np.float32] | None
    analysis: NDArray[np.float32] = field(repr=False)  # (H, W, 3): e⁻/s per photon/s of S
    hot: NDArray[np.intp] = field(repr=False, default_factory=lambda: np.zeros(0, np.intp))


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


class DoFPSensor:
    """One physical DoFP sensor: its spec plus the fixed pattern it was manufactured with.

    Args:
        spec: The sensor's spec (validated here).
        shape: (rows, columns) of the raw frame; both even (whole 2×2 super-pixels).
        rng: Generator for the manufacturing fixed pattern (orientation errors, PRNU, DSNU,
            hot pixels), drawn once here, in that order, skipping any whose σ is 0.
        optics: Optional function folding what lies between the light the caller describes and
            the analysers (the lens's own polarization, ``sensors.polarimeter.unit.lens``) into the
            (H, W, 3) analysis vectors: a ↦ a·M per pixel, M the optics' Mueller matrix on
            (S0, S1, S2) in the sensor frame. Applied once, after the crosstalk, so a frame
            costs nothing more.

    Raises:
        ValueError: If the spec is impossible or the shape is not even and positive.
    """

    # The compiled per-pixel passes (mosaic_kernel); False: the OpenCV chain they reproduce bit
    # for bit, kept as their reference for the tests.
    _kernels: bool = True

    def __init__(
        self,
        spec: PolarizationSensorSpec,
        shape: tuple[int, int],
        rng: np.random.Generator,
        optics: Callable[[NDArray[np.floating]], NDArray[np.floating]] | None = None,
    ):
        spec.validate()
        h, w = (int(v) for v in shape)
        if h < 2 or w < 2 or h % 2 or w % 2:
            raise ValueError(f"shape = {tuple(shape)!r}: rows and columns must be even and >= 2")
        self._spec = spec
        self._shape = (h, w)
        self._band_rows = max(2, min(h, _BAND_PIXELS // w))
        self._fp = self._draw_fixed_pattern(rng, optics)

    # --- properties -----------------------------------------------------------------------------
    @property
    def spec(self) -> PolarizationSensorSpec:
        """The sensor's spec."""
        return self._spec

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of the raw frame."""
        return self._shape

    @property
    def analyzer_angle_rad(self) -> NDArray[np.float32]:
        """(H, W) true analyser angle of every pixel (layout + orientation error), read-only."""
        h, w = self._shape
        nominal = np.tile(
            np.deg2rad(np.asarray(self._spec.layout_deg, np.float32)), (h // 2, w // 2)
        )
        return _read_only(nominal + self._fp.orientation_error_rad)

    @property
    def gain(self) -> NDArray[np.float32]:
        """(H, W) relative pixel gain 1 + PRNU (fixed pattern), read-only."""
        return self._fp.gain

    @property
    def dsnu_e(self) -> NDArray[np.float32]:
        """(H, W) dark-signal offset of every pixel (e⁻, fixed pattern), read-only."""
        if self._fp.dsnu_e is None:
            return _read_only(np.zeros(self._shape, np.float32))
        return self._fp.dsnu_e

    @property
    def analysis(self) -> NDArray[np.float32]:
        """(H, W, 3) effective analysis vectors: e⁻/s of a pixel per photon/s of (S0, S1, S2).

        Includes η, PRNU, diattenuation, orientation error and the lumped crosstalk: the truth a
        per-pixel calibration (``S = W⁺ I``) would estimate. Read-only.
        """
        return self._fp.analysis

    # --- fixed pattern --------------------------------------------------------------------------
    def _draw_fixed_pattern(
        self,
        rng: np.random.Generator,
        optics: Callable[[NDArray[np.floating]], NDArray[np.floating]] | None,
    ) -> _FixedPattern:
        s, (h, w) = self._spec, self._shape
        eps = np.zeros((h, w), np.float32)
        if s.orientation_error_deg > 0:
            eps = rng.normal(0.0, math.radians(s.orientation_error_deg), (h, w)).astype(np.float32)
        gain = np.ones((h, w), np.float32)
        if s.prnu > 0:
            gain = np.maximum(rng.normal(1.0, s.prnu, (h, w)), 0.0).astype(np.float32)
        dsnu = rng.normal(0.0, s.dsnu_e, (h, w)).astype(np.float32) if s.dsnu_e > 0 else None
        hot = np.zeros(0, np.intp)
        if s.hot_pixel_fraction > 0:
            # From a child stream: spawning does not advance ``rng``, so the patterns above and
            # whatever the caller draws from ``rng`` next (a frame's noise) do not change.
            hot_rng = rng.spawn(1)[0]
            n_hot = int(hot_rng.binomial(h * w, s.hot_pixel_fraction))
            hot = np.sort(hot_rng.choice(h * w, size=n_hot, replace=False)).astype(np.intp)

        nominal = np.tile(np.deg2rad(np.asarray(s.layout_deg, np.float64)), (h // 2, w // 2))
        two_a = 2.0 * (nominal + eps)
        half_gain = 0.5 * s.quantum_efficiency * gain.astype(np.float64)
        d = s.diattenuation
        analysis = np.stack(
            [half_gain, half_gain * d * np.cos(two_a), half_gain * d * np.sin(two_a)], axis=-1
        )
        if s.crosstalk > 0:
            c = s.crosstalk
            kernel = np.array([[0.0, c, 0.0], [c, 1.0 - 4.0 * c, c], [0.0, c, 0.0]])
            # Reflect-101 keeps the 2×2 phase at the borders: the mirrored neighbour is of the
            # same analyser type as the missing one.
            analysis = cv2.filter2D(analysis, -1, kernel, borderType=cv2.BORDER_REFLECT_101)
        if optics is not None:
            # Measured = a · (M S) = (a M) · S: the optics folded into each analysis vector.
            folded = np.asarray(optics(analysis))
            if folded.shape != analysis.shape or not np.all(np.isfinite(folded)):
                raise ValueError(
                    f"optics: returned {folded.shape}; must be finite {analysis.shape}"
                )
            analysis = folded
        return _FixedPattern(
            orientation_error_rad=_read_only(eps),
            gain=_read_only(gain),
            dsnu_e=None if dsnu is None else _read_only(dsnu),
            analysis=_read_only(np.ascontiguousarray(analysis, dtype=np.float32)),
            hot=_read_only(hot),
        )

    # --- helpers --------------------------------------------------------------------------------
    def _check_stokes(self, stokes: np.ndarray) -> NDArray[np.float32]:
        if not isinstance(stokes, np.ndarray):
            raise TypeError(f"stokes must be a numpy array, got {type(stokes).__name__}")
        if stokes.shape != (*self._shape, 3):
            raise ValueError(
                f"stokes.shape = {stokes.shape}: must be {(*self._shape, 3)} (rows, cols, S0/S1/S2)"
            )
        if stokes.dtype.kind != "f":
            raise TypeError(f"stokes.dtype = {stokes.dtype}: must be float32 (or float64)")
        return np.ascontiguousarray(stokes, dtype=np.float32)

    @staticmethod
    def _check_exposure(exposure_us: float) -> float:
        _finite("exposure_us", exposure_us, 0.0, math.inf, True, True)
        return float(exposure_us)

    def _bands(self) -> range:
        return range(0, self._shape[0], self._band_rows)

    def _mean_band(
        self, stokes: NDArray[np.float32], r0: int, r1: int, t_s: float, dark_e: float
    ) -> NDArray[np.float32]:
        """Expected collected electrons λ of rows r0:r1 (one compiled pass, mosaic_kernel)."""
        if not self._kernels:
            return self._mean_band_reference(stokes, r0, r1, t_s, dark_e)
        w = self._shape[1]
        st = stokes[r0:r1].reshape(-1)
        an = self._fp.analysis[r0:r1].reshape(-1)
        t32, d32 = np.float32(t_s), np.float32(dark_e)
        lam = np.empty((r1 - r0, w), np.float32)
        flat = lam.reshape(-1)
        mk.expected_charge(st, an, t32, d32, flat)
        hot = self._fp.hot
        if hot.size:
            a, b = np.searchsorted(hot, (r0 * w, r1 * w))
            if b > a:
                extra = np.float32(max(self._hot_extra_e_per_s() * t_s, 0.0))
                mk.add_hot(st, an, t32, d32, hot[a:b] - r0 * w, extra, flat)
        return lam

    def _hot_extra_e_per_s(self) -> float:
        s = self._spec
        return s.hot_pixel_dark_at_temp_e_per_s - s.dark_current_at_temp_e_per_s

    def _mean_band_reference(
        self, stokes: NDArray[np.float32], r0: int, r1: int, t_s: float, dark_e: float
    ) -> NDArray[np.float32]:
        """:meth:`_mean_band` as two fused OpenCV passes (the compiled pass's reference)."""
        prod = cv2.multiply(stokes[r0:r1], self._fp.analysis[r0:r1])
        m = np.array([[t_s, t_s, t_s, dark_e]], np.float32)
        lam = cv2.transform(prod, m).reshape(r1 - r0, self._shape[1])
        hot = self._fp.hot
        if hot.size:
            w = self._shape[1]
            a, b = np.searchsorted(hot, (r0 * w, r1 * w))
            if b > a:
                extra = self._hot_extra_e_per_s() * t_s
                lam.ravel()[hot[a:b] - r0 * w] += np.float32(max(extra, 0.0))
        return np.maximum(lam, np.float32(0.0), out=lam)

    # --- frames ---------------------------------------------------------------------------------
    def expected_electrons(
        self, stokes: NDArray[np.floating], exposure_us: float
    ) -> NDArray[np.float32]:
        """Noise-free mean collected charge λ (e⁻, float32): signal + dark current, unclipped."""
        stokes = self._check_stokes(stokes)
        t_s = self._check_exposure(exposure_us) * 1e-6
        dark_e = self._spec.dark_current_at_temp_e_per_s * t_s
        out = np.empty(self._shape, np.float32)
        for r0 in self._bands():
            r1 = min(r0 + self._band_rows, self._shape[0])
            out[r0:r1] = self._mean_band(stokes, r0, r1, t_s, dark_e)
        return out

    def expected_dn(self, stokes: NDArray[np.floating], exposure_us: float) -> NDArray[np.float32]:
        """Noise-free raw frame in DN, float32, not rounded: the ideal camera's exact output.

        ``(λ + DSNU)/K + black level`` clipped to [0, ``spec.saturation_dn``].
        """
        s = self._spec
        e = self.expected_electrons(stokes, exposure_us)
        if self._fp.dsnu_e is not None:
            e += self._fp.dsnu_e
        dn = e * np.float32(1.0 / s.conversion_gain_e_per_dn) + np.float32(s.black_level_dn)
        return np.clip(dn, 0.0, float(s.saturation_dn), out=dn)

    def render_mosaic(
        self,
        stokes: NDArray[np.floating],
        exposure_us: float,
        rng: np.random.Generator,
        *,
        poisson_below_e: float = POISSON_BELOW_E,
    ) -> NDArray[np.uint16]:
        """Expose the sensor to a Stokes irradiance field and read out the raw mosaic.

        Args:
            stokes: (H, W, 3) photons per pixel per second (S0, S1, S2), reference the image
                +u axis, angles towards +v (see the module docstring). float32 avoids a copy.
            exposure_us: Exposure time (µs); see :meth:`exposure_for`.
            rng: Generator for this frame's temporal noise (shot, read).
            poisson_below_e: Expected counts (e⁻) below which shot noise is exact Poisson;
                0 for all-Gaussian, ``math.inf`` for all-Poisson (slow: ~0.3 s a 5 MP frame).

        Returns:
            (H, W) uint16 raw frame, values in [0, saturation_dn].
        """
        s = self._spec
        stokes = self._check_stokes(stokes)
        t_s = self._check_exposure(exposure_us) * 1e-6
        _finite("poisson_below_e", poisson_below_e, 0.0, math.inf, False, False)
        h, w = self._shape
        dark_e = s.dark_current_at_temp_e_per_s * t_s
        read_var = np.float32(s.read_noise_e**2)
        inv_k = 1.0 / s.conversion_gain_e_per_dn
        sat = s.saturation_dn
        exact_lo = np.nextafter(np.float32(dark_e), np.float32(np.inf))
        noisy = s.shot_noise or s.read_noise_e > 0 or s.row_noise_e > 0
        bands = self._bands()
        seeds = rng.integers(0, 2**31 - 1, size=len(bands)) if noisy else None
        out = np.empty((h, w), np.uint16)
        z = sd = index = None
        no_rows = np.zeros(self._band_rows, np.float32)
        for b, r0 in enumerate(bands):
            r1 = min(r0 + self._band_rows, h)
            lam = self._mean_band(stokes, r0, r1, t_s, dark_e)
            rows = None
            if noisy:
                assert seeds is not None
                if z is None or z.shape != lam.shape:
                    z, sd = np.empty_like(lam), np.empty_like(lam)
                cv2.setRNGSeed(int(seeds[b]))
                cv2.randn(z, 0.0, 1.0)
                exact = None
                if s.shot_noise and poisson_below_e > 0:
                    flat = lam.reshape(-1)
                    if self._kernels:
                        if index is None or index.shape[0] < flat.shape[0]:
                            index = np.empty(flat.shape[0], dtype=np.intp)
                        n = mk.low_counts(flat, exact_lo, np.float32(poisson_below_e), index)
                        exact = index[:n] if n else None
                    else:
                        # numpy's two compares beat cv2.inRange on float32 by ~2.5× (measured).
                        mask = (lam >= exact_lo) & (lam < np.float32(poisson_below_e))
                        exact = np.flatnonzero(mask) if mask.any() else None
                    if exact is not None:
                        counts = rng.poisson(flat[exact]).astype(np.float32)
                if s.shot_noise and self._kernels:
                    mk.shot_and_read(lam.reshape(-1), z.reshape(-1), read_var)
                elif s.shot_noise:
                    np.add(lam, read_var, out=sd)
                    np.sqrt(sd, out=sd)
                    cv2.accumulateProduct(sd, z, lam)  # λ + √(λ + σ²)·z, in place
                else:
                    lam += np.float32(s.read_noise_e) * z
                if exact is not None and self._kernels:
                    mk.set_counts(flat, z.reshape(-1), exact, counts, np.float32(s.read_noise_e))
                elif exact is not None:
                    lam.ravel()[exact] = counts + np.float32(s.read_noise_e) * z.ravel()[exact]
                if s.row_noise_e > 0:  # drawn after z: the pixel noise does not depend on it
                    rows = np.empty((r1 - r0, 1), np.float32)
                    cv2.randn(rows, 0.0, float(s.row_noise_e))
                    if not self._kernels:
                        lam += rows  # (to_dn adds them as it reads λ)
            band_out = out[r0:r1]
            if self._kernels:
                dsnu = self._fp.dsnu_e
                mk.to_dn(
                    lam.reshape(-1),
                    no_rows[: r1 - r0] if rows is None else rows.reshape(-1),
                    w,
                    lam.reshape(-1) if dsnu is None else dsnu[r0:r1].reshape(-1),
                    dsnu is not None,
                    np.float32(inv_k),
                    np.float32(s.black_level_dn),
                    np.uint16(sat),
                    band_out.reshape(-1),
                )
                continue  # to_dn clamps at saturation itself
            if self._fp.dsnu_e is None:
                cv2.addWeighted(lam, inv_k, lam, 0.0, s.black_level_dn, band_out, cv2.CV_16U)
            else:
                dsnu = self._fp.dsnu_e[r0:r1]
                cv2.addWeighted(lam, inv_k, dsnu, inv_k, s.black_level_dn, band_out, cv2.CV_16U)
            cv2.min(band_out, (float(sat),), band_out)  # ~6× faster than np.minimum on uint16
        return out

    # --- exposure -------------------------------------------------------------------------------
    def _clamp_exposure(self, exposure_us: float) -> float:
        s = self._spec
        return float(min(max(exposure_us, s.min_exposure_us), s.max_exposure_us))

    def auto_exposure_us(self, stokes: NDArray[np.floating]) -> float:
        """The exposure (µs) an ideally converged auto exposure picks for this irradiance.

        The ``ae_percentile`` of the expected pixel signals (every analyser, sampled every 7th
        row and column — odd, so all four analysers are seen) is placed at ``ae_target_fraction``
        of :attr:`PolarizationSensorSpec.full_scale_e`, clamped to the exposure range. No light
        at all gives the longest exposure. A real camera converges over a few frames: use
        :meth:`next_exposure_us` to model that.
        """
        s = self._spec
        stokes = self._check_stokes(stokes)
        sub = np.einsum("hwc,hwc->hw", stokes[::7, ::7], self._fp.analysis[::7, ::7])
        rate = float(np.percentile(sub, s.ae_percentile)) + s.dark_current_at_temp_e_per_s
        if not rate > 0:
            return float(s.max_exposure_us)
        return self._clamp_exposure(s.ae_target_fraction * s.full_scale_e / rate * 1e6)

    def exposure_for(self, stokes: NDArray[np.floating]) -> float:
        """The exposure (µs) of the next frame: the fixed one, or :meth:`auto_exposure_us`."""
        if self._spec.auto_exposure:
            return self.auto_exposure_us(stokes)
        return float(self._spec.exposure_us)

    def next_exposure_us(self, raw: NDArray[np.integer], exposure_us: float) -> float:
        """One step of a frame-to-frame auto exposure from the last raw frame, as firmware does.

        Scales the exposure so the ``ae_percentile`` of the raw signal (above black level) moves
        to ``ae_target_fraction`` of full scale; if that percentile is saturated the true signal
        is unknown and the exposure is halved. Clamped to the exposure range.
        """
        s = self._spec
        exposure_us = self._check_exposure(exposure_us)
        if not isinstance(raw, np.ndarray) or raw.shape != self._shape:
            raise ValueError(f"raw must be an array of shape {self._shape}")
        level = float(np.percentile(raw[::7, ::7], s.ae_percentile))
        if level >= s.saturation_dn:
            return self._clamp_exposure(0.5 * exposure_us)
        signal_dn = max(level - s.black_level_dn, 1.0)
        target_dn = s.ae_target_fraction * (s.saturation_dn - s.black_level_dn)
        return self._clamp_exposure(exposure_us * target_dn / signal_dn)


__all__ = [
    "IMX250MZR_LAYOUT_DEG",
    "POISSON_BELOW_E",
    "PRESETS",
    "DoFPSensor",
    "PolarizationSensorSpec",
    "photon_rate_per_pixel",
    "preset",
]
