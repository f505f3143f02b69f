"""The compiled IMU sample (sensors/imu_kernel.py) is the Python one bit for bit, on a flight."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import scenarios
from sensors import registry
from sensors.imu import Imu
from twin.sim.build import build_simulation


@pytest.mark.parametrize(
    ("preset", "overrides"),
    [
        ("lig2024", {}),  # the sea trial's unit, no rate random walk
        ("lig2024", {"gyro_rate_random_walk": 1e-5, "accel_random_walk": 2e-4}),
        ("lig2024", {"earth_kinematics": False}),
        ("ideal", {}),
    ],
)
def test_the_compiled_sample_is_the_python_one_bit_for_bit(preset, overrides, monkeypatch):
    sc = scenarios.load("sea_trial_10m")
    sc = dataclasses.replace(sc, navigation=dataclasses.replace(sc.navigation, variants=("ins",)))
    sim = build_simulation(sc)
    units = {}
    for compiled in (True, False):
        imu = registry.create("imu", preset, **overrides)
        assert isinstance(imu, Imu)
        imu.reset(sim.plant, np.random.default_rng(11))
        units[compiled] = (imu, np.random.default_rng(12))
    steps, differs = 0, 0
    cmd = None
    dt = sim.physics_dt
    for k in range(600):
        if cmd is None or k % sim.autopilot_every == 0:
            cmd = sim.control()
        sim.plant.step(cmd)
        if k == 300:  # a sample after a longer gap: the Gauss–Markov factors change with dt
            sim.plant.step(cmd)
        out = {}
        for compiled, (imu, rng) in units.items():
            monkeypatch.setattr(Imu, "compiled", compiled)
            r = imu.sample(sim.plant, rng)
            out[compiled] = np.concatenate([r["angular_rate"], r["specific_force"]])
        np.testing.assert_array_equal(out[True], out[False], err_msg=f"step {k}")
        a, b = units[True][0].current_errors(), units[False][0].current_errors()
        for row in ("gyro", "accel"):
            x, y = getattr(a, row), getattr(b, row)
            np.testing.assert_array_equal(x.bias, y.bias)
            np.testing.assert_array_equal(x.noise, y.noise)
        steps += 1
        differs += int(not np.array_equal(out[True], sim.plant.data.sensordata[:6]))
    assert steps == 600 and differs > 0  # the errors and Earth terms were applied
    assert dt > 0


def test_a_subclass_that_overrides_the_ideal_reading_keeps_it() -> None:
    """The kernel is Imu._ideal's arithmetic: a subclass with its own takes the Python path."""

    class Offset(Imu):
        def _ideal(self, world):  # type: ignore[no-untyped-def]
            return super()._ideal(world) + 1.0

    sc = scenarios.load("sea_trial_10m")
    sim = build_simulation(sc)
    base = registry.create("imu", "ideal")
    assert isinstance(base, Imu)
    shifted = Offset(base.spec)
    out = []
    for imu in (base, shifted):
        rng = np.random.default_rng(5)
        imu.reset(sim.plant, rng)
        r = imu.sample(sim.plant, rng)
        out.append(np.concatenate([r["angular_rate"], r["specific_force"]]))
    np.testing.assert_allclose(out[1] - out[0], 1.0, rtol=0, atol=1e-12)
