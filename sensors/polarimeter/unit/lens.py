"""The lens's own polarization: Fresnel diattenuation and retardance that grow with field angle.

World side. A real fisheye changes the polarization it images (xin2024 §2.3 measures the AoP
error of its FE185 against incidence angle): a chief ray far off axis crosses the front
element's surfaces obliquely, and an oblique (even anti-reflection coated) interface transmits
p-polarized light (E in the plane of incidence, here the meridional plane of the ray, which the
meridional mapping images along the sensor's radial direction) better than s. The result is a
linear diattenuator with its axis radial on the sensor, a small retardance about the same axes,
and a transmission that falls with field angle.

Model, from the Fresnel equations (thin-film characteristic matrix, Macleod, *Thin-Film Optical
Filters*, 4th ed., §2.2) of ``surfaces`` air–glass interfaces, each with a single quarter-wave
MgF₂ anti-reflection layer, crossed by the chief ray of field angle θ at an incidence angle
``incidence_fraction · θ``. Per interface: amplitude transmittances t_s, t_p ⇒ intensity
transmittances T_s, T_p and the phase difference; across all interfaces they multiply (add).
Then, on (S0, S1, S2) referenced to the radial direction,

    M(θ) = T̄ · [[1, D, 0], [D, 1, 0], [0, 0, √(1 − D²) cos δ]],
    T̄ = ½(T_p + T_s) / T̄(0),  D = (T_p − T_s)/(T_p + T_s),  δ = φ_p − φ_s,

normalized to the axis (the on-axis throughput is ``PolarimeterSpec.lens_transmission``'s).

Parameters and their sources:

* ``glass_index = 1.52``: a crown glass (Schott N-BK7: n = 1.5214 at 500 nm); the FE185C057HA-1's
  prescription is not published [uncertain].
* ``coating_index = 1.38`` (MgF₂), quarter-wave at ``coating_design_nm = 550`` — the standard
  single-layer AR coating (Macleod §3.2.1). Multilayer coatings are better at normal incidence;
  at 45° they are not much better [uncertain].
* ``surfaces = 2`` and ``incidence_fraction = 0.5``: the two faces of the front meniscus, which
  does most of a fisheye's field compression, each bending the chief ray by about half the field
  angle [uncertain: a geometric estimate, not a ray trace of the real lens]. At θ = 90° this gives
  D = 0.036, δ = −0.005 rad and T̄ = 0.99 — an AoP error of up to D/(2p) rad (1° for fully
  polarized light, 3.5° at p = 0.3) at the edge of the field, the size of the errors xin2024
  compensates.

``ideal``: M = identity everywhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twin.core import options
from twin.core.arrays import Float64Array as FloatArray
from twin.core.fields import Range, check_ranges

LensModel = Literal["fresnel", "ideal"]
LENS_MODELS = options.LENS_MODELS  # declared in twin.core.options (the scenario offers it)


@dataclass(frozen=True, slots=True)
class LensPolarization:
    """The lens's polarization transfer (module docstring for the model and its sources)."""

    model: LensModel = "fresnel"
    glass_index: float = 1.52
    coating_index: float = 1.38
    coating_design_nm: float = 550.0
    surfaces: int = 2
    incidence_fraction: float = 0.5

    def __post_init__(self) -> None:
        if self.model not in LENS_MODELS:
            raise ValueError(f"lens.model: {self.model!r}; allowed: {', '.join(LENS_MODELS)}")
        checks = (
            ("glass_index", self.glass_index, 1.0, 2.5),
            ("coating_index", self.coating_index, 1.0, 2.5),
            ("coating_design_nm", self.coating_design_nm, 200.0, 2000.0),
            ("incidence_fraction", self.incidence_fraction, 0.0, 1.0),
        )
        check_ranges("lens", ((n, v, Range(lo, hi)) for n, v, lo, hi in checks))
        s = self.surfaces
        if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s <= 40:
            raise ValueError(f"lens.surfaces: {s!r}; allowed: an integer in [0, 40]")

    @classmethod
    def ideal(cls) -> LensPolarization:
        return cls(model="ideal")

    @property
    def is_ideal(self) -> bool:
        return self.model == "ideal" or self.surfaces == 0 or self.incidence_fraction == 0.0

    def transfer(
        self, field_angle_rad: ArrayLike, wavelength_nm: float
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(T̄, D, δ) at field angles θ (rad): relative transmission, diattenuation, retardance."""
        theta = np.abs(np.asarray(field_angle_rad, dtype=np.float64))
        if self.is_ideal:
            one = np.ones_like(theta)
            return one, np.zeros_like(theta), np.zeros_like(theta)
        i = np.minimum(self.incidence_fraction * theta, math.radians(89.9))
        ts, tp, phs, php = self._interface(i, wavelength_nm)
        t0s, t0p, _, _ = self._interface(np.zeros(1), wavelength_nm)
        n = self.surfaces
        big_s, big_p = ts**n, tp**n
        mean = 0.5 * (big_s + big_p) / (0.5 * (t0s[0] ** n + t0p[0] ** n))
        return mean, (big_p - big_s) / (big_p + big_s), n * (php - phs)

    def _interface(
        self, i: FloatArray, wavelength_nm: float
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """T_s, T_p and transmitted phases of one coated air → glass interface at incidence i."""
        n0, nc, ng = 1.0, self.coating_index, self.glass_index
        s0 = n0 * np.sin(i)
        cos_c = np.sqrt(1.0 - (s0 / nc) ** 2 + 0j)
        cos_g = np.sqrt(1.0 - (s0 / ng) ** 2 + 0j)
        cos_0 = np.cos(i) + 0j
        # Phase thickness of a layer that is a quarter wave at normal incidence at the design λ.
        delta = 2.0 * math.pi * nc * (self.coating_design_nm / (4.0 * nc)) * cos_c / wavelength_nm
        out = []
        for pol in ("s", "p"):
            if pol == "s":
                e0, ec, eg = n0 * cos_0, nc * cos_c, ng * cos_g
            else:
                e0, ec, eg = n0 / cos_0, nc / cos_c, ng / cos_g
            b = np.cos(delta) + 1j * np.sin(delta) / ec * eg
            c = 1j * ec * np.sin(delta) + np.cos(delta) * eg
            den = e0 * b + c
            big_t = 4.0 * e0.real * eg.real / np.abs(den) ** 2
            out.append((big_t, np.angle(2.0 * e0 / den)))
        (t_s, ph_s), (t_p, ph_p) = out
        return t_s, t_p, ph_s, ph_p


def radial_mueller(
    transmission: ArrayLike, diattenuation: ArrayLike, retardance: ArrayLike, radial_rad: ArrayLike
) -> FloatArray:
    """(..., 3, 3) Mueller matrices on sensor-frame (S0, S1, S2) of a radial diattenuator/retarder.

    Args:
        transmission: T̄ per pixel.
        diattenuation: D per pixel.
        retardance: δ per pixel (rad).
        radial_rad: Angle of the radial direction in the sensor frame (from +u towards +v).
    """
    t = np.asarray(transmission, dtype=np.float64)
    d = np.asarray(diattenuation, dtype=np.float64)
    cd = np.sqrt(np.maximum(1.0 - d * d, 0.0)) * np.cos(np.asarray(retardance, dtype=np.float64))
    a = 2.0 * np.asarray(radial_rad, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    m = np.zeros((*t.shape, 3, 3))
    # R(−φ) · diag-block · R(φ) on (S1, S2); the S0 row/column carry D along the radial axis.
    m[..., 0, 0] = 1.0
    m[..., 0, 1] = d * c
    m[..., 0, 2] = d * s
    m[..., 1, 0] = d * c
    m[..., 2, 0] = d * s
    m[..., 1, 1] = c * c + cd * s * s
    m[..., 1, 2] = c * s * (1.0 - cd)
    m[..., 2, 1] = c * s * (1.0 - cd)
    m[..., 2, 2] = s * s + cd * c * c
    return m * t[..., None, None]


def fold_radial(
    analysis: NDArray[np.floating],
    transmission: ArrayLike,
    diattenuation: ArrayLike,
    retardance: ArrayLike,
    radial_rad: ArrayLike,
) -> NDArray[np.float32]:
    """Analysis vectors a (H, W, 3) behind a radial diattenuator/retarder: a · M per pixel.

    The same M as :func:`radial_mueller`, applied element by element in float32 without building
    the (H, W, 3, 3) matrices (360 MB at full resolution).
    """
    f32 = np.float32
    t = np.asarray(transmission, f32)
    d = np.asarray(diattenuation, f32)
    cd = (np.sqrt(np.maximum(1 - d * d, 0)) * np.cos(np.asarray(retardance, f32))).astype(f32)
    a2 = 2 * np.asarray(radial_rad, f32)
    c, s = np.cos(a2), np.sin(a2)
    a0, a1, a2_ = (np.asarray(analysis[..., k], f32) for k in range(3))
    cs = c * s * (1 - cd)
    out = np.empty((*t.shape, 3), f32)
    out[..., 0] = t * (a0 + d * (c * a1 + s * a2_))
    out[..., 1] = t * (d * c * a0 + (c * c + cd * s * s) * a1 + cs * a2_)
    out[..., 2] = t * (d * s * a0 + cs * a1 + (s * s + cd * c * c) * a2_)
    return out


__all__ = ["LENS_MODELS", "LensPolarization", "fold_radial", "radial_mueller"]
