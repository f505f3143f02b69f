"""Stage 1 of the polarimeter chain: camera geometry (fisheye or pinhole), binning and housing port.

Frames and image axes
---------------------
* **Camera frame** = the MJCF ``polarimeter`` site frame: x right (starboard), y forward, z = the
  optical axis (up when the vehicle is level). A pixel's *ray* is the unit vector, in this frame,
  along which the pixel looks (from the camera out towards the scene); the light it records
  travels along ``-ray``.
* **Image axes**: column ``u`` increases along camera +x, row ``v`` increases along camera −y; pixel
  centres sit at integer ``(u, v)``, pixel ``(0, 0)`` is the top-left one, and arrays are indexed
  ``[v, u]`` (``(H, W)`` = (rows, columns)). A level, upward-looking camera on a vehicle heading
  North therefore sees North at the top and East on the right of the image: the sky drawn as a
  map seen from above, the convention of the MOI paper's hypothetical imager (its eq. 16: body x
  along the columns, body y against the rows, ray ∝ (x, y, f), eq. 18). A physical camera looking
  up delivers the mirror image of this (the sky as seen from below, East on the left); frames from
  real hardware must be mirrored (e.g. flipped left-right) to match, and so must any micro-polarizer
  angles quoted for them.
* **Sensor-plane polarization**: Stokes vectors on the sensor are stated with the
  :mod:`sensors.polarimeter.stokes` convention for light hitting the sensor, i.e. propagation
  ``SENSOR_PROPAGATION`` = −z and reference ``SENSOR_REFERENCE`` = +x (= +u). An E-vector angle ψ
  therefore turns from +x towards d × ref = −y, i.e. from +u towards +v (clockwise on a displayed
  image, whose v axis points down).

Projection models (``FisheyeSpec.projection``)
----------------------------------------------
The radial model maps the angle θ between a ray and the optical axis, θ = atan2(√(x²+y²), z) —
valid up to 180°, unlike OpenCV's fisheye model, which uses θ = atan(r) and folds rays beyond 90°
onto the wrong side (optics.md §3.5) — to a radius ρ on the sensor (full-resolution pixels):

* ``"kannala_brandt"``: ρ = f·(θ + k1θ³ + k2θ⁵ + k3θ⁷ + k4θ⁹) (Kannala & Brandt 2006; k = 0 is the
  equidistant fisheye ρ = fθ).
* ``"scaramuzza"`` (OCamCalib, Scaramuzza et al. 2006): the back-projected ray of sensor point
  (x', y') is ∝ (x', y', g(ρ)) with g(ρ) = a0 + a1ρ + a2ρ² + … in OCamCalib's sign convention
  (a0 < 0, the camera looking along −g), i.e. θ(ρ) = atan2(ρ, −g(ρ)); the image point is
  [u − cu, v − cv] = A·[x', y'] with the affine stretch A = [[c, d], [e, 1]]. Coefficients are in
  full-resolution pixels and in *this module's* (u, v) axes; OCamCalib's own files list (row, col)
  first, so importing one needs the axes swapped (not done here).
* ``"perspective"``: ρ = f·tan θ — the MOI paper's in-air pinhole (eqs. 16–18), θ < 90° only.

Projection (direction → pixel) inverts the monotone radial model by table interpolation and Newton
steps; pixel → ray → pixel round trips to ~1e-12 px, also beyond θ = 90°.

Binning
-------
``binning`` b ∈ {1, 2, 4} models on-sensor binning of a division-of-focal-plane polarization sensor
that keeps the 2×2 micro-polarizer super-pixel meaningful: within every 2b×2b block the b×b pixels
that carry the *same* polarizer orientation are summed, so the binned frame is again a 2×2-mosaic,
of (H/b)×(W/b) pixels with an effective pitch of b·p. (Binning adjacent pixels instead would mix
the four orientations and destroy the polarization measurement.) The geometry treats the binned
frame as a uniform grid: binned pixel k is centred at full-resolution coordinate b·k + (b − 1)/2.
The true centroid of the b×b same-orientation pixels lies ±(b − 1)/2 full-resolution pixels from
that, alternating with the super-pixel phase — neglected (it is below one binned pixel). Both
sensor sizes must therefore be multiples of 2b. Intrinsics (focal length, principal point, OCamCalib
polynomial) are always given for the full-resolution sensor. A binning-2 camera's pixel centres are
also the centres of the full-resolution 2×2 super-pixels.

Housing (``FisheyeSpec.housing``)
---------------------------------
* ``"dome"``: a hemispherical dome concentric with the lens's entrance pupil passes every ray
  unbent (normal incidence on both dome surfaces: an angle-independent, non-polarizing Fresnel
  loss, left to the renderer's throughput factor). The lens sees the whole in-water hemisphere.
* ``"flat"``: a plane-parallel port perpendicular to the optical axis. A ray leaving the lens at θ_a
  in the housing air crosses glass at θ_g and continues in water at θ_w with
  n_a sin θ_a = n_g sin θ_g = n_w sin θ_w (Snell twice; the glass shifts the ray sideways only,
  the direction change is the air↔water one). Lens rays at θ_a ≥ 90° never leave the housing, and
  in-water rays beyond the critical angle asin(n_a/n_w) never reach the lens (optics.md §2.4).
  :func:`flat_port_refraction` / :func:`flat_port_inverse` map the directions, :class:`PortRays`
  carries the per-pixel angles and indices of both interfaces — the boundary to the Fresnel
  transmission Mueller matrices of :mod:`sensors.polarimeter.optics.surface`, which the renderer
  applies
  in each interface's plane of incidence (the plane through the ray and the camera z axis:
  ``stokes.meridian_reference(d, up=(0, 0, 1))`` in the camera frame).

How the lens carries polarization onto the sensor (``FisheyeSpec.polarization_mapping``)
--------------------------------------------------------------------------------------
An E-vector is perpendicular to its ray, not to the optical axis, so a lens must map it
(optics.md §7):

* ``"meridional"`` (default): an ideal rotationally symmetric lens turns each ray onto the optical
  axis by the rotation about ẑ × ray (in the ray's meridional plane); the E-vector turns with it.
  A pure change of reference, linear in (I, Q, U): the sensor +x axis corresponds, at a ray p
  (camera frame), to ``R_p x̂ = (1 − p_x²/(1+p_z), −p_x p_y/(1+p_z), −p_x)`` (Rodrigues' formula
  for the rotation taking ẑ to p), see :attr:`Camera.sensor_reference`.
  :meth:`Camera.sensor_stokes_from_meridian` is the per-frame fast path from ENU-meridian Stokes.
* ``"orthographic"``: the E-vector's component along the optical axis is dropped (the MOI paper's
  hypothetical imager, eqs. 22–23); I and the DoP are kept, the AoP is that of the projected
  E-vector. Not linear in Stokes; the MOI preset uses it so that the paper's simulation is
  reproduced exactly.
Real lenses add incidence-angle dependent diattenuation and retardance; not modelled.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from sensors.polarimeter import stokes as stokes_mod
from sensors.polarimeter.unit.fisheye import FisheyeSpec, _RadialModel
from sensors.polarimeter.unit.port import (
    PortRays,
    _check_index,
    flat_port_inverse,
    flat_port_refraction,
)
from twin.core.arrays import BoolArray, FloatArray

#: Propagation direction (camera frame) of light arriving at the sensor: down the optical axis.
SENSOR_PROPAGATION: FloatArray = np.array([0.0, 0.0, -1.0])
#: Reference axis (camera frame) of sensor-plane Stokes vectors: camera +x = image +u.
SENSOR_REFERENCE: FloatArray = np.array([1.0, 0.0, 0.0])


# --------------------------------------------------------------------------------------------------
# Camera
# --------------------------------------------------------------------------------------------------


class Camera:
    """Per-pixel geometry of one :class:`FisheyeSpec`, computed once and cached.

    The per-pixel arrays are computed on first access (float64 internally, then stored as
    ``dtype``: float32 by default, which keeps rays to ~1e-7 rad; use float64 where a test needs
    1e-6-level angles). Vector arrays are (H, W, 3) views of planar (3, H, W) storage, so each
    component is contiguous (fast for the sky evaluation, see :meth:`rotated_rays`).

    Args:
        spec: The camera specification.
        dtype: Floating dtype of the cached arrays (float32 or float64).
    """

    def __init__(self, spec: FisheyeSpec, *, dtype: DTypeLike = np.float32) -> None:
        self.spec = spec
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise ValueError(f"Camera dtype must be float32 or float64, got {self.dtype}")
        self.width = spec.image_width
        self.height = spec.image_height
        self._radial = _RadialModel(spec)
        c, d, e = spec.ocam_affine
        self._affine = np.array([[c, d], [e, 1.0]])
        self._affine_inv = np.linalg.inv(self._affine)
        self._cu, self._cv = spec.principal_point_full_px
        self._port_cache: dict[tuple[float, float], PortRays] = {}

    # Scalars --------------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) of the frame."""
        return (self.height, self.width)

    @property
    def theta_max(self) -> float:
        """Half field of view (radians)."""
        return self._radial.theta_max

    @property
    def image_circle_radius_px(self) -> float:
        """Radius of the image circle θ = θ_max in (binned) pixels.

        With a non-identity OCamCalib affine stretch this is the sensor-plane radius.
        """
        return self._radial.rho_max / self.spec.binning

    # Pixel <-> ray --------------------------------------------------------------------------------
    def _sensor_plane(self, u: FloatArray, v: FloatArray) -> tuple[FloatArray, FloatArray]:
        b = self.spec.binning
        du = b * np.asarray(u, dtype=np.float64) + (b - 1) / 2.0 - self._cu
        dv = b * np.asarray(v, dtype=np.float64) + (b - 1) / 2.0 - self._cv
        ai = self._affine_inv
        return ai[0, 0] * du + ai[0, 1] * dv, ai[1, 0] * du + ai[1, 1] * dv

    def _rays(self, u: ArrayLike, v: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(planar rays (3, ...), θ, ρ) of image points, float64: the one back-projection path."""
        xs, ys = self._sensor_plane(u, v)
        rho = np.hypot(xs, ys)
        theta = self._radial.theta_of_rho(rho)
        if self.spec.projection == "perspective":
            # Exactly the MOI paper's eq. 18 ray, (x, y, f) normalised, with no trig round trip.
            f = self._radial.f_px
            norm = np.sqrt(xs * xs + ys * ys + f * f)
            return np.stack([xs / norm, -ys / norm, f / norm]), theta, rho
        s = np.sin(theta)
        inv = np.divide(s, rho, out=np.zeros_like(rho), where=rho > 0)
        return np.stack([xs * inv, -ys * inv, np.cos(theta)]), theta, rho

    def pixel_to_ray(self, u: ArrayLike, v: ArrayLike) -> tuple[FloatArray, BoolArray]:
        """Unit rays (camera frame, float64) of image points (u, v) and whether they are valid.

        Valid = inside the image circle θ ≤ θ_max. Beyond it the ray is extrapolated (clamped to
        the radial model's monotone range) — finite, but not seen by the lens.
        """
        planar, theta, _ = self._rays(u, v)
        return np.moveaxis(planar, 0, -1), theta <= self.theta_max + 1e-12

    def project(self, dirs: ArrayLike) -> tuple[FloatArray, FloatArray, BoolArray]:
        """Image points (u, v) (float64, binned pixels) of camera-frame directions (lens side).

        Works for any direction, also θ ≥ 90° off the axis (θ = atan2(√(x²+y²), z)); need not be
        normalised. ``valid``: non-zero direction, θ ≤ θ_max and inside the frame
        (−0.5 ≤ u ≤ W − 0.5, same for v). u and v are finite everywhere.
        """
        d = np.asarray(dirs, dtype=np.float64)
        if d.shape[-1:] != (3,):
            raise ValueError(f"project: dirs must have shape (..., 3), got {d.shape}")
        rxy = np.hypot(d[..., 0], d[..., 1])
        theta = np.arctan2(rxy, d[..., 2])
        nonzero = (rxy > 0) | (d[..., 2] != 0)
        rho = self._radial.rho_of_theta(theta)
        scale = np.divide(rho, rxy, out=np.zeros_like(rho), where=rxy > 0)
        xs = d[..., 0] * scale
        ys = -d[..., 1] * scale
        a = self._affine
        b = self.spec.binning
        u = (self._cu + a[0, 0] * xs + a[0, 1] * ys - (b - 1) / 2.0) / b
        v = (self._cv + a[1, 0] * xs + a[1, 1] * ys - (b - 1) / 2.0) / b
        valid = (
            nonzero
            & np.all(np.isfinite(d), axis=-1)
            & (theta <= self.theta_max + 1e-12)
            & (u >= -0.5)
            & (u <= self.width - 0.5)
            & (v >= -0.5)
            & (v <= self.height - 0.5)
        )
        if self.spec.projection == "perspective":
            valid &= theta < math.pi / 2
        return np.nan_to_num(u), np.nan_to_num(v), valid

    # Cached per-pixel arrays ----------------------------------------------------------------------
    @cached_property
    def _pixel_geometry(self) -> tuple[FloatArray, FloatArray, BoolArray, FloatArray]:
        """(planar rays (3,H,W), θ, valid, solid angle), computed once."""
        v, u = np.mgrid[0 : self.height, 0 : self.width].astype(np.float64)
        planar, theta, rho = self._rays(u, v)
        valid = theta <= self.theta_max + 1e-12
        # dΩ = sinθ dθ dφ and dA' = ρ dρ dφ ⇒ dΩ/dA' = (sinθ/ρ)·dθ/dρ (→ (dθ/dρ)² on the axis);
        # a binned pixel covers b² full-res px², the affine stretch divides by |det A|.
        dtdr = self._radial.dtheta_drho(theta, rho)
        sin_over_rho = np.divide(np.sin(theta), rho, out=dtdr.copy(), where=rho > 0)
        area = self.spec.binning**2 / abs(np.linalg.det(self._affine))
        solid = sin_over_rho * dtdr * area
        return planar.astype(self.dtype), theta.astype(self.dtype), valid, solid.astype(self.dtype)

    @property
    def rays(self) -> FloatArray:
        """(H, W, 3) unit rays of the pixel centres (camera frame, lens side)."""
        return np.moveaxis(self._pixel_geometry[0], 0, -1)

    @property
    def rays_planar(self) -> FloatArray:
        """(3, H, W) the same rays, component-major."""
        return self._pixel_geometry[0]

    @property
    def theta(self) -> FloatArray:
        """(H, W) angle of each pixel's ray off the optical axis (radians)."""
        return self._pixel_geometry[1]

    @property
    def valid(self) -> BoolArray:
        """(H, W) pixels inside the image circle θ ≤ θ_max."""
        return self._pixel_geometry[2]

    @property
    def pixel_solid_angle_sr(self) -> FloatArray:
        """(H, W) solid angle (sr, lens side) subtended by each (binned) pixel."""
        return self._pixel_geometry[3]

    @cached_property
    def _sensor_reference_planar(self) -> FloatArray:
        x, y, z = (c.astype(np.float64) for c in self._pixel_geometry[0])
        return np.stack(_meridional_sensor_reference(x, y, z)).astype(self.dtype)

    @cached_property
    def _sensor_basis_flat(self) -> FloatArray:
        """(6, H·W): the sensor x axis r_s = R_p x̂ and y axis t_s = p × r_s = R_p ŷ at each ray."""
        r_s = self._sensor_reference_planar.astype(np.float64)
        p = self._pixel_geometry[0].astype(np.float64)
        t_s = np.cross(p, r_s, axis=0)
        return np.concatenate([r_s, t_s]).reshape(6, -1).astype(self.dtype)

    @property
    def sensor_basis(self) -> FloatArray:
        """(6, H·W) the sensor axes r_s, t_s of every pixel (:meth:`sensor_basis_at`'s source)."""
        return self._sensor_basis_flat

    @property
    def sensor_reference(self) -> FloatArray:
        """(H, W, 3) per pixel, the 3-D axis ⊥ the ray that the lens maps onto the sensor's +x axis.

        Meridional mapping (module docstring): R_p x̂ with R_p the rotation taking ẑ to the ray p.
        A Stokes vector referenced to this axis, for light travelling along −ray, *is* the
        sensor-plane Stokes vector (reference +x, propagation −z).
        """
        return np.moveaxis(self._sensor_reference_planar, 0, -1)

    def rotated_rays(self, rotation: ArrayLike) -> FloatArray:
        """(H, W, 3) rays expressed in another frame: ``rotation @ ray`` for every pixel.

        ``rotation`` is a 3×3 rotation matrix, e.g. C_cam^n (camera → ENU world) for the world
        directions the pixels look along. One BLAS product on the planar storage (no Python loop);
        the result is again a view of planar storage.
        """
        r = np.asarray(rotation, dtype=np.float64)
        if r.shape != (3, 3) or not np.all(np.isfinite(r)):
            raise ValueError(f"rotation must be a finite 3x3 matrix, got shape {r.shape}")
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-6):
            raise ValueError("rotation must be orthonormal (R @ R.T == I within 1e-6)")
        planar = self._pixel_geometry[0]
        out = (r.astype(self.dtype) @ planar.reshape(3, -1)).reshape(planar.shape)
        return np.moveaxis(out, 0, -1)

    # Housing --------------------------------------------------------------------------------------
    def outside(self, n_outside: float, n_inside: float = 1.0) -> PortRays:
        """Per-pixel rays in the outside medium (index ``n_outside``) through the housing port.

        Dome: the lens rays, unbent. Flat: :func:`flat_port_refraction` of the lens rays. Cached
        per index pair.
        """
        n_out = _check_index("n_outside", n_outside)
        n_in = _check_index("n_inside", n_inside)
        key = (n_out, n_in)
        if key not in self._port_cache:
            ones = np.ones(self.shape, dtype=self.dtype)
            if self.spec.housing == "dome":
                rays = PortRays(self.rays, self.valid, ones, ones, ones, n_in, n_in, n_out, "dome")
            else:
                d, ok, ci, cg, co = flat_port_refraction(
                    self.rays, n_out, self.spec.port_glass_index, n_in
                )
                rays = PortRays(
                    d,
                    ok & self.valid,
                    ci.astype(self.dtype),
                    cg.astype(self.dtype),
                    co.astype(self.dtype),
                    n_in,
                    self.spec.port_glass_index,
                    n_out,
                    "flat",
                )
            self._port_cache[key] = rays
        return self._port_cache[key]

    def project_outside(
        self, dirs: ArrayLike, n_outside: float, n_inside: float = 1.0
    ) -> tuple[FloatArray, FloatArray, BoolArray]:
        """:meth:`project` for directions given in the outside medium (camera frame)."""
        d = np.asarray(dirs, dtype=np.float64)
        if self.spec.housing == "dome":
            return self.project(d)
        lens_side, ok = flat_port_inverse(d, n_outside, n_inside)
        u, v, valid = self.project(lens_side)
        return u, v, valid & ok

    # Polarization onto the sensor -----------------------------------------------------------------
    def to_sensor_stokes(
        self, stokes: ArrayLike, ref: ArrayLike, rays: ArrayLike | None = None
    ) -> FloatArray:
        """Stokes vectors of the light entering the lens → sensor-plane Stokes vectors.

        Args:
            stokes: (..., 3) (I, Q, U) of the light arriving along −ray, relative to ``ref``.
            ref: (..., 3) its reference axes, camera frame, perpendicular to the rays.
            rays: (..., 3) camera-frame rays; default: every pixel's ray (then ``stokes`` is
                (H, W, 3)).

        Returns:
            (..., 3) Stokes relative to ``SENSOR_REFERENCE`` (+x) for propagation
            ``SENSOR_PROPAGATION`` (−z), by the spec's ``polarization_mapping``.
        """
        s = np.asarray(stokes)
        r = np.asarray(ref)
        if rays is None:
            p = self.rays
            meridional = self.spec.polarization_mapping == "meridional"
            sens_ref = self.sensor_reference if meridional else None
        else:
            p = np.asarray(rays)
            sens_ref = None
        if s.shape[-1:] != (3,) or r.shape != s.shape or p.shape != s.shape:
            raise ValueError(
                f"to_sensor_stokes: stokes {s.shape}, ref {r.shape} and rays {p.shape} must all "
                "be the same (..., 3) shape"
            )
        d = -p
        if self.spec.polarization_mapping == "meridional":
            if sens_ref is None:
                sens_ref = np.stack(
                    _meridional_sensor_reference(p[..., 0], p[..., 1], p[..., 2]), axis=-1
                )
            return stokes_mod.rotate_reference(s, d, r, sens_ref)
        # Orthographic (MOI eqs. 22-23): project the E-vector on the sensor plane, keep I and DoP.
        e = stokes_mod.to_evector(s, d, r)
        ex, ey = e[..., 0], e[..., 1]
        # ψ from +x about −z: e_img = cos ψ x̂ + sin ψ (−ŷ) ⇒ cos 2ψ ∝ ex² − ey², sin 2ψ ∝ −2 ex ey.
        n2 = ex * ex + ey * ey
        c2 = np.divide(ex * ex - ey * ey, n2, out=np.zeros_like(n2), where=n2 > 0)
        s2 = np.divide(-2.0 * ex * ey, n2, out=np.zeros_like(n2), where=n2 > 0)
        lin = np.hypot(s[..., 1], s[..., 2])
        return np.stack([s[..., 0], lin * c2, lin * s2], axis=-1)

    def sensor_stokes_from_meridian(
        self, stokes: ArrayLike, rotation: ArrayLike, out: FloatArray | None = None
    ) -> FloatArray:
        """Sensor-plane Stokes for the whole frame from ENU-meridian-referenced Stokes (fast path).

        The common case of the renderer: ``stokes`` (H, W, 3) of the light reaching each pixel
        along −(C · ray), referenced to the ENU local meridian of that direction — what
        :func:`sensors.polarimeter.optics.sky.sky_radiance` returns for ``dirs=camera.rays,
        rotation=C``, and what a flat sea surface or a dome keeps. Same result as
        :meth:`to_sensor_stokes` with that reference, for the meridional mapping, without building
        any reference vectors: with up_c = Cᵀẑ (the world vertical in the camera frame) and the
        cached sensor axes r_s, t_s = p × r_s of each pixel, the meridian reference m satisfies
        m·r_s ∝ up_c·r_s and (m × r_s)·d ∝ up_c·t_s (d = −p), so the reference rotation χ has
        (cos χ, sin χ) ∝ (up_c·r_s, up_c·t_s): two dot products a pixel, no trigonometry.
        At the exact world zenith (up_c ∥ p) the chain's North reference is used.

        Args:
            stokes: (H, W, 3) meridian-referenced Stokes.
            rotation: C_cam^n, camera → ENU (3×3 rotation).
            out: Optional planar (3, H, W) buffer of the camera dtype to fill (reuse per frame).

        Returns:
            (H, W, 3) sensor-plane Stokes (reference ``SENSOR_REFERENCE``), a view of planar
            storage.
        """
        c = np.asarray(rotation, dtype=np.float64)
        if c.shape != (3, 3) or not np.allclose(c @ c.T, np.eye(3), atol=1e-6):
            raise ValueError("rotation must be an orthonormal 3x3 matrix (C_cam^n)")
        s = np.asarray(stokes)
        if s.shape != (*self.shape, 3):
            raise ValueError(f"stokes must have shape {(*self.shape, 3)}, got {s.shape}")
        if self.spec.polarization_mapping != "meridional":
            ref = _meridian_reference_in_camera(self.rays.astype(np.float64), c)
            return self.to_sensor_stokes(s, ref.astype(s.dtype))
        n = self.height * self.width
        flat = s.reshape(n, 3)
        dtype = self.dtype
        res = np.empty((3, n), dtype=dtype) if out is None else out.reshape(3, n)
        if res.shape != (3, n) or res.dtype != dtype:
            raise ValueError(f"out must be a {dtype} array of shape {(3, *self.shape)}")
        _meridian_to_sensor(flat, c, self._sensor_basis_flat, res.T)
        return np.moveaxis(res.reshape(3, *self.shape), 0, -1)

    def sensor_basis_at(self, index: ArrayLike) -> FloatArray:
        """(6, N) the sensor axes r_s, t_s (:meth:`sensor_stokes_from_meridian`) of some pixels.

        ``index`` holds flat pixel indices (row-major, ``v * width + u``). Meridional mapping only.
        """
        return np.take(self._sensor_basis_flat, np.asarray(index), axis=1)


def sensor_basis(rays: ArrayLike, dtype: DTypeLike = np.float32) -> FloatArray:
    """(6, N) the sensor x axis r_s = R_p x̂ and y axis t_s = p × r_s of (N, 3) rays p.

    The meridional mapping (module docstring) at arbitrary rays — e.g. the points of a coarse grid
    between pixel centres — for :func:`meridian_to_sensor_stokes`.
    """
    p = np.asarray(rays, dtype=np.float64).reshape(-1, 3).T
    r_s = np.stack(_meridional_sensor_reference(p[0], p[1], p[2]))
    t_s = np.cross(p, r_s, axis=0)
    return np.concatenate([r_s, t_s]).astype(dtype)


def meridian_to_sensor_stokes(
    stokes: ArrayLike, rotation: ArrayLike, basis: FloatArray, out: FloatArray | None = None
) -> FloatArray:
    """:meth:`Camera.sensor_stokes_from_meridian` for any set of N rays given by their ``basis``.

    Args:
        stokes: (N, 3) ENU-meridian-referenced Stokes of the light along −(C · ray).
        rotation: C_cam^n (3×3 rotation; not re-validated here: the caller's frame attitude).
        basis: (6, N) :func:`sensor_basis` (or :meth:`Camera.sensor_basis_at`) of the rays.
        out: Optional (N, 3) buffer of the basis dtype.

    Returns:
        (N, 3) sensor-plane Stokes (reference ``SENSOR_REFERENCE``), the basis dtype.
    """
    s = np.asarray(stokes)
    n = basis.shape[1]
    if s.shape != (n, 3):
        raise ValueError(f"stokes must have shape {(n, 3)}, got {s.shape}")
    res = np.empty((n, 3), dtype=basis.dtype) if out is None else out
    _meridian_to_sensor(s, np.asarray(rotation, dtype=np.float64), basis, res)
    return res


def _meridian_to_sensor(
    flat: FloatArray, c: NDArray[np.float64], basis: FloatArray, res: FloatArray
) -> None:
    """res[i] = sensor-plane Stokes of meridian Stokes flat[i] (both (N, 3), res may be strided).

    With up_c = Cᵀẑ, (cos χ, sin χ) ∝ (up_c·r_s, up_c·t_s) (see
    :meth:`Camera.sensor_stokes_from_meridian`); North's projections stand in at the exact zenith.
    """
    n = basis.shape[1]
    dtype = basis.dtype
    # Rows: (up·r_s, up·t_s), then the same with North for the zenith fallback.
    proj = np.zeros((4, 6), dtype=dtype)
    proj[0, :3] = proj[1, 3:] = c[2]
    proj[2, :3] = proj[3, 3:] = c[1]
    chunk = min(_CHUNK, max(n, 1))
    buf = np.empty((4, chunk), dtype=dtype)
    for i0 in range(0, n, chunk):
        i1 = min(i0 + chunk, n)
        m = i1 - i0
        cc, ss, c2, s2 = (row[:m] for row in buf)
        cs = np.matmul(proj[:2], basis[:, i0:i1])  # (cos χ, sin χ) · |horizontal part of up|
        cc[...], ss[...] = cs[0], cs[1]
        np.multiply(cc, cc, out=c2)
        np.multiply(ss, ss, out=s2)
        n2 = cs[0]
        np.add(c2, s2, out=n2)
        zen = np.flatnonzero(n2 == 0.0)
        if zen.size:
            north = proj[2:] @ basis[:, i0 + zen]
            cc[zen], ss[zen] = north[0], north[1]
            c2[zen], s2[zen] = north[0] ** 2, north[1] ** 2
            n2[zen] = 1.0
        c2 -= s2
        c2 /= n2  # cos 2χ
        np.multiply(cc, ss, out=s2)
        s2 *= 2.0
        s2 /= n2  # sin 2χ
        q, u = flat[i0:i1, 1], flat[i0:i1, 2]
        o = res[i0:i1]
        o[:, 0] = flat[i0:i1, 0]
        # stokes.rotate_reference: (Q, U) turn by −2χ.
        np.multiply(c2, q, out=cc)
        np.multiply(s2, u, out=ss)
        cc += ss
        o[:, 1] = cc
        np.multiply(c2, u, out=cc)
        np.multiply(s2, q, out=ss)
        cc -= ss
        o[:, 2] = cc


def _meridian_reference_in_camera(rays: FloatArray, c: NDArray[np.float64]) -> FloatArray:
    """ENU local-meridian references (North at the zenith) of camera rays, in the camera frame."""
    w = rays @ c.T
    rho = np.hypot(w[..., 0], w[..., 1])
    zen = rho == 0.0
    inv = 1.0 / np.where(zen, 1.0, rho)
    ref = np.stack([-w[..., 2] * w[..., 0] * inv, -w[..., 2] * w[..., 1] * inv, rho], axis=-1)
    ref[zen] = (0.0, 1.0, 0.0)
    return ref @ c


_CHUNK = 16384


def _meridional_sensor_reference(
    x: FloatArray, y: FloatArray, z: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """R_p x̂ for rays p = (x, y, z): Rodrigues' rotation taking ẑ to p (defined for z > −1)."""
    inv = 1.0 / np.maximum(1.0 + z, 1e-12)
    return 1.0 - x * x * inv, -x * y * inv, -x
