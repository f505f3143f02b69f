"""Build the shipped light-field tables: the radiative-transfer reference for every Jerlov type.

    python -m sensors.polarimeter.optics.rt.build [--photons N] [--workers W] [--types I II ...]

Writes ``sensors/polarimeter/optics/data/lightfield_jerlov_500nm.npz`` (one table per type, at
turbidity 1, with the scattered light of the default sky model; see
:mod:`sensors.polarimeter.optics.rt.table`) and prints, per type, the wall time, the
standard error of the tabulated radiance and the diffuse attenuation K_d the reference gives next
to Jerlov's. Deterministic: the same photon count gives the same file.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from sensors.polarimeter.optics import water as wa
from sensors.polarimeter.optics.rt import sky_table as skt
from sensors.polarimeter.optics.rt import table as tb
from sensors.polarimeter.optics.sky import SkySpec


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--photons", type=int, default=tb.SHIPPED_PHOTONS)
    p.add_argument("--sky-photons", type=int, default=skt.SHIPPED_SKY_PHOTONS)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--types", nargs="*", default=list(wa.JERLOV_TYPES))
    p.add_argument("--out", type=Path, default=tb.DATA_FILE, help="default: the shipped file")
    p.add_argument(
        "--sky-only",
        action="store_true",
        help="keep the shipped file's sun tables (they are deterministic) and rebuild the skies",
    )
    a = p.parse_args()
    arrays: dict[str, np.ndarray] = {}
    names = []
    for i, name in enumerate(a.types):
        t0 = time.perf_counter()
        w = wa.jerlov_water(name)
        key = tb.WaterKey.of(w)
        if a.sky_only and key in tb._shipped() and tb._shipped()[key].photons == a.photons:
            t = tb._shipped()[key]
        else:
            t = tb.LightFieldTable.build(key, a.photons, seed=i, workers=a.workers)
        arrays.update(t.arrays(prefix=f"{name}/"))
        sky = skt.SkyTable.build(
            t.key, skt.SkyKey.of(SkySpec()), a.sky_photons, seed=i, workers=a.workers
        )
        arrays.update(sky.arrays(prefix=f"{name}/{skt.SKY_PREFIX}"))
        names.append(name)
        rel = t.sun_se.astype(float) / np.maximum(t.sun[..., 0], 1e-30)
        sky_rel = sky.field_se.astype(float) / np.maximum(sky.field[..., 0], 1e-30)
        k = 10  # c z = 3
        z = t.planes / t.key.c_per_m
        ed = t.e_down_sun[2]  # sun at 30°
        sel = ed > 0.1 * ed[0]
        kd = -np.polyfit(z[sel], np.log(ed[sel]), 1)[0]
        print(
            f"{name:4s} {time.perf_counter() - t0:6.1f} s  median rel. SE at c z = 3: "
            f"{np.median(rel[:, k]):.3f}  K_d(sun 30°) {kd:.4f} vs Jerlov {w.kd_per_m:.3f}  "
            f"sky T {sky.transmittance.min():.3f}–{sky.transmittance.max():.3f}, "
            f"sky median rel. SE at c z = 3: {np.median(sky_rel[:, k]):.3f}",
            flush=True,
        )
        np.savez_compressed(
            a.out, names=np.array(names), **arrays
        )  # after each type: a crash keeps those done
    print(f"wrote {a.out} ({a.out.stat().st_size / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
