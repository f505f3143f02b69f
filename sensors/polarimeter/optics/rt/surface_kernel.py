"""The sea surface as a photon of the radiative-transfer reference meets it (numba).

Fresnel reflection and transmission with their retardance, from below and through a tilted
Cox–Munk facet, and the Stokes bases they need (a direction's meridian reference, the s and p
axes of a plane of incidence, the rotation of (Q, U) between bases). The transport itself is
:func:`sensors.polarimeter.optics.rt.kernel.transport`; conventions as there.
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.kernel_cache import njit


@njit(cache=True, inline="always")
def meridian(dx, dy, dz):
    """The meridian reference of light travelling along d.

    The unit vector ⟂ d in the vertical plane, towards +z; North at the poles (as
    :func:`sensors.polarimeter.stokes.meridian_reference`).
    """
    h = 1.0 - dz * dz
    if h > 1e-12:
        inv = 1.0 / math.sqrt(h)
        return -dz * dx * inv, -dz * dy * inv, h * inv
    return 0.0, 1.0, 0.0


@njit(cache=True, inline="always")
def rotate(q: float, u: float, chi: float) -> tuple[float, float]:
    """(Q, U) re-expressed relative to a reference turned by χ about d."""
    c2 = math.cos(2.0 * chi)
    s2 = math.sin(2.0 * chi)
    return c2 * q + s2 * u, -s2 * q + c2 * u


@njit(cache=True, inline="always")
def fresnel_from_below(cos_i, n_water, si, sq, su, sv):
    """The Stokes vector (p-axis reference) reflected from below at incidence cosine ``cos_i``.

    Born & Wolf amplitudes; beyond the critical angle cos θ_t is imaginary and the reflection
    total, with its retardance (U' = Re(r_p r_s*) U − Im(r_p r_s*) V, V' = Im U + Re V).
    """
    sin_t2 = n_water * n_water * (1.0 - cos_i * cos_i)
    if sin_t2 < 1.0:
        cos_t = complex(math.sqrt(1.0 - sin_t2), 0.0)
    else:
        cos_t = complex(0.0, math.sqrt(sin_t2 - 1.0))
    rs = (n_water * cos_i - cos_t) / (n_water * cos_i + cos_t)
    rp = (cos_i - n_water * cos_t) / (cos_i + n_water * cos_t)
    r_s = abs(rs) ** 2
    r_p = abs(rp) ** 2
    zc = rp * rs.conjugate()
    ni = 0.5 * (r_p + r_s) * si + 0.5 * (r_p - r_s) * sq
    nq = 0.5 * (r_p - r_s) * si + 0.5 * (r_p + r_s) * sq
    nu = zc.real * su - zc.imag * sv
    nv = zc.imag * su + zc.real * sv
    return ni, nq, nu, nv


@njit(cache=True)
def reflect_from_below(dx, dy, dz, rx, ry, rz, si, sq, su, sv, n_water):
    """Fresnel reflection at the flat surface of light coming up (d_z > 0).

    Returns the reflected Stokes (I, Q, U, V), its new d_z and reference (the p-axis s × d' of the
    plane of incidence, s ∝ ẑ × d), and the escaped flux. Born & Wolf amplitudes; beyond the
    critical angle cos θ_t is imaginary and the reflection total, with its retardance
    (U' = Re(r_p r_s*) U − Im(r_p r_s*) V, V' = Im U + Re V).
    """
    h = math.sqrt(max(dx * dx + dy * dy, 0.0))
    if h < 1e-12:
        sx, sy = 0.0, 1.0
    else:
        sx, sy = -dy / h, dx / h
    # Stokes into the (p, s) basis of the plane of incidence (p = s × d).
    sq, su = to_p_basis(dx, dy, dz, rx, ry, rz, sq, su, sx, sy, 0.0)
    cos_i = dz
    ni, nq, nu, nv = fresnel_from_below(cos_i, n_water, si, sq, su, sv)
    ndz = -dz
    return ni, nq, nu, nv, ndz, sy * ndz, -sx * ndz, sx * dy - sy * dx, si - ni


@njit(cache=True)
def facet(dx, dy, dz, sigma):
    """A facet of the Cox–Munk sea that light travelling along d meets (upward unit normal).

    Slopes (z_x, z_y) are isotropic Gaussian, σ per component; the facet met is drawn with the
    probability of its area projected on the light's path, p(z) (d·n)/(n_z d_z) =
    p(z) (1 − (d_x z_x + d_y z_y)/d_z), by rejection (the weight is bounded by 1 + 4σ|d_h|/|d_z|:
    the rare steeper facets are kept at that bound). Facets facing away are never met;
    shadowing by other waves is not modelled (Cox–Munk Monte Carlo's usual approximation).
    """
    tz = max(abs(dz), 1e-3)
    bound = 1.0 + 4.0 * sigma * math.sqrt(max(1.0 - dz * dz, 0.0)) / tz
    zx = 0.0
    zy = 0.0
    for _ in range(100_000):
        zx = sigma * np.random.standard_normal()
        zy = sigma * np.random.standard_normal()
        w = 1.0 - (dx * zx + dy * zy) / dz
        if w > 0.0 and np.random.random() * bound < w:
            break
    nn = 1.0 / math.sqrt(1.0 + zx * zx + zy * zy)
    return -zx * nn, -zy * nn, nn


@njit(cache=True, inline="always")
def s_axis(dx, dy, dz, nx, ny, nz):
    """The s-axis n × d / |n × d| of the plane of incidence (any ⟂ axis at normal incidence)."""
    sx = ny * dz - nz * dy
    sy = nz * dx - nx * dz
    sz = nx * dy - ny * dx
    h = math.sqrt(sx * sx + sy * sy + sz * sz)
    if h < 1e-12:
        # Normal incidence: every plane is one of incidence; take one ⟂ d.
        if abs(dx) < 0.9:
            sx, sy, sz = 0.0, -dz, dy
        else:
            sx, sy, sz = dz, 0.0, -dx
        h = math.sqrt(sx * sx + sy * sy + sz * sz)
    return sx / h, sy / h, sz / h


@njit(cache=True, inline="always")
def to_p_basis(dx, dy, dz, rx, ry, rz, sq, su, sx, sy, sz):
    """(Q, U) re-expressed relative to the p-axis s × d of the plane of incidence."""
    px = sy * dz - sz * dy
    py = sz * dx - sx * dz
    pz = sx * dy - sy * dx
    cx = ry * pz - rz * py
    cy = rz * px - rx * pz
    cz = rx * py - ry * px
    chi = math.atan2(cx * dx + cy * dy + cz * dz, rx * px + ry * py + rz * pz)
    return rotate(sq, su, chi)


@njit(cache=True, inline="always")
def unit_and_p_axis(x, y, z, sx, sy, sz):
    """A new direction made unit, and its p-axis s × d in the plane of incidence of axis s."""
    n = 1.0 / math.sqrt(x * x + y * y + z * z)
    x *= n
    y *= n
    z *= n
    return x, y, z, sy * z - sz * y, sz * x - sx * z, sx * y - sy * x


@njit(cache=True)
def reflect_facet(dx, dy, dz, rx, ry, rz, si, sq, su, sv, n_water, nx, ny, nz):
    """Fresnel reflection from below at a facet with upward normal n (d·n > 0).

    As :func:`reflect_from_below`, in the facet's plane of incidence. Returns the reflected
    Stokes (I, Q, U, V), its direction and reference (the p-axis s × d'), and the escaped flux.
    """
    sx, sy, sz = s_axis(dx, dy, dz, nx, ny, nz)
    sq, su = to_p_basis(dx, dy, dz, rx, ry, rz, sq, su, sx, sy, sz)
    cos_i = min(max(dx * nx + dy * ny + dz * nz, 0.0), 1.0)
    ni, nq, nu, nv = fresnel_from_below(cos_i, n_water, si, sq, su, sv)
    ex = dx - 2.0 * cos_i * nx
    ey = dy - 2.0 * cos_i * ny
    ez = dz - 2.0 * cos_i * nz
    ex, ey, ez, qx, qy, qz = unit_and_p_axis(ex, ey, ez, sx, sy, sz)
    return ni, nq, nu, nv, ex, ey, ez, qx, qy, qz, si - ni


@njit(cache=True)
def enter_facet(ax, ay, az, rx, ry, rz, si, sq, su, n_water, nx, ny, nz):
    """Fresnel transmission from air into the water at a facet with upward normal n (a·n < 0).

    Light travelling along a with Stokes (I, Q, U) relative to r. Returns the transmitted Stokes
    (I, Q, U, V; I is the transmitted flux, Born & Wolf power transmittances as in
    :func:`sensors.polarimeter.optics.surface.fresnel_elements`), its direction t (Snell) and
    reference (the p-axis s × t).
    """
    sx, sy, sz = s_axis(ax, ay, az, nx, ny, nz)
    sq, su = to_p_basis(ax, ay, az, rx, ry, rz, sq, su, sx, sy, sz)
    ci = min(max(-(ax * nx + ay * ny + az * nz), 0.0), 1.0)
    eta = 1.0 / n_water
    ct = math.sqrt(max(1.0 - eta * eta * (1.0 - ci * ci), 0.0))
    num = 4.0 * n_water * ci * ct
    t_s = num / (ci + n_water * ct) ** 2
    t_p = num / (n_water * ci + ct) ** 2
    m00 = 0.5 * (t_p + t_s)
    m01 = 0.5 * (t_p - t_s)
    m22 = math.sqrt(t_s * t_p)
    ni = m00 * si + m01 * sq
    nq = m01 * si + m00 * sq
    nu = m22 * su
    k = eta * ci - ct
    tx = eta * ax + k * nx
    ty = eta * ay + k * ny
    tz = eta * az + k * nz
    tx, ty, tz, qx, qy, qz = unit_and_p_axis(tx, ty, tz, sx, sy, sz)
    return ni, nq, nu, 0.0, tx, ty, tz, qx, qy, qz
