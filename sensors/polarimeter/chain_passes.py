"""The exact chain's compiled kernel, a block of rays at a time in passes that LLVM vectorises.

:func:`chain_points` computes, for each ray under a flat sea, what
``column_kernel.scatter_pixels`` (the water's scattered light) and the sky, the sea's Fresnel
transmission and the lens's rotation give it (:mod:`sensors.polarimeter.chain_kernel` has the
chain and its reference). Done a ray at a time that is scalar code: LLVM does not vectorise a
loop that reads a table at a computed index, nor one that calls ``exp``, nor one whose stores it
cannot prove apart from its loads. So a block of :data:`BLOCK` rays goes through five passes:

1. :func:`_index_pass` (vectorised): where each ray reads the tables. The phase table's node,
   the frame field's coordinates, and each table's row as a *count* of the row cosines at or
   above the ray's (``column_kernel._row``'s binary search's answer, without its branches).
2. :func:`_gather_pass` (scalar): the table reads, the aureole near the sun and the lens's
   sensor axes, into a block scratch.
3. :func:`_transcendental_pass` (vectorised): the transmittance and single scattering's path
   factor, and the sky's radiance. Its exponentials and arc cosine are polynomials
   (:func:`_exp_neg`, :func:`_acos`: libm's are calls, which LLVM does not vectorise), within
   3e-13 of libm's (``tests/sensors/polarimeter/test_chain_passes.py``).
4. :func:`_arithmetic_pass` (vectorised): single scattering along the ray and its mirror, the
   surface's reflection, the sky's polarization, the Fresnel transmission, the lens's rotation.
5. :func:`_candidate_pass` (scalar): the few rays that may see the solar disc.

The scratch is one flat float64 array, row r of the block at ``r * ROW``: every access in a
pass is then the same array at offsets LLVM knows at compile time, and it needs no run-time
alias checks (with a 2-D scratch it needed more than its limit of 8 and gave up). Its rows are
a block and 8 values long, so that every fourth does not start 4 KB after another (the same
sets of the first-level cache), and the polynomials have a pass of their own (in the
arithmetic pass's loop, their constants made it spill registers): the two together took an
exact pixel's ray from 118 to 104–108 ns (``benchmarks/chain_passes.py``).

The same formulas as the scalar kernel, their branches written as selects, the rays read as
the scalar kernel read them (numba's ``float()`` of a float32 is a float32, so a product of two
of a ray's components is rounded to float32 in both): the results agree to float64 rounding
(``tests/sensors/polarimeter/test_chain_kernel.py`` holds the chain to the numpy chain;
``benchmarks/chain_passes.py`` times it against the scalar layout).
"""

from __future__ import annotations

import math

import numpy as np

from sensors.polarimeter.optics.column_kernel import _atan2_pos, aureole_at
from twin.core.kernel_cache import njit

#: Rays a pass works on at a time: the block's scratch (:data:`SCRATCH_ROWS` × :data:`ROW` × 8
#: bytes, 41 KB) stays in the core's first two cache levels between the passes (64 and 256 were
#: no faster, benchmarks/chain_passes.py).
BLOCK = 128

# The scratch's rows. Filled by the index pass:
_PJ = 0  # 0–1: the phase table's node (a float) and fraction at the ray's scattering angle
_RPJ = 2  # 2–3: the same for its mirror v' = (v_x, v_y, −v_z)
_CZT = 4  # the frame field's look-zenith coordinate (this water's window edge on the table's)
_AZ = 5  # 5–7: the field's azimuth column (a float, not yet clamped), its fraction, U's sign
_CNT = 8  # how many row cosines of the field (inside or outside the window) are ≥ _CZT
_CUP = 9  # how many row cosines of the upwelling light are ≥ −v_z
# By the gather pass:
_PH = 10  # 10–13: β, m12, m22, m33 at the ray's scattering angle (0 without a lit beam)
_RPH = 14  # 14–17: the same along v' (0 where the reflection is not added)
_TAB = 18  # 18–20: the field's light and the aureole (I, Q, U)
_UP = 21  # 21–23: the field's upwelling light at the surface along v' (0: not added)
_REF = 24  # 1: the surface's reflection of the upwelling light is added
_LIT = 25  # 1: the sky reaches the ray (inside the window, not occluded)
_LENS = 26  # 26–28: the lens rotation's projections cc, ss and their squared norm
# By the transcendental pass (the candidate pass reads _T and _CG), _G and _RAD too:
_T = 29  # transmittance from the surface, e^(−c z / v_z) (0 looking down)
_CG = 30  # the cosine of the window's sky direction's angle from the sun (−2: no sky)
# By the arithmetic pass:
_OUT = 31  # 31–33: the sensor-plane Stokes (photons/s); 34–36: its scattered part alone
_G = 37  # single scattering's path factor along v (column_kernel._single's g)
_RAD = 38  # the sky's radiance along the window's sky direction (0: the sky does not reach it)
#: A scratch row's length: a block and 8 more, so that the rows do not start 1 KB apart (rows
#: 4 KB apart fall in the same sets of the first-level cache, and a pass reads ~25 of them at
#: once).
ROW = BLOCK + 8
#: Rows of the scratch ``w`` (``SCRATCH_ROWS * ROW`` float64) that :func:`chain_points` takes.
SCRATCH_ROWS = 39


@njit(cache=True, inline="always")
def _at(w, row, j):
    """Row ``row`` of the block scratch at ray ``j``."""
    return w[row * ROW + j]


@njit(cache=True, inline="always")
def _put(w, row, j, value):
    """Set row ``row`` of the block scratch at ray ``j``."""
    w[row * ROW + j] = value


#: asin's Taylor coefficients (2n)! / (4ⁿ (n!)² (2n + 1)), n = 0…23: on [0, ½] the 24th term is
#: below 1e-16 of the sum.
_ASIN_TAYLOR = np.array(
    [math.factorial(2 * n) / (4**n * math.factorial(n) ** 2 * (2 * n + 1)) for n in range(24)]
)
#: 1/n, n = 0…16, for :func:`_exp_neg`'s Taylor polynomial (a product, not a division).
_INV_N = np.array([0.0] + [1.0 / n for n in range(1, 17)])


@njit(cache=True, inline="always")
def _exp_neg(x):
    """e^x for x ≤ 0 in arithmetic alone (vectorisable), within 3e-13 relative; 0 below −700.

    e^x = (e^(x/1024))^1024: the Taylor polynomial of degree 16 at |x/1024| ≤ 0.69 (remainder
    < 1e-17), squared ten times (which multiplies its rounding by ~1000). e^−700 ≈ 1e−304.
    """
    y = max(x, -700.0) * (1.0 / 1024.0)
    p = 1.0
    for n in range(16, 0, -1):
        p = 1.0 + p * y * _INV_N[n]
    for _ in range(10):
        p = p * p
    return p if x >= -700.0 else 0.0


@njit(cache=True, inline="always")
def _acos(x):
    """The arc cosine on [−1, 1] in arithmetic alone (vectorisable), within 5e-16 absolute.

    acos |x| = π/2 − asin |x| for |x| ≤ ½, else 2 asin √((1 − |x|)/2); asin on [0, ½] by its
    Taylor series; acos(−x) = π − acos x.
    """
    ax = abs(x)
    big = ax > 0.5
    z = math.sqrt(max(0.5 - 0.5 * ax, 0.0)) if big else ax
    t = z * z
    p = _ASIN_TAYLOR[23]
    for n in range(22, -1, -1):
        p = p * t + _ASIN_TAYLOR[n]
    s = z * p
    r = 2.0 * s if big else 0.5 * math.pi - s
    return math.pi - r if x < 0.0 else r


@njit(cache=True, inline="always")
def fresnel_in(n, g, ca, vz):
    """The flat sea's Fresnel transmission into the water, radiance factors (m00, m01, m22).

    transmission._flat_fresnel_block's: c_a the cosine in air, v_z in the water, g = n² (the n²
    radiance law); in the meridian reference, which is the plane of incidence's.
    """
    mu = max(vz, 0.0)
    num = 4.0 * n * ca * mu
    a_s = ca + n * mu
    a_p = n * ca + mu
    m22 = g * num / (a_s * a_p + 1e-30)
    t_s = num / (a_s * a_s + 1e-30)
    t_p = num / (a_p * a_p + 1e-30)
    return 0.5 * g * (t_p + t_s), 0.5 * g * (t_p - t_s), m22


@njit(cache=True, inline="always")
def _phase_node(luts, ct, w, row, j):
    """``rt.kernel.lut_index`` at cos Θ = ``ct``: the node (as a float) and fraction into ``w``."""
    nk = luts.shape[1] - 1
    uu = math.sqrt(max(0.5 - 0.5 * ct, 0.0)) * nk
    jj = min(int(uu), nk - 1)
    _put(w, row, j, jj)
    _put(w, row + 1, j, uu - jj)


@njit(cache=True, error_model="numpy", fastmath=True)
def _index_pass(x, y, z, w, k):
    """Where the block's rays read the tables (arithmetic and counts: vectorised).

    ``x``, ``y``, ``z`` are the block's slices, ``k`` the scattering kernel's arguments. A table's
    row is found by counting its row cosines (descending) at or above the ray's, a table row at a
    time over the block's rays. The binary searches' branches cost ~25 ns a ray in the staged
    layout (timed with the rows held fixed, best of 50 on a noisy VM); this whole pass ~12–14.
    """
    sx, sy, sz = k[3], k[4], k[5]
    luts = k[11]
    t_in, t_out = k[14], k[16]
    cos_c_frame, cos_c_table, dphi, cphi, sphi = k[17], k[18], k[19], k[20], k[21]
    b = x.shape[0]
    for j in range(b):
        vx = float(x[j])
        vy = float(y[j])
        vz = float(z[j])
        _phase_node(luts, min(max(vx * sx + vy * sy + vz * sz, -1.0), 1.0), w, _PJ, j)
        _phase_node(luts, min(max(vx * sx + vy * sy - vz * sz, -1.0), 1.0), w, _RPJ, j)
        # scatter_pixels' mapping of this water's window edge onto the table's, in cos θ.
        inside = vz > cos_c_frame
        in_t = 1.0 - (1.0 - vz) * (1.0 - cos_c_table) / (1.0 - cos_c_frame)
        out_t = vz * cos_c_table / cos_c_frame if vz > 0.0 else vz
        _put(w, _CZT, j, in_t if inside else out_t)
        # The azimuth from the sun, folded onto [0, π] (U changes sign under the mirror).
        px = vx * cphi + vy * sphi
        py = -vx * sphi + vy * cphi
        _put(w, _AZ + 2, j, -1.0 if py < 0.0 else 1.0)
        p = _atan2_pos(abs(py), px) / dphi + 0.5
        jc = int(p)
        _put(w, _AZ, j, jc)
        _put(w, _AZ + 1, j, p - jc)
        _put(w, _CNT, j, 0.0)
        _put(w, _CUP, j, 0.0)
    for r in range(t_in.shape[0]):
        tr = t_in[r]
        for j in range(b):
            inside = float(z[j]) > cos_c_frame
            _put(w, _CNT, j, _at(w, _CNT, j) + (1.0 if inside and tr >= _at(w, _CZT, j) else 0.0))
    for r in range(t_out.shape[0]):
        tr = t_out[r]
        for j in range(b):
            vz = float(z[j])
            outside = not vz > cos_c_frame
            _put(w, _CNT, j, _at(w, _CNT, j) + (1.0 if outside and tr >= _at(w, _CZT, j) else 0.0))
            _put(w, _CUP, j, _at(w, _CUP, j) + (1.0 if tr >= -vz else 0.0))


@njit(cache=True, inline="always")
def _row(count, t_cos, cz):
    """``column_kernel._row``'s (row, fraction) from a count of :func:`_index_pass`'s."""
    n = t_cos.shape[0]
    c = int(count)
    if c == 0:
        return 0, 0.0
    if c >= n:
        return n - 2, 1.0
    r = c - 1
    return r, (t_cos[r] - cz) / (t_cos[r] - t_cos[r + 1])


@njit(cache=True, inline="always")
def _bilinear(grid, r, fr, jc, fp, w, row, j):
    """``column_kernel._lookup``'s interpolation at row r and column jc (clamped here), into w."""
    last = grid.shape[1] - 2
    if jc > last:
        fp += jc - last
        jc = last
    w00 = (1.0 - fr) * (1.0 - fp)
    w01 = (1.0 - fr) * fp
    w10 = fr * (1.0 - fp)
    w11 = fr * fp
    for c in range(3):
        v = w00 * grid[r, jc, c] + w01 * grid[r, jc + 1, c] + w10 * grid[r + 1, jc, c]
        _put(w, row + c, j, v + w11 * grid[r + 1, jc + 1, c])


@njit(cache=True, inline="always")
def _phase(luts, w, node, row, j):
    """``_single``'s phase-matrix rows β, m12, m22, m33 at a node of :func:`_index_pass`'s."""
    jj = int(_at(w, node, j))
    f = _at(w, node + 1, j)
    g0 = 1.0 - f
    for c in range(4):
        _put(w, row + c, j, luts[c, jj] * g0 + luts[c, jj + 1] * f)


@njit(cache=True, error_model="numpy", fastmath=True)
def _gather_pass(x, y, z, cos_air, occluded, basis, column, sees, lo, w, up_c, north_c, k):
    """The block's table reads (scalar: LLVM does not vectorise a read at a computed index).

    Rays ``lo`` to ``lo + BLOCK`` (or the end) of the whole arrays; ``sees`` is written here.
    """
    (single, _, _, sx, sy, sz, _, _, _, _, _, luts, has_field, f_in, t_in, f_out, t_out,
     cos_c_frame, _, _, cphi, sphi, agrid, apsi, dom, up, _) = k  # fmt: skip
    do_refl = has_field and up.shape[0] > 1
    do_aur = has_field and apsi.shape[0] > 1
    cos_aur = math.cos(apsi[apsi.shape[0] - 1]) if do_aur else 2.0
    any_occ = occluded.shape[0] > 0
    for i in range(lo, min(lo + BLOCK, x.shape[0])):
        j = i - lo
        vx = float(x[i])
        vy = float(y[i])
        vz = float(z[i])
        if single:
            _phase(luts, w, _PJ, _PH, j)
        else:  # zero rows: the arithmetic pass adds zeros, without a branch
            for r in range(_PH, _PH + 4):
                _put(w, r, j, 0.0)
        refl = False
        if has_field:
            # scatter_pixels' field, aureole and reflection, at the index pass's nodes.
            inside = vz > cos_c_frame
            jc = int(_at(w, _AZ, j))
            fp = _at(w, _AZ + 1, j)
            sign = _at(w, _AZ + 2, j)
            if inside:
                r, fr = _row(_at(w, _CNT, j), t_in, _at(w, _CZT, j))
                _bilinear(f_in, r, fr, jc, fp, w, _TAB, j)
            else:
                r, fr = _row(_at(w, _CNT, j), t_out, _at(w, _CZT, j))
                _bilinear(f_out, r, fr, jc, fp, w, _TAB, j)
            _put(w, _TAB + 2, j, sign * _at(w, _TAB + 2, j))
            if do_aur and vx * sx + vy * sy + vz * sz > cos_aur:
                ai, aq, au = aureole_at(vx, vy, vz, sx, sy, sz, cphi, sphi, agrid, apsi, dom)
                _put(w, _TAB, j, _at(w, _TAB, j) + ai)
                _put(w, _TAB + 1, j, _at(w, _TAB + 1, j) + aq)
                _put(w, _TAB + 2, j, _at(w, _TAB + 2, j) + au)
            if do_refl and inside:
                refl = True
                r, fr = _row(_at(w, _CUP, j), t_out, -vz)
                _bilinear(up, r, fr, jc, fp, w, _UP, j)
                _put(w, _UP + 2, j, sign * _at(w, _UP + 2, j))
                if single:
                    _phase(luts, w, _RPJ, _RPH, j)
        else:
            for r in range(_TAB, _TAB + 3):
                _put(w, r, j, 0.0)
        if not refl:
            for r in range(_UP, _UP + 3):
                _put(w, r, j, 0.0)
        if not (refl and single):
            for r in range(_RPH, _RPH + 4):
                _put(w, r, j, 0.0)
        _put(w, _REF, j, 1.0 if refl else 0.0)
        # Whether the sky reaches the ray: inside the window, not occluded.
        see = float(cos_air[i]) > 0.0
        sees[i] = see
        _put(w, _LIT, j, 1.0 if see and not (any_occ and occluded[i] != 0) else 0.0)
        # The lens's meridional mapping: up's projections on the sensor axes (North at the
        # exact zenith).
        jb = column[i]
        rx, ry, rz = basis[0, jb], basis[1, jb], basis[2, jb]
        tx, ty, tz = basis[3, jb], basis[4, jb], basis[5, jb]
        cc = up_c[0] * rx + up_c[1] * ry + up_c[2] * rz
        ss = up_c[0] * tx + up_c[1] * ty + up_c[2] * tz
        n2 = cc * cc + ss * ss
        if n2 == 0.0:
            cc = north_c[0] * rx + north_c[1] * ry + north_c[2] * rz
            ss = north_c[0] * tx + north_c[1] * ty + north_c[2] * tz
            n2 = 1.0
        _put(w, _LENS, j, cc)
        _put(w, _LENS + 1, j, ss)
        _put(w, _LENS + 2, j, n2)


@njit(cache=True, inline="always")
def _single(vx, vy, vz, w, ph, g, sx, sy, sz, beam_q, r0x, r0y, r0z, f, j):
    """column_kernel._single from its table rows at ``ph`` and path factor g, branches as selects.

    ``f`` = E μ_s / c, the beam's factor. (I, Q, U) in the meridian reference of −v.
    """
    # meridian(−v): ⟂ −v in the vertical plane, towards +z; North at the poles.
    h = 1.0 - vz * vz
    pole = h <= 1e-12
    inv = 1.0 / math.sqrt(1.0 if pole else h)
    mx = 0.0 if pole else -vz * vx * inv
    my = 1.0 if pole else -vz * vy * inv
    mz = 0.0 if pole else h * inv
    ct = min(max(vx * sx + vy * sy + vz * sz, -1.0), 1.0)
    # e1 ⟂ d0 = −ŝ towards d = −v: (−v + ct ŝ)/sin Θ (the beam's reference straight along it).
    e1x = -vx + ct * sx
    e1y = -vy + ct * sy
    e1z = -vz + ct * sz
    st = math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    along = st <= 1e-9
    ist = 1.0 / (1.0 if along else st)
    e1x = r0x if along else e1x * ist
    e1y = r0y if along else e1y * ist
    e1z = r0z if along else e1z * ist
    st = 0.0 if along else st
    # χ₁ from r0 to e1 about d0 = −ŝ.
    c1 = r0x * e1x + r0y * e1y + r0z * e1z
    s1 = -((r0y * e1z - r0z * e1y) * sx + (r0z * e1x - r0x * e1z) * sy
           + (r0x * e1y - r0y * e1x) * sz)  # fmt: skip
    q1 = (c1 * c1 - s1 * s1) * beam_q
    u1 = -2.0 * c1 * s1 * beam_q
    m12 = _at(w, ph + 1, j)
    oi = 1.0 + m12 * q1
    oq = m12 + _at(w, ph + 2, j) * q1
    ou = _at(w, ph + 3, j) * u1
    # e2 = cos Θ e1 + sin Θ ŝ; χ₂ from e2 to the meridian about d = −v.
    e2x = ct * e1x + st * sx
    e2y = ct * e1y + st * sy
    e2z = ct * e1z + st * sz
    c2 = e2x * mx + e2y * my + e2z * mz
    s2 = -((e2y * mz - e2z * my) * vx + (e2z * mx - e2x * mz) * vy
           + (e2x * my - e2y * mx) * vz)  # fmt: skip
    n2 = c2 * c2 + s2 * s2
    flat = n2 <= 0.0
    in2 = 1.0 / (1.0 if flat else n2)
    cc = 1.0 if flat else (c2 * c2 - s2 * s2) * in2
    ss = 0.0 if flat else 2.0 * c2 * s2 * in2
    lss = _at(w, ph, j) * g * f
    return lss * oi, lss * (cc * oq + ss * ou), lss * (-ss * oq + cc * ou)


@njit(cache=True, error_model="numpy", fastmath=True)
def _transcendental_pass(x, y, z, cos_air, w, sky, n, k):
    """The block's exponentials and arc cosines (its slices ``x`` … ``cos_air``): vectorised.

    The transmittance from the surface and single scattering's path factor along each ray, and
    the sky's radiance along its window direction, into the scratch. A loop of its own: with
    the polynomials' constants in the arithmetic pass's loop, that loop spilled registers.
    """
    cz, sz = k[1], k[5]
    ssx, ssy, ssz, a_c, b_c, c_c, d_c, e_c, edh = sky[:9]
    mu_s = max(sz, 1e-3)
    a1 = cz / mu_s
    e_a1 = math.exp(-a1)  # the beam's attenuation to the camera's depth
    for j in range(x.shape[0]):
        vx = float(x[j])
        vy = float(y[j])
        vz = float(z[j])
        # The transmittance from the surface along v, and column_kernel._single's path factor:
        # |e^(−a1) − e^(−a2)| / |μ_s − v_z| looking up, its series form where a2 ≈ a1 (there
        # e^(−min(a1, a2)) (1 − e^(−x)) / |μ_s − v_z|, x = |a2 − a1|); e^(−a1)/(μ_s − v_z) down.
        looks_up = vz > 0.0
        vzp = vz if looks_up else 1.0
        a2 = cz / vzp
        e_a2 = _exp_neg(-a2) if looks_up else 0.0
        _put(w, _T, j, e_a2)
        dm = max(abs(mu_s - vz), 1e-9)
        xx = cz * dm / (mu_s * vzp)
        series = xx * (1.0 - xx * (0.5 - xx * (1.0 / 6.0 - xx * (1.0 / 24.0 - xx * (1.0 / 120.0)))))
        g_up = abs(e_a1 - e_a2) / dm if abs(a2 - a1) > 1e-3 else max(e_a1, e_a2) * series / dm
        _put(w, _G, j, g_up if looks_up else e_a1 / (mu_s - vz))
        # The CIE sky's radiance (sky.py's gradation and indicatrix; the 15 types' b, d < 0).
        lit = _at(w, _LIT, j) > 0.0
        ca = float(cos_air[j])
        cg = n * vx * ssx + n * vy * ssy + ca * ssz
        _put(w, _CG, j, cg if lit else -2.0)
        rad = e_c * cg * cg + (1.0 - c_c * edh)
        rad += c_c * _exp_neg(d_c * _acos(min(max(cg, -1.0), 1.0)))
        rad *= 1.0 + a_c * _exp_neg(b_c / (ca if lit else 1.0))
        _put(w, _RAD, j, rad if lit else 0.0)


@njit(cache=True, error_model="numpy", fastmath=True)
def _arithmetic_pass(x, y, z, cos_air, w, sky, n, scale, k):
    """The block's arithmetic (its slices ``x`` … ``cos_air``): branch-free, so vectorised.

    Into the scratch's :data:`_OUT` rows, which it does not read. A frame without a lit beam has
    zero phase rows, so single scattering adds zeros here without a branch.
    """
    c, sx, sy, sz, e_sun, beam_q, r0x, r0y, r0z = k[2:11]
    n_water = k[26]
    ssx, ssy, ssz = sky[0], sky[1], sky[2]
    sky_scale, dop_max = sky[9], sky[10]
    pol = sky_scale * dop_max
    g = n * n  # the n² radiance law
    mu_s = max(sz, 1e-3)
    f = e_sun * mu_s / c
    for j in range(x.shape[0]):
        vx = float(x[j])
        vy = float(y[j])
        vz = float(z[j])
        g1 = _at(w, _G, j)
        a, b, d = _single(vx, vy, vz, w, _PH, g1, sx, sy, sz, beam_q, r0x, r0y, r0z, f, j)
        si = _at(w, _TAB, j) + a
        sq = _at(w, _TAB + 1, j) + b
        su = _at(w, _TAB + 2, j) + d
        # Along the mirror v', looking down: only e^(−a1) enters, at c z = 0 (column_kernel).
        # (Its phase rows are zero where the reflection is not added: there its factor need
        # only be finite, and μ_s + v_z may be 0 looking down.)
        g2 = 1.0 / (mu_s + vz if vz > 0.0 else 1.0)
        a, b, d = _single(vx, vy, -vz, w, _RPH, g2, sx, sy, sz, beam_q, r0x, r0y, r0z, f, j)
        ui = _at(w, _UP, j) + a
        uq = _at(w, _UP + 1, j) + b
        uu = _at(w, _UP + 2, j) + d
        # column_kernel.fresnel_up_meridian at incidence cosine v_z, attenuated to the camera.
        refl = _at(w, _REF, j) > 0.0
        t = _at(w, _T, j)
        cos_t = math.sqrt(max(1.0 - n_water * n_water * (1.0 - vz * vz), 0.0))
        ias = 1.0 / (n_water * vz + cos_t if refl else 1.0)  # (rays without it: any finite)
        iap = 1.0 / (vz + n_water * cos_t if refl else 1.0)
        rs = (n_water * vz - cos_t) * ias
        rp = (vz - n_water * cos_t) * iap
        ra = 0.5 * (rp * rp + rs * rs)
        rd = 0.5 * (rp * rp - rs * rs)
        tr = t if refl else 0.0
        si += tr * (ra * ui + rd * uq)
        sq += tr * (rd * ui + ra * uq)
        su += tr * (rp * rs * uu)
        cc = _at(w, _LENS, j)
        ss = _at(w, _LENS + 1, j)
        in2 = 1.0 / _at(w, _LENS + 2, j)
        c2 = (cc * cc - ss * ss) * in2
        s2 = 2.0 * cc * ss * in2
        _put(w, _OUT + 3, j, si * scale)
        _put(w, _OUT + 4, j, (c2 * sq + s2 * su) * scale)
        _put(w, _OUT + 5, j, (c2 * su - s2 * sq) * scale)
        # The sky's Rayleigh polarization (reference North at the exact zenith), through the
        # flat sea's Fresnel transmission, times the transmittance.
        lit = _at(w, _LIT, j) > 0.0
        ca = float(cos_air[j])
        px = n * vx
        py = n * vy
        hh = px * ssx + py * ssy
        rad = _at(w, _RAD, j)
        rho2 = px * px + py * py
        zen = rho2 == 0.0
        pa = -ssx if zen else py * ssx - px * ssy
        pb = ssy if zen else rho2 * ssz - ca * hh
        rho2 = 1.0 if zen else rho2
        a2 = pa * pa
        b2 = pb * pb
        amp = rad / (2.0 * rho2 - a2 - b2 if lit else 1.0) * pol
        wi = rad * sky_scale
        wq = (a2 - b2) * amp
        wu = 2.0 * pa * pb * amp
        m00, m01, m22 = fresnel_in(n, g, ca, vz)
        tl = t if lit else 0.0
        si += (m00 * wi + m01 * wq) * tl
        sq += (m01 * wi + m00 * wq) * tl
        su += m22 * wu * tl
        _put(w, _OUT, j, si * scale)
        _put(w, _OUT + 1, j, (c2 * sq + s2 * su) * scale)
        _put(w, _OUT + 2, j, (c2 * su - s2 * sq) * scale)


@njit(cache=True, error_model="numpy", fastmath=True)
def _candidate_pass(x, y, z, cos_air, lo, w, cand, cand_chi, cand_resp, ncand, n, sky,
                    cos_reach, scale):  # fmt: skip
    """The block's rays that may see the solar disc, listed from ``ncand`` (few: scalar)."""
    g = n * n
    for j in range(min(BLOCK, x.shape[0] - lo)):
        if _at(w, _LIT, j) > 0.0 and _at(w, _CG, j) >= cos_reach:
            i = lo + j
            ca = float(cos_air[i])
            px = n * float(x[i])
            py = n * float(y[i])
            m00, m01, _ = fresnel_in(n, g, ca, float(z[i]))
            t = _at(w, _T, j)
            cc = _at(w, _LENS, j)
            ss = _at(w, _LENS + 1, j)
            n2 = _at(w, _LENS + 2, j)
            c2 = (cc * cc - ss * ss) / n2
            s2 = 2.0 * cc * ss / n2
            nrm = math.sqrt(px * px + py * py + ca * ca)
            dx = px / nrm - sky[0]
            dy = py / nrm - sky[1]
            dz = ca / nrm - sky[2]
            chord = math.sqrt(dx * dx + dy * dy + dz * dz)
            cand[ncand] = i
            cand_chi[ncand] = 2.0 * math.asin(min(0.5 * chord, 1.0))
            cand_resp[ncand, 0] = m00 * t * scale
            cand_resp[ncand, 1] = c2 * m01 * t * scale
            cand_resp[ncand, 2] = -s2 * m01 * t * scale
            ncand += 1
    return ncand


@njit(cache=True, error_model="numpy", fastmath=True)
def chain_points(
    x, y, z, cos_air, occluded, basis, column, out, scat, sees, cand, cand_chi, cand_resp,
    n, sky, cos_reach, up_c, north_c, scale, w, k,
):  # fmt: skip
    """The exact chain at m rays; returns the number of solar-disc candidates listed.

    Args (in order): x, y, z ((m,) float32 ENU look components); cos_air ((m,) float32 cosine
    of the refracted ray in air, 0 outside Snell's window); occluded ((m,) uint8, or (0,): none);
    basis, column ((6, M) the sensor axes r_s, t_s of M rays, and the column of each of the m);
    out ((m, 3) float32 sensor-plane Stokes, photons/s, before the clamp); scat ((m, 3) the
    scattered part alone, or (0, 3): not wanted); sees ((m,) bool); cand, cand_chi, cand_resp
    ((m,), (m,), (m, 3)): the rays that may see the solar disc, their angle from the sun in air
    and their sensor-plane response to a unit unpolarized sky radiance; n (the water's index);
    sky (the sun in air, the CIE coefficients a–e, e^(dπ/2), the scale, the maximum degree of
    polarization: ``chain_kernel.render_points``'); cos_reach (a ray is a disc candidate when
    the cosine of its sky direction's angle from the sun is at least this); up_c, north_c (ENU
    up and North in the camera frame: rows 2 and 1 of C_c^n); scale (the photon scale); w
    ((:data:`SCRATCH_ROWS` · :data:`BLOCK`,) float64 scratch); k
    (:func:`column_kernel.scatter_pixels`'s arguments after ``out``).
    """
    m = x.shape[0]
    want_scat = scat.shape[0] > 0
    ncand = 0
    for lo in range(0, m, BLOCK):
        hi = min(lo + BLOCK, m)
        _index_pass(x[lo:hi], y[lo:hi], z[lo:hi], w, k)
        _gather_pass(x, y, z, cos_air, occluded, basis, column, sees, lo, w, up_c, north_c, k)
        _transcendental_pass(x[lo:hi], y[lo:hi], z[lo:hi], cos_air[lo:hi], w, sky, n, k)
        _arithmetic_pass(x[lo:hi], y[lo:hi], z[lo:hi], cos_air[lo:hi], w, sky, n, scale, k)
        for j in range(hi - lo):
            for c in range(3):
                out[lo + j, c] = _at(w, _OUT + c, j)
                if want_scat:
                    scat[lo + j, c] = _at(w, _OUT + 3 + c, j)
        ncand = _candidate_pass(x, y, z, cos_air, lo, w, cand, cand_chi, cand_resp, ncand, n,
                                sky, cos_reach, scale)  # fmt: skip
    return ncand
