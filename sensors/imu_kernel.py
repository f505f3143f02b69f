"""The IMU's sample, compiled: :meth:`Imu._ideal` and :meth:`_ErrorModel.measure` in one call.

At 100 Hz the Python sample (the Earth terms in floats, then a dozen small numpy operations on
the error processes) cost ~12 µs, nearly all of it per-call overhead. :func:`sample` is the same
arithmetic in the same order: the matrix products through BLAS as numpy's (numba's ``np.dot``
calls the same routines), elementwise operations as numpy does them, ``sin²`` through libm's
``pow`` as CPython's ``**`` (the exponent passed in, so LLVM cannot turn it into a product, see
:mod:`twin.world.hydrodynamics_kernel`). So a compiled sample is the Python one bit for bit
(``tests/sensors/test_imu_kernel.py``); :attr:`Imu.compiled` False takes the Python path.
"""

from __future__ import annotations

import math

import numpy as np

from twin.core.kernel_cache import njit


@njit(cache=True)
def sample(  # type: ignore[no-untyped-def]
    gyro, accel, linvel, c_sn, h, lat, earth_terms, consts, block, turn_on, gm_value, gm_phi,
    gm_q, rw_value, rw_density, dt, has_rw, white_sigma, white_value, w,
):  # fmt: skip
    """The measured [angular_rate, specific_force] (6,); the error processes advanced in place.

    Args (in order): the MJCF gyro, accelerometer and linvel readings (3,); the site's C_s^n
    (3, 3); its height above the surface h and latitude (rad); whether to add the Earth terms;
    ``consts`` = (a, e², Ω_ie, 2.0); the scale/misalignment block (6, 6); the turn-on bias, the
    Gauss–Markov state, φ and q, the random walk's state and density, the white noise's σ and
    last value (all (6,), [gyro, accel]); dt; whether the random walk adds; the 18 standard
    normals (3, 6): white, Gauss–Markov, random walk.
    """
    true = np.empty(6)
    for i in range(3):
        true[i] = gyro[i]
        true[3 + i] = accel[i]
    if earth_terms:
        a_m, e2, omega, two = consts
        v_e, v_n, v_u = linvel[0], linvel[1], linvel[2]
        d = 1.0 - e2 * math.pow(math.sin(lat), two)
        r_n = a_m / math.sqrt(d)
        r_m = r_n * (1.0 - e2) / d
        ie_n = omega * math.cos(lat)
        ie_u = omega * math.sin(lat)
        en_e = -v_n / (r_m + h)
        en_n = v_e / (r_n + h)
        en_u = v_e * math.tan(lat) / (r_n + h)
        a_e, a_n, a_u = en_e, 2.0 * ie_n + en_n, 2.0 * ie_u + en_u
        terms = np.empty((2, 3))
        terms[0, 0] = en_e
        terms[0, 1] = ie_n + en_n
        terms[0, 2] = ie_u + en_u
        terms[1, 0] = a_n * v_u - a_u * v_n
        terms[1, 1] = a_u * v_e - a_e * v_u
        terms[1, 2] = a_e * v_n - a_n * v_e
        rot = np.dot(terms, c_sn)
        for i in range(3):
            true[i] += rot[0, i]
            true[3 + i] += rot[1, i]
    out = np.dot(block, true)
    for i in range(6):
        gm_value[i] *= gm_phi[i]
        gm_value[i] += gm_q[i] * w[1, i]
    if has_rw:
        s = math.sqrt(max(dt, 0.0))
        for i in range(6):
            rw_value[i] += rw_density[i] * w[2, i] * s
            out[i] += rw_value[i]
    for i in range(6):
        white_value[i] = white_sigma[i] * w[0, i]
        out[i] += turn_on[i]
        out[i] += gm_value[i]
        out[i] += white_value[i]
    return out
