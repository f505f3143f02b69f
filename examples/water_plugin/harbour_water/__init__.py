"""An example auv-twin plug-in: a water body (``turbid_harbour``)."""

from harbour_water.bodies import TURBID_HARBOUR

__all__ = ["TURBID_HARBOUR"]
