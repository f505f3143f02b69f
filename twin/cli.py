"""The ``auv-twin`` command line: run, validate and list sea trials."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import scenarios
from scenarios import ScenarioError


def _cmd_scenarios(args: argparse.Namespace) -> int:
    for name, path in scenarios.shipped().items():
        try:
            sc = scenarios.load_scenario(path)
            desc = sc.description.splitlines()[0] if sc.description else ""
            print(f"{name:28s} {sc.duration_s:7.0f} s  {sc.scene:9s} {desc}")
        except ScenarioError as exc:  # a shipped file that does not validate is a bug: say so
            print(f"{name:28s} INVALID: {exc}")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    status = 0
    for f in args.files:
        try:
            sc = scenarios.load(f)
        except FileNotFoundError as exc:
            print(f"{f}: {exc}", file=sys.stderr)
            status = 2
        except ScenarioError as exc:
            print(f"{f}: invalid\n{exc}", file=sys.stderr)
            status = 1
        else:
            print(f"{f}: ok ({sc.name}, {sc.duration_s:g} s, mission {sc.mission.kind})")
    return status


def _cmd_run(args: argparse.Namespace) -> int:
    from twin.run import format_summary, run_scenario  # heavy imports only when running

    try:
        sc = scenarios.load(args.scenario)
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ScenarioError as exc:
        print(f"error: scenario {args.scenario} is invalid\n{exc}", file=sys.stderr)
        return 2
    if args.seed is not None and args.seed < 0:
        print(f"error: --seed {args.seed}: must be an integer >= 0", file=sys.stderr)
        return 2
    out = Path(args.out) if args.out else Path("runs") / sc.name
    try:
        metrics = run_scenario(
            sc,
            out,
            seed=args.seed,
            progress=not args.quiet,
            camera=False if args.no_camera else None,
        )
    except KeyboardInterrupt:
        print(f"\ninterrupted: partial recording and metrics in {out}", file=sys.stderr)
        return 130
    print(format_summary(metrics))
    print(f"recording: {out / 'recording.rrd'}  (open with: rerun {out / 'recording.rrd'})")
    print(f"metrics:   {out / 'metrics.json'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="auv-twin",
        description="A MuJoCo digital twin of an AUV that navigates by skylight.",
    )
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("run", help="run a sea trial; write a Rerun recording and metrics")
    r.add_argument(
        "scenario", help="a shipped scenario name (see `auv-twin scenarios`) or a .toml file"
    )
    r.add_argument("--out", help="output folder (default: runs/<scenario name>)")
    r.add_argument("--seed", type=int, help="root seed (default: the scenario's)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.add_argument("--no-camera", action="store_true", help="do not render the chase camera")
    r.set_defaults(func=_cmd_run)

    s = sub.add_parser("scenarios", help="list the shipped scenarios")
    s.set_defaults(func=_cmd_scenarios)

    v = sub.add_parser("validate", help="check scenario files without running them")
    v.add_argument("files", nargs="+")
    v.set_defaults(func=_cmd_validate)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    raise SystemExit(main())
