"""``jackson map``: map a world on the twin (the real host maps while it drives a survey), or map
a recorded run offline (``--from``)."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from jackson.commands.checks import (
    CliError,
    check_twin_files,
    host_config,
    out_folder,
    refuse_bad_route,
)
from jackson.common.args import nonneg_int, pose_text

if TYPE_CHECKING:
    from jackson.sim.config import WorldSpec


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson map``."""
    p = sub.add_parser(
        "map",
        help="map a world on the twin: the real host maps (scan matching) while it drives a "
        "survey; or map a recorded run offline (--from RUN)",
    )
    p.add_argument(
        "--from",
        dest="run",
        type=Path,
        metavar="RUN",
        help="map a recorded run folder offline (its bag's /scan and odometry) instead of "
        "surveying a world; not with --world, --robot, --waypoint, --seed or --config",
    )
    p.add_argument(
        "--no-deskew",
        dest="deskew",
        action="store_false",
        help="with --from: take each revolution as recorded instead of moving its returns to "
        "the base's pose at its end (docs/mapping.md, Deskewing)",
    )
    p.add_argument("--world", help="world (default maze)")
    p.add_argument("--robot", help="twin robot (default jackson_physical)")
    p.add_argument(
        "--waypoint",
        action="append",
        type=pose_text,
        metavar="X,Y[,YAW]",
        help="survey route in world coordinates [m, rad], repeatable (default: the Stage 3 "
        "goal and back to the start)",
    )
    p.add_argument("--seed", type=nonneg_int, help="noise seed (deterministic; default 0)")
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="host YAML the robot runs with (default: the paper's robot)",
    )
    p.add_argument(
        "--out",
        type=Path,
        help="output folder (default maps/<stamp>-<world>, or maps/<stamp>-<run>)",
    )
    p.set_defaults(func=_cmd_map)


def _cmd_map(args: argparse.Namespace) -> int:
    """Survey the world on the twin while the host maps it; the map and its SSIM."""
    if args.run is not None:
        return _cmd_map_from(args)
    if not args.deskew:
        raise CliError(
            "--no-deskew: only with --from (a survey on the twin deskews as the daemon does)"
        )
    args.world = args.world or "maze"
    args.robot = args.robot or "jackson_physical"
    args.seed = args.seed if args.seed is not None else 0
    return _cmd_map_world(args)


def _cmd_map_world(args: argparse.Namespace) -> int:
    """``jackson map`` on the twin."""
    import datetime as dt

    from jackson.experiments.stage3 import check_world_route, mapping_spec, run_nav_trial
    from jackson.sim.config import load_world

    check_twin_files(args.robot, args.world)
    config = host_config(args.config)
    waypoints = None
    if args.waypoint:
        from jackson.host.control.navigate import poses

        try:
            waypoints = poses(args.waypoint)
        except ValueError as exc:
            raise CliError(f"--waypoint: {exc}") from exc
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = out_folder(args.out or Path("maps") / f"{stamp}-{Path(args.world).stem}")
    spec = mapping_spec(args.robot, args.world, args.seed, out, config)
    if waypoints is not None:
        spec = dataclasses.replace(spec, goals=waypoints)
    world_spec = load_world(args.world)
    refuse_bad_route(lambda: check_world_route(world_spec, spec.goals), f"--world {args.world}")
    r = run_nav_trial(spec)
    _report(out, out, world_spec)
    if not r["completed"]:
        print(f"jackson map: the survey stopped: {r['failure']}; the partial map is in {out}")
        return 1
    print(
        f"map: {out / 'built_map.yaml'} (+ .pgm), SSIM {r['map_ssim']:.3f} against the twin's "
        f"world; survey {r['path_length_m']:.2f} m in {r['sim_s']:.1f} s of sim time, "
        f"localisation error mean {r['localisation_error_mean_cm']:.1f} cm"
    )
    return 0


def _cmd_map_from(args: argparse.Namespace) -> int:
    """``jackson map --from RUN``: the map of a recorded run, built offline with progress."""
    import datetime as dt

    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    from jackson.host.nav.offline import map_recording, plan_recording

    given = [
        name
        for name, value in (
            ("--world", args.world),
            ("--robot", args.robot),
            ("--waypoint", args.waypoint),
            ("--seed", args.seed),
            ("--config", args.config),
        )
        if value is not None
    ]
    if given:
        raise CliError(
            f"{', '.join(given)}: not with --from (which maps a recorded run; these set up a "
            "survey of a world on the twin)"
        )
    run: Path = args.run
    plan = plan_recording(run)  # refuses a missing folder, bag, /scan or odometry first
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = out_folder(args.out or Path("maps") / f"{stamp}-{run.resolve().name}")
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[info]}"),
        console=Console(stderr=True),
    ) as progress:
        task = progress.add_task(f"map {run.name}", total=plan.scan_count, info="")

        def on_scan(read: int, robot_s: float) -> None:
            progress.update(task, completed=read, info=f"{robot_s:.1f} s of robot time")

        summary = map_recording(run, out, progress=on_scan, plan=plan, deskewed=args.deskew)
    _report(out, run, None)
    print(
        f"map: {summary.map_yaml} (+ .pgm) from {summary.scans_paired} scans over "
        f"{summary.robot_s:.1f} s of robot time (odometry: {summary.odometry_topic}); "
        f"{summary.robot_s_per_cpu_s:.1f} robot-seconds mapped per CPU-second"
    )
    return 0


def _report(out: Path, run: Path, world: WorldSpec | None) -> None:
    """Write the map's report (``built_map.png``, ``map_quality.json``) and print its figures;
    nothing when the run wrote no map. ``world``: the twin's (None: the one the run's
    ``meta.json`` names, if it is a twin run)."""
    from jackson.experiments.map_report import write_map_report
    from jackson.experiments.metrics.inputs import MetricInputError

    if not (out / "built_map.yaml").is_file() or not (out / "built_map.graph.npz").is_file():
        return
    print(f"judging the map and drawing its report ({out / 'built_map.png'}) ...", file=sys.stderr)
    try:
        report = write_map_report(out, run, world)
    except MetricInputError as exc:
        raise CliError(f"the map's report: {exc}") from exc
    print(f"report: {report.png}, {report.json}")
    print("\n".join(report.lines()))
