"""Navigation aids: a sensor's readings turned into filter updates, one class each.

A sensor from a package (``auv_twin.sensors``) is sampled and recorded by the world; for the
vehicle's filters to use it, the package adds an *aid* here, onboard: a :class:`NavAid` subclass
declared in :data:`twin.core.extensions.NAV_AIDS` (entry-point group ``auv_twin.nav_aids``) whose
:meth:`NavAid.update` takes a reading and updates the variant's filter
(:meth:`twin.onboard.eskf.Eskf.update_vector`: innovation, H, R; gated and counted like the
built-in updates). A scenario ties a sensor to an aid and gives the aid's parameters::

    [navigation.aids.usbl]      # the sensor's name ([sensors.extra.usbl])
    aid = "usbl_position"       # a registered aid
    sigma_floor_m = 0.1         # the aid's parameters (its constructor's keywords)

Every filter variant gets its own instance, on the same readings (paired, as the compass's).
Onboard side: an aid sees the reading and the variant's own estimate (:class:`AidContext`),
never the truth. Helpers for the common case, a position fix: :func:`horizontal_position_rows`.
"""

from __future__ import annotations

import abc
import inspect
import math
from typing import Any, ClassVar, Protocol

import numpy as np

from twin.core.arrays import Float64Array as FloatArray
from twin.core.extensions import NAV_AIDS, class_entry
from twin.core.messages import Reading
from twin.onboard.eskf import Eskf, NavEstimate, UpdateResult
from twin.onboard.eskf_dynamics import DIM, I_H, I_LAT, I_LON


class AidContext(Protocol):
    """What an aid sees of its variant (a :class:`twin.onboard.navigator.Navigator`)."""

    @property
    def filter(self) -> Eskf:
        """The variant's filter."""

    def estimate(self) -> NavEstimate:
        """The variant's current estimate."""

    @property
    def metres_per_radian(self) -> tuple[float, float]:
        """(North, East) metres per radian of latitude and longitude at the launch point."""

    def local_en(self, est: NavEstimate) -> tuple[float, float]:
        """An estimate's (East, North) in metres from the launch point."""


class NavAid(abc.ABC):
    """A sensor's readings as filter updates.

    Subclasses set ``name`` (the registry's key) and implement :meth:`update`; their constructor
    takes the scenario's ``[navigation.aids.<sensor>]`` parameters as keywords and raises a
    ``ValueError`` naming a bad one (the field, the value, what is allowed).
    """

    name: ClassVar[str] = ""
    #: The reading's channels it reads: ``validate`` checks that the tied sensor gives them.
    channels: ClassVar[tuple[str, ...]] = ()

    @abc.abstractmethod
    def update(self, nav: AidContext, reading: Reading) -> UpdateResult | None:
        """Update ``nav.filter`` with ``reading``; None when the reading is not used.

        A reading the aid cannot use (a non-finite value: a dropped fix) is skipped with None;
        :meth:`~twin.onboard.eskf.Eskf.update_vector` refuses non-finite numbers with a
        ``ValueError``, which stops the run.
        """


def horizontal_position_rows(nav: AidContext) -> tuple[FloatArray, FloatArray]:
    """(predicted East and North in metres from the launch point, H (2×15)) of the estimate.

    The local-level metres of a position error are δλ · (R_N cos L₀) East and δL · R_M North
    (the launch point's radii, as :meth:`AidContext.local_en` uses).
    """
    est = nav.estimate()
    east, north = nav.local_en(est)
    m_north, m_east = nav.metres_per_radian
    h = np.zeros((2, DIM))
    h[0, I_LON] = m_east
    h[1, I_LAT] = m_north
    return np.array([east, north]), h


def vertical_row() -> FloatArray:
    """H (1×15) of the height h (= −depth)."""
    h = np.zeros((1, DIM))
    h[0, I_H] = 1.0
    return h


def create_aid(name: str, **params: Any) -> NavAid:
    """A configured aid by name; errors name the allowed aids or the bad parameter."""
    cls = NAV_AIDS.load(name, class_entry(NavAid, "name"))
    allowed = [p for p in inspect.signature(cls).parameters if p not in ("args", "kwargs")]
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise ValueError(f"{unknown[0]}: not a parameter of aid {name!r}; allowed: {allowed}")
    return cls(**params)


def finite(name: str, value: Any, lo: float = 0.0, *, open_lo: bool = True) -> float:
    """A parameter checked finite and above ``lo`` (a ValueError naming it otherwise)."""
    v = float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
    ok = v is not None and math.isfinite(v) and (v > lo if open_lo else v >= lo)
    if not ok:
        bound = f"> {lo:g}" if open_lo else f">= {lo:g}"
        raise ValueError(f"{name}: {value!r}; allowed: a finite number {bound}")
    return float(v)  # type: ignore[arg-type]
