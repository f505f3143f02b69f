"""Where light-field tables are kept and how they are filled.

The cache folder, an atomic write, and the reference runs (one process or several) a table is
built from.

The shipped file is :data:`sensors.polarimeter.optics.rt.grid.DATA_FILE`; tables computed on first
use go under :func:`cache_dir`. Nothing here knows a table's layout (that is
:mod:`~sensors.polarimeter.optics.rt.table` and :mod:`~sensors.polarimeter.optics.rt.sky_table`).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import secrets
import sys
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from sensors.polarimeter.optics.rt import reference
from sensors.polarimeter.optics.rt.grid import TABLE_INDEX
from twin.core.arrays import FloatArray


def cache_dir() -> Path:
    """Where tables computed on first use are kept."""
    return (
        Path(os.environ.get("AUV_TWIN_CACHE", Path.home() / ".cache" / "auv-twin")) / "lightfield"
    )


def save(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write ``arrays`` to ``path`` atomically; an unwritable cache costs time, not correctness.

    The temporary name is this writer's own: campaign workers that compute the same table at
    once each write their own file, and the last rename wins with an identical table.
    """
    tmp = path.with_name(f"{path.stem}.{os.getpid()}-{secrets.token_hex(4)}.tmp.npz")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(tmp, **arrays)
        tmp.replace(path)
    except OSError as e:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        print(f"auv-twin: could not cache the table ({e}); it will be recomputed", file=sys.stderr)


@functools.cache
def _code_digest() -> bytes:
    """A digest of this package's source: derived arrays are stale when any of it changes."""
    h = hashlib.blake2b(digest_size=16)
    for f in sorted(Path(__file__).parent.glob("*.py")):
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.digest()


def derived(name: str, inputs: tuple[object, ...], compute: Callable[[], np.ndarray]) -> np.ndarray:
    """An array derived from a table, computed once per machine and kept under :func:`cache_dir`.

    A table's derived fields (the remainder the renderer reads, about a second of numpy for the
    shipped water) would otherwise be recomputed at the start of every process: every CLI run
    and every campaign worker. The file is named by a digest of ``name``, of ``inputs`` (arrays
    by dtype, shape and bytes; anything else by ``repr``) and of this package's source code, so
    changed inputs or changed code give another file, never a stale one. Loaded arrays are the
    computed ones bit for bit (``.npy``); a file that cannot be read is recomputed and
    rewritten, and an unwritable cache costs time, not correctness (:func:`save`'s note).
    """
    h = hashlib.blake2b(name.encode(), digest_size=16)
    h.update(_code_digest())
    for x in inputs:
        if isinstance(x, np.ndarray):
            a = np.ascontiguousarray(x)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.view(np.uint8).reshape(-1).data)
        else:
            h.update(repr(x).encode())
    path = cache_dir() / "derived" / f"{name}-{h.hexdigest()}.npy"
    with contextlib.suppress(OSError, ValueError, EOFError):
        return np.load(path, allow_pickle=False)
    out = compute()
    tmp = path.with_name(f"{path.stem}.{os.getpid()}-{secrets.token_hex(4)}.tmp.npy")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.save(tmp, out, allow_pickle=False)
        tmp.replace(path)
    except OSError as e:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        print(f"auv-twin: could not cache {name} ({e}); it will be recomputed", file=sys.stderr)
    return out


def run_jobs(args: list[tuple], workers: int) -> list[reference.LightField]:
    if workers > 1:
        with ProcessPoolExecutor(workers) as ex:
            return list(ex.map(_solve_one, args))
    return [_solve_one(a) for a in args]


def _solve_one(args: tuple) -> reference.LightField:
    key, src, z, grid, photons, seed, sky = args
    return reference.solve(
        key.a_per_m,
        key.b_molecular_per_m,
        key.b_particle_per_m,
        key.particle_backscatter_ratio,
        particle_dop_max=key.particle_dop_max,
        depolarization_ratio=key.depolarization_ratio,
        source=src,
        sun_zenith_air_deg=z,
        sky=None if sky is None else sky.spec(),
        wind_speed_mps=key.wind_speed_mps,
        n_water=TABLE_INDEX,
        grid=grid,
        photons=photons,
        batches=10,
        seed=seed,
    )


def per_ed(field: FloatArray, e_down: FloatArray, dtype: type = np.float16) -> FloatArray:
    """The field / E_d as float16 (0 where no history reached the plane)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(e_down > 0, field / np.where(e_down > 0, e_down, 1.0), 0.0).astype(dtype)
