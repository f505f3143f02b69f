"""Radiative transfer in the water column: the offline reference and the table the renderer reads.

* :mod:`~sensors.polarimeter.optics.rt.kernel` — the numba photon-transport kernel;
* :mod:`~sensors.polarimeter.optics.rt.reference` —
  :func:`~sensors.polarimeter.optics.rt.reference.solve`, the polarized Monte Carlo reference for
  one water body and one source;
* :mod:`~sensors.polarimeter.optics.rt.grid` — what a table is computed on (sun nodes, planes,
  winds, index) and the key of its water;
* :mod:`~sensors.polarimeter.optics.rt.table` — the light-field table over sun zenith and depth
  that the per-frame renderer interpolates, built from the reference; its sky's part in
  :mod:`~sensors.polarimeter.optics.rt.sky_table`;
* :mod:`~sensors.polarimeter.optics.rt.decompose`, :mod:`~sensors.polarimeter.optics.rt.poles` —
  the aureole and reflection taken out of a table and added back, the smooth poles;
* :mod:`~sensors.polarimeter.optics.rt.frame_field` — one frame's grid, what the kernel samples;
* :mod:`~sensors.polarimeter.optics.rt.store` — the cache, atomic writes and the reference runs;
  :mod:`~sensors.polarimeter.optics.rt.build` rebuilds the shipped file.
"""
