"""The polarimeter: what an upward-looking 185 deg fisheye DoFP polarization camera records.

The physics chain, one module a stage (see docs/polarimeter.md):
``camera`` (fisheye geometry, housing) → ``sun`` (NREL SPA) → ``sky`` (radiance and polarization
above the surface) → ``surface`` (Snell, Fresnel Mueller, waves) → ``water`` (attenuation,
scattering, depolarization) → ``mosaic`` (micro-polarizers, noise, ADC) → the raw frame.

Polarization convention, shared by every stage (:mod:`sensors.polarimeter.stokes`): linear Stokes
vectors (I, Q, U) are always stated relative to an explicit reference unit vector ``ref``
perpendicular to the propagation direction ``d`` of the light. The E-vector at angle ψ is
``e = cos ψ · ref + sin ψ · (d × ref)``, Q = I·P·cos 2ψ, U = I·P·sin 2ψ. Circular polarization is
ignored (skylight's V is negligible, and the camera cannot measure it).
"""
