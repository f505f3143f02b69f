"""The scenario checker's words and bounds: its error messages and the ranges of its fields.

One home for each range a field is checked against; the loader's sections read them here and
:mod:`scenarios.reference` quotes them (through the checks' own error text) in the field reference.
"""

from __future__ import annotations

from datetime import UTC, datetime

from twin.core.fields import COMPASS_DEG as COMPASS_DEG
from twin.core.fields import DURATION_S as DURATION_S
from twin.core.fields import NON_NEGATIVE as NON_NEGATIVE
from twin.core.fields import POSITIVE as POSITIVE
from twin.core.fields import Range
from twin.core.mission import COMMANDED_SPEED_MPS as COMMANDED_SPEED_MPS
from twin.core.mission import LANES as LANES

# The tank scene (models/auv/scene_tank.xml): 12 m (East) x 6 m (North) x 4 m deep, centred on the
# world origin, water surface at z = 0.
TANK_LENGTH_M = 12.0
TANK_WIDTH_M = 6.0
TANK_FLOOR_DEPTH_M = 4.0
# Deepest depth a scenario may command in the tank: the floor is at 4 m and the hull (about 0.19 m
# in diameter) pitches while it holds depth, so keep half a metre of water under the keel.
TANK_MAX_DEPTH_M = 3.5

# ---- error text --------------------------------------------------------------------------------


MSG_NAIVE_TIME = (
    "{value} has no UTC offset; write a timezone-aware time such as 2021-09-03T02:00:00Z "
    "or 2021-09-03T10:00:00+08:00"
)
MSG_LEG_BOTH = (
    "has both to_m and heading_deg; a leg is EITHER a waypoint leg (to_m, depth_m, speed_mps) "
    "OR a heading leg (heading_deg, duration_s, depth_m, speed_mps)"
)
MSG_LEG_NEITHER = (
    "has neither to_m nor heading_deg; a leg is EITHER a waypoint leg (to_m, depth_m, speed_mps) "
    "OR a heading leg (heading_deg, duration_s, depth_m, speed_mps)"
)
MSG_TANK_DEPTH = (
    "{value:g} is too deep for the tank scene (floor at {floor:g} m); allowed: {allowed}"
)
MSG_TANK_OUTSIDE = (
    "{what} lies outside the tank; the {length:g} m x {width:g} m tank spans "
    "East {east}, North {north}"
)
MSG_TANK_SEABED = (
    "not allowed in the tank scene, whose floor is part of the scene at {floor:g} m; remove it"
)
MSG_BELOW_SEABED = "{value:g} is not above the seabed (water.seabed_depth_m = {seabed:g})"
MSG_ACCEPT_TOO_BIG = (
    "{value} is not smaller than the shortest lawnmower leg ({shortest:g} m); "
    "waypoints would be skipped"
)
MSG_PROFILE_ORDER = (
    "{value:g} is not deeper than the previous point's {prev:g}; depths must increase"
)


# ---- ranges ------------------------------------------------------------------------------------


#: A root seed: an int64 (a Parquet column holds it; numpy's SeedSequence takes any int).
SEED_MAX = 2**63 - 1
SEED = Range(0, SEED_MAX)
# The poles are excluded: the INS mechanises in local-level ENU, whose East axis and longitude rate
# (v_E / (R cos φ)) are undefined at ±90° (twin/onboard/ins.py); a grid-frame INS would be needed.
LATITUDE_DEG = Range(-90.0, 90.0, lo_open=True, hi_open=True)
# The sun model (pvlib's SPA) and the recorder's timeline take nanosecond timestamps (numpy/pandas
# datetime64[ns]): 1677-09-21 to 2262-04-11. A run must start and end inside whole years of that.
START_UTC_MIN = datetime(1678, 1, 1, tzinfo=UTC)
START_UTC_END = datetime(2262, 1, 1, tzinfo=UTC)
MSG_START_RANGE = (
    "{value} is out of range; allowed 1678-01-01 to 2261-12-31 UTC (the sun model's "
    "nanosecond timestamps); the whole run must fit"
)
LONGITUDE_DEG = Range(-180.0, 180.0)
ROLL_DEG = Range(-180.0, 180.0)
PITCH_DEG = Range(-90.0, 90.0)
DENSITY_KG_M3 = Range(990.0, 1050.0)
TEMPERATURE_C = Range(-2.0, 40.0)
SALINITY_PSU = Range(0.0, 42.0)
UNIT_INTERVAL = Range(0.0, 1.0)
DEPOLARIZATION_RATIO = Range(0.0, 0.5, hi_open=True)
# A water's absorption and K_d, and its scattering (m⁻¹ at 500 nm): Jerlov's types span
# 0.026-0.99; 100 m⁻¹ is a sediment plume's order (sensors.polarimeter.optics.water_body.WaterBody).
ATTENUATION_PER_M = Range(0.0, 100.0, lo_open=True)
SCATTERING_PER_M = Range(0.0, 100.0)
CURRENT_SPEED_MPS = Range(0.0, 3.0)
GUST_SIGMA_MPS = Range(0.0, 1.0)
VEHICLE_SPEED_MPS = Range(0.0, 3.0)  # the initial speed: may be 0 (starting at rest)
RATE_HZ = Range(0.0, 1000.0, lo_open=True)
CAMERA_RATE_HZ = Range(0.0, 30.0, lo_open=True)
CAMERA_WIDTH = Range(16, 1920)
CAMERA_HEIGHT = Range(16, 1080)
CIE_SKY_TYPE = Range(1, 15)
BERRY_DELTA_DEG = Range(0.0, 60.0)
ZENITH_RADIANCE = Range(0.0, 10.0, lo_open=True)
TURBIDITY = Range(0.0, 50.0, lo_open=True)
WIND_SPEED_MPS = Range(0.0, 30.0)
#: The Beaufort scale's wind speeds (m/s at 10 m), force 0–11: the middle of each force's range
#: in WMO's table (WMO-No. 8, Guide to Instruments and Methods of Observation, Annex 5.A:
#: 0–0.2, 0.3–1.5, 1.6–3.3, 3.4–5.4, 5.5–7.9, 8.0–10.7, 10.8–13.8, 13.9–17.1, 17.2–20.7,
#: 20.8–24.4, 24.5–28.4, 28.5–32.6 m/s). Force 11's middle (30.55) is clipped to the surface
#: model's 30 m/s; force 12 (≥ 32.7 m/s) is beyond it. The 2 % difference between WMO's 10 m
#: and Cox & Munk's 12.5 m (a neutral log profile over the sea) is well inside a force's range.
BEAUFORT_MPS: tuple[float, ...] = (
    0.1, 0.9, 2.45, 4.4, 6.7, 9.35, 12.3, 15.5, 18.95, 22.6, 26.45, 30.0,
)  # fmt: skip
BEAUFORT_FORCE = Range(0.0, 11.0)
WAVELENGTH_NM = Range(400.0, 700.0)
#: [hardware]'s on/off keys, with the position an ideal model gives them.
HARDWARE_SWITCHES: dict[str, bool] = {"lens_compensation": False, "distortion_correction": True}
GATE_PROBABILITY = Range(0.5, 1.0)
MAP_SIZE_KM = Range(1.0, 1000.0)
MAP_SPACING_M = Range(10.0, 20_000.0)
MAP_CORRELATION_KM = Range(0.01, 1000.0)
MAP_RANGE_MGAL = Range(0.0, 10_000.0, lo_open=True)
MAP_POSITION_KM = Range(0.0, 1000.0)
MAP_ERROR_MGAL = Range(0.0, 100.0)
TANK_DEPTH_M = Range(0.0, TANK_MAX_DEPTH_M)
TANK_EAST_M = Range(-TANK_LENGTH_M / 2, TANK_LENGTH_M / 2, lo_open=True, hi_open=True)
TANK_NORTH_M = Range(-TANK_WIDTH_M / 2, TANK_WIDTH_M / 2, lo_open=True, hi_open=True)
