"""A minimal valid scenario for tests of one table."""

from __future__ import annotations

from typing import Any

from scenarios import parse_scenario
from scenarios.schema import Scenario


def minimal_scenario(**tables: Any) -> Scenario:
    """A 10 s heading leg at 2 m, with ``tables`` (e.g. ``optics={...}``) added or replaced."""
    return parse_scenario(
        {
            "name": "t",
            "duration_s": 10.0,
            "start_utc": "2021-07-31T04:00:00Z",
            "place": {"latitude_deg": 36.0, "longitude_deg": 120.0},
            "mission": {
                "kind": "legs",
                "legs": [
                    {"heading_deg": 0.0, "speed_mps": 1.0, "duration_s": 10.0, "depth_m": 2.0}
                ],
            },
            **tables,
        }
    )
