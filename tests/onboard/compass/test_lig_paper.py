"""LIG as the paper writes it (``lig_paper``) beside the twin's variant (``lig``)."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

import sensors
from scenarios.schema import nav_variants
from sensors.polarimeter.render import OpticsConfig
from twin.onboard.compass.base import CompassContext, available, create
from twin.onboard.compass.lig import LIG_PAPER, LigConfig, _paper_normals


def test_the_papers_method_is_registered_and_a_scenario_can_name_it():
    assert {"lig", "lig_paper"} <= set(available())
    assert "lig_paper" in nav_variants()
    m = create("lig_paper")
    assert m.config == LIG_PAPER
    assert LIG_PAPER.mapping == "paper" and LIG_PAPER.window_margin_rad == 0.0
    assert LIG_PAPER.gradient_snr_min == 0.0 and not LIG_PAPER.exclude_saturated
    assert create("lig").config == LigConfig()  # the twin's variant keeps its own defaults
    with pytest.raises(ValueError, match="mapping"):
        LigConfig(mapping="exact")


def test_eq12_is_c_l_h_times_v_l_and_the_printed_row_differs_by_cos_chi():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(50, 3))
    p[:, 2] = np.abs(p[:, 2]) + 2.0
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    gx, gy = rng.normal(size=50), rng.normal(size=50)
    v = _paper_normals(p, p, gx, gy, 1.34, printed=False)
    # Eq. 10 × eq. 8, built here from the paper's matrices.
    phi = np.arctan2(p[:, 1], p[:, 0])
    chi = np.arctan(np.tan(np.arctan2(-gy, gx) - phi - np.pi / 2))
    si = np.minimum(1.34 * np.hypot(p[:, 0], p[:, 1]), 1.0)
    ci = np.sqrt(1 - si**2)
    for k in range(50):
        c = np.array(
            [
                [ci[k] * np.cos(phi[k]), -np.sin(phi[k]), si[k] * np.cos(phi[k])],
                [ci[k] * np.sin(phi[k]), np.cos(phi[k]), si[k] * np.sin(phi[k])],
                [-si[k], 0.0, ci[k]],
            ]
        )
        want = c @ np.array([np.cos(chi[k]), np.sin(chi[k]), 0.0])
        np.testing.assert_allclose(v[k], want / np.linalg.norm(want), atol=1e-12)
    printed = _paper_normals(p, p, gx, gy, 1.34, printed=True)
    assert not np.allclose(printed, v)


def test_the_papers_lig_finds_the_sun_in_scattering_water_on_an_ideal_frame():
    """Measured: II at 5 m, suns 50° and 70° up: zenith within 0.4°, azimuth within 0.3°."""
    cam = sensors.create("polarimeter", "ideal_bin4")
    cam.configure(OpticsConfig(jerlov_type="II"))
    cal = cam.calibration()
    rng = np.random.default_rng(0)
    for el_deg in (50.0, 70.0):
        el, az = math.radians(el_deg), 0.7
        sun = np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])
        raw, _ = cam.render_offline(np.eye(3), 5.0, sun, rng)
        ctx = CompassContext(
            dt.datetime(2021, 7, 31, 4, tzinfo=dt.UTC), 36.175, 120.482,
            roll_rad=0.0, pitch_rad=0.0, depth_m=5.0, water_index=cam.n_water, sun_enu=sun,
        )  # fmt: skip
        fix = create("lig_paper").solve(raw, cal, ctx)
        assert fix.ok
        e = fix.sun_h
        assert abs(math.degrees(math.acos(e[2]) - math.acos(sun[2]))) < 2.0
        daz = math.degrees(math.atan2(e[0], e[1]) - math.atan2(sun[0], sun[1]))
        assert abs((daz + 180.0) % 360.0 - 180.0) < 1.0
