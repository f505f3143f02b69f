"""A turbid harbour water at 500 nm, for auv-twin's ``auv_twin.water_bodies`` entry point.

A water body is its inherent optical properties at the twin's one wavelength (500 nm): absorption
a, scattering b (water molecules included) and the diffuse attenuation K_d, with where they come
from (:class:`sensors.polarimeter.optics.water.WaterBody`). The twin's particle phase function,
P and δ apply to it as to any water; its light-field table is computed on first use and cached.

This one is an example of the mechanism, not a measurement: Jerlov's coastal type 3C as the twin
ships it (a and b measured by Williamson & Hollins 2022) with its particle scattering doubled, as
a harbour after a storm might be; K_d follows Kirk's (1984) √(a² + G a b) scaling from 3C's
K_d, as the twin's ``turbidity`` does. A package for a real site would give its own measured
a, b and K_d (an ac-s and a radiometer cast) and cite them in ``iop_source``.
"""

from __future__ import annotations

import math

from sensors.polarimeter.optics.water import B_SEAWATER_500NM, JERLOV_500NM, KIRK_G, WaterBody

_BASE = JERLOV_500NM["3C"]
_PARTICLE_FACTOR = 2.0  # assumption: the example's "after a storm"
_B = B_SEAWATER_500NM + _PARTICLE_FACTOR * (_BASE.b_per_m - B_SEAWATER_500NM)
_A = _BASE.a_per_m

TURBID_HARBOUR = WaterBody(
    kd_per_m=_BASE.kd_per_m
    * math.sqrt((_A * _A + KIRK_G * _A * _B) / (_A * _A + KIRK_G * _A * _BASE.b_per_m)),
    a_per_m=_A,
    b_per_m=_B,
    iop_source=(
        "assumption (an example): Jerlov 3C at 500 nm (a, b: Williamson & Hollins 2022; K_d: "
        "Jerlov 1976) with twice its particle scattering, K_d by Kirk's (1984) scaling"
    ),
)
