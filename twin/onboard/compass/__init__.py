"""Compass methods: a raw polarimeter frame → a solar vector, a heading (and, for some, roll/pitch).

One module per published method; each method is declared once, in
:data:`twin.core.extensions.COMPASS_METHODS` (name → class, imported on first use), and an
installed package adds its own through the ``auv_twin.compass_methods`` entry-point group
(docs/extending.md):

* ``lig`` — light-intensity gradient (Hu et al. 2024, §2)
* ``pol`` — E-vector method with refraction compensation in Snell's window (the LIG paper's ref. 22)
* ``roia`` — attitude-adaptive zenith region + vector superposition (Fang et al. 2024)
* ``snell`` — Snell-window attitude with Canny + Hough (Xin et al. 2024)
* ``moi``, ``patz``, ``ht`` — Liang et al. 2020
* ``<method>_paper`` — the method as its paper writes it (the plain name is the twin's refinement)

Use :func:`create` (``create("lig", min_pixels=500)``) or the classes directly.
"""

from __future__ import annotations

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

__all__ = [
    "CompassContext",
    "CompassFix",
    "CompassMethod",
    "available",
    "create",
    "heading_from_sun",
    "no_fix",
    "register",
]
