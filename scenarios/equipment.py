"""The scenario's equipment tables.

The sensors and their overrides (``[sensors]``), their hardware errors (``[hardware]``), the
onboard navigation (``[navigation]``) and the recording.

Each ``read_*`` reads one table through :class:`~scenarios.reading._Table` (every problem
reported, none raised) and returns its dataclass, or None where a problem was reported.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from scenarios.ranges import (
    HARDWARE_SWITCHES,
)
from scenarios.reading import (
    _MISSING,
    MSG_NOT_A_CHOICE,
    MSG_NOT_FINITE,
    MSG_WRONG_TYPE,
    _all_set,
    _build,
    _choices,
    _Default,
    _Report,
    _show,
    _Table,
    _type_name,
)
from scenarios.schema import (
    CALIBRATION_MODELS,
    HARDWARE_SIGMAS,
    LENS_MODELS,
    MOUNTING_MODELS,
    SENSOR_SLOTS,
    ExtraSensor,
    Hardware,
    Navigation,
    OverrideValue,
    Recording,
    Sensors,
    nav_variants,
)
from twin.core.extensions import INS_ONLY, NAV_AIDS


def _overrides(t: _Table | None) -> tuple[tuple[str, OverrideValue], ...] | None:
    if t is None:
        return None
    expected = "a number or an array of numbers"
    out: list[tuple[str, OverrideValue]] = []
    ok = True
    for key, raw in t.data.items():
        t.known.append(key)
        path = t.at(key)
        if not key.isidentifier():
            t.report.add(path, "is not a spec field name (a Python identifier)")
            ok = False
            continue
        if isinstance(raw, list):
            if not raw:
                t.report.add(path, f"is an empty array; expected {expected}")
                ok = False
                continue
            items = [_override_number(t.report, f"{path}[{i}]", v) for i, v in enumerate(raw)]
            if _all_set(*items):
                out.append((key, tuple(items)))
            else:
                ok = False
        else:
            value = _override_number(t.report, path, raw, expected=expected)
            if value is None:
                ok = False
            else:
                out.append((key, value))
    return tuple(sorted(out)) if ok else None


def _override_number(
    errs: _Report, path: str, value: Any, expected: str = "a number"
) -> int | float | None:
    # Ints stay ints: a spec field may be an integer (bits, a sample count).
    if isinstance(value, bool) or not isinstance(value, int | float):
        errs.add(
            path,
            MSG_WRONG_TYPE.format(
                value=_show(value), type_name=_type_name(value), expected=expected
            ),
        )
        return None
    if isinstance(value, float) and not math.isfinite(value):
        errs.add(path, MSG_NOT_FINITE.format(value=_show(value), expected=expected))
        return None
    return value


def read_sensors(t: _Table | None) -> Sensors | None:
    if t is None:
        return None
    t.of(Sensors)
    sensors = _build(
        Sensors,
        imu=t.string("imu", non_empty=True),
        depth=t.string("depth", non_empty=True),
        imu_overrides=_overrides(t.table("imu_overrides")),
        depth_overrides=_overrides(t.table("depth_overrides")),
        # "" stands for "no polarimeter" here: _build treats None as a failed check.
        polarimeter=t.string("polarimeter", non_empty=True, default=""),
        polarimeter_overrides=_overrides(t.table("polarimeter_overrides")),
        gravimeter=t.string("gravimeter", non_empty=True, default=""),
        gravimeter_overrides=_overrides(t.table("gravimeter_overrides")),
        extra=_extra_sensors(t.table("extra", expected="a table of sensors by name")),
    )
    t.finish()
    if sensors is not None and sensors.polarimeter == "":
        sensors = dataclasses.replace(sensors, polarimeter=None)
    if sensors is not None and sensors.gravimeter == "":
        sensors = dataclasses.replace(sensors, gravimeter=None)
    return sensors


#: An extra sensor's own keys; the rest of its table is its spec's fields.
_EXTRA_KEYS = ("kind", "preset", "site")


def _extra_sensors(t: _Table | None) -> tuple[ExtraSensor, ...] | None:
    """``[sensors.extra.<name>]``: more sensors, each a kind, a preset, a site and spec fields.

    The kind is checked here against the registry; the preset, the site and the fields by
    building the sensor as a run does (``validate`` = ``run``: ``twin.world.assembly``).
    """
    if t is None:
        return None
    out: list[ExtraSensor] = []
    ok = True
    for name, raw in t.data.items():
        t.known.append(name)
        path = t.at(name)
        if not name.isidentifier():
            t.report.add(path, "is not a sensor name (a Python identifier)")
            ok = False
            continue
        if name in SENSOR_SLOTS:
            t.report.add(
                path, f"is a built-in sensor's name ({_choices(SENSOR_SLOTS)}); choose another"
            )
            ok = False
            continue
        if not isinstance(raw, Mapping):
            t.report.add(
                path,
                MSG_WRONG_TYPE.format(
                    value=_show(raw), type_name=_type_name(raw), expected="a table"
                ),
            )
            ok = False
            continue
        st = _Table(t.report, path, raw, ExtraSensor)
        kind = st.string("kind")
        preset = st.string("preset", non_empty=True, default="")
        site = st.string("site", non_empty=True, default="")
        fields = _overrides(
            _Table(t.report, path, {k: v for k, v in raw.items() if k not in _EXTRA_KEYS})
        )
        st.known += [k for k in raw if k not in _EXTRA_KEYS]
        st.finish()
        if not _all_set(kind, preset, site, fields):
            ok = False
            continue
        out.append(ExtraSensor(name, kind, preset or None, site or None, fields))
    return tuple(out) if ok else None


def read_navigation(t: _Table | None) -> Navigation | None:
    if t is None:
        return None
    t.of(Navigation)
    choices = nav_variants()
    raw = t._raw("variants", [], "a list of variant names")
    variants: tuple[str, ...] | None = ()
    if not isinstance(raw, _Default):
        path = t.at("variants")
        if not isinstance(raw, list):
            t.report.add(
                path,
                MSG_WRONG_TYPE.format(
                    value=_show(raw), type_name=_type_name(raw), expected="a list of names"
                ),
            )
            variants = None
        else:
            names: list[str] = []
            for i, v in enumerate(raw):
                if not isinstance(v, str) or v not in choices:
                    t.report.add(
                        f"{path}[{i}]",
                        MSG_NOT_A_CHOICE.format(value=_show(v), choices=_choices(choices)),
                    )
                    variants = None
                elif v in names:
                    t.report.add(f"{path}[{i}]", f"{_show(v)} is listed twice")
                    variants = None
                else:
                    names.append(v)
            if variants is not None:
                variants = tuple(names)
    steer_on = t.string("steer_on", choices=choices, default="")
    if variants is not None and steer_on and steer_on not in variants:
        t.report.add(
            t.at("steer_on"),
            f"{_show(steer_on)} is not one of the variants run ({list(variants)})",
        )
        steer_on = None
    nav = _build(
        Navigation,
        variants=variants,
        steer_on=steer_on,
        compass_rate_hz=t.number("compass_rate_hz"),
        gravity_aiding=t.boolean("gravity_aiding"),
        depth_aiding=t.boolean("depth_aiding"),
        initial_error=t.boolean("initial_error"),
        gate_probability=t.number("gate_probability"),
        sun_measurement=t.string("sun_measurement"),
        tuning=t.string("tuning"),
        alignment=t.string("alignment"),
        methods=_method_params(t.table("methods"), variants),
        aids=_aids(t.table("aids", expected="a table of aids by sensor name")),
    )
    t.finish()
    if nav is not None and nav.steer_on == "":
        nav = dataclasses.replace(nav, steer_on=None)
    return nav


def _method_params(
    t: _Table | None, variants: tuple[str, ...] | None
) -> tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] | None:
    """``[navigation.methods.<name>]``: each compass method's config fields, for a method run.

    The fields and their values are checked by building the method as a run does
    (``twin.sim.build.check_navigation``); here, the tables' shapes and names.
    """
    if t is None:
        return None
    out = []
    ok = True
    for name, params in t.data.items():
        t.known.append(name)
        path = t.at(name)
        if not isinstance(params, Mapping):
            expected = "a table of the method's parameters"
            t.report.add(
                path,
                MSG_WRONG_TYPE.format(
                    value=_show(params), type_name=_type_name(params), expected=expected
                ),
            )
            ok = False
        elif name == INS_ONLY:
            t.report.add(path, f"{_show(name)} has no compass method to configure")
            ok = False
        elif variants is not None and name not in variants:
            run = [v for v in variants if v != INS_ONLY]
            t.report.add(
                path,
                f"configures {_show(name)}, which is not a compass method run here; "
                f"allowed: the compass variants in navigation.variants ({run})",
            )
            ok = False
        else:
            out.append((name, tuple(params.items())))
    return tuple(out) if ok else None


def _aids(t: _Table | None) -> tuple[tuple[str, str, tuple[tuple[str, Any], ...]], ...] | None:
    """``[navigation.aids.<sensor>]``: the aid that fuses a sensor's readings, and its parameters.

    The sensor must be one of the scenario's extra sensors (the loader's cross-table check);
    the parameters are checked by building the aid as a run does
    (``twin.sim.build.check_navigation``); here, the tables' shapes and the aid's name.
    """
    if t is None:
        return None
    out = []
    ok = True
    for sensor, raw in t.data.items():
        t.known.append(sensor)
        path = t.at(sensor)
        if not isinstance(raw, Mapping):
            what = MSG_WRONG_TYPE.format(
                value=_show(raw), type_name=_type_name(raw), expected="a table with aid = ..."
            )
            t.report.add(path, what)
            ok = False
            continue
        st = _Table(t.report, path, raw)
        aid = st.string("aid", choices=NAV_AIDS.names(), default=_MISSING)
        st.known += [k for k in raw if k != "aid"]
        st.finish()
        if aid is None:
            ok = False
            continue
        out.append((sensor, aid, tuple((k, v) for k, v in raw.items() if k != "aid")))
    return tuple(out) if ok else None


def read_recording(t: _Table | None) -> Recording | None:
    if t is None:
        return None
    t.of(Recording)
    recording = _build(
        Recording,
        truth_rate_hz=t.number("truth_rate_hz"),
        camera=t.boolean("camera"),
        camera_rate_hz=t.number("camera_rate_hz"),
        camera_width=t.integer("camera_width"),
        camera_height=t.integer("camera_height"),
        polarimeter_log_rate_hz=t.number("polarimeter_log_rate_hz"),
    )
    t.finish()
    return recording


def read_hardware(t: _Table | None) -> Hardware | None:
    if t is None:
        return None
    t.of(Hardware)
    values: dict[str, Any] = {}
    choices = {
        "calibration": CALIBRATION_MODELS,
        "mounting": MOUNTING_MODELS,
        "lens": LENS_MODELS,
    }
    for model, sigmas in HARDWARE_SIGMAS.items():
        kind = t.string(model)
        values[model] = kind
        for key in sigmas:
            if kind == "ideal" and key in t.data:
                t.known.append(key)
                t.report.add(
                    t.at(key),
                    f"is set while hardware.{model} = 'ideal'; an ideal model has no error "
                    f"(use {model} = {_show(choices[model][0])} for it)",
                )
                values[key] = None
                continue
            if key in HARDWARE_SWITCHES:
                values[key] = t.boolean(key)
            else:
                values[key] = t.number(key)
    hardware = _build(Hardware, **values)
    t.finish()
    if hardware is not None:
        # An ideal model's σ are 0 and its switches take their ideal position (an ideal lens
        # needs no compensation; an exact calibration is a corrected one): nothing is drawn for
        # it downstream.
        for model, sigmas in HARDWARE_SIGMAS.items():
            if getattr(hardware, model) == "ideal":
                off = {k: HARDWARE_SWITCHES.get(k, 0.0) for k in sigmas}
                hardware = dataclasses.replace(hardware, **off)
    return hardware
