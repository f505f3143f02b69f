"""Sensor registry: a sensor kind is one class, declared once in an extension point.

The kinds are :data:`twin.core.extensions.SENSORS`: the project's, and those installed packages
declare under the ``auv_twin.sensors`` entry-point group (imported on first use, so a sensor with
heavy dependencies costs nothing until it is used). ``@register`` on a class adds it at run time
(a notebook's or a test's own sensor).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from sensors.base import Sensor, SensorSpec
from twin.core.extensions import SENSORS, class_entry

_check_sensor = class_entry(Sensor, "kind")


def register(cls: type[Sensor]) -> type[Sensor]:
    """Class decorator: a sensor class under its ``kind`` (once only).

    The built-in and installed kinds are declared in :data:`twin.core.extensions.SENSORS`; the
    decorator on those is a no-op that checks the declaration names this class. Any other class
    is added at run time.
    """
    if not cls.kind:
        raise ValueError(f"{cls.__name__} has no 'kind'")
    target = SENSORS.builtins.get(cls.kind) or SENSORS.plugins().get(cls.kind)
    if target is not None:
        if target != f"{cls.__module__}:{cls.__qualname__}":
            raise ValueError(f"sensor kind {cls.kind!r} is already registered ({target})")
        return cls
    if cls.kind in SENSORS.names():
        existing = SENSORS.load(cls.kind)
        if existing is not cls:
            raise ValueError(
                f"sensor kind {cls.kind!r} is already registered by {existing.__name__}"
            )
        return cls
    SENSORS.add(cls.kind, cls)
    return cls


def available() -> dict[str, type[Sensor]]:
    """All sensor kinds: built in, installed and registered at run time."""
    return {k: SENSORS.load(k, _check_sensor) for k in sorted(SENSORS.names())}


def sensor_class(kind: str) -> type[Sensor]:
    """The class registered under ``kind``; KeyError naming the known kinds otherwise."""
    if kind not in SENSORS.names():
        raise KeyError(f"unknown sensor kind {kind!r}; known: {', '.join(sorted(SENSORS.names()))}")
    return SENSORS.load(kind, _check_sensor)


def create(
    kind: str,
    preset: str | None = None,
    *,
    name: str | None = None,
    site: str | None = None,
    **overrides: Any,
) -> Sensor:
    """Build a sensor from a preset, with field overrides.

    Args:
        kind: Registry key (``"imu"``, ``"depth"``, ...).
        preset: A key of the class's ``PRESETS``; ``None`` uses the spec's defaults.
        name: Unique name in the run (defaults to the kind).
        site: MJCF mount site (defaults to the class's ``default_site``).
        **overrides: Spec fields to change from the preset.

    Raises:
        KeyError: Unknown kind or preset.
        ValueError: An override names no field of the spec, or makes the spec impossible.
    """
    cls = sensor_class(kind)
    if preset is None:
        spec: SensorSpec = cls.spec_type()
    else:
        if preset not in cls.PRESETS:
            raise KeyError(
                f"unknown {kind} preset {preset!r}; known: {', '.join(sorted(cls.PRESETS))}"
            )
        spec = cls.PRESETS[preset]
    if overrides:
        fields = {f.name for f in dataclasses.fields(spec)}
        unknown = sorted(set(overrides) - fields)
        if unknown:
            raise ValueError(
                f"{kind} spec has no field(s) {unknown}; fields are: {', '.join(sorted(fields))}"
            )
        spec = dataclasses.replace(spec, **overrides)
    return cls(spec, name=name, site=site)
