"""The scorer's samples scored together (VariantScore._settle) equal the one-sample path.

The run's scorer keeps each truth sample and scores many at once; the recorder and a log's
replay read one sample at a time (``VariantScore.last_sample``, the arithmetic the scorer had
before). Both are held equal here, bit for bit, on a real flight.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import scenarios
from twin.scoring import navigation
from twin.scoring.observer import RunScorer
from twin.sim.build import build_simulation

KEYS = {
    "heading_err": "heading_err_deg",
    "heading_sigma": "heading_sigma_deg",
    "roll_err": "roll_err_deg",
    "pitch_err": "pitch_err_deg",
    "pos_err": "position_err_m",
    "nees": "nees",
}


class _OneByOne:
    """Reads every variant's last sample after each truth sample, as the recorder does."""

    def __init__(self, scorer: RunScorer) -> None:
        self.scorer = scorer
        self.rows: dict[str, list[dict[str, float]]] = {}
        self._n = 0

    def on_step(self, sim, result) -> None:  # type: ignore[no-untyped-def]
        v = next(iter(self.scorer.variants.values()))
        n = len(v._pending) + len(v._t)
        if n == self._n:
            return
        self._n = n
        for name, sample in self.scorer.last_samples.items():
            self.rows.setdefault(name, []).append(sample)


def test_samples_scored_together_equal_the_one_sample_path(monkeypatch) -> None:
    monkeypatch.setattr(navigation, "_SETTLE_EVERY", 7)  # several settles, and a ragged last
    sc = scenarios.load("sea_trial_10m")
    sc = dataclasses.replace(
        sc, duration_s=12.0, navigation=dataclasses.replace(sc.navigation, variants=("ins", "pol"))
    )
    sim = build_simulation(sc)
    scorer = RunScorer(sim)
    one = _OneByOne(scorer)
    sim.observers[:] = [scorer, one]
    sim.fly(6.0)
    sim.fly(12.0)
    for name, vs in scorer.variants.items():
        rows = one.rows[name]
        assert len(rows) == len(vs.t) == 120
        for attr, key in KEYS.items():
            got = np.array(getattr(vs, attr))
            want = np.array([r[key] for r in rows])
            np.testing.assert_array_equal(got, want, err_msg=f"{name}.{attr}")
    assert all(math.isfinite(x) for v in scorer.variants.values() for x in v.nees)
    # A singular attitude block among real samples: the stacked solve fails, and each sample is
    # solved on its own, as the one-sample path does: NEES = inf there only.
    raw = scorer.variants["pol"]._last
    assert raw is not None
    singular = (*raw[:13], np.zeros((3, 3)), raw[14])
    vs = navigation.VariantScore("pol")
    want = []
    for r in (raw, singular, raw):
        vs._last = r
        want.append(vs.last_sample()["nees"])
    vs._pending = [raw, singular, raw]
    assert vs.nees == want and [math.isinf(x) for x in want] == [False, True, False]


def test_a_variant_read_before_any_sample_is_empty() -> None:
    vs = navigation.VariantScore("ins")
    assert vs.t == [] and vs.nees == [] and vs.last_sample() == {}


@pytest.mark.parametrize("angle", [0.0, 1e-9, 0.5, 3.0, math.pi - 1e-7])
def test_the_stacked_attitude_error_is_the_scalar_one(angle) -> None:
    from twin.core.frames import euler_to_dcm
    from twin.onboard.eskf import attitude_error

    rng = np.random.default_rng(int(angle * 1e3))
    c_true = np.stack([euler_to_dcm(*rng.uniform(-3, 3, 3)) for _ in range(5)])
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
    c_est = rot @ c_true
    got = navigation._attitude_errors(c_est, c_true)
    want = np.stack([attitude_error(a, b) for a, b in zip(c_est, c_true, strict=True)])
    np.testing.assert_array_equal(got, want)
