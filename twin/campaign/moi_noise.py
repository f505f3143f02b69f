"""The MOI paper's simulation study as a campaign trial (liang2020 §4.1, Figs. 8, 9, 11).

One trial: a random solar azimuth at solar elevation ``elevation_deg``, the ideal AoP image of the
paper's hypothetical imager (Table 1: level camera at the zenith, pinhole f = 8 mm, 3.45 µm,
2048 columns × 2448 rows, DOP_max = 1, orthographic E-vector projection), the ``case``'s noise,
then each of the three axis methods (MOI, PATZ, HT: ``twin.onboard.compass.moi_axis.estimate_axis``)
on the same image. The paper's 2000 trials per elevation are 2000 seeds of this trial
(scenarios/campaigns/moi_noise.toml), the study's one home (its report:
validation/results/campaigns/moi_noise/report.md).

Cases:

* ``ideal`` (Fig. 8): no noise;
* ``gaussian`` (§4.1.2, Fig. 9): zero-mean Gaussian noise on the AOPLM image with σ = 1 % of
  (max AOPLM − min AOPLM). The paper says "variance … set to 1 %(Max − Min)"; read literally in
  radians that is σ = √(0.01·π) = 10°, which contradicts its own MOI result (< 0.011° max error
  needs σ of about 2° or less), so σ = 1 % of the range (1.8°) is used;
* ``crosstalk`` (§4.1.3, Fig. 11): the same Gaussian noise plus uniform noise U(0, 2 % of the
  range) whose sign alternates between adjacent pixels (Fig. 10(a), a checkerboard of ±).

Noise is added to the AoP image (AOPLM = AoP − ξ with ξ fixed per pixel, so that is the same
perturbation) and wrapped back to [−π/2, π/2), as a real AoP would be. The error is that of the
SM-ASM line (mod 180°); the sun/anti-sun decision is reported separately (``flip``; undecidable
at h_s = 0°, where the sun and anti-sun patterns coincide).

Random streams: one ``numpy`` Generator from the run's seed alone, drawn in a fixed order
(azimuth, Gaussian noise, crosstalk noise). The same seed therefore gives the same azimuth and
the same Gaussian draw in every case and at every elevation: the cases are paired.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from sensors.polarimeter.unit.calibration import calibration_from_spec
from sensors.polarimeter.unit.fisheye import preset
from twin.campaign.trials import StudyTrial
from twin.onboard.compass.moi_axis import _geometry, estimate_axis

METHODS = ("moi", "patz", "ht")
CASES = ("ideal", "gaussian", "crosstalk")
HALF_PI = np.float32(math.pi / 2)
PI = np.float32(math.pi)


@functools.lru_cache(maxsize=1)
def imager() -> tuple[Any, Any, np.ndarray]:
    """The paper's imager (calibration), its geometry cache and the crosstalk sign pattern.

    Built once per process (~3 s: the per-pixel rays of a 5-megapixel frame).
    """
    cal = calibration_from_spec(preset("moi_pinhole"))
    g = _geometry(cal, "interpolate", None)
    h, w = g.shape
    sign = (1 - 2 * (np.add.outer(np.arange(h), np.arange(w)) % 2)).astype(np.float32)
    return cal, g, sign


@functools.lru_cache(maxsize=1)
def _planar_rays(cal: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # The (H, W, 3) rays as three contiguous planes: the strided [..., k] views cost 5× more.
    p, _ = cal.rays("interpolate")
    return tuple(np.ascontiguousarray(p[..., k]) for k in range(3))  # type: ignore[return-value]


def ideal_aop(cal: Any, sun_cam: np.ndarray) -> np.ndarray:
    """AoP (from +u towards +v) of the Rayleigh sky on the orthographic imager: E ∝ s × p."""
    px, py, pz = _planar_rays(cal)
    sx, sy, sz = (float(x) for x in sun_cam)
    ex = sy * pz
    ex -= sz * py
    ey = sx * pz
    ey -= sz * px  # = −(sz·px − sx·pz), the −E_y of the AoP convention below
    psi = np.arctan2(ey, ex).astype(np.float32)
    psi += HALF_PI
    np.mod(psi, PI, out=psi)
    psi -= HALF_PI
    return psi


def add_noise(
    aop: np.ndarray, xi: np.ndarray, sign: np.ndarray, rng: np.random.Generator, crosstalk: bool
) -> np.ndarray:
    """The case's noise on an AoP image (see the module docstring), wrapped to [−π/2, π/2)."""
    aoplm = np.mod(aop - xi + HALF_PI, PI) - HALF_PI
    span = float(aoplm.max() - aoplm.min())
    n = rng.standard_normal(size=aop.shape, dtype=np.float32) * np.float32(0.01 * span)
    if crosstalk:
        n += sign * rng.random(size=aop.shape, dtype=np.float32) * np.float32(0.02 * span)
    n += aop + HALF_PI
    return np.mod(n, PI) - HALF_PI


def check(params: Mapping[str, Any]) -> list[str]:
    """Errors of a parameter table (elevation_deg, case, methods)."""
    errs = []
    e = params.get("elevation_deg")
    if not (isinstance(e, int | float) and not isinstance(e, bool) and 0.0 <= e < 90.0):
        errs.append(f"elevation_deg: {e!r}; allowed: a number in [0, 90) (solar elevation, °)")
    c = params.get("case")
    if c not in CASES:
        errs.append(f"case: {c!r}; allowed: {list(CASES)}")
    m = params.get("methods")
    if not (isinstance(m, list) and m and all(x in METHODS for x in m) and len(set(m)) == len(m)):
        errs.append(f"methods: {m!r}; allowed: a non-empty list of distinct {list(METHODS)}")
    return errs


def run_trial(params: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """One trial: per method the axis error (°), the sun/anti-sun flip and the solve time."""
    cal, g, sign = imager()
    rng = np.random.default_rng(seed)
    er = math.radians(float(params["elevation_deg"]))
    az = float(rng.uniform(0.0, 2.0 * math.pi))
    sun = np.array([math.cos(er) * math.sin(az), math.cos(er) * math.cos(az), math.sin(er)])
    aop = ideal_aop(cal, sun)
    case = params["case"]
    if case != "ideal":
        aop = add_noise(aop, g.xi, sign, rng, crosstalk=case == "crosstalk")
    methods: dict[str, dict[str, Any]] = {}
    for m in params["methods"]:
        t0 = time.perf_counter()
        est = estimate_axis(m, aop, cal, sun_elevation_rad=er)
        out: dict[str, Any] = {"ok": bool(est.ok), "solve_s": time.perf_counter() - t0}
        if est.ok:  # a failed fix has no error: the column stays empty (counted by "ok")
            d = (est.axis_rad - az + math.pi / 2) % math.pi - math.pi / 2
            out["error_deg"] = abs(math.degrees(d))
            ds = (est.sun_azimuth_rad - az + math.pi) % (2 * math.pi) - math.pi
            out["flip"] = int(abs(ds) > math.pi / 2)
        methods[m] = out
    return {"complete": True, "sun_azimuth_deg": math.degrees(az), "methods": methods}


TRIAL = StudyTrial(
    name="moi_noise",
    run=run_trial,
    defaults={"elevation_deg": 30.0, "case": "gaussian", "methods": list(METHODS)},
    check=check,
)
