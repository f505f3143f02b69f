"""The named choices and sourced defaults a scenario sets and the world implements.

Declared once, here, because both sides of the scenario layer need them: the scenario schema
offers them (and the field reference and the JSON Schema list them) without importing the optics
that implement them, and each optics module checks its own input against the same tuple. The
sensors modules re-export what they own (``bubbles.BUBBLE_MODELS`` is this module's tuple).
"""

from __future__ import annotations

#: Breaking-wave bubbles under a wind sea (sensors.polarimeter.optics.bubbles).
BUBBLE_MODELS: tuple[str, ...] = ("hall_novarini", "ideal")
#: Wave-focused sunlight in the scattered light (sensors.polarimeter.optics.caustics).
FLICKER_MODELS: tuple[str, ...] = ("caustics", "ideal")
#: Marine snow in the field of view (sensors.polarimeter.optics.particles).
PARTICLE_MODELS: tuple[str, ...] = ("marine_snow", "ideal")
#: The fisheye's polarization through its glass (sensors.polarimeter.unit.lens).
LENS_MODELS: tuple[str, ...] = ("fresnel", "ideal")
#: Jerlov (1976)'s water types: open ocean I..III, coastal 1C..9C (increasingly turbid); the keys
#: of sensors.polarimeter.optics.water.JERLOV_500NM, in this order (tests/scenarios/test_schema.py).
JERLOV_TYPES: tuple[str, ...] = ("I", "IA", "IB", "II", "III", "1C", "3C", "5C", "7C", "9C")
#: The water body's name when a scenario gives its own absorption, scattering and K_d
#: (``[water.iops]``) instead of naming one; reserved: no registered water body may take it.
INLINE_WATER = "inline"

#: Depolarization ratio of sea water at S = 35: 0.039 + a₁S with a₁ = 1.5e-4 (Hu, Zhang et al.
#: 2019, Appl. Opt. 58(4):991, read; sensors.polarimeter.optics.scattering's docstring).
WATER_DEPOLARIZATION_RATIO = 0.044
#: Its measured range at S = 35 (a₁ = 1–2e-4); Morel's (1974) older 0.09 is outside it.
WATER_DEPOLARIZATION_RANGE = (0.0425, 0.046)
#: Peak linear polarization of ocean particle scattering: the middle of the range of six natural
#: waters (Front. Remote Sens. 2:735512, 2021, read; scattering's docstring).
PARTICLE_DOP_MAX = 0.75
#: The measured range of that peak over diverse natural waters (same source).
PARTICLE_DOP_MAX_RANGE = (0.6, 0.9)
