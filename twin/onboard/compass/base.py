"""One interface for every compass method: a raw polarimeter frame in, a solar-vector fix out.

Onboard side of the world/onboard boundary: a method sees the raw mosaic, the camera calibration
(:class:`~twin.core.calibration.CameraCalibration`), the attitude hint from the INS (roll and
pitch, as the LIG paper's C_b^h), and the place and time — never truth.

Frames (``twin.core.frames``): body b = x starboard, y forward, z up; horizontal h = the body frame
turned level (h = C_b^h b with C_b^h = Rx(pitch)·Ry(roll)), so that n = Rz(yaw)·h; navigation
n = ENU. The camera frame c is the ``polarimeter`` site frame (C_c^b = the calibration's mount
rotation, identity for the shipped vehicle). A solar vector points from the camera towards the
sun *in air* (the refraction at the surface is undone by each method that needs it); the heading
it implies is compass degrees clockwise from North (radians inside).

Every method returns a :class:`CompassFix`. Low signal (night, deep water, occluded, too few
usable pixels) gives ``ok=False`` with a ``reason`` — never a NaN handed on.
"""

from __future__ import annotations

import abc
import dataclasses
import datetime as dt
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from twin.core.arrays import Float64Array as FloatArray
from twin.core.calibration import CameraCalibration
from twin.core.ephemeris import sun_direction_enu
from twin.core.extensions import COMPASS_METHODS
from twin.core.fields import Range, check_ranges
from twin.core.frames import euler_to_dcm, wrap_pi


@dataclass(frozen=True, slots=True)
class CompassContext:
    """What accompanies a frame: the vehicle's own knowledge at the frame's time.

    Attributes:
        utc: Time of the exposure (timezone-aware UTC, or naive meaning UTC).
        latitude_deg: Declared (or INS) latitude.
        longitude_deg: Declared (or INS) longitude.
        roll_rad: Attitude hint from the INS (``twin.core.frames`` convention); 0 for a level
            camera.
        pitch_rad: Attitude hint from the INS.
        depth_m: Depth hint (depth gauge), m; 0 in air.
        water_index: Refractive index of the water the camera looks up through (declared
            knowledge); 1.0 means the camera is in air (no refraction to undo).
        sun_enu: Optional ephemeris solar vector (ENU, unit). When None the method computes it
            from utc and the place (:func:`twin.core.ephemeris.sun_direction_enu`).
    """

    utc: dt.datetime
    latitude_deg: float
    longitude_deg: float
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    depth_m: float = 0.0
    water_index: float = 1.338
    sun_enu: FloatArray | None = None

    def __post_init__(self) -> None:
        check_ranges(
            "CompassContext",
            (
                ("latitude_deg", self.latitude_deg, Range(-90.0, 90.0)),
                ("longitude_deg", self.longitude_deg, Range(-180.0, 360.0)),
                ("roll_rad", self.roll_rad, Range(-math.pi, math.pi)),
                ("pitch_rad", self.pitch_rad, Range(-math.pi / 2, math.pi / 2)),
                ("depth_m", self.depth_m, Range(0.0, 12000.0)),
                ("water_index", self.water_index, Range(1.0, 2.0)),
            ),
        )

    @property
    def c_b_h(self) -> FloatArray:
        """C_b^h: body → horizontal (level, heading-free) frame, from the roll/pitch hint."""
        return euler_to_dcm(self.roll_rad, self.pitch_rad, 0.0)


@dataclass(frozen=True)
class CompassFix:
    """What a compass method returns for one frame.

    Attributes:
        method: The method's name.
        ok: A usable solution. When False, every vector is None and ``reason`` says why.
        reason: Why there is no solution ("" when ok).
        sun_body: (3,) unit solar vector in the body frame (towards the sun, in air).
        sun_h: (3,) the same in the horizontal frame (C_b^h · sun_body).
        sun_enu: (3,) the ephemeris solar vector used for the heading.
        heading_rad: Heading implied by the fix through the ephemeris: compass, clockwise from
            North, in [0, 2π). None when the sun is at the zenith (no azimuth).
        roll_rad: Roll measured by the method itself (Snell-window method), else None.
        pitch_rad: Pitch measured by the method itself, else None.
        covariance_body: (3, 3) measurement covariance of ``sun_body`` (rad² on the tangent
            plane), for the Kalman filter's R_s.
        heading_sigma_rad: 1σ of ``heading_rad`` (from the covariance and the sun's elevation).
        pixels_used: Pixels (or super-pixels) that entered the estimate.
        residual: Method-specific fit residual (documented per method).
        eigen_gap: Ratio of the two smallest eigenvalues (λ2/λ1 ≥ 1; larger = better
            conditioned), where the method solves an eigenproblem, else None.
        extras: Method-specific diagnostics (numbers only), e.g. the ambiguity decision.
    """

    method: str
    ok: bool
    reason: str = ""
    sun_body: FloatArray | None = None
    sun_h: FloatArray | None = None
    sun_enu: FloatArray | None = None
    heading_rad: float | None = None
    roll_rad: float | None = None
    pitch_rad: float | None = None
    covariance_body: FloatArray | None = None
    heading_sigma_rad: float | None = None
    pixels_used: int = 0
    residual: float | None = None
    eigen_gap: float | None = None
    extras: dict[str, float] = field(default_factory=dict)

    @property
    def heading_deg(self) -> float | None:
        return None if self.heading_rad is None else math.degrees(self.heading_rad)


def no_fix(method: str, reason: str, pixels_used: int = 0, **extras: float) -> CompassFix:
    """A fix that says "no solution" and why."""
    return CompassFix(
        method=method, ok=False, reason=reason, pixels_used=pixels_used, extras=extras
    )


def heading_from_sun(sun_h: FloatArray, sun_enu: FloatArray) -> float | None:
    """Compass heading (rad, [0, 2π)) that turns the horizontal-frame solar vector onto the ENU one.

    n = Rz(yaw)·h and compass heading = −yaw, so the sun's compass azimuth in n (atan2(E, N)) minus
    its azimuth relative to the bow in h (atan2(x, y)) is the heading. None when either vector has
    no horizontal component (sun at the zenith).
    """
    h = np.asarray(sun_h, dtype=np.float64)
    n = np.asarray(sun_enu, dtype=np.float64)
    if math.hypot(h[0], h[1]) < 1e-9 or math.hypot(n[0], n[1]) < 1e-9:
        return None
    az_n = math.atan2(n[0], n[1])
    az_h = math.atan2(h[0], h[1])
    return wrap_pi(az_n - az_h) % (2 * math.pi)


def heading_sigma(cov_body: FloatArray, sun_h: FloatArray, c_b_h: FloatArray) -> float:
    """1σ heading uncertainty from the solar-vector covariance (small-angle, first order).

    The heading is the azimuth of sun_h; its sensitivity to a perturbation of sun_h is the
    horizontal tangent direction divided by the horizontal norm.
    """
    h = np.asarray(sun_h, dtype=np.float64)
    rho = math.hypot(h[0], h[1])
    if rho < 1e-9:
        return math.pi
    g = np.array([h[1], -h[0], 0.0]) / (rho * rho)  # d az / d sun_h
    cov_h = c_b_h @ np.asarray(cov_body) @ c_b_h.T
    return float(math.sqrt(max(float(g @ cov_h @ g), 0.0)))


def finish_fix(
    method: str,
    sun_body: FloatArray,
    ctx: CompassContext,
    sun_enu: FloatArray,
    covariance_body: FloatArray,
    *,
    pixels_used: int,
    residual: float | None = None,
    eigen_gap: float | None = None,
    roll_rad: float | None = None,
    pitch_rad: float | None = None,
    c_b_h: FloatArray | None = None,
    **extras: float,
) -> CompassFix:
    """Assemble an ``ok`` fix from a body-frame solar vector (normalised here; NaN ⇒ no fix).

    ``c_b_h`` overrides the context's roll/pitch hint (a method that measures its own roll and
    pitch levels the vector with those).
    """
    s = np.asarray(sun_body, dtype=np.float64).reshape(3)
    norm = float(np.linalg.norm(s))
    if not (math.isfinite(norm) and norm > 0):
        return no_fix(method, "solar vector is not finite", pixels_used)
    s = s / norm
    cbh = ctx.c_b_h if c_b_h is None else c_b_h
    sun_h = cbh @ s
    heading = heading_from_sun(sun_h, sun_enu)
    cov = np.asarray(covariance_body, dtype=np.float64)
    return CompassFix(
        method=method,
        ok=True,
        sun_body=s,
        sun_h=sun_h,
        sun_enu=np.asarray(sun_enu, dtype=np.float64),
        heading_rad=heading,
        roll_rad=roll_rad,
        pitch_rad=pitch_rad,
        covariance_body=cov,
        heading_sigma_rad=heading_sigma(cov, sun_h, cbh),
        pixels_used=int(pixels_used),
        residual=residual,
        eigen_gap=eigen_gap,
        extras={k: float(v) for k, v in extras.items()},
    )


#: Apparent solar elevation below which it is night (the upper limb below the horizon).
NIGHT_ELEVATION_RAD = math.radians(-0.833)


def check_frame(
    raw: object, calibration: object, ctx: object, method: str
) -> tuple[NDArray[np.generic], CameraCalibration, CompassContext]:
    """Validate a frame's inputs; a ValueError names the argument, its value and what is allowed."""
    if not isinstance(calibration, CameraCalibration):
        raise ValueError(
            f"{method}: calibration: {type(calibration).__name__}; allowed: "
            "twin.core.calibration.CameraCalibration"
        )
    if not isinstance(ctx, CompassContext):
        raise ValueError(f"{method}: ctx: {type(ctx).__name__}; allowed: a CompassContext")
    if not isinstance(raw, np.ndarray):
        raise ValueError(f"{method}: raw: {type(raw).__name__}; allowed: a 2-D numpy array")
    want = (calibration.height_px, calibration.width_px)
    if raw.shape != want:
        raise ValueError(
            f"{method}: raw.shape: {raw.shape}; allowed: {want} = (calibration.height_px, "
            "calibration.width_px)"
        )
    if raw.dtype.kind not in "uif":
        raise ValueError(f"{method}: raw.dtype: {raw.dtype}; allowed: an integer or float mosaic")
    if raw.dtype.kind == "f" and not np.isfinite(raw).all():
        raise ValueError(f"{method}: raw holds NaN or infinite values; allowed: finite values")
    return raw, calibration, ctx


@dataclass(frozen=True, slots=True)
class Frame:
    """A checked frame and what every method starts with (the shared prologue's output).

    Attributes:
        raw: The raw mosaic, validated against the calibration.
        calibration: The camera calibration.
        ctx: The vehicle's knowledge at the frame's time.
        sun_enu: The ephemeris solar vector (ENU, unit): the context's, else NREL SPA.
        sun_elevation_rad: Its elevation.
    """

    raw: NDArray[np.generic]
    calibration: CameraCalibration
    ctx: CompassContext
    sun_enu: FloatArray
    sun_elevation_rad: float


class CompassMethod(abc.ABC):
    """Base of every compass method: one constructor contract, one frame prologue.

    A method is ``Method(config=None, **overrides)``: its frozen config dataclass
    (:attr:`config_type`, validated in its ``__post_init__``), with any field overridden by
    keyword; an unknown field is a ValueError naming it. :meth:`solve` runs the shared prologue
    (:func:`check_frame`, the ephemeris sun, "no solution: night" when the sun has set) and hands
    the :class:`Frame` to :meth:`solve_frame`, the method's own algorithm.
    """

    name: ClassVar[str] = ""
    config_type: ClassVar[type] = object

    def __init__(self, config: Any = None, **overrides: Any) -> None:
        ct = self.config_type
        base = config if config is not None else ct()
        if not isinstance(base, ct):
            raise ValueError(
                f"{self.name}: config: {type(base).__name__}; allowed: {ct.__name__} or None"
            )
        if overrides:
            fields = {f.name for f in dataclasses.fields(base)}
            unknown = sorted(set(overrides) - fields)
            if unknown:
                raise ValueError(
                    f"{self.name}: {ct.__name__} has no field(s) {unknown}; allowed: "
                    f"{', '.join(sorted(fields))}"
                )
            base = dataclasses.replace(base, **overrides)
        self.config = base

    def solve(
        self, raw: NDArray[np.generic], calibration: CameraCalibration, ctx: CompassContext
    ) -> CompassFix:
        """A raw frame → a :class:`CompassFix` (or "no solution" and why)."""
        frame = self.begin_frame(raw, calibration, ctx)
        if isinstance(frame, CompassFix):
            return frame
        return self.solve_frame(frame)

    def begin_frame(self, raw: object, calibration: object, ctx: object) -> Frame | CompassFix:
        """The shared prologue: checked inputs and the ephemeris sun, or a night "no fix"."""
        raw_c, cal, c = check_frame(raw, calibration, ctx, self.name)
        if c.sun_enu is not None:
            s = np.asarray(c.sun_enu, dtype=np.float64).reshape(3)
            sun_enu = s / np.linalg.norm(s)
        else:
            sun_enu = sun_direction_enu(c.utc, c.latitude_deg, c.longitude_deg)
        el = math.asin(max(-1.0, min(1.0, float(sun_enu[2]))))
        if el < NIGHT_ELEVATION_RAD:
            return no_fix(
                self.name, f"night: the sun is below the horizon ({math.degrees(el):.1f}°)"
            )
        return Frame(raw_c, cal, c, sun_enu, el)

    @abc.abstractmethod
    def solve_frame(self, frame: Frame) -> CompassFix:
        """The method's own algorithm on a checked frame with the sun above the horizon."""


def _check_method(name: str, obj: object) -> None:
    """What the registry takes: a CompassMethod subclass whose ``name`` is its entry's name."""
    if not (isinstance(obj, type) and issubclass(obj, CompassMethod)):
        raise ValueError(f"compass method {name!r}: {obj!r} is not a CompassMethod subclass")
    if not obj.name:
        obj.name = name  # a plug-in's class may leave its name to its entry point
    elif obj.name != name:
        raise ValueError(
            f"compass method {name!r}: its class {obj.__name__} is named {obj.name!r}; the "
            "entry's name and the class's name must agree"
        )


def register(cls: type) -> type:
    """Class decorator: add a compass method at run time (a notebook's or a test's own).

    The project's methods and installed plug-ins are declared in
    :data:`twin.core.extensions.COMPASS_METHODS` instead (one declaration each).
    """
    if not (isinstance(cls, type) and issubclass(cls, CompassMethod)):
        raise TypeError(f"{cls!r} must subclass CompassMethod")
    name = getattr(cls, "name", None)
    if not isinstance(name, str) or not name:
        raise TypeError(f"{cls!r} needs a class attribute 'name'")
    COMPASS_METHODS.add(name, cls)
    return cls


def available() -> dict[str, type]:
    """Every compass method by name (imports each one's module)."""
    return {n: COMPASS_METHODS.load(n, _check_method) for n in COMPASS_METHODS.names()}


def create(name: str, **kwargs: object) -> CompassMethod:
    """A configured method by name; a clear error listing the allowed names.

    ``kwargs`` are the method's config fields (``Method(**overrides)``): the scenario's
    ``[navigation.methods.<name>]`` table.
    """
    return COMPASS_METHODS.load(name, _check_method)(**kwargs)
