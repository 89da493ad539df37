"""The ``jackson`` command: one entry point for every tool of the stack.

Each subcommand imports what it needs when it runs, so ``jackson --help`` stays fast
and the host never pulls in the twin. Errors a user can cause end as one line on
stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, BinaryIO

from jackson import __version__
from jackson.common.args import (
    MAX_HOURS,
    MAX_TRIALS,
    MAX_WORKERS,
    OneLineParser,
    int_in,
    nonneg_int,
    nonneg_upto,
    one_line,
    output_folder,
    positive_float,
    positive_int,
)
from jackson.common.errors import JacksonError
from jackson.common.fields import ConfigError

DEFAULT_ROBOT = "jackson_physical"  # the twin robot of run and campaign


class CliError(JacksonError):
    """A user-facing error: printed as one line, exit status 2."""


def _cmd_bench(args: argparse.Namespace) -> int:
    from jackson.benchmark import print_table, run_all, write_json

    if args.out.is_dir():
        raise CliError(f"--out {args.out}: is a folder, give a JSON file name")
    for parent in args.out.parents:
        if parent.exists() and not parent.is_dir():
            raise CliError(f"--out {args.out}: {parent} is a file, not a folder")
    try:
        results = run_all(quick=args.quick, only=args.suite)
    except ModuleNotFoundError as exc:  # a peer the ratios are taken against (pymavlink)
        raise CliError(
            f"the benchmarks need {exc.name}, which is not installed: run `make setup` "
            "(or pip install -e '.[dev]')"
        ) from exc
    print_table(results)
    write_json(results, args.out)
    print(f"wrote {args.out}")
    return 0


def _open_input(name: str) -> BinaryIO:
    if name == "-":
        return sys.stdin.buffer
    try:
        return open(name, "rb")
    except OSError as exc:
        raise CliError(f"cannot read {name}: {exc.strerror}") from exc


def _cmd_decode(args: argparse.Namespace) -> int:
    from jackson.protocol import FrameDecoder, Telemetry, decode_message

    stream = _open_input(args.input)
    decoder = FrameDecoder()
    per_type: Counter[str] = Counter()
    telemetry: list[Telemetry] = []
    verbose = not (args.quiet or args.summary)

    def handle(frames: list[Any]) -> None:
        for frame in frames:
            msg = decode_message(frame)
            per_type[msg.NAME] += 1
            if isinstance(msg, Telemetry):
                telemetry.append(msg)
            if verbose:
                print(f"seq={frame.seq:3d} {msg}")

    try:
        while chunk := stream.read(65536):
            handle(decoder.feed(chunk))
        handle(decoder.flush())
    finally:
        if stream is not sys.stdin.buffer:
            stream.close()
    if args.summary:
        _print_summary(per_type, telemetry)
    counters = decoder.counters.as_dict()
    print("counters: " + " ".join(f"{k}={v}" for k, v in counters.items()))
    return 0


def _print_summary(per_type: Counter[str], telemetry: list[Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title="decoded messages")
    table.add_column("message")
    table.add_column("count", justify="right")
    for name, count in sorted(per_type.items()):
        table.add_row(name, str(count))
    console = Console()
    console.print(table)
    if len(telemetry) >= 2:
        first, last = telemetry[0], telemetry[-1]
        span_s = (last.t_us - first.t_us) / 1e6
        rate = f"{(len(telemetry) - 1) / span_s:.1f} Hz" if span_s > 0 else "rate unknown"
        console.print(
            f"telemetry: {len(telemetry)} frames over {span_s:.2f} s of MCU time "
            f"({rate}); encoder counts "
            f"left {first.enc_left} -> {last.enc_left}, right {first.enc_right} -> {last.enc_right}"
        )


def _check_twin_files(robot: str, world: str) -> None:
    """Read the robot and world files before anything is written or started."""
    from jackson.sim.config import load_robot, load_world
    from jackson.sim.twin import Twin

    Twin(load_world(world), load_robot(robot), lidar=False)  # refuses a blocked start pose


def _out(path: Path, option: str = "--out") -> Path:
    try:
        return output_folder(path, option)
    except ValueError as exc:
        raise CliError(str(exc)) from exc


STAGE3 = ("maze", "ofat", "robustness")


def _map_file(path: Path | None) -> Path | None:
    """A map_server YAML the user named, checked before anything runs."""
    if path is None:
        return None
    from jackson.host.nav.grid import MapFileError, OccupancyGrid

    try:
        OccupancyGrid.load(path)
    except MapFileError as exc:
        raise CliError(f"--map: {exc}") from exc
    return path


def _host_config(path: Path | None) -> Path | None:
    """A host YAML the user named (``--config``), read and checked before anything runs."""
    if path is None:
        return None
    from jackson.host.config import load_config

    try:
        load_config(path)
    except ConfigError as exc:
        raise CliError(f"--config: {one_line(exc)}") from exc
    return path.resolve()  # the campaign's worker processes read it too


def _check_route(check: Callable[[], None], against: str) -> None:
    """Run a route check; its RouteError becomes one line naming what it was checked against."""
    from jackson.host.control.navigator import RouteError

    try:
        check()
    except RouteError as exc:
        raise CliError(f"{exc} ({against})") from exc


def _cmd_map(args: argparse.Namespace) -> int:
    import datetime as dt

    from jackson.experiments.stage3 import check_world_route, mapping_spec, run_nav_trial
    from jackson.sim.config import load_world

    _check_twin_files(args.robot, args.world)
    config = _host_config(args.config)
    waypoints = None
    if args.waypoint:
        from jackson.host.control.navigate import poses

        try:
            waypoints = poses(args.waypoint)
        except ValueError as exc:
            raise CliError(f"--waypoint: {exc}") from exc
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = _out(args.out or Path("maps") / f"{stamp}-{Path(args.world).stem}")
    spec = mapping_spec(args.robot, args.world, args.seed, out, config)
    if waypoints is not None:
        spec = dataclasses.replace(spec, goals=waypoints)
    world_spec = load_world(args.world)
    _check_route(lambda: check_world_route(world_spec, spec.goals), f"--world {args.world}")
    r = run_nav_trial(spec)
    if not r["completed"]:
        print(f"jackson map: the survey stopped: {r['failure']}; the partial map is in {out}")
        return 1
    print(
        f"map: {out / 'built_map.yaml'} (+ .pgm), SSIM {r['map_ssim']:.3f} against the twin's "
        f"world; survey {r['path_length_m']:.2f} m in {r['sim_s']:.1f} s of sim time, "
        f"localisation error mean {r['localisation_error_mean_cm']:.1f} cm"
    )
    return 0


def _cmd_run_maze(args: argparse.Namespace) -> int:
    import datetime as dt

    from rich.console import Console
    from rich.table import Table

    from jackson.experiments.stage3 import (
        NavTrialSpec,
        check_world_route,
        mapping_spec,
        plot_stage3,
        run_nav_trial,
        world_goals,
    )
    from jackson.host.control.navigator import NavigatorConfig, check_route
    from jackson.host.nav.grid import OccupancyGrid
    from jackson.host.nav.types import Pose2D
    from jackson.sim.config import load_world
    from jackson.sim.faults import summary

    map_yaml = _map_file(args.map)  # the map and the goals first: nothing is built before
    goals = None
    if args.goal:
        from jackson.host.control.navigate import poses

        try:
            goals = poses(args.goal)
        except ValueError as exc:
            raise CliError(f"--goal: {exc}") from exc
    world = args.world or "maze"
    _check_twin_files(args.robot, world)
    config = _host_config(args.config)
    world_spec = load_world(world)
    goals = goals or world_goals(world_spec)
    _check_route(lambda: check_world_route(world_spec, goals), f"--world {world}")
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = _out(args.out or Path("runs") / f"{stamp}-maze")
    if map_yaml is None:
        survey = mapping_spec(args.robot, world, args.seed, out / "map", config)
        m = run_nav_trial(dataclasses.replace(survey, lidar_mode=_lidar_mode(args)))
        if not m["completed"]:
            print(f"jackson run maze: the mapping run stopped: {m['failure']}")
            return 1
        map_yaml = out / "map" / "built_map.yaml"
    grid = OccupancyGrid.load(map_yaml)
    start = Pose2D(*world_spec.start_pose)
    _check_route(lambda: check_route(grid, start, goals, NavigatorConfig()), f"map {map_yaml}")
    faults = tuple(args.fault)  # on the navigation run, not on the mapping run before it
    spec = NavTrialSpec(
        0, args.seed, args.robot, world, out / "nav", map_yaml, config=config, faults=faults
    )
    spec = dataclasses.replace(spec, goals=goals, lidar_mode=_lidar_mode(args))
    r = run_nav_trial(spec)
    r["run"] = "nav"
    plot_stage3(out / "maze.png", out, [r])
    table = Table(title=f"maze on the twin ({args.robot}, {world}, seed {args.seed})")
    table.add_column("figure")
    table.add_column("value", justify="right", overflow="fold")
    table.add_column("paper (physical / Isaac)", justify="right")
    for label, value, paper in (
        (
            "goal reached (navigator)",
            "yes" if r["reached"] else f"no: {r['failure']}",
            "",
        ),
        (
            "goal reached (ground truth)",
            f"{'yes' if r['reached_truth'] else 'no'}: ends {100 * r['goal_error_m']:.1f} cm "
            f"from the goal (tolerance {100 * r['goal_tolerance_m']:g} cm)",
            "10/10",
        ),
        ("contacts", str(r["collisions"]), "0"),
        (
            "d_min (Eq. 21)",
            f"{100 * r['d_min_m']:.1f} cm" if r["cylinder"] else "no obstacle dropped",
            "12.2 / 7.4 cm",
        ),
        ("path length", f"{r['path_length_m']:.3f} m", "1.958 / 1.888 m"),
        ("t_nav", f"{r['t_nav_s']:.2f} s", "22.41 / 13.32 s"),
        ("recoveries", str(r["recoveries"]), ""),
        ("localisation error mean / max", f"{r['localisation_error_mean_cm']:.1f} / "
         f"{r['localisation_error_max_cm']:.1f} cm", ""),
        ("real-time factor", f"x{r['real_time_factor']:.1f}", "x0.7"),
        ("scans", str(r["scans"]), ""),
        *(("fault", f"{f['fault']}: {summary(f)}", "") for f in r["faults"]),
    ):  # fmt: skip
        table.add_row(label, value, paper)
    Console().print(table)
    print(f"plot: {out / 'maze.png'}\nrun folder: {out / 'nav'}")
    return 0 if r["completed"] else 1


def _cmd_run(args: argparse.Namespace) -> int:
    import datetime as dt

    from rich.console import Console
    from rich.table import Table

    from jackson.experiments.report import plot_trajectories
    from jackson.experiments.trial import TrialSpec, run_trial
    from jackson.sim.faults import summary

    args.robot = args.robot or DEFAULT_ROBOT
    if args.mission == "maze":
        return _cmd_run_maze(args)
    if args.mission in STAGE3:
        raise CliError(f"{args.mission} is a campaign: jackson campaign {args.mission}")
    if args.map is not None or args.goal:
        raise CliError("--map and --goal are for the maze")
    if _lidar_mode(args) is not None:
        raise CliError("--lidar-mode is for the maze (the square and figure-eight use no LiDAR)")
    world = args.world or ("square_room" if args.mission == "square" else "open_floor")
    _check_twin_files(args.robot, world)
    config = _host_config(args.config)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = _out(args.out or Path("runs") / f"{stamp}-{args.mission}")
    faults = tuple(args.fault)
    r = run_trial(TrialSpec(args.mission, 0, args.seed, args.robot, world, out, config, faults))
    png = out / "trajectory.png"
    plot_trajectories(png, args.mission, [out])
    table = Table(title=f"{args.mission} on the twin ({args.robot}, {world}, seed {args.seed})")
    table.add_column("figure")
    table.add_column("value", justify="right")
    for label, value in (
        ("ground-truth closure", f"{r['gt_closure_cm']:.2f} cm"),
        ("EKF closure", f"{r['ekf_closure_cm']:.2f} cm"),
        ("raw-odometry closure", f"{r['odom_closure_cm']:.2f} cm"),
        ("EKF position RMSE vs ground truth", f"{r['ekf_position_rmse_vs_gt_cm']:.2f} cm"),
        ("EKF cross-track RMSE", f"{r['ekf_cross_track_rmse_cm']:.2f} cm"),
        ("duration (from time zero)", f"{r['duration_s']:.1f} s"),
        ("real-time factor", f"x{r['real_time_factor']:.0f}"),
        *((f"fault {f['fault']}", summary(f)) for f in r["faults"]),
    ):
        table.add_row(label, value)
    Console().print(table)
    print(f"plot: {png}\nrun folder: {out}")
    return 0 if r["completed"] else 1


def _cmd_campaign(args: argparse.Namespace) -> int:
    """``jackson campaign``, its trials on the local pool or on a Ray cluster (``--cluster``:
    connected once here, so a wrong address fails before any trial or mapping run)."""
    if args.cluster is None:
        return _cmd_campaign_kind(args)
    from jackson.experiments.cluster import ClusterError, RayMissingError, ray_session

    try:
        with ray_session(args.cluster, num_cpus=args.workers):
            return _cmd_campaign_kind(args)
    except RayMissingError as exc:
        raise CliError(str(exc)) from exc
    except ClusterError as exc:
        print(f"jackson campaign: {one_line(exc)}", file=sys.stderr)
        return 1


def _lidar_mode_arg(text: str) -> str:
    """A scan mode the twin's A1M8 has (any case), ``densest`` or ``standard``."""
    from jackson.sim.rplidar import A1M8_SCAN_MODES

    names = ["densest", "standard", *(m.name.lower() for m in A1M8_SCAN_MODES[1:])]
    if text.lower() not in names:
        raise argparse.ArgumentTypeError(
            f"{text!r} is no scan mode of the twin's RPLIDAR (one of: {', '.join(names)})"
        )
    return text.lower()


def _cluster_arg(text: str) -> str:
    from jackson.experiments.cluster import parse_cluster

    try:
        return parse_cluster(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from exc


def _cmd_campaign_kind(args: argparse.Namespace) -> int:
    import datetime as dt

    from jackson.experiments.campaign import run_campaign

    if args.mission != "fidelity":
        for option, value in (
            ("--docs", args.docs),
            ("--ablation", args.ablation),
            ("--notes", args.notes),
            ("--stages", args.stages),
        ):
            if value:
                raise CliError(f"{option} is for jackson campaign fidelity")
    if args.mission == "worlds":
        return _cmd_campaign_worlds(args)
    args.robot = args.robot or DEFAULT_ROBOT
    if args.mission == "faults":
        return _cmd_campaign_faults(args)
    for option, value in (
        ("--short", args.short),
        ("--clean-hours", args.clean_hours),
        ("--case", args.case),
    ):
        if value:
            raise CliError(f"{option} is for jackson campaign faults")
    if args.mission in STAGE3:
        return _cmd_campaign_stage3(args)
    if args.mission == "fidelity":
        return _cmd_campaign_fidelity(args)
    if _lidar_mode(args) is not None:
        raise CliError("--lidar-mode is for the Stage 3 campaigns (maze, ofat, robustness)")
    if args.map is not None:
        raise CliError(
            "--map is for the Stage 3 campaigns (maze, ofat, robustness) and the fault "
            "campaign's maze cases"
        )
    _check_twin_files(
        args.robot, args.world or ("square_room" if args.mission == "square" else "open_floor")
    )
    config = _host_config(args.config)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    trials = args.trials if args.trials is not None else 10
    out = _out(args.out or Path("reports") / f"{stamp}-{args.mission}-x{trials}")
    results = run_campaign(
        args.mission,
        trials,
        out,
        robot=args.robot,
        world=args.world,
        seed=args.seed,
        workers=args.workers,
        cluster=args.cluster,
        config=config,
    )
    done = sum(1 for r in results if r["completed"])
    print((out / "summary.md").read_text())
    print(f"report: {out}/summary.md ({done}/{len(results)} trials completed)")
    return 0 if done == len(results) else 1


def _cmd_campaign_worlds(args: argparse.Namespace) -> int:
    import datetime as dt

    from jackson.experiments.worlds_campaign import ROBOTS, WORLDS, run_worlds_campaign

    for option, value in (
        ("--short", args.short),
        ("--clean-hours", args.clean_hours),
        ("--case", args.case),
        ("--map", args.map),
    ):
        if value:
            raise CliError(f"{option} is not for jackson campaign worlds (each world maps itself)")
    worlds = [w for w in (args.world or ",".join(WORLDS)).split(",") if w]
    robots = [r for r in (args.robot or ",".join(ROBOTS)).split(",") if r]
    if not worlds or not robots:
        raise CliError("--world and --robot: give at least one name")
    for world in worlds:
        for robot in robots:
            _check_twin_files(robot, world)
    config = _host_config(args.config)
    trials = args.trials if args.trials is not None else 10
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = _out(args.out or Path("reports") / f"{stamp}-worlds-x{trials * len(worlds)}")
    results = run_worlds_campaign(
        out,
        trials,
        worlds=worlds,
        robots=robots,
        seed=args.seed,
        workers=args.workers,
        config=config,
        cluster=args.cluster,
    )
    passed = sum(1 for r in results if r["passed"])
    print((out / "summary.md").read_text())
    print(f"report: {out}/summary.md ({passed}/{len(results)} runs passed)")
    return 0 if passed == len(results) == trials * len(worlds) else 1


def _cmd_campaign_faults(args: argparse.Namespace) -> int:
    import datetime as dt

    from jackson.experiments.fault_campaign import (
        CASES,
        WORLDS,
        FaultCampaignError,
        run_fault_campaign,
    )

    if args.world is not None:
        raise CliError(
            "--world: the fault campaign drives the figure-eight on open_floor, the square on "
            "square_room and the navigation trial on maze"
        )
    cases = [c for c in CASES if not args.case or c.name in args.case]
    missions = {c.mission for c in cases}
    if args.map is not None and "maze" not in missions:
        raise CliError("--map is for the maze cases (lidar_noise, lidar_dropout, lidar_dead)")
    for mission in sorted(missions | {"figure8"}):
        _check_twin_files(args.robot, WORLDS[mission])
    config = _host_config(args.config)
    map_yaml = _map_file(args.map)
    trials = args.trials if args.trials is not None else (3 if args.short else 10)
    hours = args.clean_hours if args.clean_hours is not None else (0.1 if args.short else 1.0)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = _out(args.out or Path("reports") / f"{stamp}-faults-x{trials}")
    tty = sys.stdout.isatty()
    try:
        summary = run_fault_campaign(
            out,
            trials=trials,
            clean_hours=hours,
            cases=cases,
            robot=args.robot,
            seed=args.seed,
            workers=args.workers,
            cluster=args.cluster,
            config=config,
            map_yaml=map_yaml,
            progress=tty,
            log=None if tty else lambda line: print(line, flush=True),
        )
    except FaultCampaignError as exc:
        raise CliError(f"{exc} (its run folder: {out / 'map'})") from exc
    print((out / "summary.md").read_text())
    print(f"report: {out}/summary.md, {out}/faults.png")
    for name, reasons in summary["missed"].items():
        print(f"missed: {name}: {'; '.join(reasons)}")
    return 0 if summary["all_met"] else 1


def _cmd_campaign_fidelity(args: argparse.Namespace) -> int:
    from jackson.experiments.fidelity import (
        BRINGUP_CONFIG,
        MECHANISMS,
        STAGES,
        FidelityError,
        ablate,
        check_docs,
        read_notes,
        run_fidelity,
    )

    for option, value in (("--world", args.world), ("--map", args.map)):
        if value is not None:
            raise CliError(
                f"{option}: the fidelity campaign drives the paper's courses (square_room, "
                "open_floor, maze)"
            )
    if _lidar_mode(args) is not None:
        raise CliError("--lidar-mode: the fidelity campaign's maze reads the densest mode")
    stages = args.stages or STAGES
    worlds = {"square": "square_room", "figure8": "open_floor", "maze": "maze"}
    for stage in stages:
        _check_twin_files(args.robot, worlds[stage])
    config = _host_config(args.config if args.config is not None else BRINGUP_CONFIG)
    try:  # every check before anything runs or is written
        if args.notes is not None:
            option = "--notes"
            read_notes(args.notes)
        if args.docs is not None:
            option = "--docs"
            check_docs(args.docs)
        if args.ablation:
            option = "--ablation:"
            ablate(MECHANISMS, args.robot, config, [])
    except FidelityError as exc:
        raise CliError(f"{option} {one_line(exc)}") from exc
    trials = args.trials if args.trials is not None else 10
    out = _out(args.out or Path("build/fidelity"))
    report = run_fidelity(
        trials,
        out,
        seed=args.seed,
        robot=args.robot,
        config=config,
        workers=args.workers,
        cluster=args.cluster,
        ablation=args.ablation,
        stages=stages,
        docs=args.docs,
        notes=args.notes,
    )
    print((out / "fidelity.md").read_text())
    pages = f"; page: {args.docs}, {args.docs.with_suffix('.png')}" if args.docs else ""
    print(f"report: {out}/fidelity.md, {out}/fidelity.png, {out}/fidelity.json{pages}")
    nav = report.nav
    done = all(r.completed == r.attempted for r in report.figures)
    done = done and nav.completed == nav.attempted and nav.failure is None
    return 0 if done else 1


def _stages_arg(text: str) -> tuple[str, ...]:
    """A comma list of the fidelity campaign's stages, in their own order."""
    from jackson.experiments.fidelity import STAGES

    names = [t.strip() for t in text.split(",") if t.strip()]
    bad = [n for n in names if n not in STAGES]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a comma list of {', '.join(STAGES)}")
    return tuple(s for s in STAGES if s in names)


def _lidar_mode(args: argparse.Namespace) -> str | None:
    """The RPLIDAR scan mode ``--lidar-mode`` names (None: the densest)."""
    from jackson.host.lidar.rplidar import start_mode

    return start_mode(args.lidar_mode)


def _cmd_campaign_stage3(args: argparse.Namespace) -> int:
    import datetime as dt

    from jackson.experiments.stage3 import CAMPAIGNS, run_stage3_campaign

    world = args.world or "maze"
    _check_twin_files(args.robot, world)
    config = _host_config(args.config)
    map_yaml = _map_file(args.map)
    trials = args.trials if args.trials is not None else (10 if args.mission == "maze" else 15)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    runs = trials * len(CAMPAIGNS[args.mission])
    out = _out(args.out or Path("reports") / f"{stamp}-{args.mission}-x{runs}")
    results = run_stage3_campaign(
        args.mission,
        trials,
        out,
        robot=args.robot,
        world=world,
        seed=args.seed,
        workers=args.workers,
        cluster=args.cluster,
        config=config,
        map_yaml=map_yaml,
        lidar_mode=_lidar_mode(args),
    )
    done = sum(1 for r in results if r["completed"])
    print((out / "summary.md").read_text())
    print(f"report: {out}/summary.md ({done}/{len(results)} runs reached the goal)")
    return 0 if done == len(results) else 1


def build_parser() -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = OneLineParser(
        prog="jackson", description="Firmware-plus-host stack for differential-drive robots."
    )
    parser.add_argument("--version", action="version", version=f"jackson {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("bench", help="run the benchmarks, print a table, write build/bench.json")
    p.add_argument("--out", type=Path, default=Path("build/bench.json"), help="JSON output path")
    p.add_argument("--quick", action="store_true", help="smaller workloads (seconds, noisier)")
    from jackson.benchmark import SUITES

    p.add_argument(
        "--suite",
        action="append",
        choices=list(SUITES),
        help="run only this suite (repeatable; default: all)",
    )
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser(
        "decode", help="decode a captured byte stream (file or -) and print messages and counters"
    )
    p.add_argument("input", help="file with raw serial bytes, or - for standard input")
    p.add_argument("-q", "--quiet", action="store_true", help="print only the counters")
    p.add_argument(
        "--summary", action="store_true", help="a table of message counts instead of each message"
    )
    p.set_defaults(func=_cmd_decode)

    for name, helptext in (
        ("run", "one mission on the twin with the real host; a table, a plot and a run folder"),
        ("campaign", "many trials on the twin in parallel; a report folder like the paper's"),
    ):
        p = sub.add_parser(name, help=helptext)
        missions = ["square", "figure8", "maze"] + (
            ["ofat", "robustness", "faults", "worlds", "fidelity"] if name == "campaign" else []
        )
        p.add_argument("mission", choices=missions)
        p.add_argument(
            "--map",
            type=Path,
            help="maze (and the fault campaign's maze cases): a map (map_server YAML) instead "
            "of mapping first",
        )
        if name == "run":
            from jackson.sim.cli import FAULT_HELP, fault_arg

            p.add_argument(
                "--fault",
                type=fault_arg,
                action="append",
                default=[],
                metavar="SPEC",
                help=f"{FAULT_HELP}; maze: on the navigation run, not on the mapping run",
            )
            p.add_argument(
                "--goal",
                action="append",
                metavar="X,Y[,YAW]",
                help="maze: navigate here (world coordinates, repeatable; default the world "
                "file's goal, else the Stage 3 goal)",
            )
        if name == "campaign":
            p.add_argument(
                "--trials",
                type=int_in(1, MAX_TRIALS),
                help="trials (per variant for ofat and robustness, per case for faults; default "
                "10, ofat/robustness 15)",
            )
            p.add_argument(
                "--workers",
                type=int_in(1, MAX_WORKERS),
                default=2,
                help="worker processes (2); with --cluster local, the Ray instance's CPUs",
            )
            p.add_argument(
                "--cluster",
                type=_cluster_arg,
                metavar="auto|local|ray://HOST:PORT",
                help="run the trials on Ray: auto = the running cluster, local = a Ray instance "
                "started here, ray://HOST:PORT = Ray Client (default: the local process pool)",
            )
            from jackson.experiments.fault_campaign import CASE_NAMES

            p.add_argument(
                "--short",
                action="store_true",
                help="faults: 3 trials per case and 0.1 h of clean runs (unless given)",
            )
            p.add_argument(
                "--clean-hours",
                type=nonneg_upto(MAX_HOURS),
                metavar="H",
                help="faults: hours of driving without faults for the false alarms (default 1)",
            )
            p.add_argument(
                "--case",
                action="append",
                choices=CASE_NAMES,
                metavar="NAME",
                help=f"faults: only this case (repeatable; {', '.join(CASE_NAMES)})",
            )
            p.add_argument(
                "--docs",
                type=Path,
                metavar="PATH",
                help="fidelity: also write the page to PATH (a .md) and its PNG beside it, "
                "e.g. docs/fidelity.md",
            )
            p.add_argument(
                "--ablation",
                action="store_true",
                help="fidelity: also run the square and figure-eight with each of the twin's "
                "mechanisms switched off in turn",
            )
            p.add_argument(
                "--notes",
                type=Path,
                metavar="FILE",
                help="fidelity: markdown appended verbatim at the end of the page",
            )
            p.add_argument(
                "--stages",
                type=_stages_arg,
                metavar="LIST",
                help="fidelity: the stages to run, a comma list (default square,figure8,maze)",
            )
        p.add_argument(
            "--robot",
            help="twin robot file (default jackson_physical; campaign worlds: a comma list, "
            "default both shipped robots in turn)",
        )
        p.add_argument(
            "--world",
            help="world (default: square_room / open_floor / maze; campaign worlds: a comma "
            "list, default all six of its worlds)",
        )
        p.add_argument(
            "--lidar-mode",
            type=_lidar_mode_arg,
            default="densest",
            metavar="MODE",
            help="maze, ofat, robustness: the twin's RPLIDAR scan mode the host reads: densest "
            "(the default, as the daemon: Sensitivity), standard, express, boost, stability, "
            "sensitivity",
        )
        p.add_argument("--seed", type=nonneg_int, default=0, help="noise seed (deterministic)")
        p.add_argument(
            "--config",
            type=Path,
            metavar="FILE",
            help="host YAML the robot runs with, e.g. one jackson calibrate --write made "
            "(default: the paper's robot; campaign fidelity: host/config/jackson_bringup.yaml)",
        )
        p.add_argument(
            "--out", type=Path, help="output folder (campaign fidelity: default build/fidelity)"
        )
        p.set_defaults(func=_cmd_run if name == "run" else _cmd_campaign)

    from jackson.calibration import cli as calibrate_cli
    from jackson.host import cli as host_cli

    calibrate_cli.add_parser(sub)
    from jackson.sim import cli as sim_cli

    host_cli.add_parsers(sub)
    from jackson.host import bag_cli
    from jackson.host import brake as brake_cli

    bag_cli.add_parser(sub)
    brake_cli.add_parser(sub)

    sim_cli.add_parser(sub)
    sub.choices["sim"].set_defaults(func=sim_cli.run)
    p = sub.add_parser(
        "map",
        help="map a world on the twin: the real host maps (scan matching) while it drives a survey",
    )
    p.add_argument("--world", default="maze", help="world (default maze)")
    p.add_argument("--robot", default="jackson_physical", help="twin robot (jackson_physical)")
    p.add_argument(
        "--waypoint",
        action="append",
        metavar="X,Y[,YAW]",
        help="survey route in world coordinates [m, rad], repeatable (default: the Stage 3 "
        "goal and back to the start)",
    )
    p.add_argument("--seed", type=nonneg_int, default=0, help="noise seed (deterministic)")
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="host YAML the robot runs with (default: the paper's robot)",
    )
    p.add_argument("--out", type=Path, help="output folder (default maps/<stamp>-<world>)")
    p.set_defaults(func=_cmd_map)
    p = sub.add_parser(
        "faults",
        help="the fault matrix: each fault injected into the twin under the real daemon, a report",
    )
    p.add_argument("--short", action="store_true", help="repeated faults 2-3 times, not 10/100")
    p.add_argument("--out", type=Path, default=Path("build/faults"), help="report folder")
    p.set_defaults(func=_cmd_faults)
    p = sub.add_parser(
        "patrol",
        help="a navigation service in service: the twin and one daemon process, goal after goal "
        "(cancels, preemptions, teleop, unreachable goals, obstacles dropped); docs/patrol.md",
    )
    p.add_argument("--world", default="office_floor", help="a world with a patrol: section")
    p.add_argument("--goals", type=positive_int, default=70, help="goals to send (default 70)")
    p.add_argument(
        "--robot-hours",
        type=positive_float,
        help="run for this much MCU time instead of a number of goals (the soak)",
    )
    p.add_argument("--seed", type=nonneg_int, default=0, help="seed of the goals, drops, noise")
    p.add_argument("--config", type=Path, metavar="FILE", help="host YAML (default: shipped)")
    p.add_argument("--budget-mb", type=positive_float, default=2000.0, help="recording budget [MB]")
    p.add_argument(
        "--sample-s",
        type=positive_float,
        default=20.0,
        help="wall seconds between samples of the processes' memory and CPU (default 20)",
    )
    p.add_argument("--out", type=Path, help="output folder (default build/patrol/<world>-<seed>)")
    p.set_defaults(func=_cmd_patrol)
    return parser


def _cmd_patrol(args: argparse.Namespace) -> int:
    import json

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from jackson.experiments.patrol import Patrol, PatrolSpec

    _check_twin_files("jackson", args.world)
    out = _out(args.out or Path("build/patrol") / f"{Path(args.world).stem}-{args.seed}")
    spec = PatrolSpec(
        args.world,
        out,
        seed=args.seed,
        goals=args.goals,
        robot_hours=args.robot_hours,
        config=_host_config(args.config),
        budget_mb=args.budget_mb,
        sample_s=args.sample_s,
    )
    patrol = Patrol(spec)
    hours = args.robot_hours
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
    ) as progress:
        total = hours * 3600.0 if hours else float(args.goals)
        task = progress.add_task(f"patrol {args.world}", total=total, info="starting")

        def on_step(p: Patrol, o: object) -> None:
            done = (p.last_status.get("t_s") or 0.0) if hours else len(p.result.outcomes)
            ok = sum(x.ok for x in p.result.outcomes)
            last = p.result.outcomes[-1]
            progress.update(
                task,
                completed=done,
                info=f"{ok}/{len(p.result.outcomes)} ok; last {last.kind} {last.status}",
            )

        result = patrol.run(on_step)
    summary = json.loads((out / "summary.json").read_text())
    for key, value in summary.items():
        print(f"{key}: {value}")
    print(f"plot: {out / 'patrol.png'}\ngoals: {out / 'patrol.csv'}\nsamples: {out / 'soak.csv'}")
    good = (
        result.failure is None
        and all(o.ok for o in result.outcomes)
        and result.contacts == 0
        and not result.exclusions
    )
    return 0 if good else 1


def _cmd_faults(args: argparse.Namespace) -> int:
    from rich.console import Console

    from jackson.experiments.fault_matrix import run_matrix

    console = Console(stderr=True)
    if args.out.exists() and not args.out.is_dir():
        raise CliError(f"--out {args.out}: is a file, give a folder")
    for parent in args.out.parents:
        if parent.exists() and not parent.is_dir():
            raise CliError(f"--out {args.out}: {parent} is a file, not a folder")
    rows = run_matrix(args.out, short=args.short, progress=lambda text: console.print(text))
    print((args.out / "report.md").read_text())
    print(f"report: {args.out / 'report.md'}, rows: {args.out / 'faults.json'}")
    return 0 if all(r.passed for r in rows) else 1


def _brake_parser() -> argparse.ArgumentParser:
    """``jackson brake`` alone: the command systemd runs after a crash must brake within a
    fraction of a second, not after importing every other command's modules."""
    from jackson.host import brake as brake_cli

    parser: argparse.ArgumentParser = OneLineParser(prog="jackson")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    brake_cli.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    given = list(sys.argv[1:] if argv is None else argv)
    brake = given[:1] == ["brake"] and not {"-h", "--help"} & set(given)
    args = (_brake_parser() if brake else build_parser()).parse_args(given)
    try:
        rc: int = args.func(args)
    except OSError as exc:  # the machine refused: a full disk, a folder where a file goes, ...
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"jackson {args.command}: {where}{exc.strerror or one_line(exc)}", file=sys.stderr)
        return 2
    except JacksonError as exc:  # every error of the project's own: one line (common/errors.py)
        print(f"jackson {args.command}: {one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return 0
    return rc
