"""Snell's window's edge band on a grid in (cos θ in air, azimuth), where its light is smooth.

The fast path (:mod:`~sensors.polarimeter.fast_path`) cannot interpolate the band just inside
Snell's window's edge from its pixel grids: there the Fresnel transmission, the sky's compressed
horizon and the surface's reflectance all go as √x of the distance x from the edge, so the band
(three coarse cells wide at 2448×2048, five at 612×512) was rendered through the exact chain
pixel by pixel: ~75 000 rays of a 2448×2048 frame, half of its chain.

In the cosine of the ray's zenith *in air*, c_a (c_a² = 1 − n²(1 − v_z²)), those terms are
smooth: the sky is a function of its own zenith cosine c_a and azimuth, the water's
transmittance, the table's light inside the window and the surface's reflection are smooth in
v_z = √(1 − (1 − c_a²)/n²), and the meridian reference is the polar grid's own. The Fresnel
transmission factors are rational in c_a and v_z but vanish as c_a at the edge, which a linear
interpolation in c_a cannot follow in relative terms (5 % of the direct light between rows
0.04 apart, measured); so they are taken out at the nodes and put back at each pixel, exactly.
This module renders the exact chain at nodes on a regular grid in (c_a, world azimuth φ), in the
meridian reference (the lens's rotation left out, C_c^n = I), keeps there the direct light with
its Fresnel factors undone and the scattered light, and gives a band pixel the bilinear value
of both at its own (c_a, φ), the direct light times its own Fresnel factors, turned into the
sensor plane by its own rotation, as the exact chain would. The window mask stays the exact
chain's (each pixel's own c_a > 0, in the same float32 arithmetic).

Kept exact (the fast path's job, not this grid's): pixels within :data:`MIN_COS_AIR` of the
edge (the table's inside/outside switch there is float32-close), occluded pixels, and the cells
near the sun, the horizon's scattering step or the frame's border. What is left is the table's
own structure (bilinear between nodes 3–4° × 15° apart, with its Monte Carlo noise) across a
grid that is not aligned with it: within 0.6 % of S0 at 2448×2048 and 1.6 % at 612×512, against
the table's standard error of 2–3 % (``tests/sensors/polarimeter/test_window_grid.py``,
``validation/fast_path_error.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from sensors.polarimeter.chain_kernel import cos_in_air
from sensors.polarimeter.chain_passes import fresnel_in
from sensors.polarimeter.optics.blocks import world_components
from sensors.polarimeter.optics.column_kernel import _atan2_pos
from twin.core.arrays import FloatArray
from twin.core.kernel_cache import njit

#: Pixels with c_a below this stay exact: the table's light switches from inside to outside the
#: window where v_z crosses cos θ_c in float64, while c_a comes from float32 v_z (an error of
#: ~1e-7 in c_a², so c_a ≥ 0.01 is on the inside without doubt). A sliver ~6e-5 rad wide.
MIN_COS_AIR = 0.01
#: Node spacing in c_a, chosen by measuring the error against the exact chain at the band's
#: pixels (2448×2048, level 10 m): 0.6 % of S0 at most with 0.02, 0.8 % with 0.03; the grid's
#: rows are ~5 % of a frame's rays either way.
D_COS_AIR = 0.02


#: Columns per coarse cell of arc along the window's edge, chosen by measuring the band's error
#: against the exact chain: one a cell gives 0.6 % of S0 at most at 2448×2048 (level 10 m), and
#: at 612×512 1.2 % against 0.6 % with two a cell (nodes twice as many: the grid's node count is
#: what it costs).
COLUMNS_PER_CELL = 1.0

#: The nodes are world directions: the chain renders them with C_c^n = I.
IDENTITY = np.eye(3)

# The rows stop short of the zenith (c_a = 1), where the azimuth is undefined; the edge band
# never reaches it.
_MAX_COS_AIR = 0.99


class WindowGrid:
    """The nodes of the (c_a, φ) grid for one water index and azimuth spacing (built once).

    Rows at c_a = :data:`MIN_COS_AIR` + k·:data:`D_COS_AIR` below 0.99 (a frame renders the first
    rows its band needs), columns at φ = −π + j·2π/n_φ, φ the world azimuth atan2(y, x) of the
    look direction (ENU). Each node's ray is a world look direction (float32), with a sensor
    basis whose rotation from the meridian is the identity (r_s in the ray's vertical plane,
    t_s horizontal), so the chain returns the meridian Stokes there.

    Args:
        n_water: The water's refractive index.
        n_phi: Columns (azimuths) around the full circle.
    """

    def __init__(self, n_water: float, n_phi: int) -> None:
        n = float(n_water)
        ca = np.arange(MIN_COS_AIR, _MAX_COS_AIR, D_COS_AIR)
        vz = np.sqrt(1.0 - (1.0 - ca * ca) / (n * n))
        z32 = vz.astype(np.float32)
        # Each row's own c_a, in the chain's float32 arithmetic (chain_kernel.cos_in_air): the
        # pixels' c_a are computed so, and the interpolation is in them.
        self.row_cos = cos_in_air(z32, n).astype(np.float64)
        self.n_phi = n_phi
        self.dphi = 2.0 * math.pi / n_phi
        phi = -math.pi + self.dphi * np.arange(n_phi)
        h = np.sqrt(1.0 - vz * vz)
        rays = np.empty((ca.size, n_phi, 3), dtype=np.float32)
        rays[..., 0] = h[:, None] * np.cos(phi)[None, :]
        rays[..., 1] = h[:, None] * np.sin(phi)[None, :]
        rays[..., 2] = z32[:, None]
        self.rays = rays.reshape(-1, 3)
        # r_s: up's part ⟂ the ray (in its vertical plane); t_s: horizontal, z exactly 0, so that
        # the chain's cos and sin of the rotation are exactly 1 and 0.
        basis = np.zeros((6, ca.size, n_phi), dtype=np.float32)
        basis[0] = -vz[:, None] * h[:, None] * np.cos(phi)[None, :]
        basis[1] = -vz[:, None] * h[:, None] * np.sin(phi)[None, :]
        basis[2] = (h * h)[:, None]
        basis[0:3] /= h[None, :, None]
        basis[3] = -np.sin(phi)[None, :]
        basis[4] = np.cos(phi)[None, :]
        self.basis = basis.reshape(6, -1)
        self.psf = np.zeros(self.rays.shape[0], dtype=np.float32)  # no disc: none is near
        # Each row's Fresnel factors (m00, m01, m22), as the chain applies them at its nodes.
        rows = zip(self.row_cos.tolist(), z32.tolist(), strict=True)
        self._fresnel = np.array([fresnel_in.py_func(n, n * n, c, v) for c, v in rows])

    @classmethod
    def for_cell(cls, n_water: float, cell_rad: float) -> WindowGrid:
        """The grid whose columns lie one coarse cell (``cell_rad``) apart along the edge.

        The edge is the circle of angular radius θ_c, sin θ_c = 1/n: 2π/(n · cell) columns.
        """
        return cls(
            n_water, max(math.ceil(COLUMNS_PER_CELL * 2.0 * math.pi / (n_water * cell_rad)), 8)
        )

    def node_values(self, total: FloatArray, scattered: FloatArray, rows: int) -> FloatArray:
        """(rows, n_φ, 6) float32: the grid from the chain's meridian Stokes at the first rows.

        Channels 0–2: the direct light (total − scattered) with the node's Fresnel factors
        undone (M⁻¹, M = [[m00, m01, 0], [m01, m00, 0], [0, 0, m22]]): the sky's transmitted
        Stokes times the water's transmittance, smooth in c_a where M goes as c_a. 3–5: the
        scattered light.
        """
        m00, m01, m22 = (self._fresnel[:rows, k, None] for k in range(3))
        det = m00 * m00 - m01 * m01
        tot = total.reshape(rows, self.n_phi, 3).astype(np.float64)
        sc = scattered.reshape(rows, self.n_phi, 3).astype(np.float64)
        d = tot - sc
        out = np.empty((rows, self.n_phi, 6), dtype=np.float32)
        out[..., 0] = (m00 * d[..., 0] - m01 * d[..., 1]) / det
        out[..., 1] = (m00 * d[..., 1] - m01 * d[..., 0]) / det
        out[..., 2] = d[..., 2] / m22
        out[..., 3:] = sc
        return out

    def rows_for(self, cos_air_max: float) -> int:
        """How many rows (≥ 2) a band reaching ``cos_air_max`` reads."""
        k = int(np.searchsorted(self.row_cos, cos_air_max, side="left")) + 1
        return min(max(k, 2), self.row_cos.size)


@njit(cache=True, fastmath=True)
def interpolate_pixels(x, y, z, ca, n, basis, column, up_c, north_c, grid, row_cos, dphi, out):  # type: ignore[no-untyped-def]
    """out[i] = the sensor-plane Stokes of pixel i from the (c_a, φ) grid (S0 ≥ 0).

    The grid's first three channels are the transmitted sky light before the Fresnel factors
    (their inverse applied at the node), the last three the scattered light; the pixel's own
    Fresnel factors (:func:`chain_passes.fresnel_in`'s, with two divisions fewer) turn the
    first back into the direct light. fastmath: this is an interpolation, not a reference (its
    rounding is ~1e-16 against its ~1e-3 interpolation error). Args (in order): x, y, z ((m,)
    float32 world look components); ca ((m,) float32 c_a, at least ``row_cos[0]``); n (the
    water's index); basis, column ((6, M) the pixels' sensor axes, the column of each of the m);
    up_c, north_c (ENU up and North in the camera frame); grid ((rows, n_φ, 6) float32 meridian
    Stokes); row_cos ((rows,) ascending c_a of the rows, 0.02 apart but for float32 rounding);
    dphi (the column spacing); out ((m, 3) float32).
    """
    m = x.shape[0]
    nr = grid.shape[0]
    nc = grid.shape[1]
    g = n * n
    c0 = row_cos[0]
    inv_row = (nr - 1) / (row_cos[nr - 1] - c0)
    inv_dphi = 1.0 / dphi
    u0, u1, u2 = up_c[0], up_c[1], up_c[2]
    for i in range(m):
        c = float(ca[i])
        # The rows are evenly spaced to float32 rounding: the even guess is at most one off.
        r = int((c - c0) * inv_row)
        if r > nr - 2:
            r = nr - 2
        if r > 0 and c < row_cos[r]:
            r -= 1
        elif r < nr - 2 and c >= row_cos[r + 1]:
            r += 1
        fr = (c - row_cos[r]) / (row_cos[r + 1] - row_cos[r])
        vx = float(x[i])
        vy = float(y[i])
        phi = _atan2_pos(abs(vy), vx)
        if vy < 0.0:
            phi = -phi
        p = (phi + math.pi) * inv_dphi
        j = int(p)
        if j >= nc:
            j = nc - 1
        fp = p - j
        j1 = j + 1 if j + 1 < nc else 0
        w00 = (1.0 - fr) * (1.0 - fp)
        w01 = (1.0 - fr) * fp
        w10 = fr * (1.0 - fp)
        w11 = fr * fp
        a = grid[r, j]
        b = grid[r, j1]
        d = grid[r + 1, j]
        e = grid[r + 1, j1]
        v0 = w00 * a[0] + w01 * b[0] + w10 * d[0] + w11 * e[0]
        v1 = w00 * a[1] + w01 * b[1] + w10 * d[1] + w11 * e[1]
        v2 = w00 * a[2] + w01 * b[2] + w10 * d[2] + w11 * e[2]
        v3 = w00 * a[3] + w01 * b[3] + w10 * d[3] + w11 * e[3]
        v4 = w00 * a[4] + w01 * b[4] + w10 * d[4] + w11 * e[4]
        v5 = w00 * a[5] + w01 * b[5] + w10 * d[5] + w11 * e[5]
        # The flat sea's Fresnel transmission at this pixel: chain_passes.fresnel_in's formula
        # with two reciprocals for its three divisions (fresnel_in inlined here, and the lens
        # rotation shared with the chain, cost 13–15 ns a pixel more, measured interleaved).
        mu = max(float(z[i]), 0.0)
        num = 4.0 * n * c * mu
        ias = 1.0 / (c + n * mu)
        iap = 1.0 / (n * c + mu)
        t_s = num * ias * ias
        t_p = num * iap * iap
        m00 = 0.5 * g * (t_p + t_s)
        m01 = 0.5 * g * (t_p - t_s)
        m22 = g * num * ias * iap
        si = m00 * v0 + m01 * v1 + v3
        sq = m01 * v0 + m00 * v1 + v4
        su = m22 * v2 + v5
        # The lens's meridional mapping: the meridian → sensor rotation, chain_points' written
        # out with up's components held in registers and one division (chain_points' own,
        # inlined here from a shared function, cost 13 ns a pixel more, measured interleaved).
        k = column[i]
        rx, ry, rz = basis[0, k], basis[1, k], basis[2, k]
        tx, ty, tz = basis[3, k], basis[4, k], basis[5, k]
        cc = u0 * rx + u1 * ry + u2 * rz
        ss = u0 * tx + u1 * ty + u2 * tz
        n2 = cc * cc + ss * ss
        if n2 == 0.0:
            cc = north_c[0] * rx + north_c[1] * ry + north_c[2] * rz
            ss = north_c[0] * tx + north_c[1] * ty + north_c[2] * tz
            n2 = 1.0
        inv = 1.0 / n2
        c2 = (cc * cc - ss * ss) * inv
        s2 = 2.0 * cc * ss * inv
        out[i, 0] = max(si, 0.0)
        out[i, 1] = c2 * sq + s2 * su
        out[i, 2] = c2 * su - s2 * sq


def band_stokes(
    grid: WindowGrid,
    band: NDArray[np.intp],
    rays: FloatArray,
    sensor_basis: FloatArray,
    c_cn: NDArray[np.float64],
    n_water: float,
    occluded: NDArray[np.bool_] | None,
    render: Callable[
        [FloatArray, tuple[FloatArray, NDArray[np.intp]], FloatArray],
        tuple[FloatArray, NDArray[np.bool_], FloatArray | None],
    ],
) -> tuple[NDArray[np.intp], FloatArray] | None:
    """The band pixels the grid gives and their sensor-plane Stokes (photons/s), or None.

    Of ``band`` (flat pixel indices, their camera-frame ``rays``), those with c_a at or above the
    first row's and not ``occluded``; the others are left to the exact chain, and so is the whole
    band when the grid would render as many nodes as it has such pixels.

    Args:
        grid: The frame's :class:`WindowGrid`.
        band: (N,) flat indices of the candidate pixels.
        rays: (N, 3) float32 their rays, camera frame.
        sensor_basis: (6, H·W) every pixel's sensor axes (``Camera.sensor_basis``).
        c_cn: C_c^n.
        n_water: The water's index.
        occluded: (N,) the candidates whose sky is blocked, or None.
        render: The exact chain at world-frame node rays (``FastPath._render_points`` with
            C_c^n = :data:`IDENTITY`, ``parts="split"``): (total, sees, scattered).
    """
    if band.size == 0:
        return None
    c = np.asarray(c_cn, dtype=np.float64)
    x, y, z = world_components(rays, c, np.empty((3, band.size), dtype=np.float32))
    ca = cos_in_air(z, n_water)
    use = ca >= np.float32(grid.row_cos[0])
    if occluded is not None:
        use &= ~occluded
    sel = np.flatnonzero(use)
    rows = grid.rows_for(float(ca[sel].max())) if sel.size else 0
    nodes = rows * grid.n_phi
    if sel.size == 0 or nodes >= sel.size:
        return None
    cols = np.arange(nodes)
    total, _, scattered = render(grid.rays[:nodes], (grid.basis, cols), grid.psf[:nodes])
    assert scattered is not None
    out = np.empty((sel.size, 3), dtype=np.float32)
    interpolate_pixels(
        x[sel], y[sel], z[sel], ca[sel], float(n_water), sensor_basis, band[sel], c[2].copy(),
        c[1].copy(), grid.node_values(total, scattered, rows), grid.row_cos[:rows], grid.dphi, out,
    )  # fmt: skip
    return band[sel], out
