"""The compass interface: heading from a solar vector, context validation, the registry."""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import numpy as np
import pytest

from twin.core.frames import euler_to_dcm, heading_deg_to_yaw
from twin.onboard.compass import CompassContext, available, create, heading_from_sun
from twin.onboard.compass.base import finish_fix

UTC = dt.datetime(2021, 9, 3, 2, 0, tzinfo=dt.UTC)


def _sun(elev_deg: float, az_deg: float) -> np.ndarray:
    e, a = math.radians(elev_deg), math.radians(az_deg)
    return np.array([math.cos(e) * math.sin(a), math.cos(e) * math.cos(a), math.sin(e)])


@pytest.mark.parametrize("heading", [0.0, 37.0, 90.0, 181.0, 300.0])
@pytest.mark.parametrize(("roll", "pitch"), [(0.0, 0.0), (12.0, -7.0)])
def test_heading_from_the_solar_vector_inverts_the_attitude(heading, roll, pitch) -> None:
    sun_enu = _sun(40.0, 133.0)
    c_bn = euler_to_dcm(math.radians(roll), math.radians(pitch), heading_deg_to_yaw(heading))
    sun_body = c_bn.T @ sun_enu
    ctx = CompassContext(UTC, 37.54, 122.06, math.radians(roll), math.radians(pitch))
    fix = finish_fix("test", sun_body, ctx, sun_enu, 1e-6 * np.eye(3), pixels_used=1)
    assert fix.ok and fix.heading_deg is not None
    assert (fix.heading_deg - heading + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(fix.sun_h, ctx.c_b_h @ sun_body)
    assert 0.0 < fix.heading_sigma_rad < 0.01


def test_no_azimuth_at_the_zenith_and_no_nan_handed_on() -> None:
    assert heading_from_sun(np.array([0.0, 0.0, 1.0]), _sun(40, 10)) is None
    ctx = CompassContext(UTC, 37.54, 122.06)
    bad = finish_fix("test", np.array([np.nan, 0, 1]), ctx, _sun(40, 10), np.eye(3), pixels_used=3)
    assert not bad.ok and "not finite" in bad.reason and bad.sun_body is None


@pytest.mark.parametrize(
    ("field", "kwargs"),
    [
        ("latitude_deg", {"latitude_deg": 91.0}),
        ("pitch_rad", {"pitch_rad": 2.0}),
        ("water_index", {"water_index": 0.5}),
        ("depth_m", {"depth_m": float("nan")}),
    ],
)
def test_bad_context_names_the_field(field, kwargs) -> None:
    base = {"utc": UTC, "latitude_deg": 37.54, "longitude_deg": 122.06}
    with pytest.raises(ValueError, match=field):
        CompassContext(**{**base, **kwargs})


def test_every_published_method_is_registered_and_unknown_names_are_refused() -> None:
    assert {"lig", "pol", "roia", "snell", "moi", "patz", "ht"} <= set(available())
    assert create("lig").name == "lig"
    with pytest.raises(ValueError, match="allowed"):
        create("astrolabe")


# ---- the CompassMethod contract: one constructor, one prologue, for every method -------------
ALL_METHODS = ("lig", "pol", "roia", "snell", "moi", "patz", "ht")


def _calibration():
    import sensors

    return sensors.create("polarimeter", "ideal_bin4").calibration()


@pytest.mark.parametrize("name", ALL_METHODS)
def test_every_method_shares_the_constructor_contract(name) -> None:
    from twin.onboard.compass.base import CompassMethod

    cls = available()[name]
    assert issubclass(cls, CompassMethod)
    default = cls()
    assert isinstance(default.config, cls.config_type)
    # An override by keyword replaces that field (and only that field) of the default config.
    field = next(f for f in dataclasses.fields(default.config) if f.type in ("float", float))
    changed = cls(**{field.name: getattr(default.config, field.name) * 0.9})
    assert getattr(changed.config, field.name) == pytest.approx(
        0.9 * getattr(default.config, field.name)
    )
    with pytest.raises(ValueError, match="no field"):
        cls(warp_drive=1.0)
    with pytest.raises(ValueError, match="config"):
        cls(config=object())


@pytest.mark.parametrize("name", ALL_METHODS)
def test_every_method_shares_the_frame_prologue(name) -> None:
    cal = _calibration()
    m = create(name)
    raw = np.zeros((cal.height_px, cal.width_px), np.uint16)
    ctx = CompassContext(UTC, 37.54, 122.06, sun_enu=_sun(30.0, 120.0))
    for bad, match in (
        (raw[:, :-2], r"raw\.shape"),
        (raw.tolist(), "numpy"),
        (np.full(raw.shape, np.nan, np.float32), "NaN"),
    ):
        with pytest.raises(ValueError, match=match):
            m.solve(bad, cal, ctx)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="calibration"):
        m.solve(raw, None, ctx)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="ctx"):
        m.solve(raw, cal, None)  # type: ignore[arg-type]
    night = m.solve(raw, cal, CompassContext(UTC, 37.54, 122.06, sun_enu=_sun(-5.0, 120.0)))
    assert not night.ok and night.reason.startswith("night")
