"""A table's frame field through the compiled interpolation is numpy's, bit for bit.

:func:`sensors.polarimeter.optics.rt.frame_kernel.at` replaces
``LightFieldTable._at_numpy`` (two depth interpolations, two sun warps, a blend) in
:meth:`LightFieldTable.frame`: every array of the frame, with and without it, at and between the
table's sun nodes and planes, past its last plane (where the numpy path stays), for the day's
sky and the night's, in three of the shipped waters (a flat sea's; a wavy sea's tables differ
only in having no upwelling field, and are computed on first use: minutes).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from sensors.polarimeter.optics import water as wa
from sensors.polarimeter.optics.rt import sky_table as skt
from sensors.polarimeter.optics.rt import table as tb
from sensors.polarimeter.optics.sky import SkySpec


def _arrays(field: tb.FrameField) -> list[np.ndarray]:
    return [
        np.asarray(getattr(field, name))
        for name in ("inside", "inside_theta", "outside", "outside_theta", "aureole", "up")
    ]


def _both(
    monkeypatch: pytest.MonkeyPatch, t: tb.LightFieldTable, *args: object, **kw: object
) -> tuple[tb.FrameField, tb.FrameField]:
    fast = t.frame(*args, **kw)
    with monkeypatch.context() as m:
        m.setattr(tb.LightFieldTable, "compiled", False)
        ref = t.frame(*args, **kw)
    return fast, ref


@pytest.mark.parametrize("jerlov", ["II", "3C", "IB"])
def test_the_compiled_frame_is_numpys_at_and_between_nodes(
    monkeypatch: pytest.MonkeyPatch, jerlov: str
) -> None:
    t = tb.table_for(tb.WaterKey.of(wa.jerlov_water(jerlov)))  # shipped: no table computed
    sky = skt.sky_table_for(t.key, skt.SkyKey.of(SkySpec()))
    nodes = [float(x) for x in np.radians(t.sun_zenith_water_deg)]
    mids = [0.5 * (a + b) for a, b in itertools.pairwise(nodes)]
    rng = np.random.default_rng(7)
    suns = [*nodes, *mids, *rng.uniform(0.0, max(nodes), 6).tolist(), math.asin(1 / tb.TABLE_INDEX)]
    planes = [float(p) for p in t.planes]
    taus = [*planes[:-1], *(0.5 * (a + b) for a, b in itertools.pairwise(planes))]
    taus += [planes[-1], planes[-1] + 3.0]  # at and past the last plane: numpy's extrapolation
    checked = 0
    for th in suns:
        for tau in taus[:: 3 if th not in nodes else 1]:
            for s in (sky, None):
                fast, ref = _both(monkeypatch, t, th, tau, 2.0, 0.5, tb.TABLE_INDEX, s)
                for a, b in zip(_arrays(fast), _arrays(ref), strict=True):
                    assert a.dtype == b.dtype and a.shape == b.shape
                    np.testing.assert_array_equal(a, b)
                checked += 1
    assert checked > 200


def test_the_kernel_is_what_the_frame_calls(monkeypatch: pytest.MonkeyPatch) -> None:
    """Not a test that passes by taking numpy's path everywhere: the kernel writes the fields."""
    from sensors.polarimeter.optics.rt import frame_kernel

    calls = []
    at = frame_kernel.at

    def counted(*args: object) -> object:
        calls.append(1)
        return at(*args)

    monkeypatch.setattr(frame_kernel, "at", counted)
    t = tb.table_for(tb.WaterKey.of(wa.jerlov_water("II")))
    sky = skt.sky_table_for(t.key, skt.SkyKey.of(SkySpec()))
    t.frame(0.5, 2.4, 2.0, 0.5, tb.TABLE_INDEX, sky)
    assert len(calls) == 5  # the sun's and the sky's light, their upwelling, the aureole
