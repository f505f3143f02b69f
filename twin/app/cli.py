"""The ``auv-twin`` command line: run, validate and list sea trials."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from twin.app.interrupts import held

# A Ctrl-C while these load is held, and answered by main() (twin.app.interrupts says why).
with held(raise_after=False) as _startup:
    import scenarios
    from scenarios import Scenario, ScenarioError
    from twin.app import render
    from twin.core.extensions import ExtensionError


def writable_out(out: str | Path) -> Path | None:
    """``--out`` created and proved writable before anything runs; None (said in a line) if not."""
    from twin.app.run import prepare_output

    try:
        return prepare_output(out)
    except OSError as exc:
        print(f"error: --out {exc.strerror or exc}", file=sys.stderr)
        return None


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
            status = 2  # the exit code `run` gives the same file
        else:
            print(f"{f}: ok ({sc.name}, {sc.duration_s:g} s, mission {sc.mission.kind})")
    return status


def _load(name: str) -> Scenario | None:
    """The scenario, or None after printing why it cannot be loaded (the caller exits 2)."""
    try:
        return scenarios.load(name)
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
    except ScenarioError as exc:
        print(f"error: scenario {name} is invalid\n{exc}", file=sys.stderr)
    return None


def _cmd_run(args: argparse.Namespace) -> int:
    with held():  # heavy: when running
        from twin.app.run import format_summary, run_scenario

    sc = _load(args.scenario)
    if sc is None:
        return 2
    if args.seed is not None and args.seed < 0:
        print(f"error: --seed {args.seed}: must be an integer >= 0", file=sys.stderr)
        return 2
    out = Path(args.out) if args.out else Path("runs") / sc.name
    if writable_out(out) is None:  # before anything is flown
        return 2
    live = args.connect
    if args.connect is not None:
        from twin.record.live import check_live

        try:
            check_live(args.connect)
        except OSError as exc:
            print(f"error: --connect: {exc}", file=sys.stderr)
            return 2
    if args.viewer:
        from twin.record.live import spawn_viewer

        try:
            live = spawn_viewer()
        except OSError as exc:
            print(f"note: {exc}; the run goes on, recording to the file only", file=sys.stderr)
    try:
        metrics = run_scenario(
            sc,
            out,
            seed=args.seed,
            progress=not args.quiet,
            camera=False if args.no_camera else None,
            timeseries=args.timeseries,
            mcap=args.mcap,
            live=live,
        )
    except KeyboardInterrupt:
        print(f"\ninterrupted: partial recording and metrics in {out}", file=sys.stderr)
        return 130
    except OSError as exc:  # e.g. the disk filled up, or closing the recording failed
        print(f"error: {exc}; metrics.json in {out} records it", file=sys.stderr)
        return 1
    print(format_summary(metrics))
    print(f"recording: {out / 'recording.rrd'}  (open with: rerun {out / 'recording.rrd'})")
    print(f"metrics:   {out / 'metrics.json'}")
    if args.timeseries:
        print(f"series:    {out / 'timeseries'}/*.parquet")
    if args.mcap:
        print(f"mcap:      {out / 'run.mcap'}  (ROS 2 messages; opens in Foxglove)")
    return 0


def _cmd_replay(args: argparse.Namespace) -> int:
    with held():  # heavy: when running
        from twin.app.replay import LogError, replay
        from twin.core.calibration import calibration_from_dict

    sc = None
    if args.scenario:
        sc = _load(args.scenario)
        if sc is None:
            return 2
    topics: dict[str, str] = {}
    for item in args.topic or []:
        role, sep, topic = item.partition("=")
        if not sep or not role or not topic.startswith("/"):
            print(f"error: --topic {item!r}: allowed: ROLE=/topic, e.g. imu=/imu", file=sys.stderr)
            return 2
        topics[role] = topic
    cal = None
    if args.calibration:
        try:
            cal = calibration_from_dict(json.loads(Path(args.calibration).read_text()))
        except (OSError, ValueError, TypeError) as exc:
            print(f"error: --calibration {args.calibration}: {exc}", file=sys.stderr)
            return 2
    out = Path(args.out) if args.out else Path(args.log).with_suffix("").parent / "replay"
    if writable_out(out) is None:
        return 2
    try:
        metrics = replay(args.log, out, scenario=sc, topics=topics, calibration=cal)
    except (LogError, ScenarioError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for name, nav in metrics["navigation"]["variants"].items():
        if nav.get("samples"):
            print(
                f"{name:>14}: heading RMSE {nav['heading_rmse_deg']:.3f} deg, final position "
                f"error {nav['position_drift_final_m']:.1f} m ({nav['samples']} samples)"
            )
    if not metrics["scored"]:
        print("no reference topic in the log: the estimates are written, not scored")
    print(f"metrics:   {out / 'metrics.json'}")
    print(f"series:    {out / 'timeseries'}/*.parquet")
    return 0


def _cmd_campaign_validate(args: argparse.Namespace) -> int:
    from twin.campaign.spec import CampaignError, load_campaign

    status = 0
    for f in args.specs:
        try:
            spec = load_campaign(f)
        except CampaignError as exc:
            print(f"{f}: invalid\n{exc}", file=sys.stderr)
            status = 2  # the exit code `campaign run` gives the same spec
        else:
            axes = ", ".join(f"{a.name} ({len(a.values)})" for a in spec.axes) or "no sweep"
            what = f"base {spec.base.name}" if spec.base is not None else f"trial {spec.trial}"
            print(
                f"{f}: ok ({spec.name}: {len(spec.runs)} runs = {spec.combine} of {axes} "
                f"x {len(spec.seeds)} seeds; {what})"
            )
    return status


def _cmd_campaign_run(args: argparse.Namespace) -> int:
    from twin.campaign.folder import FolderError

    with held():
        from twin.campaign.runner import run_campaign
    from twin.campaign.spec import CampaignError, load_campaign

    if args.workers < 1:
        print(f"error: --workers {args.workers}: must be an integer >= 1", file=sys.stderr)
        return 2
    try:
        spec = load_campaign(args.spec)
    except CampaignError as exc:
        print(f"error: campaign {args.spec} is invalid\n{exc}", file=sys.stderr)
        return 2
    out = writable_out(args.out)
    if out is None:
        return 2
    try:
        counts = run_campaign(
            spec,
            out,
            workers=args.workers,
            use_ray=args.ray is not None,
            ray_address=None if args.ray in (None, "local") else args.ray,
            progress=not args.quiet,
        )
    except KeyboardInterrupt:
        return 130
    except (FolderError, CampaignError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    total = sum(counts.values())
    print(
        f"campaign {spec.name}: {total} runs this time ("
        + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
        + f"); results: {out / 'results.parquet'}"
    )
    return 0 if counts.get("ok", 0) == total else 1


def _cmd_campaign_report(args: argparse.Namespace) -> int:
    from twin.campaign.report import write_report

    if not Path(args.dir).is_dir():
        print(f"error: {args.dir}: no such campaign folder", file=sys.stderr)
        return 2
    try:
        path = write_report(
            args.dir, metric=args.metric, say=lambda m: print(f"note: {m}", file=sys.stderr)
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"report: {path}")
    print(f"        {path.with_suffix('.html')}  (one page, figures embedded)")
    return 0


class _Version(argparse.Action):
    """``--version``: the package version and the git commit (git is asked only then)."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs: object) -> None:
        super().__init__(option_strings, dest, nargs=0, help="print the version and git commit")

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        from twin.record.provenance import version_line

        print(version_line())
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="auv-twin",
        description="A MuJoCo digital twin of an AUV that navigates by skylight.",
    )
    p.add_argument("--version", action=_Version)
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("run", help="run a sea trial; write a Rerun recording and metrics")
    r.add_argument(
        "scenario", help="a shipped scenario name (see `auv-twin scenarios`) or a .toml file"
    )
    r.add_argument("--out", help="output folder (default: runs/<scenario name>)")
    r.add_argument("--seed", type=int, help="root seed (default: the scenario's)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.add_argument("--no-camera", action="store_true", help="do not render the chase camera")
    r.add_argument(
        "--timeseries",
        action="store_true",
        help="also write the time series (truth, readings, filters, compass fixes) as Parquet "
        "in OUT/timeseries/",
    )
    live = r.add_mutually_exclusive_group()
    live.add_argument(
        "--viewer",
        action="store_true",
        help="also stream the recording to a Rerun viewer (spawned) while the run goes on",
    )
    live.add_argument(
        "--connect",
        metavar="URL",
        help="also stream the recording to the Rerun viewer or server at this gRPC URL "
        "(e.g. rerun+http://127.0.0.1:9876/proxy) while the run goes on",
    )
    r.add_argument(
        "--mcap",
        action="store_true",
        help="also write the run as ROS 2 messages (IMU, pressure, the raw polarization mosaic, "
        "odometry of the truth and each filter, compass fixes, /tf) in OUT/run.mcap",
    )
    r.set_defaults(func=_cmd_run)

    rp = sub.add_parser(
        "replay",
        help="run the onboard filters and compass methods on a recorded MCAP or rosbag2 log",
    )
    rp.add_argument("log", help="an MCAP file (a twin run's run.mcap) or a rosbag2 folder")
    rp.add_argument(
        "--scenario", help="the scenario whose [navigation] runs (default: the log's own)"
    )
    rp.add_argument("--out", help="output folder (default: replay/ beside the log)")
    rp.add_argument(
        "--topic",
        action="append",
        metavar="ROLE=TOPIC",
        help="map a role (imu, depth, polarimeter, reference) to a topic; repeatable",
    )
    rp.add_argument(
        "--calibration", help="the camera's calibration as JSON (default: the log's own)"
    )
    rp.set_defaults(func=_cmd_replay)

    render.add_parser(sub)

    s = sub.add_parser("scenarios", help="list the shipped scenarios")
    s.set_defaults(func=_cmd_scenarios)

    v = sub.add_parser("validate", help="check scenario files without running them")
    v.add_argument("files", nargs="+")
    v.set_defaults(func=_cmd_validate)

    c = sub.add_parser("campaign", help="Monte Carlo campaigns: many seeded trials as a table")
    csub = c.add_subparsers(dest="campaign_command", required=True)
    cv = csub.add_parser("validate", help="check campaign specs (every run's scenario included)")
    cv.add_argument("specs", nargs="+")
    cv.set_defaults(func=_cmd_campaign_validate)
    cr = csub.add_parser("run", help="run a campaign (resumes: finished runs are skipped)")
    cr.add_argument("spec", help="a campaign .toml file")
    cr.add_argument("--out", required=True, help="results folder")
    cr.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    cr.add_argument(
        "--ray",
        nargs="?",
        const="local",
        metavar="ADDRESS",
        help="run on Ray: a local instance, or the cluster at ADDRESS ('auto' or host:port)",
    )
    cr.add_argument("--quiet", action="store_true", help="no progress bar")
    cr.set_defaults(func=_cmd_campaign_run)
    cp = csub.add_parser("report", help="statistics with confidence intervals and plots")
    cp.add_argument("dir", help="a campaign's results folder")
    cp.add_argument(
        "--metric",
        default=None,
        help="the per-variant metric to report (default: heading_rmse_deg for flights, "
        "error_deg for the MOI study)",
    )
    cp.set_defaults(func=_cmd_campaign_report)
    return p


def main(argv: list[str] | None = None) -> int:
    """The command line's entry point: an exit code, never a traceback.

    Ctrl-C at any moment (start-up included) exits with 130; an error a user can fix is one line
    naming what and where; an unexpected one is one line too, with how to get the traceback
    (``AUV_TWIN_DEBUG=1``).
    """
    try:
        if _startup.pending:  # Ctrl-C while the command line itself was loading
            raise KeyboardInterrupt
        args = build_parser().parse_args(argv)
        return int(args.func(args))
    except KeyboardInterrupt:
        print("\ninterrupted", file=sys.stderr)
        return 130
    except ExtensionError as exc:  # a plug-in's fault the user can fix, as a bad scenario's
        if os.environ.get("AUV_TWIN_DEBUG"):
            raise
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        if os.environ.get("AUV_TWIN_DEBUG"):
            raise
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        print(f"error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 1
    except Exception as exc:
        if os.environ.get("AUV_TWIN_DEBUG"):
            raise
        print(
            f"error: {type(exc).__name__}: {exc} (an internal error; AUV_TWIN_DEBUG=1 shows the "
            "traceback)",
            file=sys.stderr,
        )
        return 1


def _exit(code: int) -> None:
    """Exit with ``code``; after Ctrl-C without the interpreter's shutdown.

    Measured on a fresh checkout: a Ctrl-C half a second into start-up came back as death by
    SIGINT (−2) in 1 of 3 tries, after the handler had printed "interrupted" and returned 130
    (most likely a KeyboardInterrupt raised again while the interpreter shut down; 0 of 6 with
    this). Everything the run owns is closed before ``main`` returns, so skipping the shutdown
    loses nothing, and the exit status is the 130 a shell expects.
    """
    if code != 130:
        raise SystemExit(code)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)


def entry() -> None:
    """The ``auv-twin`` console script: :func:`main`'s exit code, Ctrl-C's 130 included."""
    _exit(main())


if __name__ == "__main__":
    entry()
