"""The world's quiet steps: physics and the IMU's sample alone, flown many at a time, compiled.

A step is *quiet* when the IMU's sample is all the physics side does in it: no other sensor is
due (a reading sampled before may be delivered in it, from the suite's queue, in the queue's
order), and (decided by :class:`twin.sim.step.Simulation`) no filter, observer or autopilot
acts on it beyond taking its readings. :class:`QuietSteps`
says how many of the next steps are quiet on the world's side and flies them through
:func:`twin.world.quiet_steps_kernel.fly`: :meth:`Plant.step` and :meth:`Imu.sample` in one
compiled call, the same numbers bit for bit (``tests/sim/test_quiet_steps.py``). A block may
end with the step after its quiet ones (:meth:`QuietSteps.fly_closing`): that step's physics and
IMU sample are flown with them, and the suite's poll of it, given that sample, does the rest.

It applies to the built-in configuration only: the plant's own step with the compiled wrench
and no current, the built-in command limiter, and one :class:`Imu` of its own class (compiled
sample, no delay, no clock offset) sampled every physics step (the classes checked once, the
state on every call); anything else (a sensor subclass, a current, a delayed IMU, a MuJoCo
whose library is not beside its bindings) is flown one step at a time as before.
The IMU's error processes keep their coefficients for one time step; a block ends before the
step whose time step differs (MuJoCo's running clock changes it by an ulp when it crosses a
power of two).
"""

from __future__ import annotations

import ctypes
import functools
import heapq
import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from sensors.imu import _EARTH_CONSTANTS, Imu
from sensors.suite import _EPS_STEPS, SensorSuite
from twin.core.messages import ActuatorCommand, Reading
from twin.world import quiet_steps_kernel
from twin.world.actuators import CommandLimiter
from twin.world.hydrodynamics import Hydrodynamics
from twin.world.plant import Plant

# MuJoCo's shared library beside its Python bindings, as the wheels ship it.
_LIBRARIES = ("libmujoco.so*", "libmujoco*.dylib", "mujoco*.dll")


@functools.cache
def _mujoco_functions() -> tuple[int, int, int] | None:
    """The addresses of ``mj_step1``, ``mj_step2`` and ``mj_forwardSkip`` the bindings call.

    None when the library is not where the wheels put it (the steps are then flown one by one).
    """
    here = Path(mujoco.__file__).parent
    libs = [p for pattern in _LIBRARIES for p in sorted(here.glob(pattern))]
    if not libs:
        return None
    lib = ctypes.CDLL(str(libs[-1]))  # the loaded library: dlopen returns the same handle

    def address(name: str) -> int:
        value = ctypes.cast(getattr(lib, name), ctypes.c_void_p).value
        assert value is not None
        return value

    return address("mj_step1"), address("mj_step2"), address("mj_forwardSkip")


def _plant_class_applies(plant: Plant) -> bool:
    cls = type(plant)
    return (
        all(getattr(cls, m) is getattr(Plant, m) for m in ("step", "_sync", "_apply_hydrodynamics"))
        and plant.compiled
        and type(plant.hydro).wrench_f is Hydrodynamics.wrench_f
        and plant.current.kind == "none"
        and type(plant.limiter) is CommandLimiter
        and plant.surface_z_m == 0.0
    )


def _imu_class_applies(imu: Imu) -> bool:
    return (
        type(imu) is Imu
        and imu.compiled
        and imu._kernel_applies
        and imu.delay_s == 0.0
        and getattr(imu, "clock_offset_s", 0.0) == 0.0
    )


class QuietSteps:
    """How many of the next steps are quiet on the world's side, and flying them.

    Args:
        plant: The physics.
        suite: The sensors, sampled by their schedule.
    """

    def __init__(self, plant: Plant, suite: SensorSuite) -> None:
        self.plant = plant
        self.suite = suite
        imus = [i for i, s in enumerate(suite.sensors) if isinstance(s, Imu)]
        self._imu_index = imus[0] if len(imus) == 1 else None
        self._imu = suite.sensors[imus[0]] if len(imus) == 1 else None
        # The configuration's classes and settings, checked once (a run does not swap them).
        self._applies = (
            isinstance(self._imu, Imu)
            and _imu_class_applies(self._imu)
            and _plant_class_applies(plant)
            and _mujoco_functions() is not None
        )
        self._static: tuple[Any, ...] = ()
        self._static_for: object = None
        self._normals = np.empty((16, 3, 6))

    @property
    def imu_name(self) -> str | None:
        """The IMU's sensor name (None: no single IMU, no quiet steps)."""
        return None if self._imu is None else self._imu.name

    def times(self, max_steps: int) -> list[float]:
        """The clock after each of the next quiet steps (at most ``max_steps``; none: no block).

        The times are MuJoCo's running clock, advanced as ``mj_step2`` advances it.
        """
        times, quiet = self.block_times(max_steps)
        return times[:quiet]

    def block_times(self, max_steps: int) -> tuple[list[float], int]:
        """:meth:`times`, and then the step at which another sensor is due, if one is in reach.

        Returns the clock after each step (at most ``max_steps``) and how many of them are
        quiet: all of them, or all but the last, a step that :meth:`fly_closing` can end a block
        with (its other sensors sampled in Python after the block's physics).
        """
        imu, plant, suite = self._imu, self.plant, self.suite
        if not self._applies or max_steps < 1:
            return [], 0
        assert isinstance(imu, Imu)
        i = self._imu_index
        assert i is not None
        dt = float(plant.model.opt.timestep)
        if (
            plant.limiter._last is None
            or plant._views_of is not plant.data
            or imu._t_last is None
            or suite._dt != dt
            or suite._steps_per_sample(imu) != 1.0
        ):
            return [], 0
        t = plant.t
        now = round(t / dt)
        if suite._next_step[i] != now + 1:
            return [], 0
        # Steps before any other sensor is due (its sample is Python's), and that one; a reading
        # waiting in the queue may be delivered in them (deliveries).
        last, due = now + max_steps, False
        for j, step in enumerate(suite._next_step):
            if j != i and step <= last:
                last, due = step, True
        quiet = last - now - 1 if due else last - now
        t_prev, gm_dt = imu._t_last, imu._errors.gm._dt
        if t_prev != t:
            return [], 0
        out: list[float] = []
        for _ in range(last - now):
            t = t + dt
            if t - t_prev != gm_dt:  # the Gauss–Markov coefficients would be recomputed
                break
            out.append(t)
            t_prev = t
        return out, max(0, min(quiet, len(out)))

    def deliveries(self, n: int) -> list[tuple[int, Reading, object]]:
        """The readings waiting in the suite's queue that the next ``n`` steps would deliver.

        As (step index in the block, reading, its truth), in the queue's order.
        """
        suite = self.suite
        if not suite._pending or n < 1:
            return []
        now = round(self.plant.t / float(self.plant.model.opt.timestep))
        due = sorted(e for e in suite._pending if e[0] <= now + n)
        return [(e[0] - now - 1, e[3], e[4]) for e in due]

    def _static_args(self) -> tuple[Any, ...]:
        """The kernel's arguments that stay from block to block (for this MjData)."""
        plant, imu = self.plant, self._imu
        assert isinstance(imu, Imu)
        m, d = plant.model, plant.data
        if self._static_for is d:
            return self._static
        limiter = plant.limiter
        q0 = plant._qpos
        views = plant._views
        errors = imu._errors
        turn_on, gm_value, rw_value, white_value = errors._flat
        site_pos, c_sn = plant.site_pose(imu.site)
        functions = _mujoco_functions()
        assert functions is not None  # checked in __init__
        step1, step2, forward_skip = functions
        self._static = (
            step1, step2, forward_skip, m._address, d._address, quiet_steps_kernel.STAGE_VEL,
            float(m.opt.timestep), np.array(limiter._min, dtype=np.float64),
            np.array(limiter._max, dtype=np.float64), np.array(limiter._rate, dtype=np.float64),
            np.array(plant._act_ids, dtype=np.int64), d.ctrl,
            d.qpos, d.qvel, q0 + 2, plant._dof, plant.surface_z_m, plant._lat0, plant._r_m,
            q0 + 1,
            views[0], views[1], views[2], views[3], views[4], d.act, plant._act_ids_t,
            plant._still, plant.hydro.kernel_constants, plant.hydro._strips, plant._ma_b_tuple,
            plant._buoyancy_n, plant._radius, plant._minv_total_b, plant._rhs_b,
            plant.mj_sensor(imu._gyro_sensor), plant.mj_sensor(imu._accel_sensor),
            plant.mj_sensor(imu._linvel_sensor), site_pos, c_sn, imu.spec.earth_kinematics,
            _EARTH_CONSTANTS, errors._block, turn_on, gm_value, rw_value,
            errors.rw.density.reshape(6), errors._has_rw, errors.white.sigma.reshape(6),
            white_value,
        )  # fmt: skip
        self._static_for = d
        return self._static

    def fly(self, command: ActuatorCommand, times: list[float]) -> tuple[list[Reading], np.ndarray]:
        """Fly the quiet steps :meth:`times` gave, under ``command``.

        Returns:
            The readings the steps deliver, in delivery order (the IMU's one a step and those
            :meth:`deliveries` named, taken from the queue), and the IMU's channels as rows
            (n, 6) [angular_rate, specific_force] (its readings' arrays are views of them).

        Raises:
            ValueError: The command has a non-finite value (as the limiter says it).
            FloatingPointError: The state went non-finite (as :meth:`Plant.step` says it).
            RuntimeError: MuJoCo's clock is not where the block put it.
        """
        out = self._fly(command, times)
        step = self._after(times)
        readings = self._imu_readings(times, out)
        return self._merged(readings, step), out

    def fly_closing(
        self, command: ActuatorCommand, times: list[float]
    ) -> tuple[list[Reading], np.ndarray, dict[int, dict[str, Any]]]:
        """Fly the steps :meth:`block_times` gave, the last one not quiet, under ``command``.

        The steps but the last are :meth:`fly`'s. The last one's physics and IMU sample are
        flown with them and the IMU left due at it: the suite's poll of that step
        (:meth:`SensorSuite.poll_with_truth` with the returned ``sampled``) then takes that
        sample, samples the other sensors due (the world as it is after the block is that
        step's) and delivers what is due, as a step by step run would.

        Returns:
            :meth:`fly`'s readings and rows for the steps but the last, and the last step's
            IMU sample as the poll's ``sampled``.
        """
        out = self._fly(command, times)
        step = self._after(times, closing=True)
        readings = self._merged(self._imu_readings(times[:-1], out), step - 1)
        i = self._imu_index
        assert i is not None
        last = len(times) - 1
        sampled = {i: {"angular_rate": out[last, 0:3], "specific_force": out[last, 3:6]}}
        return readings, out[:last], sampled

    def _fly(self, command: ActuatorCommand, times: list[float]) -> np.ndarray:
        """The kernel's call: the steps' physics and IMU samples, (n, 6) rows of the latter."""
        n = len(times)
        plant, suite, imu = self.plant, self.suite, self._imu
        assert isinstance(imu, Imu) and self._imu_index is not None
        if n > self._normals.shape[0]:
            self._normals = np.empty((n, 3, 6))
        raw = (command.rudder_rad, command.stern_rad, command.propeller_rps)
        limiter = plant.limiter
        if not (math.isfinite(raw[0]) and math.isfinite(raw[1]) and math.isfinite(raw[2])):
            limiter(command, float(plant.model.opt.timestep))  # raises, naming the command
        normals = self._normals[:n]
        # The 18 normals each sample draws (Imu.sample), all at once: the same stream.
        suite._rngs[self._imu_index].standard_normal(out=normals)
        out = np.empty((n, 6))  # new: the readings keep views of it
        last = np.array(limiter._last, dtype=np.float64)
        gm = imu._errors.gm
        done = quiet_steps_kernel.fly(
            *self._static_args(), n, plant.t, np.array(raw, dtype=np.float64), last,
            imu._t_last, gm._phi.reshape(6), gm._q.reshape(6), normals, out,
        )  # fmt: skip
        limiter._last = (float(last[0]), float(last[1]), float(last[2]))
        d = plant.data
        if done < n:
            raise plant.diverged()
        if float(d.time) != times[-1]:
            raise RuntimeError(
                f"quiet steps: MuJoCo's clock reads {float(d.time)!r} after {n} steps, the block "
                f"expected {times[-1]!r}"
            )
        return out

    def _after(self, times: list[float], *, closing: bool = False) -> int:
        """The IMU's clock and schedule after the block; returns the block's last step.

        A closing step leaves the IMU due at it: the suite's poll takes the block's sample.
        """
        imu, suite, plant = self._imu, self.suite, self.plant
        assert isinstance(imu, Imu) and self._imu_index is not None
        imu._t_last = times[-1]
        step = round(times[-1] / float(plant.model.opt.timestep))
        suite._next_step[self._imu_index] = (
            step
            if closing
            else suite._step_of(
                math.floor(step / suite._steps_per_sample(imu) + _EPS_STEPS) + 1, imu
            )
        )
        return step

    def _imu_readings(self, times: list[float], out: np.ndarray) -> list[Reading]:
        assert self._imu is not None
        name = self._imu.name
        return [
            Reading(name, t, t, {"angular_rate": out[k, 0:3], "specific_force": out[k, 3:6]})
            for k, t in enumerate(times)
        ]

    def _merged(self, readings: list[Reading], step: int) -> list[Reading]:
        """The IMU's readings (the steps up to ``step``) and the queue's due by then, in order."""
        pending = self.suite._pending
        if not pending or pending[0][0] > step:
            return readings
        # Readings from the queue, each in its step: before the step's IMU sample when the queue
        # would pop it first (an earlier delivery time; on a tie the older entry, which it is).
        first = step - len(readings) + 1
        merged: list[Reading] = []
        k = 0
        while pending and pending[0][0] <= step:
            due, t_delivered, _, reading, _ = heapq.heappop(pending)
            j = due - first
            while k < j or (k == j and readings[k].t < t_delivered):
                merged.append(readings[k])
                k += 1
            merged.append(reading)
        merged.extend(readings[k:])
        return merged
