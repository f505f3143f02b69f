"""What a datasheet says about a DoFP polarization sensor: the spec and the presets.

Split from :mod:`sensors.polarimeter.unit.mosaic` (which re-exports everything here): the sensor's
figures and their sources, apart from the model that exposes it (the measurement model and the
noise are described there).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

#: Sony IMX250MZR / IMX264MZR super-pixel: analyser angle (deg) of raw pixel (row, col).
IMX250MZR_LAYOUT_DEG: tuple[tuple[float, float], tuple[float, float]] = ((90.0, 45.0), (135.0, 0.0))


def _finite(name: str, value: float, lo: float, hi: float, lo_open: bool, hi_open: bool) -> None:
    """Raise ValueError naming ``name`` unless ``value`` is a number in the stated interval."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} = {value!r}: must be a number")
    v = float(value)
    ok = not math.isnan(v)
    ok = ok and (v > lo if lo_open else v >= lo)
    ok = ok and (v < hi if hi_open else v <= hi)
    if not ok:
        left, right = ("(" if lo_open else "["), (")" if hi_open else "]")
        raise ValueError(f"{name} = {value!r}: must be in {left}{lo}, {hi}{right}")


@dataclass(frozen=True, slots=True)
class PolarizationSensorSpec:
    """What a datasheet (and an EMVA 1288 report) says about a DoFP polarization sensor.

    Values marked [derived] follow from other figures, [uncertain] are typical values not checked
    against a measurement of this very sensor. See :data:`PRESETS`.

    Attributes:
        layout_deg: Analyser angle (deg) of raw pixel (r, c) of each 2×2 super-pixel, counted
            from the image +u axis (columns) towards +v (rows).
        quantum_efficiency: η, electrons per photon polarized along the analyser's transmission
            axis (polarizer and fill factor included); unpolarised light gives η/2. In (0, 1].
        full_well_e: Saturation capacity (e⁻).
        conversion_gain_e_per_dn: K, electrons per digital number at the gain used.
        read_noise_e: Temporal dark noise σ (e⁻), the EMVA "temporal dark noise".
        dark_current_e_per_s: Mean dark current (e⁻/s) at ``dark_current_ref_temp_c``.
        dark_current_ref_temp_c: Temperature of the dark-current figure (°C).
        dark_current_doubling_k: Temperature rise that doubles the dark current (K).
        sensor_temp_c: Operating temperature of the sensor (°C).
        exposure_us: Fixed exposure time (µs), used when ``auto_exposure`` is False.
        auto_exposure: Pick the exposure so the ``ae_percentile`` of the raw signal lands at
            ``ae_target_fraction`` of full scale, within [min_exposure_us, max_exposure_us].
        ae_percentile: Percentile (0, 100] of the pixel signals the auto exposure targets.
        ae_target_fraction: Fraction (0, 1] of the usable full scale that percentile should hit.
        min_exposure_us: Shortest exposure the camera allows (µs).
        max_exposure_us: Longest exposure the auto exposure may choose (µs).
        extinction_ratio: ER = T_max/T_min of the micro-polarizers, > 1 (``math.inf``: perfect).
        orientation_error_deg: σ of each analyser's orientation error (deg), fixed per pixel.
        crosstalk: c, fraction of each of the 4 edge neighbours' light a pixel receives, [0, 0.25).
        prnu: σ of the photo-response non-uniformity (fraction of the signal), fixed per pixel.
        dsnu_e: σ of the dark-signal non-uniformity (e⁻), a fixed per-pixel offset.
        hot_pixel_fraction: Fraction of pixels that are hot (a fixed pattern, drawn per sensor).
        hot_pixel_dark_e_per_s: Dark current of a hot pixel (e⁻/s) at
            ``dark_current_ref_temp_c``; it doubles with temperature like the mean's.
        row_noise_e: σ of a temporal offset common to each row of a frame (e⁻), the row noise of
            a column-parallel CMOS readout.
        black_level_dn: Offset (DN) added before quantization so dark noise is not clipped.
        adc_bits: ADC resolution (bits), 8–16; raw values are in [0, 2^bits − 1].
        shot_noise: Draw photon (and dark-current) shot noise; False only for the ideal camera.
    """

    layout_deg: tuple[tuple[float, float], tuple[float, float]] = IMX250MZR_LAYOUT_DEG
    quantum_efficiency: float = 0.5
    full_well_e: float = 10_700.0
    conversion_gain_e_per_dn: float = 10_700.0 / (4095.0 - 240.0)
    read_noise_e: float = 2.9
    dark_current_e_per_s: float = 5.0
    dark_current_ref_temp_c: float = 25.0
    dark_current_doubling_k: float = 7.0
    sensor_temp_c: float = 25.0
    exposure_us: float = 1000.0
    auto_exposure: bool = False
    ae_percentile: float = 99.0
    ae_target_fraction: float = 0.8
    min_exposure_us: float = 20.0
    max_exposure_us: float = 100_000.0
    extinction_ratio: float = 250.0
    orientation_error_deg: float = 0.5
    crosstalk: float = 0.005
    prnu: float = 0.01
    dsnu_e: float = 1.0
    hot_pixel_fraction: float = 0.0
    hot_pixel_dark_e_per_s: float = 5000.0
    row_noise_e: float = 0.0
    black_level_dn: float = 240.0
    adc_bits: int = 12
    shot_noise: bool = True

    @property
    def diattenuation(self) -> float:
        """Diattenuation d = (ER − 1)/(ER + 1): the fraction of the DoP the analysers see."""
        er = self.extinction_ratio
        return 1.0 if math.isinf(er) else (er - 1.0) / (er + 1.0)

    @property
    def max_dn(self) -> int:
        """Largest raw value the ADC can output, 2^bits − 1."""
        return (1 << self.adc_bits) - 1

    @property
    def saturation_dn(self) -> int:
        """Raw value of a saturated pixel: the ADC's top or the full well, whichever comes first."""
        fw_dn = round(self.full_well_e / self.conversion_gain_e_per_dn + self.black_level_dn)
        return int(min(self.max_dn, fw_dn))

    @property
    def full_scale_e(self) -> float:
        """Electrons above black level at saturation: the usable signal range."""
        return (self.saturation_dn - self.black_level_dn) * self.conversion_gain_e_per_dn

    @property
    def dark_current_at_temp_e_per_s(self) -> float:
        """Dark current at ``sensor_temp_c``: doubles every ``dark_current_doubling_k`` K."""
        return self.dark_current_e_per_s * self._temperature_factor

    @property
    def hot_pixel_dark_at_temp_e_per_s(self) -> float:
        """A hot pixel's dark current at ``sensor_temp_c`` (same doubling)."""
        return self.hot_pixel_dark_e_per_s * self._temperature_factor

    @property
    def _temperature_factor(self) -> float:
        dt = self.sensor_temp_c - self.dark_current_ref_temp_c
        return 2.0 ** (dt / self.dark_current_doubling_k)

    def validate(self) -> None:
        """Raise ValueError naming the field, its value and the allowed range if impossible."""
        lay = np.asarray(self.layout_deg, dtype=float)
        if lay.shape != (2, 2) or not np.all(np.isfinite(lay)):
            raise ValueError(f"layout_deg = {self.layout_deg!r}: must be 2×2 finite angles (deg)")
        two_a = np.deg2rad(2.0 * lay.ravel())
        m = np.stack([np.ones(4), np.cos(two_a), np.sin(two_a)], axis=1)
        if np.linalg.matrix_rank(m, tol=1e-9) < 3:
            raise ValueError(
                f"layout_deg = {self.layout_deg!r}: needs >= 3 distinct angles (mod 180°)"
            )
        inf = math.inf
        for name, lo, hi, lo_open, hi_open in (
            ("quantum_efficiency", 0.0, 1.0, True, False),
            ("full_well_e", 0.0, inf, True, True),
            ("conversion_gain_e_per_dn", 0.0, inf, True, True),
            ("read_noise_e", 0.0, inf, False, True),
            ("dark_current_e_per_s", 0.0, inf, False, True),
            ("dark_current_ref_temp_c", -273.15, inf, True, True),
            ("dark_current_doubling_k", 0.0, inf, True, True),
            ("sensor_temp_c", -273.15, inf, True, True),
            ("exposure_us", 0.0, inf, True, True),
            ("ae_percentile", 0.0, 100.0, True, False),
            ("ae_target_fraction", 0.0, 1.0, True, False),
            ("min_exposure_us", 0.0, inf, True, True),
            ("max_exposure_us", 0.0, inf, True, True),
            ("extinction_ratio", 1.0, inf, True, False),
            ("orientation_error_deg", 0.0, 45.0, False, True),
            ("crosstalk", 0.0, 0.25, False, True),
            ("prnu", 0.0, 0.5, False, False),
            ("dsnu_e", 0.0, inf, False, True),
            ("hot_pixel_fraction", 0.0, 0.1, False, False),
            ("hot_pixel_dark_e_per_s", 0.0, inf, False, True),
            ("row_noise_e", 0.0, inf, False, True),
        ):
            _finite(name, getattr(self, name), lo, hi, lo_open, hi_open)
        if self.min_exposure_us > self.max_exposure_us:
            raise ValueError(
                f"min_exposure_us = {self.min_exposure_us!r} > max_exposure_us = "
                f"{self.max_exposure_us!r}: the auto-exposure range must not be empty"
            )
        if isinstance(self.adc_bits, bool) or not isinstance(self.adc_bits, int):
            raise ValueError(f"adc_bits = {self.adc_bits!r}: must be an int in [8, 16]")
        if not 8 <= self.adc_bits <= 16:
            raise ValueError(f"adc_bits = {self.adc_bits!r}: must be an int in [8, 16]")
        _finite("black_level_dn", self.black_level_dn, 0.0, float(self.max_dn), False, True)
        for name in ("auto_exposure", "shot_noise"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} = {getattr(self, name)!r}: must be True or False")


def _imx250mzr() -> PolarizationSensorSpec:
    # EMVA figures of the mono IMX250 (optics.md §3.1): SNR_max 40.3 dB ⇒ saturation ≈ 10.7 ke⁻,
    # temporal dark noise ≈ 2.9 e⁻ [derived]. Black level 240 DN: Sony's 12-bit default offset
    # [uncertain: cameras re-program it]. K chosen so the full well meets the ADC's top [derived].
    # η = 0.5 (xin2024: "QE ≈ 50 % at 530 nm"; whether that includes the polarizer is not said
    # [uncertain]). ER 250 (xin2024: 100–425 over 400–680 nm; optics.md: O(100–300)) [uncertain].
    # Orientation error 0.5°, crosstalk 0.5 %, PRNU 1 %, DSNU 1 e⁻, dark current 5 e⁻/s at 25 °C
    # doubling every 7 K: typical Pregius-class values [uncertain]. Defects: 1 pixel in 10⁴ hot
    # at 1000× the mean dark current, and a temporal row noise of 0.5 e⁻ (≈ 1/6 of the dark
    # noise; EMVA 1288 R4.0 reports row/column noise as its own spatial-variance term) — typical
    # of global-shutter CMOS, not measured on this sensor [uncertain]. Cameras can map hot pixels
    # out (LUCID's "defect pixel correction"); the twin leaves them in, the worst case.
    return PolarizationSensorSpec(
        hot_pixel_fraction=1e-4, hot_pixel_dark_e_per_s=5000.0, row_noise_e=0.5
    )


PRESETS: Mapping[str, PolarizationSensorSpec] = MappingProxyType(
    {
        # The bare Sony sensor, fixed 1 ms exposure (an arbitrary default).
        "imx250mzr": _imx250mzr(),
        # Lucid Phoenix PHX050S-P (IMX250MZR) of the LIG paper: 700 µs fixed (hu2024 §4.3).
        "phx050s_p": dataclasses.replace(_imx250mzr(), exposure_us=700.0),
        # The same camera as the Snell-window paper ran it: auto exposure within 500-2500 µs
        # (xin2024 §4.1).
        "phx050s_p_xin2024": dataclasses.replace(
            _imx250mzr(), auto_exposure=True, min_exposure_us=500.0, max_exposure_us=2500.0
        ),
        # IMX264MZR (ROI-A paper): same 3.45 µm Pregius pixel, so the IMX250MZR figures are
        # assumed [uncertain]; auto exposure (fang2024 §2.1).
        "imx264mzr": dataclasses.replace(_imx250mzr(), auto_exposure=True),
        # Ideal: η = 1, perfect analysers (d = 1), no orientation error, crosstalk, PRNU, DSNU,
        # dark current, read or shot noise, black level 0, K = 1 e⁻/DN, 16-bit ADC, full well
        # 65535 e⁻. render_mosaic returns round(t·½[S0 + S1 cos 2α + S2 sin 2α]) clipped to
        # 65535 (one photon = one electron = one DN); expected_dn returns the same unrounded
        # (float32). Auto exposure on, so any radiometric scale gives a usable frame.
        "ideal": PolarizationSensorSpec(
            quantum_efficiency=1.0,
            full_well_e=65535.0,
            conversion_gain_e_per_dn=1.0,
            read_noise_e=0.0,
            dark_current_e_per_s=0.0,
            auto_exposure=True,
            extinction_ratio=math.inf,
            orientation_error_deg=0.0,
            crosstalk=0.0,
            prnu=0.0,
            dsnu_e=0.0,
            black_level_dn=0.0,
            adc_bits=16,
            shot_noise=False,
        ),
    }
)


def preset(name: str) -> PolarizationSensorSpec:
    """The named preset spec; KeyError naming the known presets otherwise."""
    if name not in PRESETS:
        raise KeyError(f"unknown sensor preset {name!r}; known: {', '.join(PRESETS)}")
    return PRESETS[name]


__all__ = ["IMX250MZR_LAYOUT_DEG", "PRESETS", "PolarizationSensorSpec", "preset"]
