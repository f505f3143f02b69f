"""The depth gauge on the real AUV model: hydrostatics, firmware conversion, noise, saturation."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sensors import registry
from sensors.depth import BAR, MBAR, DepthGauge, DepthSpec

P_ATM = 101325.0


def gauge(preset: str = "ideal", **overrides) -> DepthGauge:
    g = registry.create("depth", preset, **overrides)
    assert isinstance(g, DepthGauge)
    return g


def read(g: DepthGauge, world, seed: int = 0) -> tuple[float, float]:
    rng = np.random.default_rng(seed)
    g.reset(world, rng)
    r = g.sample(world, rng)
    assert r["pressure_pa"].shape == (1,) and r["depth_m"].shape == (1,)
    return float(r["pressure_pa"][0]), float(r["depth_m"][0])


def site_depth(world) -> float:
    return world.surface_z_m - float(world.site_pose("depth")[0][2])


def test_ideal_pressure_is_hydrostatic_and_depth_consistent(world) -> None:
    world.place(pos=(3.0, -2.0, -25.0), rpy=(0.1, 0.3, 1.0))
    p, d = read(gauge(), world)
    depth = site_depth(world)
    # The site is 0.3 m aft and 0.06 m below the body origin, so pitch moves it.
    assert depth != pytest.approx(25.06, abs=1e-3)
    assert p == pytest.approx(P_ATM + 1025.0 * world.gravity_mps2 * depth, rel=1e-15)
    assert d == pytest.approx(depth, rel=1e-14)


def test_above_the_surface_reads_atmospheric_pressure(world) -> None:
    world.place(pos=(0.0, 0.0, 1.0))
    p, d = read(gauge(), world)
    assert p == P_ATM
    assert d == 0.0


def test_firmware_converts_with_declared_constants(world) -> None:
    world.place(pos=(0.0, 0.0, -50.0))
    p_true, d_true = read(gauge(), world)
    # A gauge configured for fresh water (Blue Robotics' example density 997) in the sea.
    p, d = read(gauge(declared_density_kg_m3=997.0), world)
    assert p == p_true
    assert d == pytest.approx(d_true * 1025.0 / 997.0, rel=1e-12)
    # Firmware constants 101300 Pa and 9.80665 m/s² (the library's) instead of the world's.
    p, d = read(
        gauge(declared_atmospheric_pressure_pa=101300.0, declared_gravity_mps2=9.80665), world
    )
    assert d == pytest.approx((p_true - 101300.0) / (1025.0 * 9.80665), rel=1e-12)


def test_quantization_step_is_visible(world, collect) -> None:
    """No noise: readings are whole multiples of the 0.1 mbar LSB, truncated like the firmware."""
    g = gauge("ms5837_30ba", noise_mbar=0.0, offset_mbar=0.0, bias_instability_mbar=0.0)
    rng = np.random.default_rng(0)
    g.reset(world, rng)
    readings, truths = [], []
    for k in range(40):
        world.place(pos=(0.0, 0.0, -10.0 - 0.0003 * k))  # 0.3 mm steps: ~0.3 LSB each
        readings.append(g.sample(world, rng)["pressure_pa"][0])
        truths.append(g.true_pressure_pa(world))
    readings, truths = np.array(readings), np.array(truths)
    lsb = 0.1 * MBAR
    np.testing.assert_allclose(readings / lsb, np.round(readings / lsb), atol=1e-6)
    steps = np.unique(np.round(np.diff(readings) / lsb))
    assert set(steps) <= {0.0, 1.0} and 1.0 in steps and 0.0 in steps
    assert np.all(readings <= truths) and np.all(truths - readings < lsb)


def test_noise_std_is_0_2_mbar_and_2_mm(world, collect) -> None:
    g = gauge("ms5837_30ba", offset_mbar=0.0, bias_instability_mbar=0.0)
    rng = np.random.default_rng(1)
    g.reset(world, rng)
    data = collect(g, world, rng, 10000)
    p_std = data["pressure_pa"].std()
    d_std = data["depth_m"].std()
    # White 0.2 mbar plus uniform quantization noise LSB²/12 (0.1 mbar LSB).
    expected = math.hypot(0.2, 0.1 / math.sqrt(12)) * MBAR
    assert p_std == pytest.approx(expected, rel=0.04)
    assert d_std == pytest.approx(expected / (1025.0 * world.gravity_mps2), rel=0.04)
    assert d_std == pytest.approx(0.002, rel=0.05)
    # Truncation biases the mean half an LSB low.
    bias = data["pressure_pa"].mean() - g.true_pressure_pa(world)
    assert bias == pytest.approx(-0.05 * MBAR, abs=4 * expected / 100)


def test_saturates_at_full_scale(world) -> None:
    world.place(pos=(0.0, 0.0, -400.0))  # ≈ 41 bar absolute, beyond the 30 bar range
    g = gauge("ms5837_30ba")
    p, d = read(g, world)
    assert g.true_pressure_pa(world) > 40 * BAR
    assert p == 30 * BAR
    assert d == pytest.approx((30 * BAR - P_ATM) / (1025.0 * world.gravity_mps2))
    p_ok, _ = read(g, world.place(pos=(0.0, 0.0, -250.0)))
    assert p_ok < 30 * BAR


def test_offset_is_drawn_per_seed(world) -> None:
    g = gauge("ms5837_30ba")
    offsets = []
    for seed in range(300):
        g.reset(world, np.random.default_rng(seed))
        offsets.append(g.current_errors().offset_pa)
    assert np.std(offsets) == pytest.approx(1.0 * MBAR, rel=0.15)
    g.reset(world, np.random.default_rng(5))
    a = g.current_errors()
    g.reset(world, np.random.default_rng(5))
    assert g.current_errors() == a


def test_errors_explain_the_reading(world) -> None:
    g = gauge("ms5837_30ba", resolution_mbar=0.0)
    rng = np.random.default_rng(2)
    g.reset(world, rng)
    world.set_time(0.1)
    p = g.sample(world, rng)["pressure_pa"][0]
    e = g.current_errors()
    assert p == pytest.approx(g.true_pressure_pa(world) + e.offset_pa + e.drift_pa + e.noise_pa)


def test_same_seed_bit_identical(world, collect) -> None:
    def run(seed: int) -> np.ndarray:
        g = gauge("ms5837_30ba")
        rng = np.random.default_rng(seed)
        world.set_time(0.0)
        g.reset(world, rng)
        return collect(g, world, rng, 100)["depth_m"]

    np.testing.assert_array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))


def test_spec_defaults_presets_and_validation() -> None:
    assert DepthSpec().rate_hz == 10.0
    ms = DepthGauge.PRESETS["ms5837_30ba"]
    assert (ms.noise_mbar, ms.resolution_mbar, ms.full_scale_bar) == (0.2, 0.1, 30.0)
    for spec in DepthGauge.PRESETS.values():
        spec.validate()
    for field, value in [
        ("noise_mbar", -0.1),
        ("resolution_mbar", math.nan),
        ("full_scale_bar", 0.0),
        ("declared_density_kg_m3", -1025.0),
        ("bias_corr_time_s", math.inf),
    ]:
        with pytest.raises(ValueError, match=field) as info:
            dataclasses.replace(DepthSpec(), **{field: value}).validate()
        assert repr(value) in str(info.value)


def test_registry_create_depth() -> None:
    g = registry.create("depth", "ms5837_30ba", name="bar30", rate_hz=20.0)
    assert isinstance(g, DepthGauge) and g.name == "bar30" and g.site == "depth"
    assert g.rate_hz == 20.0 and g.spec.noise_mbar == 0.2
    with pytest.raises(KeyError, match="unknown depth preset"):
        registry.create("depth", "bar02")
    with pytest.raises(ValueError, match="noise_pa"):
        registry.create("depth", "ms5837_30ba", noise_pa=20.0)
    with pytest.raises(ValueError, match="rate_hz"):
        registry.create("depth", rate_hz=-1.0)


def test_missing_site_sensor_and_no_reset_are_errors(world) -> None:
    g = gauge(site="imu")
    with pytest.raises(KeyError, match="imu/position"):
        g.reset(world, np.random.default_rng(0))
    with pytest.raises(RuntimeError, match="reset"):
        gauge().sample(world, np.random.default_rng(0))
