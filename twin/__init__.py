"""auv-twin: a MuJoCo digital twin of an AUV that navigates by skylight.

The package is a house of rooms; the folder tells which side of the world/onboard boundary a module
is on (docs/architecture.md; tests/test_boundary.py checks the import graph):

* :mod:`twin.core`: the contract both sides share (frames, earth, messages, calibration, the sun
  ephemeris, the mission plan).
* :mod:`twin.world`: the world: plant, vehicle, hydrodynamics, actuators, current, truth, the
  world's assembly. The sensors are the top-level :mod:`sensors` package.
* :mod:`twin.onboard`: the vehicle computer: INS, filter, compass methods, autopilot, guidance.
* :mod:`twin.scoring`: estimates and the mission scored against truth.
* :mod:`twin.record`: the Rerun recording.
* :mod:`twin.app`: the stepping core, the run loop, the dm_env/Gymnasium environments, the CLI.
* :mod:`twin.campaign`: many seeded runs: specs, the local pool and Ray, Parquet rows, reports;
  ``twin.load_campaign_results(DIR)`` reads a campaign as one DataFrame.
"""

from __future__ import annotations

from typing import Any as _Any

# One-call access to a campaign's results (twin.load_campaign_results("runs/quick") → DataFrame),
# imported on first use so that `import twin` does not pull in pandas and pyarrow.
_CAMPAIGN_API = ("load_campaign_results", "load_timeseries")


def __getattr__(name: str) -> _Any:
    if name in _CAMPAIGN_API:
        from twin.campaign import results

        return getattr(results, name)
    raise AttributeError(f"module 'twin' has no attribute {name!r}")
