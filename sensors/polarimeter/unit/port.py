"""A flat camera port: water → glass → air through parallel interfaces (optics.md §2.4).

The housing's Fresnel chain, in the interfaces' shared plane of incidence
(:func:`sensors.polarimeter.optics.surface.fresnel_elements` at each interface).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from sensors.polarimeter.optics.surface import (
    N_ACRYLIC,
    N_AIR,
    Factor,
    _check_index,
    _dtype,
    fresnel_elements,
    refract,
)
from sensors.polarimeter.unit.fisheye import Housing
from twin.core.arrays import BoolArray, FloatArray


class PortTransmission(NamedTuple):
    """Rays through a flat port and their water → glass → air Fresnel factors.

    Attributes:
        directions: The other side's look directions (water side for
            :func:`flat_port_from_camera`, housing-air side for :func:`flat_port_from_water`).
        valid: True where the ray passes the port (inside: looks out through the port; outside:
            inside the port's own Snell window).
        m00: Product of the two interfaces' Mueller blocks (radiance factor, light going water →
            glass → air), p-axis reference relative to the port normal.
        m01: see ``m00``.
        m22: see ``m00``.
    """

    directions: FloatArray
    valid: BoolArray
    m00: FloatArray
    m01: FloatArray
    m22: FloatArray


def _port_elements(
    cos_w: FloatArray, n_water: float, n_glass: float
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    e1 = fresnel_elements(cos_w, n_water, n_glass, "radiance")  # water → glass
    e2 = fresnel_elements(e1.cos_t, n_glass, N_AIR, "radiance")  # glass → air
    # Parallel interfaces share the plane of incidence: the blocks multiply in one basis.
    m00 = e2.m00 * e1.m00 + e2.m01 * e1.m01
    m01 = e2.m00 * e1.m01 + e2.m01 * e1.m00
    m22 = e2.m22 * e1.m22
    return m00, m01, m22, e1.transmitted & e2.transmitted


def flat_port_from_camera(
    look_dirs_air: ArrayLike, port_normal: ArrayLike, n_water: float, n_glass: float = N_ACRYLIC
) -> PortTransmission:
    """Camera rays (inside the housing, in air) traced out through a flat port into the water.

    Through parallel interfaces the glass only shifts the ray sideways (ignored: the port is thin
    next to the scene), so n_water sin θ_w = sin θ_air and every camera ray that meets the port
    sees the water within θ_c = arcsin(1/n_water) of the port normal; a 185° lens sees no more.

    Args:
        look_dirs_air: (..., 3) camera look directions inside the housing.
        port_normal: (3,) outward port normal (the optical axis for a centred port).
        n_water: Water index.
        n_glass: Port index (acrylic 1.49 by default; BK7 ≈ 1.52).

    Returns:
        :class:`PortTransmission` with in-water look directions; rays at or beyond 90° from the
        normal (they see the housing) are invalid and keep their direction.
    """
    u = np.asarray(look_dirs_air, dtype=_dtype(look_dirs_air))
    nrm = np.asarray(port_normal, dtype=u.dtype).reshape(3)
    nrm = nrm / np.linalg.norm(nrm)
    cos_a = u @ nrm
    r = refract(u, nrm, N_AIR, _check_index("n_water", n_water))
    valid = r.transmitted & (cos_a > 0.0)
    m00, m01, m22, _ = _port_elements(r.cos_t, n_water, _check_index("n_glass", n_glass))
    dirs = np.where(valid[..., None], r.directions, u)
    z = np.zeros_like(m00)
    return PortTransmission(
        dirs, valid, np.where(valid, m00, z), np.where(valid, m01, z), np.where(valid, m22, z)
    )


def flat_port_from_water(
    look_dirs_water: ArrayLike, port_normal: ArrayLike, n_water: float, n_glass: float = N_ACRYLIC
) -> PortTransmission:
    """In-water look directions traced in through a flat port to the camera (inverse mapping).

    Rays more than θ_c from the port normal are totally internally reflected (at the glass–air
    face) and never reach the camera: ``valid`` is False.

    Args:
        look_dirs_water: (..., 3) in-water look directions (away from the camera).
        port_normal: (3,) outward port normal.
        n_water: Water index.
        n_glass: Port index.

    Returns:
        :class:`PortTransmission` with look directions inside the housing.
    """
    w = np.asarray(look_dirs_water, dtype=_dtype(look_dirs_water))
    nrm = np.asarray(port_normal, dtype=w.dtype).reshape(3)
    nrm = nrm / np.linalg.norm(nrm)
    cos_w = w @ nrm
    r = refract(w, nrm, _check_index("n_water", n_water), N_AIR)
    valid = r.transmitted & (cos_w > 0.0)
    m00, m01, m22, ok = _port_elements(np.maximum(cos_w, 0.0), n_water, n_glass)
    valid &= ok
    dirs = np.where(valid[..., None], r.directions, w)
    z = np.zeros_like(m00)
    return PortTransmission(
        dirs, valid, np.where(valid, m00, z), np.where(valid, m01, z), np.where(valid, m22, z)
    )


def interface_chain_elements(
    interfaces: tuple[tuple[float, float, ArrayLike, ArrayLike], ...], factor: Factor = "radiance"
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Combined Mueller elements of parallel interfaces crossed in order (e.g. a flat port).

    Takes the camera module's ``PortRays.interfaces()`` tuples ``(n_i, n_t, cos_i, cos_t)``;
    parallel interfaces share the plane of incidence, so the 2×2 (I, Q) blocks multiply in one
    p basis and the U elements multiply. An empty chain (a dome port) is the identity.

    Args:
        interfaces: ``(n_i, n_t, cos_i, cos_t)`` per interface, in the order the light crosses
            them (``cos_t`` is implied by Snell and recomputed; it is accepted for the
            camera module's signature).
        factor: "radiance", "flux" or "none" (see :func:`fresnel_elements`).

    Returns:
        (m00, m01, m22) of the product, p-axis reference (Q = I_p − I_s).
    """
    m00: FloatArray | float = 1.0
    m01: FloatArray | float = 0.0
    m22: FloatArray | float = 1.0
    for n_i, n_t, cos_i, _cos_t in interfaces:
        e = fresnel_elements(cos_i, n_i, n_t, factor)
        m00, m01, m22 = e.m00 * m00 + e.m01 * m01, e.m00 * m01 + e.m01 * m00, e.m22 * m22
    return np.asarray(m00), np.asarray(m01), np.asarray(m22)


# ---- the camera's rays through the port ----------------------------------------------------------


def flat_port_refraction(
    dirs_inside: ArrayLike, n_outside: float, n_glass: float, n_inside: float = 1.0
) -> tuple[FloatArray, BoolArray, FloatArray, FloatArray, FloatArray]:
    """Housing-side (lens) ray directions → directions in the outside medium, through a flat port.

    The port is a plane-parallel window perpendicular to the camera z axis. Snell's law at both
    faces, n_in sin θ_in = n_g sin θ_g = n_out sin θ_out, with the azimuth kept (vector form:
    t_xy = (n_in/n_out)·d_xy, t_z = √(1 − |t_xy|²)).

    Args:
        dirs_inside: (..., 3) unit vectors (camera frame) along which the lens looks, in the
            housing's gas.
        n_outside: Refractive index outside (water, e.g. from Quan–Fry).
        n_glass: Index of the window.
        n_inside: Index of the housing gas (1.0 = air).

    Returns:
        ``(dirs_outside, valid, cos_inside, cos_glass, cos_outside)``: the outward directions in the
        outside medium (camera frame), whether the ray leaves through the port (θ_in < 90°), and the
        cosines of the angles to the port normal in the three media (the Fresnel hook: interface
        outside→glass has incidence cos_outside and transmission cos_glass, glass→inside has
        cos_glass and cos_inside). Invalid rays get the port normal and cosines 1, never NaN.
    """
    n_out = _check_index("n_outside", n_outside)
    n_g = _check_index("n_glass", n_glass)
    n_in = _check_index("n_inside", n_inside)
    d = np.asarray(dirs_inside)
    valid = d[..., 2] > 0.0
    s_in2 = np.minimum(d[..., 0] ** 2 + d[..., 1] ** 2, 1.0)
    cos_in = np.where(valid, np.sqrt(1.0 - s_in2), 1.0)
    ratio_g = (n_in / n_g) ** 2
    ratio_o = (n_in / n_out) ** 2
    cos_g = np.where(valid, np.sqrt(np.maximum(1.0 - ratio_g * s_in2, 0.0)), 1.0)
    cos_o = np.where(valid, np.sqrt(np.maximum(1.0 - ratio_o * s_in2, 0.0)), 1.0)
    scale = np.where(valid, n_in / n_out, 0.0)
    out = np.stack([d[..., 0] * scale, d[..., 1] * scale, cos_o], axis=-1).astype(d.dtype)
    return out, valid, cos_in, cos_g, cos_o


def flat_port_inverse(
    dirs_outside: ArrayLike, n_outside: float, n_inside: float = 1.0
) -> tuple[FloatArray, BoolArray]:
    """Outside-medium directions (camera frame, pointing away from the camera) → lens-side rays.

    The inverse of :func:`flat_port_refraction` (the window's index does not change directions).
    Rays beyond the critical angle asin(n_in/n_out), or pointing behind the port, cannot reach the
    lens: ``valid`` is False there and the direction returned is the port normal.
    """
    n_out = _check_index("n_outside", n_outside)
    n_in = _check_index("n_inside", n_inside)
    d = np.asarray(dirs_outside)
    s_out2 = d[..., 0] ** 2 + d[..., 1] ** 2
    s_in2 = (n_out / n_in) ** 2 * s_out2
    valid = (d[..., 2] > 0.0) & (s_in2 < 1.0)
    scale = np.where(valid, n_out / n_in, 0.0)
    cos_in = np.where(valid, np.sqrt(np.maximum(1.0 - s_in2, 0.0)), 1.0)
    out = np.stack([d[..., 0] * scale, d[..., 1] * scale, cos_in], axis=-1).astype(d.dtype)
    return out, valid


@dataclass(frozen=True, slots=True)
class PortRays:
    """Per-pixel rays outside the housing and the port's interface geometry (the Fresnel hook).

    Attributes:
        directions: (H, W, 3) outward directions in the outside medium (camera frame).
        valid: (H, W) pixels that see the outside medium (camera's valid mask ∧ the port passes).
        cos_inside: (H, W) cosine of the lens-side ray with the port normal (1 for a dome).
        cos_glass: (H, W) cosine inside the window (1 for a dome).
        cos_outside: (H, W) cosine in the outside medium (1 for a dome).
        n_inside: Index of the housing gas.
        n_glass: Index of the window.
        n_outside: Index of the outside medium.
        housing: ``"dome"`` or ``"flat"``.
    """

    directions: FloatArray
    valid: BoolArray
    cos_inside: FloatArray
    cos_glass: FloatArray
    cos_outside: FloatArray
    n_inside: float
    n_glass: float
    n_outside: float
    housing: Housing

    def interfaces(self) -> tuple[tuple[float, float, FloatArray, FloatArray], ...]:
        """The interfaces in the light's order, each ``(n_i, n_t, cos_i, cos_t)``.

        For a flat port: outside→glass, then glass→housing gas. The renderer applies the Fresnel
        transmission Mueller matrix (``sensors.polarimeter.optics.surface``) and the n² radiance law
        for
        each, in the plane-of-incidence basis ``stokes.meridian_reference(d, up=(0, 0, 1))`` (camera
        frame; d = −direction). A dome is at normal incidence: no interfaces listed here.
        """
        if self.housing == "dome":
            return ()
        return (
            (self.n_outside, self.n_glass, self.cos_outside, self.cos_glass),
            (self.n_glass, self.n_inside, self.cos_glass, self.cos_inside),
        )
