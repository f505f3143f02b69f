"""The vehicle computer: INS, Kalman filter, compass methods, autopilot and guidance.

Rule (checked by tests/test_boundary.py): modules here import only from ``twin.onboard`` and the
shared contract ``twin.core``, the standard library and third-party packages. Never from the world
side (``twin.world``, ``sensors``), the scorer, the recorder or the app.
"""
