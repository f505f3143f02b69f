"""Extension points: one registry per kind of thing a researcher adds, each thing declared once.

A registry maps a name to an *entry point*, ``"package.module:attribute"``, as Gymnasium's
``register(id, entry_point=...)`` does: nothing is imported until the thing is used, so the
scenario schema lists the allowed names (and a scenario is checked against them) without
importing the code that runs them. The project's own entries are declared below; an installed
package adds its own through the extension point's entry-point group, Gymnasium's
``_load_env_plugins`` pattern::

    # the plug-in package's pyproject.toml
    [project.entry-points."auv_twin.compass_methods"]
    brightest = "my_compass.method:BrightestPatch"

after which ``navigation.variants = ["brightest", "lig"]`` runs it beside LIG
(``docs/extending.md``, ``examples/compass_plugin``). A plug-in may not take a built-in name: the
error names both.

Why by hand and not a library: ``importlib.metadata`` is the standard for discovery; what is left
(a name table, lazy loading, one-line errors) is twenty lines that no package does as a whole.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

from twin.core.options import JERLOV_TYPES


class ExtensionError(ValueError):
    """A registry entry a user can fix.

    An unknown name, a plug-in that takes a built-in name or does not import. The command line
    prints it as one line and exits 2, as it does a bad scenario.
    """


@dataclass
class ExtensionPoint:
    """One registry: names → entry points, built in and from installed packages.

    Attributes:
        kind: What an entry is, for messages ("compass method").
        group: The entry-point group installed packages declare their entries in.
        builtins: The project's own entries, name → ``"module:attribute"``.
    """

    kind: str
    group: str
    builtins: Mapping[str, str]
    _added: dict[str, Any] = field(default_factory=dict, repr=False)
    _plugins: dict[str, str] | None = field(default=None, repr=False)
    _loaded: dict[str, Any] = field(default_factory=dict, repr=False)

    def plugins(self) -> dict[str, str]:
        """Entries declared by installed packages (read once), name → ``"module:attribute"``."""
        if self._plugins is None:
            found: dict[str, str] = {}
            for ep in metadata.entry_points(group=self.group):
                if ep.name in self.builtins:
                    dist = ep.dist.name if ep.dist is not None else "an installed package"
                    raise ExtensionError(
                        f"{self.kind} {ep.name!r} from {dist} ({ep.value}) takes a built-in "
                        f"name ({self.builtins[ep.name]}); rename it in that package's "
                        f"[project.entry-points.{self.group!r}]"
                    )
                found[ep.name] = ep.value
            self._plugins = found
        return dict(self._plugins)

    def names(self) -> tuple[str, ...]:
        """Every name a scenario may use: built in, then plug-ins, then added at run time."""
        out = list(self.builtins)
        out += [n for n in self.plugins() if n not in out]
        out += [n for n in self._added if n not in out]
        return tuple(out)

    def add(self, name: str, obj: Any) -> None:
        """Register ``obj`` under ``name`` at run time (a notebook's or a test's own entry)."""
        if not isinstance(name, str) or not name:
            raise ValueError(f"{self.kind} name: {name!r}; allowed: a non-empty string")
        if name in self.builtins or name in self.plugins():
            known = self.builtins.get(name) or self.plugins()[name]
            if self._loaded.get(name) is not obj:
                raise ValueError(f"{self.kind} {name!r} is already registered ({known})")
        self._added[name] = obj
        self._loaded.pop(name, None)  # checked on its first load, as an imported entry is

    def remove(self, name: str) -> None:
        """Undo :meth:`add` (tests)."""
        self._added.pop(name, None)
        if name not in self.builtins and name not in self.plugins():
            self._loaded.pop(name, None)

    def load(self, name: str, check: Callable[[str, Any], None] | None = None) -> Any:
        """The entry named ``name``, imported on first use.

        Args:
            name: A name from :meth:`names`.
            check: Called once with (name, the loaded object); raises if the object is not what
                this extension point takes.

        Raises:
            ExtensionError: Unknown name (the message lists the allowed ones), or an entry point
                that does not import (the message names it and the import error).
        """
        if name in self._loaded:
            return self._loaded[name]
        if name in self._added:
            obj = self._added[name]
            if check is not None:
                check(name, obj)
            self._loaded[name] = obj
            return obj
        target = self.builtins.get(name) or self.plugins().get(name)
        if target is None:
            raise ExtensionError(f"{self.kind}: {name!r} is unknown; allowed: {list(self.names())}")
        module, _, attr = target.partition(":")
        try:
            obj = importlib.import_module(module)
            for part in attr.split(".") if attr else ():
                # A part indexes a mapping (a table of entries: "water:JERLOV_500NM.1C").
                obj = obj[part] if isinstance(obj, Mapping) else getattr(obj, part)
        except (ImportError, AttributeError, KeyError) as exc:
            raise ExtensionError(
                f"{self.kind} {name!r} ({target}) does not import: {exc}"
            ) from None
        if check is not None:
            check(name, obj)
        self._loaded[name] = obj
        return obj


def class_entry(base: type, key: str) -> Callable[[str, Any], None]:
    """A ``check`` for :meth:`ExtensionPoint.load`: a subclass of ``base`` named by its entry.

    The class's ``key`` attribute must be the entry's name (one declaration: the registry's name
    and the class's agree).
    """

    def check(name: str, obj: Any) -> None:
        what = f"{base.__module__}.{base.__qualname__}"
        if not (isinstance(obj, type) and issubclass(obj, base)):
            raise ExtensionError(f"{name!r} is {obj!r}; expected a subclass of {what}")
        if getattr(obj, key) != name:
            raise ExtensionError(
                f"{name!r} is {obj.__name__}, whose {key} is {getattr(obj, key)!r}; the entry's "
                f"name must be the class's {key}"
            )

    return check


#: The navigation variant without a compass: strapdown INS aided by gravity and depth only. Every
#: other variant is a compass method's name.
INS_ONLY = "ins"

#: Compass methods (``twin.onboard.compass``): a raw polarimeter frame → a solar vector. Each is
#: a ``CompassMethod`` subclass whose ``name`` is its name here; ``<method>_paper`` is the method
#: as its paper writes it, ``<method>`` the twin's refinement (docs/compass_methods.md).
COMPASS_METHODS = ExtensionPoint(
    "compass method",
    "auv_twin.compass_methods",
    {
        "lig": "twin.onboard.compass.lig:LigCompass",
        "lig_paper": "twin.onboard.compass.lig:LigPaperCompass",
        "pol": "twin.onboard.compass.pol:PolCompass",
        "pol_paper": "twin.onboard.compass.pol:PolPaperCompass",
        "roia": "twin.onboard.compass.roia:RoiaMethod",
        "roia_paper": "twin.onboard.compass.roia:RoiaPaperMethod",
        "snell": "twin.onboard.compass.snell:SnellWindowMethod",
        "snell_paper": "twin.onboard.compass.snell:SnellPaperMethod",
        "moi": "twin.onboard.compass.moi:MoiCompass",
        "patz": "twin.onboard.compass.moi:PatzCompass",
        "ht": "twin.onboard.compass.moi:HoughCompass",
    },
)

#: Sensor kinds (``sensors.registry``): a kind → its :class:`sensors.base.Sensor` class. Built in:
#: the IMU, the depth gauge, the gravimeter and the polarization camera; a package adds its own,
#: which a scenario mounts with ``[sensors.extra.<name>] kind = "<kind>"`` (docs/extending.md).
SENSORS = ExtensionPoint(
    "sensor",
    "auv_twin.sensors",
    {
        "imu": "sensors.imu:Imu",
        "depth": "sensors.depth:DepthGauge",
        "gravimeter": "sensors.gravimeter:Gravimeter",
        "polarimeter": "sensors.polarimeter.render:Polarimeter",
    },
)

#: Navigation aids (``twin.onboard.aids``): a name → a ``NavAid`` subclass that turns a sensor's
#: readings into filter updates. None built in (the built-in sensors' updates are the filter's
#: own); a package that adds a sensor adds its aid here, and a scenario ties them with
#: ``[navigation.aids.<sensor>] aid = "<name>"``.
NAV_AIDS = ExtensionPoint("navigation aid", "auv_twin.nav_aids", {})

#: Study trials a campaign runs (``twin.campaign.trials``): a ``StudyTrial`` or a function
#: ``run(params, seed) -> metrics``.
STUDY_TRIALS = ExtensionPoint(
    "study trial",
    "auv_twin.trials",
    {
        "moi_noise": "twin.campaign.moi_noise:TRIAL",
        "snell_turntable": "twin.campaign.snell_turntable:TRIAL",
        "snell_attitude": "twin.campaign.snell_attitude:TRIAL",
        "roia_static": "twin.campaign.roia_static:TRIAL",
        "lig_tank": "twin.campaign.lig_tank:TRIAL",
        "apparent_sun": "twin.campaign.apparent_sun:TRIAL",
    },
)

#: Checks ``validate`` runs after the schema's own, so that it rejects whatever ``run`` would:
#: each a function ``check(scenario) -> list[str]`` of one-line problems, run in this order.
#: Declared here, by name, so that the scenario layer reaches the world's build without importing
#: it (docs/architecture.md); a plug-in sensor adds its own check in this group.
SCENARIO_CHECKS = ExtensionPoint(
    "scenario check",
    "auv_twin.scenario_checks",
    {
        "sensors": "twin.world.assembly:check_sensors",
        "navigation": "twin.sim.build:check_navigation",
    },
)

#: Water bodies (``sensors.polarimeter.optics.water_body``): a name → its inherent optical
#: properties at 500 nm, a ``WaterBody`` (absorption, scattering, K_d and where they come from).
#: Built in: Jerlov's types; a package adds a measured water of its own, which a scenario names in
#: ``water.jerlov_type`` (the light field's table for it is computed on first use and cached).
WATER_BODIES = ExtensionPoint(
    "water body",
    "auv_twin.water_bodies",
    {t: f"sensors.polarimeter.optics.water_body:JERLOV_500NM.{t}" for t in JERLOV_TYPES},
)
