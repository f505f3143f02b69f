"""The Snell-window method's parameters (xin2024), and the paper's own choice of them.

:class:`SnellConfig` is what ``[navigation.methods.snell]`` configures;
:data:`SNELL_PAPER` is the method as the paper writes it (``snell_paper``). The method itself is
:mod:`twin.onboard.compass.snell`.
"""

from __future__ import annotations

from dataclasses import dataclass

from twin.core.calibration import StokesGrid
from twin.core.fields import Range, check_ranges


@dataclass(frozen=True)
class SnellConfig:
    """Parameters of the Snell-window method (xin2024; values the paper leaves open are marked).

    Attributes:
        stokes_grid: ``"interpolate"`` (full-resolution Stokes) or ``"superpixel"`` (the
            papers' 2×2 units). The super-pixel AoP is biased by ~1° where the DoP is low and S0
            has a gradient (its four analysers sample different points), e.g. near the zenith
            with the sun at 60°; the interpolated one by ~0.01°. [ours]
        grey_fraction: Keep pixels in the brightest fraction of the log grey range (§3.2: 70 %).
        min_window_contrast: Median grey inside / outside the window below which the window is
            not distinct (deep or turbid water, night) ⇒ no fix. [not in the paper]
        min_window_pixels: Fewest window super-pixels for a fix. [not in the paper]
        min_signal_dn: Median window S0 (DN) below which the frame is too dark. [not in the paper]
        symmetric_truncation: Drop window pixels whose mirror about the zenith is outside the
            field (removes the centroid bias of a window cut by the image circle). [ours]
        max_work_px: Frames larger than this (pixels, longer side) are binned by same orientation
            (``bin_mosaic``, b = 2, 4, …) to a working mosaic of at most this size before any
            other step: a 2448×2048 frame is processed as the 612×512 frame of an on-sensor
            binning-4 camera. None = never bin. [ours: the method's resolution needs are set by
            the window (≈ 100 working pixels of radius), not by the sensor]
        edge_refine: Refine the centroid by fitting the window's rim: the sun's forward-scattering
            glow spills past the rim on the sun's side and passes the grey threshold, pulling a
            plain centroid by up to ~14° in Jerlov II water; the rim is sharp, the glow smooth.
            The log grey is resampled on a polar grid about the current estimate, the rim found
            per azimuth as the steepest outward fall (derivative of a Gaussian along the polar
            angle), and a circle θ_rim(φ) = r0 + a cos φ + b sin φ fitted robustly (least median
            of squares, then Tukey IRLS); the estimate moves by (a, b) and the search narrows
            (``rim_search_deg``, 6°, 3°, 3°). [ours]
        rim_search_deg: Half-width (polar angle) of the first rim search about the critical
            angle. [ours]
        rim_azimuths: Azimuths of the polar grid. [ours]
        rim_smooth_deg: σ of the Gaussian derivative along the polar angle (at least one
            Stokes-grid pixel). [ours]
        level_scale: Pixels per radian of the levelled equidistant image, as a multiple of the
            working (binned) frame's Stokes-grid focal length. [ours]
        window_margin_deg: Keep the characteristic region this far inside the window edge,
            where the refraction-polarization pattern is steep and noisy. [ours]
        median_ksize: Median filter aperture (§2.4; 3 or 5, OpenCV float limit). [not stated]
        gauss_ksize: Gaussian filter aperture (§2.4). [not stated]
        gauss_sigma_px: Gaussian σ. [not stated]
        meridian_band_deg: |AoE| ≥ 90° − this is the solar-meridian characteristic region.
            [not stated; compyss's Hough decoder uses 0.1 rad]
        min_dop: Pixels with a lower DoP carry no AoE. [not stated]
        canny_low: Canny thresholds on the 0/255 region mask (§2.4). [not stated]
        canny_high: ″
        hough_theta_deg: Hough angular resolution. [not stated]
        hough_votes_frac: Hough accumulator threshold as a fraction of the window radius (px).
        hough_center_frac: Keep lines passing within this fraction of the window radius of the
            zenith (the meridian is a line through it).
        hough_max_lines: Strongest lines used.
        aop_error_poly_deg: Bench-fitted residual lens AoP error vs incidence angle (§2.3).
        max_sun_elevation_deg: Above this the meridian is undefined ⇒ no fix.
        min_ambiguity_margin: Smallest brightness asymmetry that decides the 180° ambiguity.
        azimuth_floor_deg: 1σ floor of the meridian direction in the covariance.
        tilt_sigma_deg: 1σ of roll/pitch in the covariance (paper: MAE 0.75°/0.62°).
    """

    stokes_grid: StokesGrid = "interpolate"
    grey_fraction: float = 0.7
    min_window_contrast: float = 2.0
    min_window_pixels: int = 200
    min_signal_dn: float = 20.0
    symmetric_truncation: bool = True
    max_work_px: int | None = 640
    edge_refine: bool = True
    rim_search_deg: float = 20.0
    rim_azimuths: int = 360
    rim_smooth_deg: float = 0.5
    level_scale: float = 1.0
    window_margin_deg: float = 4.0
    median_ksize: int = 5
    gauss_ksize: int = 5
    gauss_sigma_px: float = 1.0
    meridian_band_deg: float = 8.0
    min_dop: float = 0.02
    canny_low: float = 50.0
    canny_high: float = 150.0
    hough_theta_deg: float = 0.25
    hough_votes_frac: float = 0.25
    hough_center_frac: float = 0.08
    hough_max_lines: int = 12
    aop_error_poly_deg: tuple[float, ...] = ()
    max_sun_elevation_deg: float = 87.0
    min_ambiguity_margin: float = 0.01
    azimuth_floor_deg: float = 0.3
    tilt_sigma_deg: float = 0.7

    def __post_init__(self) -> None:
        checks = (
            ("grey_fraction", self.grey_fraction, 0.05, 0.99),
            ("min_window_contrast", self.min_window_contrast, 1.0, 1e6),
            ("level_scale", self.level_scale, 0.25, 4.0),
            ("rim_search_deg", self.rim_search_deg, 3.0, 40.0),
            ("rim_smooth_deg", self.rim_smooth_deg, 0.0, 5.0),
            ("window_margin_deg", self.window_margin_deg, 0.0, 30.0),
            ("gauss_sigma_px", self.gauss_sigma_px, 0.0, 20.0),
            ("meridian_band_deg", self.meridian_band_deg, 0.5, 45.0),
            ("min_dop", self.min_dop, 0.0, 1.0),
            ("hough_theta_deg", self.hough_theta_deg, 0.01, 5.0),
            ("hough_votes_frac", self.hough_votes_frac, 0.01, 2.0),
            ("hough_center_frac", self.hough_center_frac, 0.0, 1.0),
            ("max_sun_elevation_deg", self.max_sun_elevation_deg, 0.0, 90.0),
            ("min_ambiguity_margin", self.min_ambiguity_margin, 0.0, 1.0),
            ("azimuth_floor_deg", self.azimuth_floor_deg, 0.0, 90.0),
            ("tilt_sigma_deg", self.tilt_sigma_deg, 0.0, 90.0),
        )
        check_ranges("SnellConfig", ((n, v, Range(lo, hi)) for n, v, lo, hi in checks))
        if self.stokes_grid not in ("interpolate", "superpixel"):
            raise ValueError(
                f"SnellConfig.stokes_grid: {self.stokes_grid!r}; "
                "allowed: 'interpolate', 'superpixel'"
            )
        if self.median_ksize not in (3, 5):
            raise ValueError(f"SnellConfig.median_ksize: {self.median_ksize!r}; allowed: 3, 5")
        if self.gauss_ksize < 1 or self.gauss_ksize % 2 == 0:
            raise ValueError(f"SnellConfig.gauss_ksize: {self.gauss_ksize!r}; allowed: odd >= 1")
        if self.max_work_px is not None and not (
            isinstance(self.max_work_px, int) and self.max_work_px >= 64
        ):
            raise ValueError(
                f"SnellConfig.max_work_px: {self.max_work_px!r}; allowed: None or an int >= 64"
            )
        if not (isinstance(self.rim_azimuths, int) and 36 <= self.rim_azimuths <= 3600):
            raise ValueError(f"SnellConfig.rim_azimuths: {self.rim_azimuths!r}; allowed 36..3600")
        if self.min_window_pixels < 10 or self.hough_max_lines < 1:
            raise ValueError("SnellConfig: min_window_pixels >= 10 and hough_max_lines >= 1")


#: The Snell-window method as Xin et al. (2024) write it, where a configuration can: the papers'
#: 2×2 super-pixel Stokes, the plain centroid of the brightest 70 % (§3.2: no rim fit, no
#: symmetric truncation), the characteristic region out to the window's edge and every pixel
#: with an AoE (no DoP threshold). Kept from the twin: the working frame binned to 640 px (the
#: same MAE at both resolutions, validation/results/campaigns/snell_attitude), the fisheye
#: resampling in place of Zhang's pinhole undistortion (which cannot hold rays past 90°), eq.
#: 15's ½S0 (as printed it has cos 2φ twice), the log-grey reading of "the brightest 70 %", the
#: filters' and Hough's unstated sizes, the brightness rule for the 180° ambiguity and the
#: no-window / too-dark guards.
SNELL_PAPER = SnellConfig(
    stokes_grid="superpixel",
    edge_refine=False,
    symmetric_truncation=False,
    window_margin_deg=0.0,
    min_dop=0.0,
)
