"""The fast path's error against the exact chain, over the ten scenes of its test.

    python validation/fast_path_error.py [--out validation/results/fast_path_error]

The scenes are ``tests/sensors/polarimeter/test_render_fast.py``'s (level, tilted, 0.2–15 m,
Jerlov IB–3C, a low sun at the window's edge, overcast, Berry sky, in air, looking down, night);
each row is the max over every lit valid pixel of the relative S0 error inside Snell's window and
anywhere, the AoP error where DoP > 0.05 and > 0.2, and |Δ(S1, S2)|/S0; then the same S0 and
polarization errors at the pixels the fine level interpolates and at those the window grid gives,
and the rays the chain renders with both and without each. The tests assert bounds on the same
numbers; this writes them down with their provenance (``<out>.md``, ``<out>.json``), for
docs/polarimeter.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from twin.core.frames import euler_to_dcm
from twin.record import provenance as pv

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = (
    "s0_window", "s0", "aop_dop05", "aop_dop20", "pol", "s0_fine", "pol_fine", "s0_grid",
    "pol_grid", "rays",
)  # fmt: skip
HEADS = (
    "S0 in the window",
    "S0 anywhere",
    "AoP, DoP > 0.05",
    "AoP, DoP > 0.2",
    "\\|Δ(S1, S2)\\|/S0",
    "S0 in the fine cells",
    "\\|Δ(S1, S2)\\|/S0 there",
    "S0 at the window grid's pixels",
    "\\|Δ(S1, S2)\\|/S0 there",
    "rays through the chain (without the fine level; without the window grid)",
)


def _scenes_module():
    # The package first: tests/sensors would otherwise shadow the project's sensors package.
    import sensors.polarimeter.render  # noqa: F401

    sys.path.insert(0, str(ROOT / "tests"))
    sys.path.insert(0, str(ROOT / "tests" / "sensors" / "polarimeter"))
    import test_render_fast

    return test_render_fast


def _level(fast, exact, attr: str, c, depth, sun) -> dict[str, Any]:  # type: ignore[no-untyped-def]
    """A fast-path level's own error (at the pixels it gives) and the rays it saves.

    ``attr``: ``"fine_level"`` or ``"window_grid"``, switched off to find its pixels (those
    that change) and its rays (the chain's rays with it and without).
    """
    from sensors.polarimeter.fast_path import FastPath

    rays = [0]
    orig = FastPath._render_points

    def counted(self, r, *a, **k):  # type: ignore[no-untyped-def]
        rays[0] += len(r)
        return orig(self, r, *a, **k)

    FastPath._render_points = counted  # type: ignore[method-assign]
    try:
        out = []
        for on in (True, False):
            setattr(fast, attr, on)
            rays[0] = 0
            out.append((fast.render_stokes(None, np.zeros(3), c, depth, sun)[0], rays[0]))
    finally:
        FastPath._render_points = orig  # type: ignore[method-assign]
        delattr(fast, attr)
    (a, n_on), (before, n_off) = out
    b = exact.render_stokes(None, np.zeros(3), c, depth, sun)[0]
    mine = np.any(a != before, axis=-1) & (b[..., 0] > 0)
    s0 = np.maximum(b[..., 0], 1e-30)
    rel = np.abs(a[..., 0] - b[..., 0]) / s0
    pol = np.hypot(a[..., 1] - b[..., 1], a[..., 2] - b[..., 2]) / s0
    used = n_on != n_off or bool(mine.any())  # a frame whose stride has no such level: —
    return {
        "s0": float(rel[mine].max(initial=0.0)) if used else None,
        "pol": float(pol[mine].max(initial=0.0)) if used else None,
        "on": n_on,
        "off": n_off if used else None,
    }


def _levels(fast, exact, c, depth, sun) -> dict[str, Any]:  # type: ignore[no-untyped-def]
    """The fine level's and the window grid's columns of a row."""
    f = _level(fast, exact, "fine_level", c, depth, sun)
    g = _level(fast, exact, "window_grid", c, depth, sun)
    off = [str(x) if x is not None else "—" for x in (f["off"], g["off"])]
    return {
        "s0_fine": f["s0"],
        "pol_fine": f["pol"],
        "s0_grid": g["s0"],
        "pol_grid": g["pol"],
        "rays": f"{f['on']} ({'; '.join(off)})" if f["off"] or g["off"] else str(f["on"]),
    }


def run() -> list[tuple[str, str, dict[str, Any]]]:
    """[(frame, scene, errors)] for the binned frame's ten scenes and the full frame's one."""
    t = _scenes_module()
    rows = []
    for name, c, depth, sun, optics in t.SCENES:
        fast, exact = t._pair("phx050s_p_bin4", **optics)
        e = t._errors(fast, exact, c, depth, sun) | _levels(fast, exact, c, depth, sun)
        rows.append(("612×512 (bin4)", name, e))
        print(name, rows[-1][2], flush=True)
    fast, exact = t._pair("phx050s_p")
    c = euler_to_dcm(0.35, -0.17, 0.4)
    sun = t._sun(30, 60)
    e = t._errors(fast, exact, c, 1.0, sun) | _levels(fast, exact, c, 1.0, sun)
    rows.append(("2448×2048", "tilted 1 m", e))
    return rows


def _cell(key: str, v: Any) -> str:
    if v is None:
        return "—"
    if key == "rays":
        return str(v)
    if key.startswith("aop"):
        return f"{v:.2f}°"
    return f"{v:.3f}" if key.startswith("pol") else f"{v:.1%}"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=ROOT / "validation/results/fast_path_error")
    a = p.parse_args()
    rows = run()
    prov = pv.provenance()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.with_suffix(".json").write_text(
        json.dumps(
            {"provenance": prov, "rows": [{"frame": f, "scene": s, **e} for f, s, e in rows]},
            indent=1,
        )
    )
    lines = [
        "# The fast path against the exact chain",
        "",
        "Generated by `python validation/fast_path_error.py`; max over every lit valid pixel. The "
        "fine cells: the rough cells' pixels the fine level interpolates (sensors/polarimeter/"
        "fine_grid.py); the window grid's pixels: the edge band's pixels inside Snell's window "
        "it gives (sensors/polarimeter/window_grid.py); their errors are also in the first five "
        "columns. The rays: through the exact chain per frame, with both and (in brackets) "
        "without the fine level, without the window grid; — where the frame's stride has neither "
        "(below 8 px, sensors/polarimeter/fast_path.py).",
        "",
        *("- " + x for x in pv.describe(prov)),
        "",
        "| frame | scene | " + " | ".join(HEADS) + " |",
        "|---" * (len(HEADS) + 2) + "|",
    ]
    for f, s, e in rows:
        lines.append(f"| {f} | {s} | " + " | ".join(_cell(k, e[k]) for k in COLUMNS) + " |")
    a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {a.out.with_suffix('.md')}")


if __name__ == "__main__":
    main()
