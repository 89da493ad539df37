"""``jackson map``: map a world on the twin; the real host maps while it drives a survey."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from jackson.commands.checks import (
    CliError,
    check_twin_files,
    host_config,
    out_folder,
    refuse_bad_route,
)
from jackson.common.args import nonneg_int, pose_text


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson map``."""
    p = sub.add_parser(
        "map",
        help="map a world on the twin: the real host maps (scan matching) while it drives a survey",
    )
    p.add_argument("--world", default="maze", help="world (default maze)")
    p.add_argument("--robot", default="jackson_physical", help="twin robot (jackson_physical)")
    p.add_argument(
        "--waypoint",
        action="append",
        type=pose_text,
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


def _cmd_map(args: argparse.Namespace) -> int:
    """Survey the world on the twin while the host maps it; the map and its SSIM."""
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
    if not r["completed"]:
        print(f"jackson map: the survey stopped: {r['failure']}; the partial map is in {out}")
        return 1
    print(
        f"map: {out / 'built_map.yaml'} (+ .pgm), SSIM {r['map_ssim']:.3f} against the twin's "
        f"world; survey {r['path_length_m']:.2f} m in {r['sim_s']:.1f} s of sim time, "
        f"localisation error mean {r['localisation_error_mean_cm']:.1f} cm"
    )
    return 0
