"""Regenerate the README's polarimeter pictures: intensity | AoP | DoP for a few situations.

    python docs/images/make_readme_images.py

Noisy PHX050S-P camera binned 4×4 (612×512), 700 µs, Weihai on the LIG sea-trial morning (sun
~51° up in the south-east), rendered offline (no vehicle in view).
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

import cv2
import numpy as np

import sensors
from sensors.polarimeter.optics.sun import sun_position
from sensors.polarimeter.render import OpticsConfig
from twin.core.frames import euler_to_dcm
from twin.onboard.polarization import stokes_from_mosaic
from twin.record import images

OUT = Path(__file__).resolve().parent
SUN = sun_position(dt.datetime(2021, 9, 3, 2, 0, tzinfo=dt.UTC), 37.54, 122.06)

CASES = [
    # name, roll deg, pitch deg, depth m, Jerlov type, turbidity
    ("level_2m_clear", 0.0, 0.0, 2.0, "IB", 1.0),
    ("tilted_2m_clear", 25.0, -10.0, 2.0, "IB", 1.0),
    ("level_15m_clear", 0.0, 0.0, 15.0, "IB", 1.0),
    ("level_10m_turbid", 0.0, 0.0, 10.0, "3C", 1.0),
]


def main() -> None:
    for name, roll, pitch, depth, jerlov, turb in CASES:
        cam = sensors.create("polarimeter", "phx050s_p_bin4")
        cam.configure(OpticsConfig(jerlov_type=jerlov, turbidity=turb))
        c = euler_to_dcm(math.radians(roll), math.radians(pitch), 0.0)
        raw, _ = cam.render_offline(c, depth, SUN, np.random.default_rng(0))
        ss = cam.pspec.sensor_spec()
        pol = stokes_from_mosaic(raw, ss.layout_deg, black_level_dn=ss.black_level_dn)
        mask = images.signal_mask(pol)
        grey = cv2.cvtColor(images.intensity_u8(pol.s0), cv2.COLOR_GRAY2RGB)
        row = np.hstack([grey, images.aop_rgb(pol.aop, mask), images.dop_rgb(pol.dop, mask)])
        cv2.imwrite(str(OUT / f"{name}.png"), cv2.cvtColor(row, cv2.COLOR_RGB2BGR))
        print("wrote", OUT / f"{name}.png")


if __name__ == "__main__":
    main()
