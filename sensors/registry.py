"""Sensor registry: a new sensor is one module with ``@register`` on its class."""

from __future__ import annotations

import dataclasses
import importlib
from typing import Any

from sensors.base import Sensor, SensorSpec

_REGISTRY: dict[str, type[Sensor]] = {}

# Modules that hold the built-in sensors; imported lazily so that importing the registry is cheap
# and a sensor with heavy dependencies costs nothing until it is used.
_BUILTIN_MODULES = (
    "sensors.imu",
    "sensors.depth",
    "sensors.gravimeter",
    "sensors.polarimeter.render",
)


def register(cls: type[Sensor]) -> type[Sensor]:
    """Class decorator: register a sensor class under its ``kind`` (once only)."""
    if not cls.kind:
        raise ValueError(f"{cls.__name__} has no 'kind'")
    existing = _REGISTRY.get(cls.kind)
    if existing is not None and existing is not cls:
        raise ValueError(f"sensor kind {cls.kind!r} is already registered by {existing.__name__}")
    _REGISTRY[cls.kind] = cls
    return cls


def _load_builtins() -> None:
    for module in _BUILTIN_MODULES:
        importlib.import_module(module)


def available() -> dict[str, type[Sensor]]:
    """All registered sensor kinds."""
    _load_builtins()
    return dict(sorted(_REGISTRY.items()))


def sensor_class(kind: str) -> type[Sensor]:
    """The class registered under ``kind``; KeyError naming the known kinds otherwise."""
    kinds = available()
    if kind not in kinds:
        raise KeyError(f"unknown sensor kind {kind!r}; known: {', '.join(kinds)}")
    return kinds[kind]


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
