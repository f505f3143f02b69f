"""The perfect onboard calibration of a world camera: ``FisheyeSpec`` → ``CameraCalibration``.

World side of the world/onboard boundary (the world may import onboard code, not the reverse).
What a flawless checkerboard session would give the vehicle: the same radial model, principal
point and polarization mapping the renderer uses, expressed in pixels of the *delivered* (binned)
frame, which is how :class:`twin.core.calibration.CameraCalibration` states its intrinsics.

Binning b (``sensors.polarimeter.unit.camera``): binned pixel k sits at full-resolution coordinate
b·k + (b − 1)/2 and the intrinsics are given at full resolution, so in binned pixels the focal
length is f/b and the principal point is (c − (b − 1)/2)/b. Both radial models the calibration
knows (Kannala–Brandt, perspective) are linear in f, so this is exact.
"""

from __future__ import annotations

import math

from sensors.polarimeter.unit.fisheye import FisheyeSpec
from sensors.polarimeter.unit.mosaic import PolarizationSensorSpec
from twin.core.calibration import CameraCalibration


def calibration_from_spec(
    spec: FisheyeSpec, sensor: PolarizationSensorSpec | None = None
) -> CameraCalibration:
    """The onboard calibration that reproduces ``spec``'s pixel rays and lens mapping exactly.

    Args:
        spec: The world camera.
        sensor: Optional sensor spec for the super-pixel layout, the saturation level and the
            black level (default: the calibration's IMX250MZR layout, 12-bit saturation, no
            black level).

    Raises:
        ValueError: For a ``"scaramuzza"`` projection or a non-identity affine stretch, which the
            onboard calibration cannot represent.
    """
    if spec.projection == "scaramuzza":
        raise ValueError(
            "calibration_from_spec: projection 'scaramuzza' has no onboard equivalent; "
            "allowed: 'kannala_brandt', 'perspective'"
        )
    if tuple(spec.ocam_affine) != (1.0, 0.0, 0.0):
        raise ValueError(
            f"calibration_from_spec: ocam_affine {spec.ocam_affine!r} must be the identity"
        )
    b = spec.binning
    cu, cv = spec.principal_point_full_px
    shift = (b - 1) / 2.0
    extra: dict[str, object] = {}
    if sensor is not None:
        extra = {
            "layout_deg": sensor.layout_deg,
            "saturation_dn": int(sensor.saturation_dn),
            "black_level_dn": float(sensor.black_level_dn),
        }
    return CameraCalibration(
        width_px=spec.image_width,
        height_px=spec.image_height,
        focal_px=spec.focal_length_px / b,
        principal_point_px=((cu - shift) / b, (cv - shift) / b),
        projection=spec.projection,  # type: ignore[arg-type]
        kb_coeffs=tuple(float(k) for k in spec.kb_coeffs),  # type: ignore[arg-type]
        max_field_angle_rad=math.radians(spec.max_field_angle_deg),
        housing=spec.housing,
        polarization_mapping=spec.polarization_mapping,
        pixel_pitch_um=spec.pixel_pitch_um * b,
        **extra,  # type: ignore[arg-type]
    )
