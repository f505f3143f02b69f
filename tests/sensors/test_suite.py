"""SensorSuite with the real IMU and depth gauge: rates, delays, independent random streams."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensors import registry
from sensors.suite import SensorSuite

DT = 0.01  # the AUV model's physics step (models/auv/auv.xml)


def run(suite: SensorSuite, world, seconds: float) -> list:
    world.set_time(0.0)
    suite.reset(world)
    out = []
    for k in range(round(seconds / DT) + 1):
        world.set_time(k * DT)
        out.extend(suite.poll(world))
    return out


def test_rates_and_delays(world) -> None:
    imu = registry.create("imu", "lig2024")  # 100 Hz, no delay
    depth = registry.create("depth", "ms5837_30ba")  # 10 Hz, 0.04 s delay
    readings = run(SensorSuite([imu, depth], seed=1), world, 1.0)
    imu_r = [r for r in readings if r.sensor == "imu"]
    depth_r = [r for r in readings if r.sensor == "depth"]
    assert len(imu_r) == 101  # t = 0.00 ... 1.00
    np.testing.assert_allclose([r.t for r in imu_r], np.arange(101) * DT, atol=1e-12)
    assert all(r.t_delivered == r.t for r in imu_r)
    # Depth samples at 0.0, 0.1, ..., 0.9 are delivered 0.04 s later; 1.0's is still in flight.
    assert len(depth_r) == 10
    np.testing.assert_allclose([r.t for r in depth_r], np.arange(10) * 0.1, atol=1e-12)
    np.testing.assert_allclose([r.t_delivered - r.t for r in depth_r], 0.04, atol=1e-12)
    # Delivered in order, and no reading is handed over before its delivery time.
    t_del = [r.t_delivered for r in readings]
    assert t_del == sorted(t_del)
    assert set(depth_r[0].values) == {"pressure_pa", "depth_m"}


def test_rate_that_does_not_divide_the_physics_rate(world) -> None:
    depth = registry.create("depth", "ideal", rate_hz=30.0)
    readings = run(SensorSuite([depth], seed=0), world, 1.0)
    t = np.array([r.t for r in readings])
    assert len(t) == 31  # k / 30 for k = 0..30, each at the first physics step at or after it
    k = np.arange(31)
    assert np.all(t >= k / 30 - 1e-9) and np.all(t - k / 30 < DT)


def test_adding_a_sensor_does_not_change_the_first_sensors_noise(world) -> None:
    def imu_values(sensors) -> np.ndarray:
        readings = run(SensorSuite(sensors, seed=1234), world, 0.3)
        return np.array([r["angular_rate"] for r in readings if r.sensor == "imu"])

    alone = imu_values([registry.create("imu", "lig2024")])
    with_depth = imu_values(
        [registry.create("imu", "lig2024"), registry.create("depth", "ms5837_30ba")]
    )
    np.testing.assert_array_equal(alone, with_depth)


def test_two_imus_get_independent_streams(world) -> None:
    a = registry.create("imu", "lig2024", name="imu_a")
    b = registry.create("imu", "lig2024", name="imu_b")
    readings = run(SensorSuite([a, b], seed=5), world, 0.2)
    ra = np.array([r["specific_force"] for r in readings if r.sensor == "imu_a"])
    rb = np.array([r["specific_force"] for r in readings if r.sensor == "imu_b"])
    assert ra.shape == rb.shape == (21, 3)
    assert not np.any(ra == rb)


def test_same_seed_same_readings_and_duplicate_names_rejected(world) -> None:
    def values(seed: int) -> np.ndarray:
        s = SensorSuite(
            [registry.create("imu", "lig2024"), registry.create("depth", "ms5837_30ba")], seed
        )
        return np.concatenate([np.concatenate(list(r.values.values())) for r in run(s, world, 0.5)])

    np.testing.assert_array_equal(values(8), values(8))
    assert not np.array_equal(values(8), values(9))
    with pytest.raises(ValueError, match="unique"):
        SensorSuite([registry.create("imu"), registry.create("imu")], seed=0)


def test_a_long_run_on_mujocos_running_clock_keeps_every_rate(world) -> None:
    """MuJoCo's clock is a running sum of dt: its round-off must not move a sample.

    After ~27 000 steps of 0.01 s the sum lies 1e-10..1e-9 s below k·dt; scheduled in seconds
    within 1e-9 s, a 10 Hz gauge sampled at both 269.50 and 269.51 s, and so on (9306 samples
    in 600 s instead of 6001). Here each sensor samples once at each k / rate, at the step
    nearest to it, and is delivered its delay later, for 600 s of that clock and beyond.
    """
    depth = registry.create("depth", "ms5837_30ba")  # 10 Hz, 0.04 s delay
    slow = registry.create("depth", "ideal", rate_hz=30.0, name="depth_30hz")  # does not divide
    suite = SensorSuite([depth, slow], seed=3)
    world.set_time(0.0)
    suite.reset(world)
    t, steps, readings = 0.0, 60_000, []
    for _ in range(steps + 1):
        world.set_time(t)
        readings.extend(suite.poll(world))
        t += DT  # as mj_step advances data.time
    assert abs(t - (steps + 1) * DT) > 1e-10  # the running clock did drift
    for sensor, rate in ((depth, 10.0), (slow, 30.0)):
        r = [x for x in readings if x.sensor == sensor.name]
        k = np.arange(len(r))
        stamps = np.array([x.t for x in r])
        # One sample per instant k / rate that is delivered by the end (steps · dt).
        assert len(r) == math.floor((steps * DT - sensor.delay_s) * rate + 1e-6) + 1
        # Sampled at the first step at or after k / rate: within one step, never before it.
        assert np.all(stamps >= k / rate - 1e-6) and np.all(stamps - k / rate < DT - 1e-6)
        np.testing.assert_allclose([x.t_delivered - x.t for x in r], sensor.delay_s, atol=1e-9)
