"""``auv-twin render``: fly a scenario to an instant and write what the polarimeter sees.

Writes, in ``OUT/``:

* ``<stem>_intensity.png``, ``_aop.png``, ``_dop.png``: the images for people (8-bit);
* ``<stem>_panel.png`` and ``.svg``: the three side by side with colour bars and units (S0 in
  DN, AoP in degrees on a cyclic map, DoP from 0 to 1), titled with the time, depth and sun;
* with ``--float npz`` or ``--float tiff``: the float images (S0, AoP in radians, DoP; 32-bit),
  as one ``<stem>.npz`` or three ``<stem>_{s0,aop,dop}.tiff``;

and ``<stem>.json``: the provenance block (:mod:`twin.record.provenance`: code, packages, the
scenario's fingerprint, the seed, the date) with the instant, the sun and the files written (the
``.npz`` holds the block too). It prints the vehicle's state and the sun's elevation and azimuth,
saying so when the sun is below the horizon. ``--s0-max DN`` fixes the intensity scale (the
8-bit image and the panel's colour bar), so renders at several instants or depths compare; by
default each render scales to its own 99.5th percentile.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

import scenarios
from scenarios import ScenarioError

FLOAT_FORMATS = ("npz", "tiff")


def add_parser(sub: argparse._SubParsersAction) -> None:
    rd = sub.add_parser(
        "render", help="fly a scenario to an instant and write the polarimeter's images"
    )
    rd.add_argument("scenario", help="a shipped scenario name or a .toml file")
    rd.add_argument("--at", type=float, default=0.0, help="sim time in seconds (default 0)")
    rd.add_argument("--out", help="output folder (default: runs/<name>_t<at>)")
    rd.add_argument("--seed", type=int, help="root seed (default: the scenario's)")
    rd.add_argument(
        "--preset",
        default=None,
        help="polarimeter preset for a scenario without one (default: phx050s_p); a scenario "
        "with its own polarimeter renders that one",
    )
    rd.add_argument(
        "--float",
        choices=FLOAT_FORMATS,
        default=None,
        dest="float_format",
        help="also write the float images (S0, AoP, DoP) as .npz or 32-bit TIFF",
    )
    rd.add_argument(
        "--s0-max",
        type=float,
        default=None,
        metavar="DN",
        help="fix the intensity scale's top at DN (compare renders); default: the 99.5th "
        "percentile of each render",
    )
    rd.set_defaults(func=cmd_render)


def _error(text: str) -> int:
    print(f"error: {text}", file=sys.stderr)
    return 2


def cmd_render(args: argparse.Namespace) -> int:
    from twin.app.interrupts import held
    from twin.record.provenance import fingerprint, provenance

    with held():  # the heavy imports: a Ctrl-C here is held, then raised
        from sensors.registry import sensor_class
        from twin.app.cli import writable_out
        from twin.core.ephemeris import NIGHT_ELEVATION_DEG, sun_position
        from twin.onboard.polarization import stokes_from_mosaic
        from twin.sim.build import build_simulation
        from twin.world.assembly import polarimeter_sensor

    try:
        sc = scenarios.load(args.scenario)
    except (FileNotFoundError, ScenarioError) as exc:
        return _error(str(exc))
    if not (0.0 <= args.at <= sc.duration_s):
        return _error(f"--at {args.at}: allowed [0, {sc.duration_s:g}] s (the scenario's duration)")
    if args.seed is not None and args.seed < 0:
        return _error(f"--seed {args.seed}: must be an integer >= 0")
    if args.s0_max is not None and not (math.isfinite(args.s0_max) and args.s0_max > 0):
        return _error(f"--s0-max {args.s0_max}: allowed a number > 0 (DN)")
    presets = sorted(sensor_class("polarimeter").PRESETS)
    if args.preset is not None and args.preset not in presets:
        return _error(f"--preset {args.preset!r}: allowed one of {presets}")
    if args.preset is not None and sc.sensors.polarimeter is not None:
        return _error(
            f"--preset {args.preset!r}: the scenario has its own polarimeter "
            f"({sc.sensors.polarimeter!r}); --preset is for a scenario without one"
        )
    out = Path(args.out) if args.out else Path("runs") / f"{sc.name}_t{args.at:g}"
    try:
        cam = polarimeter_sensor(sc, None if sc.sensors.polarimeter else args.preset or "phx050s_p")
    except (KeyError, ValueError) as exc:
        return _error(f"--preset {args.preset}: {exc}")
    if writable_out(out) is None:  # before anything is flown
        return 2
    world = build_simulation(sc, args.seed)
    world.fly(args.at)
    rng = np.random.default_rng(np.random.SeedSequence(world.seed).spawn(4)[3])
    cam.reset(world.plant, rng)
    values = cam.sample(world.plant, rng)
    ss = cam.pspec.sensor_spec()
    pol = stokes_from_mosaic(
        values["raw"],
        ss.layout_deg,
        black_level_dn=ss.black_level_dn,
        saturation_dn=ss.saturation_dn,
    )
    tr = world.plant.truth()
    p = sc.place
    sun = sun_position(world.plant.utc, p.latitude_deg, p.longitude_deg)
    el, az = math.degrees(float(sun.elevation_rad)), math.degrees(float(sun.azimuth_rad))
    night = el < NIGHT_ELEVATION_DEG
    stem = f"{sc.name}_t{args.at:g}"
    title = (
        f"{sc.name}, t = {args.at:g} s ({world.plant.utc:%Y-%m-%d %H:%M:%S} UTC), depth "
        f"{tr.depth_m:.1f} m, sun elevation {el:.1f}°, azimuth {az:.1f}°"
    )
    prov = provenance(fingerprint=fingerprint(sc.to_dict()), seed=world.seed)
    try:
        written = write_images(pol, out, stem, title, s0_max=args.s0_max)
        if args.float_format:
            written += write_float(pol, out, stem, args.float_format, prov)
        # What every file beside it came from: the provenance block and the instant rendered.
        side = out / f"{stem}.json"
        side.write_text(json.dumps({
            "provenance": prov, "scenario": sc.name, "at_s": args.at,
            "utc": f"{world.plant.utc:%Y-%m-%dT%H:%M:%S.%fZ}", "depth_m": tr.depth_m,
            "sun_elevation_deg": el, "sun_azimuth_deg": az, "s0_max_dn": args.s0_max,
            "files": [p.name for p in written],
        }, indent=2) + "\n")  # fmt: skip
        written.append(side)
    except OSError as exc:
        print(f"error: writing the images to {out}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    print(
        f"{sc.name} at t = {args.at:g} s ({world.plant.utc:%Y-%m-%d %H:%M:%S} UTC): depth "
        f"{tr.depth_m:.2f} m, heading {tr.heading_deg:.1f} deg, roll "
        f"{np.degrees(tr.roll_rad):.1f}, pitch {np.degrees(tr.pitch_rad):.1f} deg"
    )
    print(f"  sun: elevation {el:.2f} deg, azimuth {az:.2f} deg (clockwise from North)")
    if night:
        print(
            f"  note: the sun is below the horizon (elevation {el:.1f} deg < "
            f"{NIGHT_ELEVATION_DEG} deg): the sky is dark and the frame holds only noise"
        )
    for path in written:
        print(f"  wrote {path}")
    return 0


def write_images(pol, out: Path, stem: str, title: str, s0_max: float | None) -> list[Path]:
    """The three 8-bit images and the panel with colour bars."""
    from twin.record import images

    written = images.write_pngs(pol, out, stem, s0_max=s0_max)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mask = images.signal_mask(pol)
    s0 = np.asarray(pol.s0, dtype=np.float64)
    top = s0_max if s0_max is not None else float(np.percentile(s0, 99.5)) or 1.0
    fig, axes = plt.subplots(1, 3, figsize=(13.5, 4.4))
    im = axes[0].imshow(s0, cmap="gray", vmin=0.0, vmax=top)
    fig.colorbar(im, ax=axes[0], fraction=0.046, pad=0.04, label="S0 (DN)")
    axes[0].set_title("intensity S0" + (" (fixed scale)" if s0_max is not None else ""))
    aop = np.where(mask, np.degrees(np.asarray(pol.aop, dtype=np.float64)), np.nan)
    cyclic = plt.get_cmap("twilight_shifted").with_extremes(bad="black")
    viridis = plt.get_cmap("viridis").with_extremes(bad="black")
    im = axes[1].imshow(aop, cmap=cyclic, vmin=-90.0, vmax=90.0)
    fig.colorbar(im, ax=axes[1], fraction=0.046, pad=0.04, label="AoP (°)")
    axes[1].set_title("angle of polarization")
    dop = np.where(mask, np.asarray(pol.dop, dtype=np.float64), np.nan)
    im = axes[2].imshow(dop, cmap=viridis, vmin=0.0, vmax=1.0)
    fig.colorbar(im, ax=axes[2], fraction=0.046, pad=0.04, label="DoP")
    axes[2].set_title("degree of polarization")
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title, fontsize=10)
    fig.text(0.01, 0.01, "AoP and DoP shown where S0 > 20 DN (black: too dark to mean anything)",
             fontsize=7, color="#444")  # fmt: skip
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    for ext in ("png", "svg"):
        path = out / f"{stem}_panel.{ext}"
        fig.savefig(path, dpi=150)
        written.append(path)
    plt.close(fig)
    return written


def write_float(pol, out: Path, stem: str, fmt: str, prov: dict | None = None) -> list[Path]:
    """S0 (DN), AoP (rad) and DoP as 32-bit floats: one .npz, or a TIFF each."""
    from twin.record.images import write_planes

    planes = {
        "s0": np.asarray(pol.s0, dtype=np.float32),
        "aop": np.asarray(pol.aop, dtype=np.float32),
        "dop": np.asarray(pol.dop, dtype=np.float32),
    }
    if fmt == "npz":
        path = out / f"{stem}.npz"
        extra = {"provenance": np.array(json.dumps(prov))} if prov is not None else {}
        np.savez_compressed(path, **planes, units=np.array(["DN", "rad", "1"]), **extra)
        return [path]
    return write_planes(planes, out, stem, "tiff")
