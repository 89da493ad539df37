"""``jackson patrol``: the navigation service in service on the twin, goal after goal."""

from __future__ import annotations

import argparse
from pathlib import Path

from jackson.commands.checks import check_twin_files, host_config, map_file, out_folder
from jackson.common.args import nonneg_int, positive_float, positive_int


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson patrol``."""
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
    p.add_argument(
        "--map",
        type=Path,
        metavar="M.yaml",
        help="the map the daemon localises and plans on (map_server YAML in the world's frame, "
        "as jackson map --world W builds it; default: the world's own raster)",
    )
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


def _cmd_patrol(args: argparse.Namespace) -> int:
    """Serve goals on the twin with a progress bar; exit 1 on a failure, contact or exclusion."""
    import json

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from jackson.experiments.patrol import Patrol, PatrolSpec

    check_twin_files("jackson", args.world)
    map_yaml = map_file(args.map)
    out = out_folder(args.out or Path("build/patrol") / f"{Path(args.world).stem}-{args.seed}")
    spec = PatrolSpec(
        args.world,
        out,
        seed=args.seed,
        goals=args.goals,
        robot_hours=args.robot_hours,
        config=host_config(args.config),
        budget_mb=args.budget_mb,
        sample_s=args.sample_s,
        map_yaml=map_yaml.resolve() if map_yaml is not None else None,
    )
    patrol = Patrol(spec)  # refuses a map that is not one of the world in its frame
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
        print(f"{key}: {_figure(key, value)}")
    print(f"plot: {out / 'patrol.png'}\ngoals: {out / 'patrol.csv'}\nsamples: {out / 'soak.csv'}")
    good = (
        result.failure is None
        and all(o.ok for o in result.outcomes)
        and result.contacts == 0
        and not result.exclusions
    )
    return 0 if good else 1


def _figure(key: str, value: object) -> object:
    """The localisation error and the path ratio as one readable line each."""
    if key == "localisation_error" and isinstance(value, dict) and value.get("max_m") is not None:
        return (
            f"median {100 * value['median_m']:.1f} cm, p99 {100 * value['p99_m']:.1f} cm, "
            f"max {100 * value['max_m']:.1f} cm at {value['max_at_xy_m']} "
            f"({value['samples']} samples while driving)"
        )
    if key == "path_ratio" and isinstance(value, dict) and value.get("max") is not None:
        return (
            f"median {value['median']:.3f}, p95 {value['p95']:.3f}, max {value['max']:.3f}, "
            f"{value['above_1_25']} of {value['goals']} reached goals above 1.25"
        )
    return value
