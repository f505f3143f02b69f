"""Compiled per-pixel chains of POL and LIG: each selected pixel's constraint, summed into Σ w v vᵀ.

POL and LIG end the same way: every usable analysis pixel gives a unit constraint vector v (an
air-side E-vector for POL, a great-circle normal for LIG) and the sun is the eigenvector of the
smallest eigenvalue of Σ w v vᵀ / Σ w
(:func:`twin.onboard.compass.analysis_grid.smallest_eigenvector`).
The numpy chains in ``pol.py`` and ``lig.py`` make ~20 passes over the pixels with an (N, 3)
temporary each; here one compiled loop per pixel does the same arithmetic (the same formulas, in
double precision, in the same order per pixel) and keeps only the 3×3 sum: no per-pixel arrays.
The numpy chains stay as the reference; ``tests/onboard/test_compass_kernels.py`` checks that
the two give the same moments (1e-12 relative) and the same fixes.

Why numba and not numpy: the chain is ~20 cheap operations per pixel on ~10⁴ pixels, where
numpy's per-call cost and the temporaries' memory traffic are most of the time (issue #31:
POL 3.5 ms → see benchmarks/results/sea_trial_rtf.md).
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.kernel_cache import njit


@njit(cache=True, inline="always")
def _meridian(x, y, z):  # type: ignore[no-untyped-def]
    """(e_θ, e_φ) at direction (x, y, z): ``geometry.meridian_basis`` for one direction."""
    rxy = math.hypot(x, y)
    if rxy > 1e-12:
        cphi = x / rxy
        sphi = y / rxy
    else:
        cphi = 1.0
        sphi = 0.0
    return z * cphi, z * sphi, -rxy, -sphi, cphi


@njit(cache=True, inline="always")
def _refract(x, y, n):  # type: ignore[no-untyped-def]
    """``geometry.refract_to_air`` for one level-frame direction: (d_x, d_y, d_z, sin r, sin i)."""
    sin_r = math.hypot(x, y)
    sin_i = min(n * sin_r, 1.0)
    cos_i = math.sqrt(max(1.0 - sin_i * sin_i, 0.0))
    scale = sin_i / sin_r if sin_r > 1e-12 else n
    return x * scale, y * scale, cos_i, sin_r, sin_i


@njit(cache=True, inline="always")
def _accumulate(mat, w, v0, v1, v2):  # type: ignore[no-untyped-def]
    """The upper triangle of mat += w v vᵀ."""
    mat[0, 0] += w * v0 * v0
    mat[0, 1] += w * v0 * v1
    mat[0, 2] += w * v0 * v2
    mat[1, 1] += w * v1 * v1
    mat[1, 2] += w * v1 * v2
    mat[2, 2] += w * v2 * v2


@njit(cache=True, inline="always")
def _symmetrize(mat):  # type: ignore[no-untyped-def]
    """The lower triangle from the upper."""
    mat[1, 0] = mat[0, 1]
    mat[2, 0] = mat[0, 2]
    mat[2, 1] = mat[1, 2]


@njit(cache=True)
def window_masks(rays, valid, up, cos_edge, cos_core, in_window, core):  # type: ignore[no-untyped-def]
    """Snell's window (eqs. 6–7) and its core, in one pass over the analysis pixels.

    A valid pixel is in the window when its ray's level-frame elevation cosine l^h(3) = ray · up
    (``up`` = row 3 of C_c^h) exceeds ``cos_edge``, in the core when it exceeds ``cos_core``.
    ``rays`` (N, 3), ``valid``, ``in_window``, ``core`` (N,). The cosine is
    (x·u₀ + y·u₁) + z·u₂ in double precision: numpy's ``rays @ up`` (BLAS) may round its last bit
    differently, so a pixel within ~1e-16 of a threshold may fall on the other side
    (``tests/onboard/compass/test_compass_kernels.py`` bounds it).
    """
    u0 = up[0]
    u1 = up[1]
    u2 = up[2]
    for i in range(valid.shape[0]):
        c = rays[i, 0] * u0 + rays[i, 1] * u1 + rays[i, 2] * u2
        v = valid[i]
        in_window[i] = v and c > cos_edge
        core[i] = v and c > cos_core


def window_and_core(
    rays: np.ndarray, valid: np.ndarray, up: np.ndarray, cos_edge: float, cos_core: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`window_masks` for (H, W, 3) rays and an (H, W) valid mask: two (H, W) masks."""
    in_window = np.empty(valid.shape, dtype=np.bool_)
    core = np.empty(valid.shape, dtype=np.bool_)
    window_masks(
        np.ascontiguousarray(rays).reshape(-1, 3),
        np.ascontiguousarray(valid).reshape(-1),
        np.ascontiguousarray(up, dtype=np.float64),
        float(cos_edge),
        float(cos_core),
        in_window.reshape(-1),
        core.reshape(-1),
    )
    return in_window, core


@njit(cache=True)
def window_sides(rays, idx, c, sp0, sp1, side):  # type: ignore[no-untyped-def]
    """side[i]: the level-frame direction of ray ``idx[i]`` lies on the side s_p points at.

    p^h = C_c^h · ray; the side is (p^h_1 s_1 + p^h_2 s_2) > 0, the sun/anti-sun rule's halves
    (``analysis_grid.resolve_by_intensity``), in double precision without the (N, 3) p^h.
    """
    c00 = c[0, 0]
    c01 = c[0, 1]
    c02 = c[0, 2]
    c10 = c[1, 0]
    c11 = c[1, 1]
    c12 = c[1, 2]
    for i in range(idx.shape[0]):
        j = idx[i]
        x = rays[j, 0]
        y = rays[j, 1]
        z = rays[j, 2]
        side[i] = (x * c00 + y * c01 + z * c02) * sp0 + (x * c10 + y * c11 + z * c12) * sp1 > 0.0


@njit(cache=True)
def pol_moments(idx, aop, dop, rays, r_s, t_s, lens_rays, c, n_w, fresnel, flat, dop_weight):  # type: ignore[no-untyped-def]
    """Σ w e eᵀ (3×3) and Σ w of POL's air-side E-vectors (``PolCompass.solve_frame``, step 3).

    Args: idx (k,) flat analysis pixels; aop, dop (k,) theirs (rad, 0–1); rays, r_s, t_s,
    lens_rays (n, 3) per analysis pixel: in-water rays, the meridional mapping's sensor axes, the
    lens rays (flat port); c (3, 3) C_c^h; n_w the water's index; fresnel: invert the Fresnel
    block; flat: a flat port; dop_weight: w = DoP (else 1).
    """
    mat = np.zeros((3, 3))
    wsum = 0.0
    for k in range(idx.shape[0]):
        i = idx[k]
        ca = math.cos(aop[k])
        sa = math.sin(aop[k])
        ex = ca * r_s[i, 0] + sa * t_s[i, 0]
        ey = ca * r_s[i, 1] + sa * t_s[i, 1]
        ez = ca * r_s[i, 2] + sa * t_s[i, 2]
        px, py, pz = rays[i, 0], rays[i, 1], rays[i, 2]
        if flat:
            lt0, lt1, lt2, lp0, lp1 = _meridian(lens_rays[i, 0], lens_rays[i, 1], lens_rays[i, 2])
            wt0, wt1, wt2, wp0, wp1 = _meridian(px, py, pz)
            a = ex * lt0 + ey * lt1 + ez * lt2
            b = ex * lp0 + ey * lp1
            ex = a * wt0 + b * wp0
            ey = a * wt1 + b * wp1
            ez = a * wt2
        hx = c[0, 0] * px + c[0, 1] * py + c[0, 2] * pz
        hy = c[1, 0] * px + c[1, 1] * py + c[1, 2] * pz
        hz = c[2, 0] * px + c[2, 1] * py + c[2, 2] * pz
        gx = c[0, 0] * ex + c[0, 1] * ey + c[0, 2] * ez
        gy = c[1, 0] * ex + c[1, 1] * ey + c[1, 2] * ez
        gz = c[2, 0] * ex + c[2, 1] * ey + c[2, 2] * ez
        et0, et1, et2, ep0, ep1 = _meridian(hx, hy, hz)
        # ψ_w = atan2(Y, X) from the in-water meridian; its double angle and the air-side ψ_a
        # by algebra rather than atan2, cos and sin (the same angles: fewer transcendentals).
        big_x = gx * et0 + gy * et1 + gz * et2
        big_y = gx * ep0 + gy * ep1
        r2 = big_x * big_x + big_y * big_y
        d = dop[k]
        dx, dy, dz, _, _ = _refract(hx, hy, n_w)
        if r2 > 0.0:
            c2 = (big_x * big_x - big_y * big_y) / r2
            s2 = 2.0 * big_x * big_y / r2
        else:  # e ∥ the ray: atan2(0, 0) = 0
            c2 = 1.0
            s2 = 0.0
        if fresnel:
            ts = 2.0 * dz / (dz + n_w * hz)
            tp = 2.0 * dz / (n_w * dz + hz)
            big_a = 0.5 * (tp * tp + ts * ts)
            big_b = 0.5 * (tp * tp - ts * ts)
            q = big_a * d * c2 - big_b
            u = tp * ts * d * s2
            rr = math.sqrt(q * q + u * u)
            if rr > 0.0:
                c2 = q / rr
                s2 = u / rr
            else:
                c2 = 1.0
                s2 = 0.0
        # ψ = ½ atan2(s2, c2) ∈ (−π/2, π/2]: cos ψ ≥ 0; the half-angle from the stable side
        # (v and −v give the same v vᵀ, so the sign at ψ = ±π/2 does not matter).
        if c2 >= 0.0:
            cp = math.sqrt(0.5 * (1.0 + c2))
            sp = 0.5 * s2 / cp
        else:
            sp = math.copysign(math.sqrt(0.5 * (1.0 - c2)), s2)
            cp = 0.5 * s2 / sp
        it0, it1, it2, ip0, ip1 = _meridian(dx, dy, dz)
        v0 = cp * it0 + sp * ip0
        v1 = cp * it1 + sp * ip1
        v2 = cp * it2
        w = d if dop_weight else 1.0
        _accumulate(mat, w, v0, v1, v2)
        wsum += w
    _symmetrize(mat)
    return mat, wsum


@njit(cache=True)
def lig_moments(idx, rays, du, dv, gxs, gys, filt, c, n_sphere, grad_weight):  # type: ignore[no-untyped-def]
    """Σ w v vᵀ (3×3), Σ w and the count of LIG's great-circle normals (the Jacobian mapping).

    ``lig._jacobian_normals`` for every pixel of ``idx``, one pixel at a time: the image
    gradient (gxs, gys: flat analysis images) carried through the lens's Jacobian (du, dv: (n, 3)
    ∂ray/∂u, ∂ray/∂v) and the refraction onto the sphere of index ``n_sphere``, the normal
    d × ∇ normalised; pixels whose normal is zero or not finite are left out (as there). Weight:
    1, or with ``grad_weight`` |n| / max(filt, 1e-6) (``LigConfig.weighting = "gradient"``).
    """
    mat = np.zeros((3, 3))
    wsum = 0.0
    count = 0
    for k in range(idx.shape[0]):
        i = idx[k]
        px, py, pz = rays[i, 0], rays[i, 1], rays[i, 2]
        hx = c[0, 0] * px + c[0, 1] * py + c[0, 2] * pz
        hy = c[1, 0] * px + c[1, 1] * py + c[1, 2] * pz
        hz = c[2, 0] * px + c[2, 1] * py + c[2, 2] * pz
        ux = c[0, 0] * du[i, 0] + c[0, 1] * du[i, 1] + c[0, 2] * du[i, 2]
        uy = c[1, 0] * du[i, 0] + c[1, 1] * du[i, 1] + c[1, 2] * du[i, 2]
        uz = c[2, 0] * du[i, 0] + c[2, 1] * du[i, 1] + c[2, 2] * du[i, 2]
        vx = c[0, 0] * dv[i, 0] + c[0, 1] * dv[i, 1] + c[0, 2] * dv[i, 2]
        vy = c[1, 0] * dv[i, 0] + c[1, 1] * dv[i, 1] + c[1, 2] * dv[i, 2]
        vz = c[2, 0] * dv[i, 0] + c[2, 1] * dv[i, 1] + c[2, 2] * dv[i, 2]
        dx, dy, dz, sin_r, sin_i = _refract(hx, hy, n_sphere)
        et0, et1, et2, ep0, ep1 = _meridian(hx, hy, hz)
        st = n_sphere * hz / max(dz, 1e-6)
        sp = sin_i / sin_r if sin_r > 1e-9 else n_sphere
        a1 = (ux * et0 + uy * et1 + uz * et2) * st
        a2 = (ux * ep0 + uy * ep1) * sp
        b1 = (vx * et0 + vy * et1 + vz * et2) * st
        b2 = (vx * ep0 + vy * ep1) * sp
        gu = float(gxs[i])
        gv = float(gys[i])
        det = a1 * b2 - a2 * b1
        g1 = (gu * b2 - gv * a2) / det
        g2 = (a1 * gv - b1 * gu) / det
        it0, it1, it2, _, _ = _meridian(dx, dy, dz)
        n0 = g1 * ep0 - g2 * it0
        n1 = g1 * ep1 - g2 * it1
        n2 = -g2 * it2
        nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if not (math.isfinite(nn) and nn > 0.0):
            continue
        v0 = n0 / nn
        v1 = n1 / nn
        v2 = n2 / nn
        w = nn / max(float(filt[i]), 1e-6) if grad_weight else 1.0
        _accumulate(mat, w, v0, v1, v2)
        wsum += w
        count += 1
    _symmetrize(mat)
    return mat, wsum, count
