"""``jackson run``: one mission on the twin with the real host; a table, a plot, a run folder."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

from jackson.commands.checks import (
    DEFAULT_ROBOT,
    STAGE3,
    CliError,
    check_twin_files,
    host_config,
    lidar_mode,
    map_file,
    out_folder,
    refuse_bad_route,
)
from jackson.commands.options import add_mission, add_twin_options
from jackson.common.args import pose_text
from jackson.experiments.stall_retry import exit_status

if TYPE_CHECKING:  # the run's modules load when it runs
    from jackson.common.figure_worker import FigureWorker
    from jackson.host.nav.types import Pose2D
    from jackson.sim.config import WorldSpec


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson run``."""
    p = sub.add_parser(
        "run", help="one mission on the twin with the real host; a table, a plot and a run folder"
    )
    add_mission(p, ["square", "figure8", "maze"])
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
        type=pose_text,
        metavar="X,Y[,YAW]",
        help="maze: navigate here (world coordinates, repeatable; default the world "
        "file's goal, else the Stage 3 goal)",
    )
    p.add_argument(
        "--pdf",
        action="store_true",
        help="also write the plot as a PDF (trajectory.pdf, maze.pdf: vector, fonts embedded), "
        "as a campaign's figures are",
    )
    add_twin_options(p)
    p.set_defaults(func=_cmd_run, exit_fast=True)  # everything is written and closed at its end


def _cmd_run(args: argparse.Namespace) -> int:
    """The square or the figure-eight on the twin (the maze: :func:`_cmd_run_maze`)."""
    import datetime as dt

    from rich.console import Console
    from rich.table import Table

    from jackson.common.figure_worker import FigureWorker
    from jackson.experiments.trial import TrialSpec, run_trial
    from jackson.sim.faults import summary

    args.robot = args.robot or DEFAULT_ROBOT
    if args.mission == "maze":
        return _cmd_run_maze(args)
    if args.mission in STAGE3:
        raise CliError(f"{args.mission} is a campaign: jackson campaign {args.mission}")
    if args.map is not None or args.goal:
        raise CliError("--map and --goal are for the maze")
    if lidar_mode(args) is not None:
        raise CliError("--lidar-mode is for the maze (the square and figure-eight use no LiDAR)")
    from jackson.sim.faults import LIDAR_KINDS

    for f in args.fault:
        if f.kind in LIDAR_KINDS:
            raise CliError(
                f"--fault {f.kind}: the {args.mission} runs without a LiDAR; LiDAR faults are "
                "for the maze"
            )
    world = args.world or ("square_room" if args.mission == "square" else "open_floor")
    check_twin_files(args.robot, world)
    config = host_config(args.config)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = out_folder(args.out or Path("runs") / f"{stamp}-{args.mission}")
    faults = tuple(args.fault)
    with FigureWorker("jackson.experiments.report_plots", "plot_trajectories") as figure:
        spec = TrialSpec(args.mission, 0, args.seed, args.robot, world, out, config, faults)
        r = run_trial(spec)
        png = out / "trajectory.png"
        figure.draw(png, args.mission, [out], vector=args.pdf)
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
    return exit_status(r)


def _cmd_run_maze(args: argparse.Namespace) -> int:
    """Map the maze (unless ``--map``), then navigate it to the goals; the table and plot."""
    import datetime as dt

    from jackson.common.figure_worker import FigureWorker
    from jackson.experiments.stage3 import check_world_route, world_goals
    from jackson.sim.config import load_world

    map_yaml = map_file(args.map)  # the map and the goals first: nothing is built before
    goals = None
    if args.goal:
        from jackson.host.control.navigate import poses

        try:
            goals = poses(args.goal)
        except ValueError as exc:
            raise CliError(f"--goal: {exc}") from exc
    world = args.world or "maze"
    check_twin_files(args.robot, world)
    config = host_config(args.config)
    world_spec = load_world(world)
    goals = goals or world_goals(world_spec)
    refuse_bad_route(lambda: check_world_route(world_spec, goals), f"--world {world}")
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = out_folder(args.out or Path("runs") / f"{stamp}-maze")
    with FigureWorker("jackson.experiments.stage3", "plot_stage3") as figure:
        return _maze_runs(args, out, map_yaml, world, world_spec, goals, config, figure)


def _maze_runs(
    args: argparse.Namespace,
    out: Path,
    map_yaml: Path | None,
    world: str,
    world_spec: WorldSpec,
    goals: tuple[Pose2D, ...],
    config: Path | None,
    figure: FigureWorker,
) -> int:
    """The maze's mapping run (without ``map_yaml``) and its navigation, then its figure
    (drawn by ``figure``, a :class:`~jackson.common.figure_worker.FigureWorker`)."""
    from jackson.experiments.stage3 import NavTrialSpec, mapping_spec, run_nav_trial
    from jackson.host.control.navigator import NavigatorConfig, check_route
    from jackson.host.nav.grid import OccupancyGrid
    from jackson.host.nav.types import Pose2D

    if map_yaml is None:
        survey = mapping_spec(args.robot, world, args.seed, out / "map", config)
        m = run_nav_trial(dataclasses.replace(survey, lidar_mode=lidar_mode(args)))
        if not m["completed"]:
            print(f"jackson run maze: the mapping run stopped: {m['failure']}")
            return exit_status(m)
        map_yaml = out / "map" / "built_map.yaml"
    grid = OccupancyGrid.load(map_yaml)
    start = Pose2D(*world_spec.start_pose)
    refuse_bad_route(lambda: check_route(grid, start, goals, NavigatorConfig()), f"map {map_yaml}")
    faults = tuple(args.fault)  # on the navigation run, not on the mapping run before it
    spec = NavTrialSpec(
        0, args.seed, args.robot, world, out / "nav", map_yaml, config=config, faults=faults
    )
    spec = dataclasses.replace(spec, goals=goals, lidar_mode=lidar_mode(args))
    r = run_nav_trial(spec)
    r["run"] = "nav"
    figure.draw(out / "maze.png", out, [r], vector=args.pdf)
    _print_maze_table(f"maze on the twin ({args.robot}, {world}, seed {args.seed})", r)
    print(f"plot: {out / 'maze.png'}\nrun folder: {out / 'nav'}")
    return exit_status(r)


def _print_maze_table(title: str, r: dict[str, Any]) -> None:
    """The navigation run's figures beside the paper's (physical robot / Isaac Sim)."""
    from rich.console import Console
    from rich.table import Table

    from jackson.sim.faults import summary

    table = Table(title=title)
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
