"""IMU samples taken in batches give every filter the one-by-one path's state, bit for bit."""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import numpy as np
import pytest

import scenarios
from twin.core.messages import Reading
from twin.onboard import imu_batch
from twin.onboard.eskf import Eskf, EskfConfig
from twin.onboard.ins import InsConfig, NavState, StrapdownIns
from twin.onboard.navigator import Navigator, NavigatorConfig, VehicleKnowledge
from twin.sim.build import build_simulation

LAT = math.radians(37.54)


def _state(f: Eskf) -> tuple:
    ins = f.ins
    return (
        ins.t, ins.lat, ins.lon, ins.h, ins._v, ins._c, ins._bg, ins._ba, ins._w, ins._f,
        ins._steps, ins.skipped, f._pending_dt, f._n_sum, f._w2_dt, tuple(f._f_sum),
        tuple(f._w_sum), f.P.tobytes(), dict(f.counts), list(f.rejections),
    )  # fmt: skip


def test_a_sea_trials_filters_are_the_one_by_one_paths_bit_for_bit(monkeypatch):
    """Three variants flown 12 s (compass frames, depth and gravity updates, covariance steps).

    The batched run takes most IMU samples through the simulation's fan-out to every variant at
    once (Navigator.fan_out_imu), its depth and gravity updates in the batch's compiled calls;
    the reference takes each sample one by one in each variant, each update by the filter's
    Python method when it comes.
    """
    sc = scenarios.load("sea_trial_10m")
    sc = dataclasses.replace(
        sc, navigation=dataclasses.replace(sc.navigation, variants=("ins", "pol", "lig"))
    )
    batched = build_simulation(sc, 3)
    batched.fly(12.03)  # ends between depth readings: on fanned-out samples
    with monkeypatch.context() as m:
        m.setattr(imu_batch, "batchable", lambda reading: False)
        m.setattr("twin.onboard.navigator.batchable", lambda reading: False)
        m.setattr(imu_batch.ImuBatch, "compiled_updates", False)
        single = build_simulation(sc, 3)
        single.fly(12.03)
    for name, nav in batched.navigators.items():
        ref = single.navigators[name]
        assert _state(nav.filter) == _state(ref.filter), name
        # What a variant keeps of the last sample (the fan-out of Navigator.fan_out_imu sets it).
        assert nav._t_imu == ref._t_imu and np.array_equal(nav._rate_b, ref._rate_b), name
        assert [(e.t, e.fix.ok) for e in nav.events] == [(e.t, e.fix.ok) for e in ref.events]
        assert nav.filter.ins.t == pytest.approx(12.03, abs=0.011)
    assert batched.navigators["pol"].updates["frames"] >= 10  # the compass ran between batches


def _imu(t: float, rng: np.random.Generator, bad: bool = False) -> Reading:
    w = rng.normal(0.0, 0.02, 3)
    f = np.array([0.0, 0.0, 9.8]) + rng.normal(0.0, 0.05, 3)
    if bad:
        f[1] = math.nan
    return Reading("imu", t, t, {"angular_rate": w, "specific_force": f})


@pytest.mark.parametrize("nonfinite", ["skip", "raise"])
def test_a_non_finite_sample_in_a_batch_is_skipped_or_named_as_configured(nonfinite: str):
    cfg = NavigatorConfig(eskf=EskfConfig(ins=InsConfig(on_nonfinite=nonfinite)))
    know = VehicleKnowledge(dt.datetime(2021, 9, 3, 2, 30), 37.54, 122.06)
    init = NavState(0.0, LAT, math.radians(122.06), -10.0)
    rng = np.random.default_rng(7)
    stream = [_imu(0.01 * k, rng, bad=k == 37) for k in range(400)]
    nav = Navigator("ins", know, init, cfg)
    ref = Eskf(cfg.eskf, init)
    next_g = 1.0 / cfg.gravity_rate_hz
    if nonfinite == "raise":
        with pytest.raises(ValueError, match=r"specific_force.*non-finite"):
            for r in stream:
                nav.on_reading(r)
            nav.estimate()
        return
    for r in stream:
        nav.on_reading(r)
        if r.t > ref.t:  # the one-by-one path, as the navigator took it before batches
            ref.predict_reading(r)
            if cfg.gravity_aiding and ref.t >= next_g - 1e-9:
                ref.update_gravity()
                next_g += 1.0 / cfg.gravity_rate_hz
    assert nav.filter.ins.skipped == 1
    assert _state(nav.filter) == _state(ref)


def test_readings_the_batch_cannot_read_take_the_python_step():
    """A list instead of an array is the Python path's to check (it names the channel)."""
    know = VehicleKnowledge(dt.datetime(2021, 9, 3, 2, 30), 37.54, 122.06)
    nav = Navigator("ins", know, NavState(0.0, LAT, 2.13, -10.0))
    good = Reading("imu", 0.01, 0.01, {"angular_rate": np.zeros(3), "specific_force": np.ones(3)})
    assert imu_batch.batchable(good)
    bad = Reading("imu", 0.02, 0.02, {"angular_rate": np.zeros(3), "specific_force": np.ones(2)})
    assert not imu_batch.batchable(bad)
    nav.on_reading(good)
    with pytest.raises(ValueError, match="specific_force: must have shape"):
        nav.on_reading(bad)


def test_a_sensor_that_reuses_its_arrays_cannot_change_a_waiting_sample():
    """Samples are copied in on arrival: mutating the arrays afterwards changes nothing."""
    know = VehicleKnowledge(dt.datetime(2021, 9, 3, 2, 30), 37.54, 122.06)
    init = NavState(0.0, LAT, math.radians(122.06), -10.0)
    rng = np.random.default_rng(11)
    stream = [_imu(0.01 * k, rng) for k in range(1, 60)]
    reused = Navigator("ins", know, init)
    fresh = Navigator("ins", know, init)
    w, f = np.empty(3), np.empty(3)  # one pair of arrays, overwritten for every sample
    for r in stream:
        w[:] = r["angular_rate"]
        f[:] = r["specific_force"]
        reused.on_reading(Reading("imu", r.t, r.t, {"angular_rate": w, "specific_force": f}))
        fresh.on_reading(r)
    w[:] = 99.0
    assert _state(reused.filter) == _state(fresh.filter)


def test_a_filter_with_its_own_time_update_takes_its_samples_one_by_one():
    class OwnGravity(StrapdownIns):
        def gravity(self, lat: float, h: float) -> float:
            return 9.80665

    f = Eskf(EskfConfig(), NavState(0.0, LAT, 2.13, -10.0))
    assert imu_batch.compiled_path(f)
    f.ins.__class__ = OwnGravity
    assert not imu_batch.compiled_path(f)
    with pytest.raises(ValueError, match="one by one"):
        imu_batch.ImuBatch(f)


def test_the_fan_out_leaves_a_navigator_that_takes_its_own_imu_path_to_it():
    """Navigator.fan_out_imu takes a step's sample for plain navigators only; a subclass that
    overrides how it takes IMU samples gets each through on_reading."""

    class Counting(Navigator):
        seen = 0

        def _on_imu(self, reading: Reading) -> None:
            Counting.seen += 1
            super()._on_imu(reading)

    know = VehicleKnowledge(dt.datetime(2021, 9, 3, 2, 30), 37.54, 122.06)
    init = NavState(0.0, LAT, math.radians(122.06), -10.0)
    rng = np.random.default_rng(3)
    plain, counting = Navigator("ins", know, init), Counting("ins", know, init)
    first, second = _imu(0.01, rng), _imu(0.02, rng)
    assert Navigator.fan_out_imu([plain], first) and len(plain._batch) == 1
    assert not Navigator.fan_out_imu([plain, counting], second)
    assert len(plain._batch) == 1 and Counting.seen == 0  # nothing done: both take it one by one


@pytest.mark.parametrize("fan_out", [False, True])
def test_gravity_updates_keep_their_instants_on_a_clock_that_lags(fan_out: bool):
    """MuJoCo's clock, a running sum of dt, lags n·dt by over 1e-9 s at times past ~25 min.

    Samples stamped 5e-9 s early (the lag that clock first reaches at 18 359 s of 0.01 s steps):
    each gravity update still comes at the sample of its instant k / rate, not one sample late
    (as with a 1e-9 s tolerance), by the one-by-one path and by the fan-out alike.
    """
    cfg = NavigatorConfig()
    know = VehicleKnowledge(dt.datetime(2021, 9, 3, 2, 30), 37.54, 122.06)
    init = NavState(0.0, LAT, math.radians(122.06), -10.0)
    rng = np.random.default_rng(11)
    lag = 5e-9
    nav = Navigator("ins", know, init, cfg)
    at: list[float] = []
    update = nav._filter.update_gravity

    def recorded(*a, **k):
        at.append(nav._filter.t)
        return update(*a, **k)

    nav._filter.update_gravity = recorded  # type: ignore[method-assign]
    for n in range(1, 301):
        r = _imu(0.01 * n - lag, rng)
        if not (fan_out and Navigator.fan_out_imu([nav], r)):
            nav.on_reading(r)
    k = np.arange(1, len(at) + 1)
    assert len(at) == round(3.0 * cfg.gravity_rate_hz)
    np.testing.assert_allclose(at, k / cfg.gravity_rate_hz - lag, atol=1e-9)


def test_a_batch_longer_than_its_arrays_grows_and_keeps_every_sample():
    """150 samples kept one by one and in blocks (past the arrays' first 64 rows), then
    integrated: the one-by-one filter's state."""
    cfg = NavigatorConfig(gravity_aiding=False)
    know = VehicleKnowledge(dt.datetime(2021, 9, 3, 2, 30), 37.54, 122.06)
    init = NavState(0.0, LAT, math.radians(122.06), -10.0)
    rng = np.random.default_rng(13)
    stream = [_imu(0.01 * k, rng) for k in range(1, 151)]
    nav = Navigator("ins", know, init, cfg)
    ref = Eskf(cfg.eskf, init)
    batch = nav._batch
    assert batch is not None
    for r in stream[:50]:
        batch.add(r)
    for a, b in ((50, 60), (60, 130)):
        run = stream[a:b]
        rows = np.array([[*r["angular_rate"], *r["specific_force"]] for r in run])
        batch.add_block(run, [r.t for r in run], rows)
    for r in stream[130:]:
        batch.add(r)
    assert len(batch) == 150
    batch.flush()
    for r in stream:
        ref.predict_reading(r)
    assert _state(batch.filter) == _state(ref)


def _with_depths(n: int, rng: np.random.Generator, bad: tuple[int, ...] = ()) -> list[Reading]:
    """IMU samples at 100 Hz, a turn at 1–1.5 s (not quasi-static), depth readings at 10 Hz
    between samples (one of them 40 m off: gated out) and one at the stream's end; the samples
    ``bad`` not finite."""
    out = []
    for k in range(1, n + 1):
        r = _imu(0.01 * k, rng, bad=k in bad)
        if 100 <= k < 150:
            r.values["angular_rate"][2] += 0.3
        out.append(r)
        if k % 10 == 4 or k == n:
            depth = 10.0 + rng.normal(0.0, 0.05) + (40.0 if k == 254 else 0.0)
            t = 0.01 * k + 0.003
            out.append(Reading("depth", t, t, {"depth_m": np.array([depth])}))
    return out


@pytest.mark.parametrize("fan_out", [False, True])
@pytest.mark.parametrize("skipped", [(), (54, 130)])
def test_queued_depth_updates_and_gravity_in_one_call_are_the_filters_own_updates(
    fan_out: bool, skipped: tuple[int, ...]
):
    """The batch's compiled work (samples, the depth updates queued among them, the gravity
    update after them) against the filter's Python updates, each made when its reading came:
    the same state bit for bit, the same rejections and counts, updates of every outcome (and
    with samples skipped as not finite: the one before a depth reading, one at a gravity
    update's instant)."""
    know = VehicleKnowledge(dt.datetime(2021, 9, 3, 2, 30), 37.54, 122.06)
    init = NavState(0.0, LAT, math.radians(122.06), -10.0)
    stream = _with_depths(400, np.random.default_rng(5), skipped)
    cfg = NavigatorConfig(eskf=EskfConfig(ins=InsConfig(on_nonfinite="skip")))
    nav = Navigator("ins", know, init, cfg)
    ref = Navigator("ins", know, init, cfg)
    ref._batch.compiled_updates = False  # type: ignore[union-attr]
    for r in stream:
        if not (fan_out and r.sensor == "imu" and Navigator.fan_out_imu([nav], r)):
            nav.on_reading(r)
        ref.on_reading(r)
    assert nav._batch.pending  # the last depth reading waits for the next look
    a, b = nav.filter, ref.filter
    assert _state(a) == _state(b)
    assert (nav._gravity_k, nav._next_gravity_t) == (ref._gravity_k, ref._next_gravity_t)
    assert a.counts["depth"] == 40 and a.counts["gravity"] > 20 and a.counts["not_static"] > 0
    assert a.ins.skipped == len(skipped)
    assert [(x.t, x.kind) for x in a.rejections] == [(pytest.approx(2.54), "depth")]


def test_updates_the_compiled_algebra_does_not_take_are_the_filters_python_paths(monkeypatch):
    """An innovation covariance with no closed-form inverse (P not finite) and a non-finite
    mean sample go to the filter's own methods: the same outcome as the Python updates."""
    numpy_path = []
    reference = Eskf._update_reference

    def counted(self, *a, **k):
        numpy_path.append(self.t)
        return reference(self, *a, **k)

    monkeypatch.setattr(Eskf, "_update_reference", counted)
    know = VehicleKnowledge(dt.datetime(2021, 9, 3, 2, 30), 37.54, 122.06)
    init = NavState(0.0, LAT, math.radians(122.06), -10.0)
    stream = _with_depths(60, np.random.default_rng(9))
    outcomes = []
    for python in (False, True):
        nav = Navigator("ins", know, init)
        if python:
            nav._batch.compiled_updates = False  # type: ignore[union-attr]
        for r in stream[:20]:
            nav.on_reading(r)
        nav.filter.P = np.full((15, 15), np.nan)  # S = H P Hᵀ + R: NaN, no closed form
        with np.errstate(invalid="ignore"):
            for r in stream[20:]:
                nav.on_reading(r)
            f = nav.filter
        outcomes.append((f.ins.t, f.P.tobytes(), dict(f.counts), len(f.rejections),
                         tuple(numpy_path)))  # fmt: skip
        numpy_path.clear()
        huge = Reading(
            "imu",
            0.61,
            0.61,
            {"angular_rate": np.zeros(3), "specific_force": np.array([1e308, 1e308, 0.0])},
        )
        with pytest.raises(ValueError, match=r"update_gravity.*non-finite input"):
            for k in range(10):
                nav.on_reading(dataclasses.replace(huge, t=0.61 + 0.01 * k))
    assert outcomes[0] == outcomes[1]
    assert len(outcomes[0][4]) == 5  # the gravity updates at 0.2 … 0.6 s took the numpy path
