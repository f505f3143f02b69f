"""One frame's scattered-light grid, what the per-pixel kernel samples, and the blend of several.

:meth:`sensors.polarimeter.optics.rt.table.LightFieldTable.frame` makes a :class:`FrameField` for
one sun zenith and depth; :func:`blend` weighs those of the table's wind nodes together.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from twin.core.arrays import FloatArray

NONE = np.zeros((1, 2, 3), dtype=np.float32)
NONE_ROWS = np.zeros(1)


@dataclass(frozen=True)
class FrameField:
    """One frame's scattered-light grid (radiance units of the irradiances given to ``frame``).

    Attributes:
        inside: (T_in + 2, n_phi + 2, 3) Stokes at the bins inside Snell's window, padded: the
            first and last rows repeat the first/last bin at the zenith and at the window's edge
            (constant extrapolation), the first/last columns mirror the first/last azimuth bin
            (U changes sign under the mirror).
        inside_theta: (T_in + 2,) the rows' look zeniths (radians): 0, bin centres, θ_c.
        outside: (T_out + 2, n_phi + 2, 3) the same from the window's edge to the nadir.
        outside_theta: (T_out + 2,) θ_c, bin centres, π.
        theta_c: The table's window edge (radians).
        dphi: Azimuth bin width (radians); padded column j sits at (j − ½) dphi.
        aureole: The sun's aureole, tapered and padded (:func:`decompose.pad_aureole`); one
            row: none.
        aureole_psi: Its rows' angles from the refracted sun (radians).
        aureole_dom: Its position-angle bin width (radians).
        up: The upwelling light at the surface, rows from the window's edge to the nadir as
            :attr:`outside` (for the reflection into the window; a flat sea's share), or one
            row: none.

    :attr:`inside` and :attr:`outside` hold the remainder: the table's light less the aureole
    and the reflection (:mod:`sensors.polarimeter.optics.rt.decompose`), which the kernel adds back.
    """

    inside: FloatArray
    inside_theta: FloatArray
    outside: FloatArray
    outside_theta: FloatArray
    theta_c: float
    dphi: float
    aureole: FloatArray = dataclasses.field(default_factory=lambda: NONE)
    aureole_psi: FloatArray = dataclasses.field(default_factory=lambda: NONE_ROWS)
    aureole_dom: float = 1.0
    up: FloatArray = dataclasses.field(default_factory=lambda: NONE)

    @functools.cached_property
    def inside_cos(self) -> FloatArray:
        """The cos of :attr:`inside_theta` (descending), what the per-pixel kernel searches."""
        return np.cos(self.inside_theta)

    @functools.cached_property
    def outside_cos(self) -> FloatArray:
        """The cos of :attr:`outside_theta` (descending)."""
        return np.cos(self.outside_theta)


def blend(parts: list[tuple[float, FrameField]]) -> FrameField:
    """The weighted sum of frame fields on one grid (the renderer's wind interpolation).

    The reflection's upwelling light is the flat sea's alone (a wavy sea keeps it in its bins).
    """
    first = parts[0][1]
    inside = sum(w * f.inside for w, f in parts)
    outside = sum(w * f.outside for w, f in parts)
    aur = sum(w * f.aureole for w, f in parts)
    ups = [w * f.up for w, f in parts if f.up.shape[0] > 1]
    return FrameField(
        np.ascontiguousarray(inside, dtype=np.float32),
        first.inside_theta,
        np.ascontiguousarray(outside, dtype=np.float32),
        first.outside_theta,
        first.theta_c,
        first.dphi,
        np.ascontiguousarray(aur, dtype=np.float32),
        first.aureole_psi,
        first.aureole_dom,
        np.ascontiguousarray(sum(ups), dtype=np.float32) if ups else NONE,
    )
