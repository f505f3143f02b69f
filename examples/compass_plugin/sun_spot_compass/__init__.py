"""An example auv-twin plug-in: the sun-spot compass (``sun_spot``)."""

from sun_spot_compass.method import SunSpotCompass, SunSpotConfig

__all__ = ["SunSpotCompass", "SunSpotConfig"]
