"""The camera's lens as a specification: fisheye projections, presets, binning, housing.

:class:`FisheyeSpec` (Kannala–Brandt valid beyond 90°, Scaramuzza/OCamCalib, perspective; the
sensor's geometry, binning, a dome or flat port, the polarization mapping), the radial models
that map field angle θ to image radius and back, and the lens presets of the seeds' cameras.
:class:`sensors.polarimeter.unit.camera.Camera` builds the per-pixel rays from one.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from twin.core.arrays import FloatArray

Projection = Literal["kannala_brandt", "scaramuzza", "perspective"]
Housing = Literal["dome", "flat"]
PolarizationMapping = Literal["meridional", "orthographic"]

_PROJECTIONS = ("kannala_brandt", "scaramuzza", "perspective")
_HOUSINGS = ("dome", "flat")
_MAPPINGS = ("meridional", "orthographic")
_BINNINGS = (1, 2, 4)


@dataclass(frozen=True, slots=True)
class FisheyeSpec:
    """Intrinsics, size, binning and housing of the polarimeter's camera (fisheye or pinhole).

    Attributes:
        width_px: Full-resolution sensor columns (> 0, a multiple of 2·binning).
        height_px: Full-resolution sensor rows (> 0, a multiple of 2·binning).
        pixel_pitch_um: Full-resolution pixel pitch in µm (square pixels).
        binning: 1, 2 or 4: same-orientation binning (module docstring); the frame is
            (height_px/binning) × (width_px/binning).
        projection: ``"kannala_brandt"``, ``"scaramuzza"`` or ``"perspective"`` (module docstring).
        focal_length_mm: Focal length f (Kannala–Brandt, perspective). Unused by ``"scaramuzza"``.
        kb_coeffs: Kannala–Brandt (k1, k2, k3, k4), θ in radians.
        ocam_poly: OCamCalib polynomial (a0, a1, a2, …) in full-resolution pixels, a0 < 0.
        ocam_affine: OCamCalib affine stretch (c, d, e) of A = [[c, d], [e, 1]].
        principal_point_px: (u, v) of the optical axis in full-resolution pixel coordinates
            (pixel centres at integers); None = the sensor centre ((W − 1)/2, (H − 1)/2).
        max_field_angle_deg: Half field of view θ_max (the image circle), in (0, 180); < 90 for a
            perspective camera. Pixels beyond it are invalid. Default 92.5° = a 185° fisheye.
        housing: ``"dome"`` or ``"flat"`` port (module docstring).
        port_glass_index: Refractive index of the flat port's window (≥ 1). Default 1.49 (PMMA, the
            transparent shell of the ROI-A paper's underwater rig); only used by ``"flat"``.
        polarization_mapping: ``"meridional"`` or ``"orthographic"`` (module docstring).
        name: A label (preset name).
    """

    width_px: int = 2448
    height_px: int = 2048
    pixel_pitch_um: float = 3.45
    binning: int = 1
    projection: Projection = "kannala_brandt"
    focal_length_mm: float = 1.8
    kb_coeffs: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    ocam_poly: tuple[float, ...] = ()
    ocam_affine: tuple[float, float, float] = (1.0, 0.0, 0.0)
    principal_point_px: tuple[float, float] | None = None
    max_field_angle_deg: float = 92.5
    housing: Housing = "dome"
    port_glass_index: float = 1.49
    polarization_mapping: PolarizationMapping = "meridional"
    name: str = "custom"

    def __post_init__(self) -> None:
        """Validate every field; raise ValueError naming the field and its allowed range."""
        if self.binning not in _BINNINGS:
            raise ValueError(
                f"FisheyeSpec.binning must be one of {_BINNINGS}, got {self.binning!r}"
            )
        for field in ("width_px", "height_px"):
            val = getattr(self, field)
            if isinstance(val, bool) or not isinstance(val, int | np.integer) or val <= 0:
                raise ValueError(f"FisheyeSpec.{field} must be a positive integer, got {val!r}")
            if val % (2 * self.binning):
                raise ValueError(
                    f"FisheyeSpec.{field} must be a multiple of 2*binning = {2 * self.binning} "
                    f"(whole 2x2 polarizer super-pixels after binning), got {val}"
                )
        _check_positive("pixel_pitch_um", self.pixel_pitch_um)
        if self.projection not in _PROJECTIONS:
            raise ValueError(
                f"FisheyeSpec.projection must be one of {_PROJECTIONS}, got {self.projection!r}"
            )
        _check_positive("focal_length_mm", self.focal_length_mm)
        if len(self.kb_coeffs) != 4 or not all(math.isfinite(k) for k in self.kb_coeffs):
            raise ValueError(
                f"FisheyeSpec.kb_coeffs must be 4 finite numbers (k1..k4), got {self.kb_coeffs!r}"
            )
        if not all(math.isfinite(a) for a in self.ocam_poly):
            raise ValueError(f"FisheyeSpec.ocam_poly must be finite, got {self.ocam_poly!r}")
        if self.projection == "scaramuzza" and (not self.ocam_poly or self.ocam_poly[0] >= 0):
            raise ValueError(
                "FisheyeSpec.ocam_poly must be non-empty with a0 < 0 (OCamCalib convention) for "
                f"projection='scaramuzza', got {self.ocam_poly!r}"
            )
        c, d, e = self.ocam_affine
        if not all(math.isfinite(v) for v in (c, d, e)) or abs(c - d * e) < 1e-9:
            raise ValueError(
                "FisheyeSpec.ocam_affine (c, d, e) must be finite with c - d*e != 0, "
                f"got {self.ocam_affine!r}"
            )
        if self.principal_point_px is not None and (
            len(self.principal_point_px) != 2
            or not all(math.isfinite(v) for v in self.principal_point_px)
        ):
            raise ValueError(
                "FisheyeSpec.principal_point_px must be None or two finite pixel coordinates, "
                f"got {self.principal_point_px!r}"
            )
        theta_lim = 90.0 if self.projection == "perspective" else 180.0
        if not (0.0 < self.max_field_angle_deg < theta_lim):
            raise ValueError(
                f"FisheyeSpec.max_field_angle_deg must be in (0, {theta_lim:g}) for projection "
                f"{self.projection!r}, got {self.max_field_angle_deg!r}"
            )
        if self.housing not in _HOUSINGS:
            raise ValueError(
                f"FisheyeSpec.housing must be one of {_HOUSINGS}, got {self.housing!r}"
            )
        if not (math.isfinite(self.port_glass_index) and self.port_glass_index >= 1.0):
            raise ValueError(
                f"FisheyeSpec.port_glass_index must be a finite number >= 1, "
                f"got {self.port_glass_index!r}"
            )
        if self.polarization_mapping not in _MAPPINGS:
            raise ValueError(
                f"FisheyeSpec.polarization_mapping must be one of {_MAPPINGS}, "
                f"got {self.polarization_mapping!r}"
            )
        # Fails here, not at first use, if the radial model folds back inside the field of view.
        _RadialModel(self)

    # Derived sizes -------------------------------------------------------------------------------
    @property
    def image_width(self) -> int:
        """Columns of the (binned) frame."""
        return self.width_px // self.binning

    @property
    def image_height(self) -> int:
        """Rows of the (binned) frame."""
        return self.height_px // self.binning

    @property
    def focal_length_px(self) -> float:
        """Focal length in full-resolution pixels."""
        return self.focal_length_mm / (self.pixel_pitch_um * 1e-3)

    @property
    def principal_point_full_px(self) -> tuple[float, float]:
        """Principal point (u, v) in full-resolution pixel coordinates."""
        if self.principal_point_px is None:
            return ((self.width_px - 1) / 2.0, (self.height_px - 1) / 2.0)
        return (float(self.principal_point_px[0]), float(self.principal_point_px[1]))


def _check_positive(field: str, value: float) -> None:
    if not (isinstance(value, int | float | np.floating) and math.isfinite(value) and value > 0):
        raise ValueError(f"FisheyeSpec.{field} must be a finite number > 0, got {value!r}")


# --------------------------------------------------------------------------------------------------
# Radial model: θ (angle off the optical axis) <-> ρ (sensor-plane radius, full-resolution pixels)
# --------------------------------------------------------------------------------------------------


class _RadialModel:
    """The monotone radial mapping of a spec, both ways, in float64."""

    _TABLE = 65537

    def __init__(self, spec: FisheyeSpec) -> None:
        self.kind = spec.projection
        self.f_px = spec.focal_length_px
        self.k = np.array(spec.kb_coeffs, dtype=np.float64)
        self.a = np.array(spec.ocam_poly, dtype=np.float64)
        self.theta_max = math.radians(spec.max_field_angle_deg)
        if self.kind == "kannala_brandt":
            self._init_kb()
        elif self.kind == "scaramuzza":
            self._init_ocam(spec)
        else:
            self.theta_lim = math.pi / 2
        self.rho_max = float(self.rho_of_theta(np.array([self.theta_max]))[0])

    # Kannala–Brandt -------------------------------------------------------------------------------
    def _init_kb(self) -> None:
        theta = np.linspace(0.0, math.pi, self._TABLE)
        drho = self._kb_drho(theta)
        bad = np.flatnonzero(drho <= 0)
        self.theta_lim = float(theta[bad[0] - 1]) if bad.size else math.pi
        if self.theta_lim < self.theta_max:
            raise ValueError(
                "FisheyeSpec.kb_coeffs make the Kannala-Brandt radius non-increasing at "
                f"theta = {math.degrees(self.theta_lim):.2f} deg, inside max_field_angle_deg"
            )
        self._theta_tab = np.linspace(0.0, self.theta_lim, self._TABLE)
        self._rho_tab = self._kb_rho(self._theta_tab)

    def _kb_rho(self, t: FloatArray) -> FloatArray:
        t2 = t * t
        k1, k2, k3, k4 = self.k
        return self.f_px * t * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))

    def _kb_drho(self, t: FloatArray) -> FloatArray:
        t2 = t * t
        k1, k2, k3, k4 = self.k
        return self.f_px * (1.0 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4))))

    # Scaramuzza / OCamCalib -----------------------------------------------------------------------
    def _init_ocam(self, spec: FisheyeSpec) -> None:
        # Search the monotone branch of θ(ρ) out to well beyond the sensor diagonal.
        diag = math.hypot(spec.width_px, spec.height_px)
        rho = np.linspace(0.0, 4.0 * diag, 40001)
        theta = self._ocam_theta(rho)
        dtheta = self._ocam_dtheta(rho)
        stop = np.flatnonzero((dtheta <= 0) | (theta >= math.pi - 1e-9))
        last = stop[0] - 1 if stop.size else rho.size - 1
        self.theta_lim = float(theta[last])
        if last < 1 or self.theta_lim < self.theta_max:
            raise ValueError(
                "FisheyeSpec.ocam_poly gives a non-increasing field angle before "
                f"max_field_angle_deg (reaches only {math.degrees(self.theta_lim):.2f} deg)"
            )
        self._rho_tab = np.linspace(0.0, float(rho[last]), self._TABLE)
        self._theta_tab = self._ocam_theta(self._rho_tab)

    def _ocam_g(self, rho: FloatArray) -> FloatArray:
        return np.polynomial.polynomial.polyval(rho, self.a)

    def _ocam_dg(self, rho: FloatArray) -> FloatArray:
        return np.polynomial.polynomial.polyval(rho, np.polynomial.polynomial.polyder(self.a))

    def _ocam_theta(self, rho: FloatArray) -> FloatArray:
        return np.arctan2(rho, -self._ocam_g(rho))

    def _ocam_dtheta(self, rho: FloatArray) -> FloatArray:
        g = self._ocam_g(rho)
        return (rho * self._ocam_dg(rho) - g) / (rho * rho + g * g)

    # Both ways ------------------------------------------------------------------------------------
    def rho_of_theta(self, theta: FloatArray) -> FloatArray:
        """Sensor radius (full-res px) of field angle θ; θ beyond the monotone range is clamped."""
        t = np.clip(theta, 0.0, self.theta_lim)
        if self.kind == "kannala_brandt":
            return self._kb_rho(t)
        if self.kind == "perspective":
            return self.f_px * np.tan(np.minimum(t, math.pi / 2 - 1e-9))
        rho = np.interp(t, self._theta_tab, self._rho_tab)
        for _ in range(4):  # Newton on θ(ρ) − t: quadratic from an already close start
            step = (self._ocam_theta(rho) - t) / np.maximum(self._ocam_dtheta(rho), 1e-300)
            rho = np.clip(rho - step, 0.0, self._rho_tab[-1])
        return rho

    def theta_of_rho(self, rho: FloatArray) -> FloatArray:
        """Field angle of sensor radius ρ (full-res px); beyond the monotone range: clamped."""
        if self.kind == "perspective":
            return np.arctan2(rho, self.f_px)
        if self.kind == "scaramuzza":
            return np.minimum(self._ocam_theta(np.minimum(rho, self._rho_tab[-1])), self.theta_lim)
        if not np.any(self.k):  # equidistant: exact, and the common case
            return np.minimum(rho / self.f_px, self.theta_lim)
        # A dense table leaves ~1e-9 rad; one Newton step squares that away.
        t = np.interp(rho, self._rho_tab, self._theta_tab)
        return np.clip(t - (self._kb_rho(t) - rho) / self._kb_drho(t), 0.0, self.theta_lim)

    def dtheta_drho(self, theta: FloatArray, rho: FloatArray) -> FloatArray:
        """dθ/dρ at matching (θ, ρ), for the pixel solid angle."""
        if self.kind == "kannala_brandt":
            return 1.0 / self._kb_drho(theta)
        if self.kind == "perspective":
            return self.f_px / (self.f_px**2 + rho * rho)
        return self._ocam_dtheta(rho)


#: The TUM VI benchmark's cam0 Kannala–Brandt coefficients (k1..k4, θ in rad): a measured fisheye
#: departure from equidistant (Schubert et al. 2018, "The TUM VI Benchmark for Evaluating
#: Visual-Inertial Odometry", IROS; the dataset's published camchain).
TUM_VI_CAM0_KB: tuple[float, float, float, float] = (
    0.0034823894022493434,
    0.0007150348452162257,
    -0.0020532361418706202,
    0.00020293673591811182,
)

#: Camera presets. Sources: sensor facts optics.md §3.1; lenses §3.5 and the seed papers.
PRESETS: dict[str, FisheyeSpec] = {
    # LUCID Phoenix PHX050S-P (Sony IMX250MZR, 2448x2048, 3.45 um) + Fujinon FE185C057HA-1, the
    # LIG paper's polarimeter. The lens is modelled as an ideal equidistant 185 deg fisheye with
    # f = 1.8 mm [uncertain: from Fujinon's naming, where "057" is the 5.7 mm image circle, and its
    # sibling FE185C046HA-1 = 1.4 mm quoted by the xin2024 seed; 1.8 mm * 92.5 deg gives a 5.81 mm,
    # i.e. 1685 px circle that fits the 2048 rows (optics.md §3.5). f = 2.7 mm would be the
    # FE185C086HA-1, whose 8.7 mm circle would not fit the 7.07 mm high sensor]. Distortion
    # coefficients are not published: k = 0 until a calibration is available.
    "phx050s_fe185": FisheyeSpec(
        name="phx050s_fe185",
        width_px=2448,
        height_px=2048,
        pixel_pitch_um=3.45,
        projection="kannala_brandt",
        focal_length_mm=1.8,
        max_field_angle_deg=92.5,
    ),
    # The Snell-window paper's polarimeter (xin2024 §4.1): the same PHX050S-P with a Fujinon
    # FE185C046HA-1, 185 deg, f = 1.4 mm (stated there): a ~1300 px image circle on the 2048 rows.
    # Its departure from the equidistant projection is not published; the twin gives it the
    # measured departure of another fisheye, the TUM VI benchmark's cam0 (Schubert et al. 2018,
    # IROS; 195 deg; Kalibr's equidistant model, the same theta polynomial as here) [uncertain:
    # another lens]: -1.0 % of the radius at 90 deg, +0.2 % at 45 deg. It matters only to a vehicle
    # that does not correct distortion (sensors/polarimeter/unit/hardware.py,
    # distortion_correction):
    # a calibrated unit knows it.
    "phx050s_fe185c046": FisheyeSpec(
        name="phx050s_fe185c046",
        width_px=2448,
        height_px=2048,
        pixel_pitch_um=3.45,
        projection="kannala_brandt",
        focal_length_mm=1.4,
        max_field_angle_deg=92.5,
        kb_coeffs=TUM_VI_CAM0_KB,
    ),
    # Sony IMX264MZR board camera (same 2448x2048, 3.45 um array; slower readout, other noise)
    # with the same FE185C057HA-1 lens, as in the ROI-A seed (fang2024 Table 2). Same geometry.
    "imx264_185": FisheyeSpec(
        name="imx264_185",
        width_px=2448,
        height_px=2048,
        pixel_pitch_um=3.45,
        projection="kannala_brandt",
        focal_length_mm=1.8,
        max_field_angle_deg=92.5,
    ),
    # The MOI paper's hypothetical in-air imager (its §3.2, Table 1): a pinhole with f = 8 mm,
    # eta_x = 2048 pixels along x (columns) and eta_y = 2448 along y (rows) — eq. 16 read literally
    # (Table 1 does not say which is rows; optics.md §7) — 3.45 um pixels, and the orthographic
    # E-vector projection of its eqs. 22-23. Half-diagonal field 34.5 deg: every pixel is valid.
    "moi_pinhole": FisheyeSpec(
        name="moi_pinhole",
        width_px=2048,
        height_px=2448,
        pixel_pitch_um=3.45,
        projection="perspective",
        focal_length_mm=8.0,
        max_field_angle_deg=60.0,
        polarization_mapping="orthographic",
    ),
}


def preset(name: str, **overrides: object) -> FisheyeSpec:
    """A preset :class:`FisheyeSpec`, with fields replaced by ``overrides`` (e.g. ``binning=4``)."""
    if name not in PRESETS:
        raise ValueError(f"camera preset must be one of {sorted(PRESETS)}, got {name!r}")
    return dataclasses.replace(PRESETS[name], **overrides)  # type: ignore[arg-type]
