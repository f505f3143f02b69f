"""The sea surface's transmission of a whole frame: the renderer's per-frame path.

:func:`surface_transmission` → :class:`SurfaceTransmission` takes the camera's rays in their own
frame F with ``rotation`` = C_F^n, as :mod:`sensors.polarimeter.optics.sky` does, works over
cache-sized blocks, and keeps Stokes in the chain's meridian reference, which for a flat sea *is*
the Fresnel p-axis: a frame costs three multiplies a pixel after the per-ray factors. The
general, any-direction functions it builds on: :mod:`sensors.polarimeter.optics.surface`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sensors.polarimeter.optics.blocks import (
    CHUNK,
    as_rotation,
    flatten_directions,
    world_components,
)
from sensors.polarimeter.optics.surface import (
    N_AIR,
    TransmittedStokes,
    _check_index,
    fresnel_elements,
    sky_directions_from_water,
    transmit_stokes,
)
from twin.core.arrays import BoolArray, FloatArray


@dataclass(frozen=True, slots=True)
class SurfaceTransmission:
    """Per-ray air → water Fresnel factors and geometry for one frame's camera rays.

    Built once per frame by :func:`surface_transmission` (the rays move with the vehicle, the
    facets with the waves); :meth:`apply` carries any number of sky Stokes fields through.
    Stokes on both sides use the chain's *meridian* convention (as :mod:`sky` returns them):
    relative to ``stokes.meridian_reference(d)`` of the light's travel direction d in ENU — for the
    sky light d = −sky_dir, for the light reaching the camera d = −look_dir. For a flat sea both
    meridians are the p-axes of the plane of incidence (up to sign, which Stokes ignore), so the
    transmission is three products a pixel; for waves the Stokes are rotated into and out of each
    facet's plane of incidence.

    Attributes:
        storage: (5, ...) planes (m00, m01, m22, cos_water, cos_air), exposed as properties;
            pass the object back as ``out=`` to :func:`surface_transmission` to reuse it next
            frame (no allocation, no page faults on full frames).
        n: The water index.
        look_dirs: The (..., 3) look directions it was built for (frame F).
        rotation: C_F^n (None: ENU).
        normals: (..., 3) ENU facet normals for waves, None for a flat sea.
        rot_in: (2, ...) cos 2χ, sin 2χ of the rotation sky meridian → p-axis (waves only).
        rot_out: (2, ...) cos 2χ, sin 2χ of the rotation p-axis → in-water meridian (waves only).
    """

    storage: FloatArray
    n: float
    look_dirs: FloatArray
    rotation: NDArray[np.float64] | None
    normals: FloatArray | None
    rot_in: FloatArray | None
    rot_out: FloatArray | None

    @property
    def m00(self) -> FloatArray:
        """(...) K(t_p² + t_s²)/2, radiance factor (n² law), p basis; 0 outside the window."""
        return self.storage[0]

    @property
    def m01(self) -> FloatArray:
        """(...) K(t_p² − t_s²)/2 (p-axis reference: transmission favours p)."""
        return self.storage[1]

    @property
    def m22(self) -> FloatArray:
        """(...) K t_p t_s."""
        return self.storage[2]

    @property
    def cos_water(self) -> FloatArray:
        """(...) cosine of each ray's in-water zenith angle (v_z in ENU)."""
        return self.storage[3]

    @property
    def cos_air(self) -> FloatArray:
        """(...) cosine of the in-air angle of incidence on the facet (0 outside the window)."""
        return self.storage[4]

    @property
    def sees_sky(self) -> BoolArray:
        """(...) True inside Snell's window (the ray reaches the sky)."""
        return self.storage[4] > 0.0

    def apply(self, sky_stokes: ArrayLike, out: FloatArray | None = None) -> FloatArray:
        """Transmit sky Stokes (meridian reference) into the water (meridian reference).

        Args:
            sky_stokes: (..., 3) sky (I, Q, U) seen along :meth:`sky_directions`, relative to
                ``stokes.meridian_reference(-sky_dir)`` (what :func:`sky.sky_radiance` returns).
            out: Optional planar (3, ...) buffer to write into (reuse it across frames).

        Returns:
            (..., 3) in-water Stokes (a view of planar (3, ...) storage) relative to
            ``stokes.meridian_reference(-look_dir)``; zero outside Snell's window.
        """
        s = np.asarray(sky_stokes)
        dt = self.storage.dtype
        shape = self.storage.shape[1:]
        if s.shape != (*shape, 3):
            raise ValueError(f"sky_stokes must have shape {(*shape, 3)}, got {s.shape}")
        if out is None:
            out = np.empty((3, *shape), dtype=dt)
        elif out.shape != (3, *shape) or out.dtype != dt:
            raise ValueError(f"out must be a {dt} array of shape {(3, *shape)}, got {out.shape}")
        total = int(np.prod(shape, dtype=np.int64))
        src = s.reshape(total, 3)
        res = self.storage.reshape(5, total)
        dst = out.reshape(3, total)
        rin = None if self.rot_in is None else self.rot_in.reshape(2, total)
        rout = None if self.rot_out is None else self.rot_out.reshape(2, total)
        chunk = min(CHUNK, max(total, 1))
        buf = np.empty((4, chunk), dtype=dt)
        for i0 in range(0, total, chunk):
            i1 = min(i0 + chunk, total)
            m = i1 - i0
            q, u, t, t2 = (row[:m] for row in buf)
            i = src[i0:i1, 0]
            q[...] = src[i0:i1, 1]
            u[...] = src[i0:i1, 2]
            if rin is not None:  # sky meridian → facet p-axis
                _rotate_qu(q, u, rin[0, i0:i1], rin[1, i0:i1], t, t2)
            m00, m01, m22 = res[0, i0:i1], res[1, i0:i1], res[2, i0:i1]
            o = dst[:, i0:i1]
            np.multiply(m00, i, out=o[0])
            np.multiply(m01, q, out=t)
            o[0] += t
            np.multiply(m01, i, out=o[1])
            np.multiply(m00, q, out=t)
            o[1] += t
            np.multiply(m22, u, out=o[2])
            if rout is not None:  # facet p-axis → in-water meridian
                _rotate_qu(o[1], o[2], rout[0, i0:i1], rout[1, i0:i1], t, t2)
        return np.moveaxis(out, 0, -1)

    def sky_directions(self) -> FloatArray:
        """(..., 3) the sky look direction each ray sees, in the rays' frame F.

        Pass them to :func:`sky.sky_radiance` with the same ``rotation``. Rays outside the window
        get the direction :func:`sky_directions_from_water` gives them (TIR mirror / unchanged);
        their transmission factors are zero, so what the sky model returns there is irrelevant.
        """
        r = self.rotation
        w = np.asarray(self.look_dirs)
        if self.normals is None:
            return self._flat_sky_directions(w)
        if r is not None:
            w = w @ r.T.astype(w.dtype)  # to ENU
        res = sky_directions_from_water(w, self.n, self.normals)
        d = res.directions
        if r is not None:
            d = d @ r.astype(d.dtype)  # back to F: C^T d
        return d.astype(self.storage.dtype, copy=False)

    def _flat_sky_directions(self, w: FloatArray) -> FloatArray:
        """Flat sea, in frame F directly, from the stored cosines (no world-frame ray array).

        :func:`_flat_water_to_air` in ENU is d = α w + β ẑ with α = n, β = c_a − n w_z inside the
        window, α = 1, β = −2 w_z for the TIR mirror (w_z > 0), α = 1, β = 0 below the horizon;
        in F (d_F = Cᵀ d) that is α w_F + β Cᵀẑ, with w_z and c_a the stored cos_water and
        cos_air: two per-ray scalars and three multiply-adds, over cache-sized blocks.
        """
        flat, shape = flatten_directions(w)
        dt = self.storage.dtype
        total = flat.shape[0]
        up_f = np.array([0.0, 0.0, 1.0]) if self.rotation is None else self.rotation[2]
        up_f = up_f.astype(dt)
        cos_w = self.storage[3].reshape(total)
        cos_a = self.storage[4].reshape(total)
        out = np.empty((3, total), dtype=dt)
        chunk = min(CHUNK, max(total, 1))
        buf = np.empty((3, chunk), dtype=dt)
        n = np.asarray(self.n, dtype=dt)
        for i0 in range(0, total, chunk):
            i1 = min(i0 + chunk, total)
            m = i1 - i0
            alpha, beta, tmp = (row[:m] for row in buf)
            wz, ca = cos_w[i0:i1], cos_a[i0:i1]
            ok = ca > 0.0
            np.multiply(wz, -2.0, out=beta)  # TIR mirror
            np.minimum(beta, 0.0, out=beta)  # 0 below the horizon (w_z ≤ 0)
            np.multiply(wz, -n, out=tmp)
            tmp += ca  # c_a − n w_z
            np.copyto(beta, tmp, where=ok)
            alpha.fill(1.0)
            alpha[ok] = n
            for k in range(3):
                o = out[k, i0:i1]
                np.multiply(flat[i0:i1, k], alpha, out=o)
                np.multiply(beta, up_f[k], out=tmp)
                o += tmp
        return np.moveaxis(out.reshape(3, *shape), 0, -1)

    def apply_with_reference(self, sky_stokes: ArrayLike, sky_ref: ArrayLike) -> TransmittedStokes:
        """Transmit sky Stokes given relative to arbitrary references (general, slower path).

        Args:
            sky_stokes: (..., 3) sky Stokes at :meth:`sky_directions`.
            sky_ref: (..., 3) their reference axes, ENU, ⟂ the light's travel direction.

        Returns:
            :class:`TransmittedStokes` relative to the transmitted rays' p-axes (ENU).
        """
        w = np.asarray(self.look_dirs)
        if self.rotation is not None:
            w = w @ self.rotation.T.astype(w.dtype)
        a = sky_directions_from_water(w, self.n, self.normals).directions
        nrm = np.array([0.0, 0.0, 1.0]) if self.normals is None else self.normals
        t = transmit_stokes(sky_stokes, sky_ref, -a, nrm, N_AIR, self.n)
        return TransmittedStokes(t.stokes * self.sees_sky[..., None], -w, t.ref, self.sees_sky)


def _rotate_qu(
    q: FloatArray, u: FloatArray, c2: FloatArray, s2: FloatArray, t: FloatArray, t2: FloatArray
) -> None:
    """In place (Q, U) ← (c2 Q + s2 U, −s2 Q + c2 U), as :func:`stokes.rotate_reference`."""
    np.multiply(s2, q, out=t)  # s2 Q
    np.multiply(s2, u, out=t2)  # s2 U
    q *= c2
    q += t2
    u *= c2
    u -= t


def _meridian_to_p(s_ax: FloatArray, d: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(cos 2χ, sin 2χ) of the rotation from the ENU meridian reference of d to p = s × d.

    With m = (ẑ − (ẑ·d) d)/ρ and p = s × d (s ⟂ d): cos χ = m·p = p_z/ρ and
    sin χ = (m × p)·d = −m·s = −s_z/ρ, and p_z² + s_z² = |s|² ρ², so an unnormalised s will do:
    cos 2χ = (p_z² − s_z²)/(p_z² + s_z²), sin 2χ = −2 p_z s_z/(p_z² + s_z²). Where that vanishes
    (normal incidence, or d vertical) the rotation is taken as the identity; there the Fresnel
    block is isotropic, or the meridian itself is a convention.
    """
    p_z = s_ax[..., 0] * d[..., 1] - s_ax[..., 1] * d[..., 0]
    s_z = s_ax[..., 2]
    a2, b2 = p_z * p_z, s_z * s_z
    norm = a2 + b2
    ok = norm > 1e-20
    inv = 1.0 / np.where(ok, norm, 1.0)
    return np.where(ok, (a2 - b2) * inv, 1.0), np.where(ok, -2.0 * p_z * s_z * inv, 0.0)


def _flat_fresnel_block(z: FloatArray, n: float, out: FloatArray, buf: FloatArray) -> None:
    """Fill out[0..4] = (m00, m01, m22, cos_water, cos_air) for one block of ENU v_z (flat sea).

    With μ = max(v_z, 0) (in water) and c_a = √max(1 − n²(1 − μ²), 0) (in air; 0 beyond the
    critical angle), the radiance-factor elements are n² × the flux forms of
    :func:`fresnel_elements` with n_i = 1, n_t = n, cos θ_i = c_a, cos θ_t = μ. Their numerator
    4 n c_a μ vanishes outside the window and below the horizon, so no mask is needed.
    """
    m = z.shape[0]
    m00, m01, m22, cos_w, ca = (row[:m] for row in out)
    mu, num, a_s, a_p, tmp = (row[:m] for row in buf)
    cos_w[...] = z
    np.maximum(z, 0.0, out=mu)
    np.multiply(mu, mu, out=ca)
    ca *= n * n
    ca += 1.0 - n * n
    np.maximum(ca, 0.0, out=ca)
    np.sqrt(ca, out=ca)
    np.multiply(ca, mu, out=num)
    num *= 4.0 * n
    np.multiply(mu, n, out=a_s)
    a_s += ca  # c_a + n μ
    np.multiply(ca, n, out=a_p)
    a_p += mu  # n c_a + μ
    g = n * n  # the n² radiance law
    np.multiply(a_s, a_p, out=tmp)
    tmp += 1e-30
    np.divide(num, tmp, out=m22)
    m22 *= g  # n² K t_p t_s
    np.multiply(a_s, a_s, out=tmp)
    tmp += 1e-30
    np.divide(num, tmp, out=a_s)  # a_s now T_s
    np.multiply(a_p, a_p, out=tmp)
    tmp += 1e-30
    np.divide(num, tmp, out=a_p)  # a_p now T_p
    np.add(a_p, a_s, out=m00)
    m00 *= 0.5 * g
    np.subtract(a_p, a_s, out=m01)
    m01 *= 0.5 * g


def surface_transmission(
    look_dirs: ArrayLike,
    n: float,
    *,
    rotation: ArrayLike | None = None,
    normals: ArrayLike | None = None,
    out: SurfaceTransmission | None = None,
) -> SurfaceTransmission:
    """Per-ray refraction and Fresnel radiance factors through the sea surface, for one frame.

    Args:
        look_dirs: (..., 3) unit in-water camera look directions in frame F (e.g. the camera's
            rays, ideally a view of planar (3, ...) storage), or ENU when ``rotation`` is None.
        n: Water index relative to air.
        rotation: C_F^n, the 3×3 rotation from F to ENU (the camera attitude).
        normals: (..., 3) ENU facet normals pointing up (waves, e.g.
            :meth:`waves.WaveSurface.normals_for_rays`), or None for a flat sea.
        out: Last frame's result, whose storage is overwritten (flat sea only).

    Returns:
        :class:`SurfaceTransmission`.
    """
    n = _check_index("n", n)
    if n <= 1.0:
        raise ValueError(f"n must be > 1 for water, got {n!r}")
    r = as_rotation(rotation)
    flat, shape = flatten_directions(look_dirs)
    dt = flat.dtype
    if normals is not None:
        return _wavy_transmission(np.asarray(look_dirs), flat, shape, n, r, normals)
    total = flat.shape[0]
    if out is not None and out.storage.shape == (5, *shape) and out.storage.dtype == dt:
        storage = out.storage
    else:
        storage = np.empty((5, *shape), dtype=dt)
    res = storage.reshape(5, total)
    chunk = min(CHUNK, max(total, 1))
    buf = np.empty((5, chunk), dtype=dt)
    wbuf = np.empty((3, chunk), dtype=dt)
    for i0 in range(0, total, chunk):
        i1 = min(i0 + chunk, total)
        _, _, z = world_components(flat[i0:i1], r, wbuf)
        _flat_fresnel_block(z, n, res[:, i0:i1], buf)
    return SurfaceTransmission(storage, n, np.asarray(look_dirs), r, None, None, None)


def _wavy_transmission(
    look_dirs: FloatArray,
    flat: FloatArray,
    shape: tuple[int, ...],
    n: float,
    r: NDArray[np.float64] | None,
    normals: ArrayLike,
) -> SurfaceTransmission:
    """General path: per-ray facet normals (vector Snell, facet planes of incidence)."""
    dt = flat.dtype
    w = flat if r is None else flat @ r.T.astype(dt)  # ENU
    nrm = np.asarray(normals, dtype=dt).reshape(-1, 3)
    res = sky_directions_from_water(w, n, nrm)
    e = fresnel_elements(res.cos_t, N_AIR, n, "radiance")
    ok = res.transmitted
    d_i = -res.directions
    d_t = -w
    # The facet's s-axis (⟂ the plane of incidence), unnormalised; p = s × d on both sides.
    s_ax = np.cross(nrm, d_i)
    c2i, s2i = _meridian_to_p(s_ax, d_i)
    c2o, s2o = _meridian_to_p(s_ax, d_t)
    s2o = -s2o  # the way out: p-axis → meridian
    zero = np.zeros((), dtype=dt)

    def plane(x: FloatArray) -> FloatArray:
        return np.where(ok, x, zero).astype(dt).reshape(shape)

    storage = np.stack(
        [plane(e.m00), plane(e.m01), plane(e.m22), w[:, 2].reshape(shape), plane(res.cos_t)]
    )
    return SurfaceTransmission(
        storage,
        n,
        look_dirs,
        r,
        nrm.reshape((*shape, 3)),
        np.stack([c2i, s2i]).astype(dt).reshape((2, *shape)),
        np.stack([c2o, s2o]).astype(dt).reshape((2, *shape)),
    )
