"""The sensor's per-pixel passes (numba): expected charge, then noise, gain and the ADC.

Stage 7 of the polarimeter chain, the arithmetic of
:class:`sensors.polarimeter.unit.mosaic.DoFPSensor`
in two compiled loops over a band of pixels, in place of five OpenCV/numpy passes
(``cv2.multiply`` + ``cv2.transform``; ``np.add`` + ``np.sqrt`` + ``cv2.accumulateProduct`` +
``cv2.addWeighted`` + ``cv2.min``). Why: each of those streams the band through memory once; the
loops stream it once per pass and keep the temporaries in registers (a 612×512 frame's sensor
stage 1.9 → 1.5 ms, ``benchmarks/results/polarimeter_frame.md``).

Same numbers: the loops do the float32 operations OpenCV 4.14's AVX2 paths do, in their order,
with their fused multiply-adds (``llvm.fma``, :func:`fma32`), so the raw frames are the OpenCV
chain's bit for bit (``tests/sensors/polarimeter/test_mosaic_kernel.py`` compares them with
:meth:`DoFPSensor._render_mosaic_reference`, the OpenCV chain, kept for that):

* expected charge, ``cv2.transform`` with the row [t, t, t, dark] on p = S ∘ a (per channel):
  fma(t, p₂, fma(t, p₀, t p₁)) + dark;
* noise, ``cv2.accumulateProduct``: fma(√(λ + σ²), z, λ);
* gain and offset, ``cv2.addWeighted(λ, 1/K, DSNU, 1/K, black)``:
  fma(λ, 1/K, fma(DSNU, 1/K, black)) (without DSNU, β = 0: fma(λ, 1/K, black)), rounded half to
  even and saturated to uint16.

The photon-counting pixels (λ below ``POISSON_BELOW_E``, whose shot noise is drawn exactly) are
found in one pass (:func:`low_counts`, ``np.flatnonzero`` of numpy's two comparisons) and get
their counts plus read noise in another (:func:`set_counts`, numpy's float32 product and sum);
the Poisson draws themselves stay numpy's, from the run's Generator. The row noise is added to
λ as :func:`to_dn` reads it (numpy's float32 ``lam += rows`` was a pass of its own).

One difference, a fix: OpenCV rounds through int32 and turns a value past 2³¹ into 0. The ideal
camera's sun can get there (K = 1 e⁻/DN, its auto exposure set by the sky), and read black;
the loop saturates it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import intrinsic

from twin.core.kernel_cache import njit


@intrinsic
def fma32(typingctx, a, b, c):
    """a·b + c rounded once (float32), as the hardware's fused multiply-add computes it."""
    sig = types.float32(types.float32, types.float32, types.float32)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return sig, codegen


@njit(cache=True, inline="always")
def _charge(stokes, analysis, t_s, dark_e, k):
    """t·(S·a)[k] + dark: ``cv2.transform``'s row [t, t, t, dark] on p = S ∘ a, its FMAs."""
    p0 = stokes[3 * k] * analysis[3 * k]
    p1 = stokes[3 * k + 1] * analysis[3 * k + 1]
    p2 = stokes[3 * k + 2] * analysis[3 * k + 2]
    return fma32(t_s, p2, fma32(t_s, p0, t_s * p1)) + dark_e


@njit(cache=True, error_model="numpy")
def expected_charge(stokes, analysis, t_s, dark_e, out):
    """out[k] = max(t·(S·a)[k] + dark, 0) for flat (3 m,) Stokes and analysis, (m,) out."""
    zero = np.float32(0.0)
    for k in range(out.shape[0]):
        out[k] = max(_charge(stokes, analysis, t_s, dark_e, k), zero)


@njit(cache=True, error_model="numpy")
def add_hot(stokes, analysis, t_s, dark_e, index, extra, out):
    """out[i] = max(t·(S·a)[i] + dark + extra, 0) at the hot pixels ``index`` (the extra dark)."""
    zero = np.float32(0.0)
    for i in index:
        out[i] = max(_charge(stokes, analysis, t_s, dark_e, i) + extra, zero)


@njit(cache=True, error_model="numpy")
def shot_and_read(lam, z, read_var):
    """λ ← λ + √(λ + σ²)·z in place: shot and read noise as one Gaussian (float32)."""
    for k in range(lam.shape[0]):
        v = lam[k]
        lam[k] = fma32(np.float32(math.sqrt(v + read_var)), z[k], v)


@njit(cache=True, error_model="numpy")
def low_counts(lam, lo, hi, index):
    """index[:n] = the k with lo ≤ λ[k] < hi, in order; returns n (``np.flatnonzero``'s).

    The pixels whose shot noise is drawn exactly (Poisson): one pass where numpy's two
    comparisons, their conjunction, ``any`` and ``flatnonzero`` made five.
    """
    n = 0
    for k in range(lam.shape[0]):
        v = lam[k]
        if v >= lo and v < hi:
            index[n] = k
            n += 1
    return n


@njit(cache=True, error_model="numpy")
def set_counts(lam, z, index, counts, read_e):
    """λ[i] = counts + σ_read·z[i] at the Poisson pixels (float32, numpy's two operations)."""
    for j in range(index.shape[0]):
        i = index[j]
        lam[i] = counts[j] + read_e * z[i]


@njit(cache=True, error_model="numpy")
def to_dn(lam, rows, width, dsnu, has_dsnu, inv_k, black, sat, out):
    """The raw DN: min(saturate_u16(rint((λ + row)/K + DSNU/K + black)), sat), flat (m,) arrays.

    ``rows``: each row's noise (e⁻, float32; zeros for none), added to λ first as numpy's
    ``lam += rows`` did, a row at a time (the inner loop then vectorises: a branch on whether
    there is row noise, or a division for the row, kept it scalar at 13× the time, measured);
    ``width``: the pixels in a row. Adding a zero changes no DN: x + 0 is x but for −0, which
    reads 0 as +0 does.
    """
    top = np.float32(65535.0)
    zero = np.float32(0.0)
    for r in range(lam.shape[0] // width):
        add = rows[r]
        base = r * width
        for c in range(width):
            v = lam[base + c] + add
            if has_dsnu:
                x = fma32(v, inv_k, fma32(dsnu[base + c], inv_k, black))
            else:
                x = fma32(v, inv_k, black)
            q = np.rint(x)
            if not q > zero:  # NaN too, as OpenCV's rounding of a NaN to int saturates to 0
                q = zero
            elif q > top:
                q = top
            u = np.uint16(q)
            out[base + c] = u if u < sat else sat
