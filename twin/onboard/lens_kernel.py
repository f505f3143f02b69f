"""The inverse lens transfer at some pixels of a grid, compiled (issue #31).

:func:`twin.onboard.lens.apply_inverse`'s algebra (into the pixel's radial frame, the inverse of
[[1, D, 0], [D, a, 0], [0, 0, c]] / T̄, back) as one loop over the pixels a method uses, reading
each one's factors from the grid's arrays in place: no gathered copies of the six factor arrays
and no (N,) temporary per operation. The same operations in the same order in double precision
(numba compiles them without fused multiply-adds), so the numbers are numpy's bit for bit
(``tests/sensors/polarimeter/test_lens.py``); the angles stay numpy's (its own arctan2 and hypot).
"""

from __future__ import annotations

from twin.core.kernel_cache import njit


@njit(cache=True)
def undo_at(s0m, s1m, s2m, idx, cos2, sin2, a, d, k, tc, s0, s1, s2):  # type: ignore[no-untyped-def]
    """s0, s1, s2[i] ← the inverse transfer of (s0m, s1m, s2m)[i] at grid pixel idx[i]."""
    for i in range(idx.shape[0]):
        j = idx[i]
        c = cos2[j]
        s = sin2[j]
        x0 = float(s0m[i])
        x1 = float(s1m[i])
        x2 = float(s2m[i])
        r1 = c * x1 + s * x2  # radial frame
        r2 = -s * x1 + c * x2
        s0[i] = (a[j] * x0 - d[j] * r1) * k[j]
        q1 = (r1 - d[j] * x0) * k[j]
        q2 = r2 / tc[j]
        s1[i] = c * q1 - s * q2
        s2[i] = s * q1 + c * q2
