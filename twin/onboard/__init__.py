"""The vehicle computer: INS, Kalman filter, compass methods.

Rule (checked by tests/test_boundary.py): modules here import only from ``twin.onboard``, the
shared ``twin.messages``, ``twin.frames`` and ``twin.earth``, the standard library and third-party
packages. Never from the world side (``twin.plant``, ``twin.truth``, ``sensors``, ...).
"""
