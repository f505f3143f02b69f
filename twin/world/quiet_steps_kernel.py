"""Quiet physics steps, compiled: :meth:`Plant.step` and the IMU's sample, many steps in one call.

Most steps of a run carry the IMU's sample alone (90 of 100 a simulated second in a sea trial,
one of them also delivering the depth gauge's reading sampled before).
Flown one by one from Python each cost ~50 µs, of which MuJoCo and the kernels took ~13 µs
(``benchmarks/results/sea_trial_profile.md`` before these blocks, at 57e688b; a block's step
costs ~32 µs now, its depth updates included). :func:`fly` runs a block of them in one call:
per step the command limiter's arithmetic, ``mj_step2``, ``mj_step1``, the hydrodynamic wrench
(:func:`twin.world.hydrodynamics_kernel.body_wrench`), ``mj_forwardSkip`` and the IMU's sample
(:func:`sensors.imu_kernel.sample`), in :meth:`Plant.step`'s and :meth:`Imu.sample`'s order, on
the same numbers: so the same state and samples bit for bit (``tests/sim/test_quiet_steps.py``).

MuJoCo's functions come in as arguments: their addresses in the ``libmujoco`` the Python
bindings loaded, with the model's and data's, as integers, called through :func:`_call_md` and
:func:`_call_md_ii` (a C call at an address, in LLVM). A kernel that named the functions as
globals could not be cached (their addresses change from process to process); one that takes
them as integers is, like every other kernel here, and integers are what numba's dispatcher
types fastest (numba's first-class function objects cost ~10 µs each a call to type).
"""

from __future__ import annotations

import math

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from sensors.imu_kernel import sample as imu_sample
from twin.core.kernel_cache import njit
from twin.world.hydrodynamics_kernel import body_wrench

# (The two kernels above are bound by name here, not looked up in their modules when this one is
# compiled: a profiler that wraps their modules' attributes in Python timers leaves them be.)

#: ``mjtStage.mjSTAGE_VEL``: what :meth:`Plant._sync` skips in ``mj_forwardSkip``.
STAGE_VEL = 2

_I8P = ir.IntType(8).as_pointer()


@intrinsic
def _call_md(typingctx, fn, m, d):  # type: ignore[no-untyped-def]
    """Call ``void fn(const mjModel* m, mjData* d)``, every argument an address (intp)."""
    sig = types.void(types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        fn_addr, m_addr, d_addr = args
        fnty = ir.FunctionType(ir.VoidType(), [_I8P, _I8P])
        f = builder.inttoptr(fn_addr, fnty.as_pointer())
        builder.call(f, [builder.inttoptr(m_addr, _I8P), builder.inttoptr(d_addr, _I8P)])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def _call_md_ii(typingctx, fn, m, d, a, b):  # type: ignore[no-untyped-def]
    """Call ``void fn(const mjModel* m, mjData* d, int a, int b)`` (addresses as intp)."""
    sig = types.void(types.intp, types.intp, types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        fn_addr, m_addr, d_addr, a_val, b_val = args
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [_I8P, _I8P, i32, i32])
        f = builder.inttoptr(fn_addr, fnty.as_pointer())
        builder.call(
            f,
            [
                builder.inttoptr(m_addr, _I8P),
                builder.inttoptr(d_addr, _I8P),
                builder.trunc(a_val, i32),
                builder.trunc(b_val, i32),
            ],
        )
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True)
def fly(  # type: ignore[no-untyped-def]
    step1, step2, forward_skip, m_ptr, d_ptr, stage_vel, dt, lo, hi, rate, act_ids, ctrl,
    qpos, qvel, i_z, i_dof, surface_z, lat0, r_m, i_y,
    xmat, qvel6, passive6, bias6, applied6, act, ids, current, k_consts, strips, ma, buoyancy_n,
    radius, minv, rhs,
    gyro, accel, linvel, site_pos, c_sn, earth_terms, e_consts, block, turn_on, gm_value,
    rw_value, rw_density, has_rw, white_sigma, white_value,
    n, t, command, last, t_last, gm_phi, gm_q, normals, out,
):  # fmt: skip
    """Fly ``n`` steps under one command; returns how many (fewer: the state went non-finite).

    The arguments before ``n`` stay the same from block to block (MuJoCo's functions, model and
    data; :meth:`Plant.step`'s and :meth:`Imu.sample`'s, named as there). ``t`` is MuJoCo's
    clock before the first step: each step adds ``dt`` to it as ``mj_step2`` does (the caller
    checks the clock it reads back). Per step ``k``: the limited command into ``ctrl`` (``last``
    updated), physics, then the IMU's sample from ``normals[k]`` (3, 6) into ``out[k]`` (6,).
    """
    for k in range(n):
        # CommandLimiter.__call__
        for i in range(3):
            x = command[i]
            x = hi[i] if x > hi[i] else (lo[i] if x < lo[i] else x)
            step = rate[i] * dt
            d = x - last[i]
            x = last[i] + (step if d > step else (-step if d < -step else d))
            last[i] = x
        for i in range(3):
            ctrl[act_ids[i]] = last[i]
        _call_md(step2, m_ptr, d_ptr)
        t = t + dt
        # Plant._sync
        _call_md(step1, m_ptr, d_ptr)
        depth = surface_z - qpos[i_z]
        body_wrench(
            xmat, qvel6, depth, current, act, ids, passive6, bias6, k_consts, strips, ma,
            buoyancy_n, radius, minv, rhs, applied6,
        )  # fmt: skip
        _call_md_ii(forward_skip, m_ptr, d_ptr, stage_vel, 0)
        if not math.isfinite(qpos[i_z]) or not math.isfinite(qvel[i_dof]):
            return k
        # Imu.sample (its measure_compiled)
        lat = lat0 + qpos[i_y] / r_m
        h = site_pos[2] - surface_z
        out[k] = imu_sample(
            gyro, accel, linvel, c_sn, h, lat, earth_terms, e_consts, block, turn_on, gm_value,
            gm_phi, gm_q, rw_value, rw_density, t - t_last, has_rw, white_sigma, white_value,
            normals[k],
        )  # fmt: skip
        t_last = t
    return n
