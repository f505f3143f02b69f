"""auv-twin: the world (physics, hydrodynamics, environment) and the run loop.

The vehicle computer lives in :mod:`twin.onboard` and must not import world modules; see
docs/architecture.md.
"""
