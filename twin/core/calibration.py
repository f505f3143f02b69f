"""The vehicle's calibration of its polarimeter: pixel ↔ ray geometry, known to onboard code.

The world renders with ``sensors.polarimeter.unit.camera``; the vehicle computer knows only this
calibration (what a checkerboard session and the mechanical drawing would give it) and must not
import the renderer. The conventions are the renderer's, so that a perfect calibration reproduces
its rays exactly (tests/sensors/polarimeter/test_calibration.py checks that against the world
camera):

* camera frame c = the ``polarimeter`` site frame: x starboard, y forward, z the optical axis;
* image column u along +x, row v along −y, arrays ``[v, u]``, pixel centres at integers;
* θ = atan2(√(x²+y²), z), valid beyond 90° for the fisheye;
* ``"kannala_brandt"``: ρ = f(θ + k1θ³ + k2θ⁵ + k3θ⁷ + k4θ⁹); ``"perspective"``: ρ = f tan θ;
* all intrinsics in pixels of the delivered (possibly binned) frame.

Polarization on the sensor: an AoP ψ (from +u towards +v, ``twin.onboard.polarization``) is the
E-vector ``cos ψ · r_s + sin ψ · t_s`` in 3-D, where for the ``"meridional"`` lens mapping r_s and
t_s are the sensor's x and −y axes carried along the ray by the rotation taking ẑ to the ray
(Rodrigues). For the ``"orthographic"`` mapping (the MOI paper's imager) the E-vector is the
direction in the plane ⟂ to the ray whose projection onto the sensor plane makes the angle ψ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twin.core.arrays import Float64Array as FloatArray

Projection = Literal["kannala_brandt", "perspective"]
Housing = Literal["dome", "flat"]
Mapping = Literal["meridional", "orthographic"]
StokesGrid = Literal["superpixel", "interpolate"]

IMX250MZR_LAYOUT_DEG: tuple[tuple[float, float], tuple[float, float]] = ((90.0, 45.0), (135.0, 0.0))


@dataclass(frozen=True)
class CameraCalibration:
    """Intrinsics and mounting of the polarimeter, in pixels of the delivered frame.

    Attributes:
        width_px: Columns of the raw frame.
        height_px: Rows of the raw frame.
        focal_px: Focal length f in frame pixels.
        principal_point_px: (u, v) of the optical axis in frame pixel coordinates.
        projection: ``"kannala_brandt"`` or ``"perspective"``.
        kb_coeffs: Kannala–Brandt (k1..k4).
        max_field_angle_rad: Half field of view (the image circle).
        housing: ``"dome"`` (rays unbent) or ``"flat"`` (Snell at the port: in-water rays bend).
        polarization_mapping: ``"meridional"`` or ``"orthographic"`` (module docstring).
        layout_deg: Analyser angles of the 2×2 super-pixel (``twin.onboard.polarization``).
        saturation_dn: Raw value at or above which a pixel is clipped.
        black_level_dn: The sensor's pedestal, subtracted before the Stokes inversion.
        mount_rotation: (3, 3) C_c^b, camera → body (identity: optical axis = body +z).
        pixel_pitch_um: Pixel pitch of the frame (after binning), µm; informational.
        lens_table: The lens's polarization as a bench measured it (``twin.onboard.lens``):
            rows (θ rad, T̄, D, a, c) of field angle, relative transmission, radial
            diattenuation, and the S1 and S2 factors of the radial frame (a = m11/m00,
            c = m22/m00: √(1 − D²) cos δ times the analysers' own diattenuation), θ
            increasing; empty = no compensation.
    """

    width_px: int
    height_px: int
    focal_px: float
    principal_point_px: tuple[float, float]
    projection: Projection = "kannala_brandt"
    kb_coeffs: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    max_field_angle_rad: float = math.radians(92.5)
    housing: Housing = "dome"
    polarization_mapping: Mapping = "meridional"
    layout_deg: tuple[tuple[float, float], tuple[float, float]] = IMX250MZR_LAYOUT_DEG
    saturation_dn: int = 4095
    black_level_dn: float = 0.0
    mount_rotation: tuple[tuple[float, ...], ...] = (
        (1.0, 0.0, 0.0),
        (0.0, 1.0, 0.0),
        (0.0, 0.0, 1.0),
    )
    pixel_pitch_um: float = 3.45
    lens_table: tuple[tuple[float, float, float, float, float], ...] = ()
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px"):
            v = getattr(self, name)
            if not isinstance(v, int | np.integer) or isinstance(v, bool) or v <= 0 or v % 2:
                raise ValueError(
                    f"CameraCalibration.{name}: {v!r}; allowed: a positive even integer"
                )
        if not (math.isfinite(self.focal_px) and self.focal_px > 0):
            raise ValueError(f"CameraCalibration.focal_px: {self.focal_px!r}; allowed: (0, inf)")
        if self.projection not in ("kannala_brandt", "perspective"):
            raise ValueError(
                f"CameraCalibration.projection: {self.projection!r}; allowed: "
                "'kannala_brandt', 'perspective'"
            )
        lim = math.pi / 2 if self.projection == "perspective" else math.pi
        if not (0 < self.max_field_angle_rad < lim):
            raise ValueError(
                f"CameraCalibration.max_field_angle_rad: {self.max_field_angle_rad!r}; "
                f"allowed: (0, {lim:.4f})"
            )
        if self.housing not in ("dome", "flat"):
            raise ValueError(
                f"CameraCalibration.housing: {self.housing!r}; allowed: 'dome', 'flat'"
            )
        if self.polarization_mapping not in ("meridional", "orthographic"):
            raise ValueError(
                f"CameraCalibration.polarization_mapping: {self.polarization_mapping!r}; "
                "allowed: 'meridional', 'orthographic'"
            )
        if self.lens_table:
            tab = np.asarray(self.lens_table, dtype=np.float64)
            ok = tab.ndim == 2 and tab.shape[1] == 5 and bool(np.all(np.isfinite(tab)))
            ok = ok and bool(np.all(np.diff(tab[:, 0]) > 0)) and bool(np.all(tab[:, 1] > 0))
            ok = ok and bool(np.all(tab[:, 3] > tab[:, 2] ** 2)) and bool(np.all(tab[:, 4] > 0))
            if not ok:
                raise ValueError(
                    "CameraCalibration.lens_table: rows (θ, T, D, a, c) with θ increasing, "
                    "T > 0, a > D², c > 0"
                )
        m = np.asarray(self.mount_rotation, dtype=np.float64)
        if m.shape != (3, 3) or not np.allclose(m @ m.T, np.eye(3), atol=1e-9):
            raise ValueError("CameraCalibration.mount_rotation: must be a 3x3 rotation matrix")

    # ---- radial model --------------------------------------------------------------------------
    def rho_of_theta(self, theta: ArrayLike) -> FloatArray:
        """Image radius (frame pixels) of off-axis angle θ."""
        t = np.asarray(theta, dtype=np.float64)
        if self.projection == "perspective":
            return self.focal_px * np.tan(t)
        k1, k2, k3, k4 = self.kb_coeffs
        t2 = t * t
        return self.focal_px * t * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))

    def theta_of_rho(self, rho: ArrayLike) -> FloatArray:
        """Off-axis angle θ of image radius ρ (inverse of :meth:`rho_of_theta`)."""
        r = np.asarray(rho, dtype=np.float64)
        if self.projection == "perspective":
            return np.arctan(r / self.focal_px)
        t = r / self.focal_px
        if any(self.kb_coeffs):
            k1, k2, k3, k4 = self.kb_coeffs
            for _ in range(8):  # Newton on the odd polynomial; converges from the equidistant guess
                t2 = t * t
                g = self.focal_px * t * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))) - r
                dg = self.focal_px * (
                    1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))
                )
                t = t - g / dg
        return t

    # ---- pixel ↔ ray ---------------------------------------------------------------------------
    def pixel_to_ray(self, u: ArrayLike, v: ArrayLike) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Unit camera-frame rays (..., 3) of image points; whether they lie in the image circle."""
        cu, cv = self.principal_point_px
        xs = np.asarray(u, dtype=np.float64) - cu
        ys = np.asarray(v, dtype=np.float64) - cv
        rho = np.hypot(xs, ys)
        theta = self.theta_of_rho(rho)
        if self.projection == "perspective":
            f = self.focal_px
            norm = np.sqrt(xs * xs + ys * ys + f * f)
            rays = np.stack([xs / norm, -ys / norm, f / norm], axis=-1)
        else:
            s = np.sin(theta)
            inv = np.divide(s, rho, out=np.zeros_like(rho), where=rho > 0)
            rays = np.stack([xs * inv, -ys * inv, np.cos(theta)], axis=-1)
        return rays, theta <= self.max_field_angle_rad + 1e-12

    def project(self, dirs: ArrayLike) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
        """Image points (u, v) of camera-frame directions; valid = in the circle and the frame."""
        d = np.asarray(dirs, dtype=np.float64)
        rxy = np.hypot(d[..., 0], d[..., 1])
        theta = np.arctan2(rxy, d[..., 2])
        rho = self.rho_of_theta(np.minimum(theta, self.max_field_angle_rad + 0.5))
        scale = np.divide(rho, rxy, out=np.zeros_like(rho), where=rxy > 0)
        cu, cv = self.principal_point_px
        u = cu + d[..., 0] * scale
        v = cv - d[..., 1] * scale
        valid = (
            (theta <= self.max_field_angle_rad + 1e-12)
            & (u >= -0.5)
            & (u <= self.width_px - 0.5)
            & (v >= -0.5)
            & (v <= self.height_px - 0.5)
        )
        if self.projection == "perspective":
            valid &= theta < math.pi / 2
        return u, v, valid

    def grid(self, kind: StokesGrid = "superpixel") -> tuple[FloatArray, FloatArray]:
        """(u, v) frame coordinates of the Stokes image's pixels (``stokes_from_mosaic``'s grid).

        ``"superpixel"``: output (i, j) is centred at raw (2j + ½, 2i + ½); ``"interpolate"``:
        output (r, c) at raw (c, r).
        """
        if kind == "superpixel":
            h, w = self.height_px // 2, self.width_px // 2
            v, u = np.mgrid[0:h, 0:w].astype(np.float64)
            return 2 * u + 0.5, 2 * v + 0.5
        if kind == "interpolate":
            v, u = np.mgrid[0 : self.height_px, 0 : self.width_px].astype(np.float64)
            return u, v
        raise ValueError(f"grid kind: {kind!r}; allowed: 'superpixel', 'interpolate'")

    def rays(self, kind: StokesGrid = "superpixel") -> tuple[FloatArray, NDArray[np.bool_]]:
        """Cached (H', W', 3) rays and validity of the Stokes image's pixels (camera frame)."""
        key = ("rays", kind)
        if key not in self._cache:
            u, v = self.grid(kind)
            rays, valid = self.pixel_to_ray(u, v)
            rays.setflags(write=False)
            valid.setflags(write=False)
            self._cache[key] = (rays, valid)
        return self._cache[key]

    def sensor_axes(self, kind: StokesGrid = "superpixel") -> tuple[FloatArray, FloatArray]:
        """Cached 3-D axes (r_s, t_s) at each pixel onto which AoP = 0 and AoP = +90° map.

        E-vector of AoP ψ: ``cos ψ · r_s + sin ψ · t_s`` (meridional mapping; for the
        orthographic one use :meth:`evectors`).
        """
        key = ("axes", kind)
        if key not in self._cache:
            p, _ = self.rays(kind)
            x, y, z = p[..., 0], p[..., 1], p[..., 2]
            den = np.maximum(1.0 + z, 1e-12)
            r_s = np.stack([1 - x * x / den, -x * y / den, -x], axis=-1)
            r_y = np.stack([-x * y / den, 1 - y * y / den, -y], axis=-1)
            t_s = -r_y  # +v = −y on the sensor
            self._cache[key] = (r_s, t_s)
        return self._cache[key]

    def evectors(self, aop: ArrayLike, kind: StokesGrid = "superpixel") -> FloatArray:
        """3-D unit E-vectors (camera frame, ⟂ the ray) of an AoP image on the ``kind`` grid."""
        a = np.asarray(aop, dtype=np.float64)
        p, _ = self.rays(kind)
        if self.polarization_mapping == "meridional":
            r_s, t_s = self.sensor_axes(kind)
            return np.cos(a)[..., None] * r_s + np.sin(a)[..., None] * t_s
        # Orthographic: the sensor-plane direction (cos ψ, −sin ψ, 0) lifted ⟂ to the ray.
        e2 = np.stack([np.cos(a), -np.sin(a), np.zeros_like(a)], axis=-1)
        e = e2 - (np.sum(e2 * p, axis=-1) / np.maximum(p[..., 2], 1e-12))[..., None] * np.stack(
            [np.zeros_like(a), np.zeros_like(a), np.ones_like(a)], axis=-1
        )
        return e / np.linalg.norm(e, axis=-1, keepdims=True)

    @property
    def c_c_b(self) -> FloatArray:
        """C_c^b as an array."""
        return np.asarray(self.mount_rotation, dtype=np.float64)


def calibration_to_dict(cal: CameraCalibration) -> dict:
    """Every field of a calibration as plain JSON values (what a log carries; exact floats)."""
    out: dict = {}
    for f in fields(cal):
        if f.name.startswith("_"):
            continue
        v = getattr(cal, f.name)
        out[f.name] = np.asarray(v).tolist() if isinstance(v, tuple | list | np.ndarray) else v
    return out


def calibration_from_dict(d: dict) -> CameraCalibration:
    """The inverse of :func:`calibration_to_dict` (nested lists back to tuples).

    Raises:
        ValueError: An unknown field, or a value the calibration refuses (naming the field).
    """
    names = {f.name for f in fields(CameraCalibration) if not f.name.startswith("_")}
    unknown = sorted(set(d) - names)
    if unknown:
        raise ValueError(
            f"camera calibration: unknown field(s) {unknown}; allowed: {sorted(names)}"
        )

    def tup(v: object) -> object:
        return tuple(tup(x) for x in v) if isinstance(v, list) else v

    kw = {k: tup(v) for k, v in d.items()}
    for k in ("width_px", "height_px", "saturation_dn"):
        if k in kw and isinstance(kw[k], float) and float(kw[k]).is_integer():
            kw[k] = int(kw[k])
    return CameraCalibration(**kw)  # type: ignore[arg-type]
