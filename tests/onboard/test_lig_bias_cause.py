"""LIG's horizon-ward zenith bias in clear shallow water comes from the clear sky's gradation.

Shown by switching each candidate cause (validation/lig_bias_cause.py has the full table): the
radiative transfer's scattered light off changes nothing, the CIE clear sky's gradation off
(type 8: type 12's indicatrix, a = 0) removes the bias. POL is unmoved by either.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

_PATH = Path(__file__).resolve().parents[2] / "validation" / "lig_bias_cause.py"


def _bench():
    spec = importlib.util.spec_from_file_location("lig_bias_cause", _PATH)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_clear_sky_gradation_not_radiative_transfer_makes_lig_lean_to_the_horizon():
    b = _bench()
    els = (30.0, 50.0)
    full = b.zenith_errors(12, True, "I", 1.0, els)
    no_rt = b.zenith_errors(12, False, "I", 1.0, els)
    flat = b.zenith_errors(8, True, "I", 1.0, els)
    lig, lig_no_rt, lig_flat = (np.array(r["LIG"], dtype=float) for r in (full, no_rt, flat))
    # The bias: tens of degrees towards the horizon (measured +79° and +41°).
    assert np.all(lig > 20.0)
    # Radiative transfer is not its cause: the scattered light is ~1e-3 of the window's, and
    # taking it away moves LIG by less than a degree.
    assert np.all(np.array(full["scattered share"]) < 0.01)
    assert np.all(np.abs(lig - lig_no_rt) < 2.0)
    # The gradation is: without it (same indicatrix) LIG is within 10° and ≥ 30° less.
    assert np.all(np.abs(lig_flat) < 10.0) and np.all(lig - lig_flat > 30.0)
    for r in (full, no_rt, flat):
        assert np.all(np.abs(np.array(r["POL"], dtype=float)) < 1.5)
