"""Radiative transfer in the water column: the offline reference and the table the renderer reads.

* :mod:`~sensors.polarimeter.optics.rt.kernel` — the numba photon-transport kernel;
* :mod:`~sensors.polarimeter.optics.rt.reference` —
  :func:`~sensors.polarimeter.optics.rt.reference.solve`, the
  polarized Monte Carlo reference for one water body and one source;
* :mod:`~sensors.polarimeter.optics.rt.table` — the light-field table over sun zenith and depth that
  the
  per-frame renderer interpolates, built from the reference.
"""
