"""Compass methods: a raw polarimeter frame → a solar vector, a heading (and, for some, roll/pitch).

One module per published method, each registered under its name (``base.register``):

* ``lig`` — light-intensity gradient (Hu et al. 2024, §2)
* ``pol`` — E-vector method with refraction compensation in Snell's window (the LIG paper's ref. 22)
* ``roia`` — attitude-adaptive zenith region + vector superposition (Fang et al. 2024)
* ``snell`` — Snell-window attitude with Canny + Hough (Xin et al. 2024)
* ``moi``, ``patz``, ``ht`` — Liang et al. 2020

Use :func:`create` (``create("lig")``) or the classes directly.
"""

from __future__ import annotations

import importlib

from twin.onboard.compass.base import (
    CompassContext,
    CompassFix,
    CompassMethod,
    available,
    create,
    heading_from_sun,
    no_fix,
    register,
)

# Method modules, imported on demand so that a missing optional one never breaks the others.
BUILTIN_MODULES: tuple[str, ...] = ("lig", "pol", "roia", "snell", "moi")


def load_builtins() -> None:
    for mod in BUILTIN_MODULES:
        try:
            importlib.import_module(f"twin.onboard.compass.{mod}")
        except ModuleNotFoundError as exc:
            if exc.name != f"twin.onboard.compass.{mod}":
                raise


__all__ = [
    "CompassContext",
    "CompassFix",
    "CompassMethod",
    "available",
    "create",
    "heading_from_sun",
    "load_builtins",
    "no_fix",
    "register",
]
