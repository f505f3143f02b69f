"""The error budget of a real polarimeter unit: how the vehicle's knowledge of it is wrong.

World side of the world/onboard boundary. The renderer draws the sky as the *true* camera sees
it; the vehicle computer works with what its calibration session and its mechanical drawing say
(:class:`twin.core.calibration.CameraCalibration`). This module draws, once per run from the run's
seed, how the two differ:

* **Calibration** (:class:`CalibrationUncertainty`): the onboard focal length, principal point and
  analyser orientations differ from the true camera's by the declared uncertainty of the session
  that produced them.
* **Mounting** (:class:`MountingError`): the camera's axes are turned from the IMU's by a small
  boresight rotation the vehicle does not know, and the camera's time stamps are off the IMU's
  clock by a constant offset.
* **Lens tolerance** (:class:`LensTolerance`): a unit's lens departs from its datasheet (focal
  length, centring on the sensor, the projection's shape). A calibration session measures the
  unit's own lens, and the vehicle works with that (``distortion_correction``, xin2024 §2.4);
  without it the vehicle has only the datasheet's nominal equidistant model.
* **Lens** (:class:`sensors.polarimeter.unit.lens.LensPolarization`): the lens's own diattenuation
  and
  retardance, growing with field angle (not drawn: the same for every unit of a lens design);
  with ``lens_compensation`` the unit is measured on the simulated bench of xin2024 §2.3
  (:mod:`sensors.polarimeter.unit.bench`) and the vehicle undoes what the bench found
  (:mod:`twin.onboard.lens`).

Each model has an ``ideal`` form (every σ = 0), which reproduces the perfect vehicle knowledge the
twin had before: the perfect calibration, an identity boresight, no clock offset, and no random
draws at all (so the run's other random streams are untouched).

Defaults and their sources (σ are 1σ, per run):

* ``focal_sigma_rel = 0.003``: 0.3 % of f. A checkerboard session of a fisheye in air fits f to
  ≈ 0.1 % (Kannala & Brandt 2006, IEEE TPAMI 28(8), residuals ≈ 0.1 px); the unit is used in water
  behind a dome, where a dome centre off the lens's entrance pupil by a fraction of a millimetre
  changes the in-water mapping by a few tenths of a percent (Kunz & Singh 2008, OCEANS'08,
  "Hemispherical refraction and camera calibration in underwater vision") [uncertain: no seed
  reports its calibration's uncertainty].
* ``principal_point_sigma_px = 2.0`` full-resolution pixels [uncertain: the same sources; the
  Snell-window paper (xin2024 §3.2) finds its window centre to < 3 px after its correction].
* ``polarizer_sigma_deg = 0.21``: a common turn of the analyser layout, the accuracy of a bench
  calibration of the AoP: xin2024 §2.3 verifies its AoP calibration to a mean absolute error of
  0.1713°, i.e. σ = MAE·√(π/2) = 0.21° for a Gaussian error.
* ``boresight_sigma_deg = 0.19`` per axis: ISO 2768-1 general tolerance, class m ("medium"), for
  an un-toleranced angle on a part with a 50–120 mm leg (a camera bracket): ±20′ = ±0.33°, read as
  a uniform bound, σ = 0.33°/√3.
* ``focal_tolerance_rel = 0.0289``: ISO 517 lets a lens's marked focal length differ from the
  real one by ±5 %; read as a uniform bound, σ = 5 %/√3. Used only without distortion correction.
* ``decentre_sigma_um = 18``: the optical axis off the sensor's centre. The TUM VI benchmark's
  two calibrated fisheye units (Schubert et al. 2018, IROS, cam0/cam1 of its camchain: principal
  points (254.93, 256.90) and (252.60, 254.92) px on 512 × 512 frames of 10.6 µm binned pixels)
  sit 6–31 µm off centre, RMS 18 µm per axis [uncertain: two units of another camera]. Used only
  without distortion correction.
* The departure of a lens's projection from equidistant is the world camera's own
  (``FisheyeSpec.kb_coeffs``, set per preset where a source gives one); without distortion
  correction the vehicle takes the projection to be ideal equidistant.
* ``clock_offset_sigma_ms = 5.0`` [uncertain]: host time stamps of GigE/USB frames on the seeds'
  computers (hu2024: a Jetson Nano) without PTP sync, after the nominal transfer time is removed;
  the seeds do not state how they stamp frames.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from sensors.polarimeter.unit.lens import LensPolarization
from twin.core.arrays import Float64Array as FloatArray
from twin.core.calibration import CameraCalibration


def _sigma(owner: str, name: str, value: float, hi: float) -> None:
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if not (ok and math.isfinite(value) and 0.0 <= value <= hi):
        raise ValueError(f"{owner}.{name}: {value!r}; allowed: [0, {hi:g}]")


@dataclass(frozen=True, slots=True)
class CalibrationUncertainty:
    """How far the onboard calibration is from the true camera (1σ per run; module docstring).

    Attributes:
        focal_sigma_rel: Relative error of the focal length.
        principal_point_sigma_px: Error of each principal-point coordinate, full-resolution px.
        polarizer_sigma_deg: Common orientation error of the analyser layout (deg).
    """

    focal_sigma_rel: float = 0.003
    principal_point_sigma_px: float = 2.0
    polarizer_sigma_deg: float = 0.21

    def __post_init__(self) -> None:
        _sigma("calibration", "focal_sigma_rel", self.focal_sigma_rel, 0.2)
        _sigma("calibration", "principal_point_sigma_px", self.principal_point_sigma_px, 200.0)
        _sigma("calibration", "polarizer_sigma_deg", self.polarizer_sigma_deg, 10.0)

    @classmethod
    def ideal(cls) -> CalibrationUncertainty:
        """The vehicle knows the camera exactly."""
        return cls(0.0, 0.0, 0.0)

    @property
    def is_ideal(self) -> bool:
        sigmas = (self.focal_sigma_rel, self.principal_point_sigma_px, self.polarizer_sigma_deg)
        return not any(sigmas)

    def draw(
        self, true: CameraCalibration, binning: int, rng: np.random.Generator
    ) -> CameraCalibration:
        """The onboard calibration of one unit: ``true`` plus one draw of the errors.

        Four standard normals are always drawn (focal length, u, v, layout turn), whatever the
        σ, so that changing one σ leaves the other errors of a seed unchanged.

        Args:
            true: The exact calibration of the world's camera (frame pixels).
            binning: Frame pixels per full-resolution pixel (the σ of the principal point is
                given at full resolution).
            rng: The run's generator for this unit.
        """
        z = rng.standard_normal(4)
        cu, cv = true.principal_point_px
        pp = self.principal_point_sigma_px / binning
        turn = self.polarizer_sigma_deg * float(z[3])
        layout = tuple(tuple(float(a) + turn for a in row) for row in true.layout_deg)
        return dataclasses.replace(
            true,
            focal_px=true.focal_px * (1.0 + self.focal_sigma_rel * float(z[0])),
            principal_point_px=(cu + pp * float(z[1]), cv + pp * float(z[2])),
            layout_deg=layout,  # type: ignore[arg-type]
        )


@dataclass(frozen=True, slots=True)
class LensTolerance:
    """How a unit's lens departs from its datasheet (1σ per unit; module docstring).

    The twin keeps the world camera as the unit's true lens and draws the datasheet's nominal
    model *from* it: the relative error, which is all a compass sees, is the same either way.

    Attributes:
        focal_tolerance_rel: Relative error of the datasheet focal length.
        decentre_sigma_um: Offset of the optical axis from the sensor's centre, each axis (µm).
    """

    focal_tolerance_rel: float = 0.05 / math.sqrt(3.0)
    decentre_sigma_um: float = 18.0

    def __post_init__(self) -> None:
        _sigma("calibration", "focal_tolerance_rel", self.focal_tolerance_rel, 0.2)
        _sigma("calibration", "decentre_sigma_um", self.decentre_sigma_um, 1000.0)

    def nominal(self, true: CameraCalibration, rng: np.random.Generator) -> CameraCalibration:
        """The datasheet's model of a unit whose true lens is ``true``.

        Equidistant (no Kannala–Brandt terms), the datasheet focal length and the optical axis at
        the sensor's centre. Three standard normals are always drawn (f, u, v).

        Args:
            true: The exact calibration of the world's camera (frame pixels; its pixel pitch is
                the frame's, binning included).
            rng: The unit's generator for its lens tolerances.
        """
        z = rng.standard_normal(3)
        cu, cv = true.principal_point_px
        d_px = self.decentre_sigma_um / true.pixel_pitch_um  # µm on the sensor → frame pixels
        return dataclasses.replace(
            true,
            focal_px=true.focal_px * (1.0 + self.focal_tolerance_rel * float(z[0])),
            principal_point_px=(cu + d_px * float(z[1]), cv + d_px * float(z[2])),
            kb_coeffs=(0.0, 0.0, 0.0, 0.0),
        )


@dataclass(frozen=True, slots=True)
class MountingError:
    """How the camera sits on the vehicle, against what the vehicle believes (1σ per run).

    Attributes:
        boresight_sigma_deg: Misalignment of the camera's axes from the nominal mount, each of
            the three rotation-vector components (deg).
        clock_offset_sigma_ms: Offset of the camera's time stamps from the IMU's clock (ms).
    """

    boresight_sigma_deg: float = 0.19
    clock_offset_sigma_ms: float = 5.0

    def __post_init__(self) -> None:
        _sigma("mounting", "boresight_sigma_deg", self.boresight_sigma_deg, 10.0)
        _sigma("mounting", "clock_offset_sigma_ms", self.clock_offset_sigma_ms, 1000.0)

    @classmethod
    def ideal(cls) -> MountingError:
        """Camera axes = the nominal mount, one clock."""
        return cls(0.0, 0.0)

    @property
    def is_ideal(self) -> bool:
        return not (self.boresight_sigma_deg or self.clock_offset_sigma_ms)

    def draw(self, rng: np.random.Generator) -> tuple[FloatArray, float]:
        """(C_true^nominal: the true camera frame → the nominal one, clock offset in s).

        Four standard normals are always drawn (three boresight components, the offset).
        """
        z = rng.standard_normal(4)
        r = math.radians(self.boresight_sigma_deg) * z[:3]
        return _rotvec(r), self.clock_offset_sigma_ms * 1e-3 * float(z[3])


def _rotvec(r: FloatArray) -> FloatArray:
    """exp([r×]) (Rodrigues)."""
    a = float(np.linalg.norm(r))
    if a < 1e-12:
        return np.eye(3)
    k = r / a
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(a) * kx + (1.0 - math.cos(a)) * (kx @ kx)


@dataclass(frozen=True, slots=True)
class HardwareErrors:
    """The whole error budget of a polarimeter unit (scenario table ``[hardware]``).

    The default is a real unit with every model at its sourced default (module docstring).
    ``distortion_correction`` (xin2024 §2.4): the vehicle's geometric model of the camera comes
    from a calibration session of the unit (``calibration``'s errors apply); False: from the
    datasheet (``tolerance``'s errors apply, and the projection is taken as ideal equidistant).
    """

    calibration: CalibrationUncertainty = dataclasses.field(default_factory=CalibrationUncertainty)
    mounting: MountingError = dataclasses.field(default_factory=MountingError)
    lens: LensPolarization = dataclasses.field(default_factory=LensPolarization)
    lens_compensation: bool = True
    tolerance: LensTolerance = dataclasses.field(default_factory=LensTolerance)
    distortion_correction: bool = True

    @classmethod
    def ideal(cls) -> HardwareErrors:
        """No error anywhere: the vehicle knows its camera exactly, the lens is neutral."""
        return cls(CalibrationUncertainty.ideal(), MountingError.ideal(), LensPolarization.ideal())

    @property
    def benched(self) -> bool:
        """Whether the unit's lens is measured on the bench (``sensors.polarimeter.unit.bench``)."""
        return self.lens_compensation and not self.lens.is_ideal

    @property
    def drawn(self) -> bool:
        """Whether a unit is drawn per run (calibration or mounting errors, a bench session)."""
        exact = self.calibration.is_ideal and self.distortion_correction
        return not (exact and self.mounting.is_ideal) or self.benched

    @property
    def is_ideal(self) -> bool:
        return not self.drawn and self.lens.is_ideal

    def draw(self, true: CameraCalibration, binning: int, rng: np.random.Generator) -> HardwareUnit:
        """One unit as built and calibrated, from the run's generator for it."""
        # A third child for the lens tolerances: SeedSequence children are numbered, so the first
        # two (and a seed's calibration and mounting errors) are what they were without it.
        cal_rng, mount_rng, tol_rng = rng.spawn(3)
        boresight, offset = self.mounting.draw(mount_rng)
        cal = self.calibration.draw(true, binning, cal_rng)
        nominal = self.tolerance.nominal(true, tol_rng)
        if not self.distortion_correction:
            # The datasheet's geometry; the analysers' orientation still comes from the bench.
            cal = dataclasses.replace(nominal, layout_deg=cal.layout_deg, lens_table=cal.lens_table)
        return HardwareUnit(cal, boresight, offset)


@dataclass(frozen=True)
class HardwareUnit:
    """One drawn unit.

    Attributes:
        calibration: What the vehicle believes about the camera (the onboard calibration).
        boresight: (3, 3) C_true^nominal, the true camera frame → the camera frame the vehicle
            believes in (its calibration's mount). The renderer's camera attitude is
            ``C_nominal^n @ boresight``.
        clock_offset_s: Added to the camera's time stamps (the frame is stamped later than it
            was taken when positive).
    """

    calibration: CameraCalibration
    boresight: FloatArray
    clock_offset_s: float

    def boresight_deg(self) -> float:
        """The misalignment's angle (deg)."""
        c = (float(np.trace(self.boresight)) - 1.0) / 2.0
        return math.degrees(math.acos(max(-1.0, min(1.0, c))))


__all__ = [
    "CalibrationUncertainty",
    "HardwareErrors",
    "HardwareUnit",
    "LensTolerance",
    "MountingError",
]
