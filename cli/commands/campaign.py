"""``jackson campaign``: many trials on the twin in parallel, a report folder like the paper's.

The square and figure-eight campaigns, the Stage 3 ones (maze, OFAT, robustness), the fault
campaign, the worlds campaign and the fidelity campaign, on the local process pool or a Ray
cluster (``--cluster``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from jackson.commands.checks import (
    DEFAULT_ROBOT,
    STAGE3,
    CliError,
    check_twin_files,
    host_config,
    lidar_mode,
    map_file,
    out_folder,
)
from jackson.commands.options import add_mission, add_twin_options
from jackson.common.args import (
    MAX_HOURS,
    MAX_TRIALS,
    MAX_WORKERS,
    int_in,
    nonneg_upto,
    one_line,
    positive_int,
)

MISSIONS = ["square", "figure8", "maze", "ofat", "robustness", "faults", "worlds", "fidelity"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson campaign``."""
    p = sub.add_parser(
        "campaign", help="many trials on the twin in parallel; a report folder like the paper's"
    )
    add_mission(p, MISSIONS)
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
        nargs="?",
        const=0,  # the flag alone: every trial (a typed 0 is refused by the type)
        type=positive_int,
        metavar="N",
        help="fidelity: also run the square and figure-eight with each of the twin's "
        "mechanisms switched off in turn (on the first N seeds; default all of --trials)",
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
    add_twin_options(p)
    p.set_defaults(func=_cmd_campaign)


def _cluster_arg(text: str) -> str:
    """A ``--cluster`` address: ``auto``, ``local`` or ``ray://HOST:PORT``."""
    from jackson.experiments.cluster import parse_cluster

    try:
        return parse_cluster(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from exc


def _stages_arg(text: str) -> tuple[str, ...]:
    """A comma list of the fidelity campaign's stages, in their own order."""
    from jackson.experiments.fidelity import STAGES

    names = [t.strip() for t in text.split(",") if t.strip()]
    bad = [n for n in names if n not in STAGES]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a comma list of {', '.join(STAGES)}")
    return tuple(s for s in STAGES if s in names)


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


def _cmd_campaign_kind(args: argparse.Namespace) -> int:
    """Refuse the options of other campaigns, then run the one ``mission`` names."""
    import datetime as dt

    from jackson.experiments.campaign import run_campaign

    if args.mission != "fidelity":
        for option, value in (
            ("--docs", args.docs),
            ("--ablation", args.ablation is not None),
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
    if lidar_mode(args) is not None:
        raise CliError("--lidar-mode is for the Stage 3 campaigns (maze, ofat, robustness)")
    if args.map is not None:
        raise CliError(
            "--map is for the Stage 3 campaigns (maze, ofat, robustness) and the fault "
            "campaign's maze cases"
        )
    check_twin_files(
        args.robot, args.world or ("square_room" if args.mission == "square" else "open_floor")
    )
    config = host_config(args.config)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    trials = args.trials if args.trials is not None else 10
    out = out_folder(args.out or Path("reports") / f"{stamp}-{args.mission}-x{trials}")
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
    """Every world with every robot, each mapped and navigated (``campaign worlds``)."""
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
            check_twin_files(robot, world)
    config = host_config(args.config)
    trials = args.trials if args.trials is not None else 10
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = out_folder(args.out or Path("reports") / f"{stamp}-worlds-x{trials * len(worlds)}")
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


def _cmd_campaign_stage3(args: argparse.Namespace) -> int:
    """The Stage 3 campaigns: maze, OFAT and robustness."""
    import datetime as dt

    from jackson.experiments.stage3 import CAMPAIGNS, run_stage3_campaign

    world = args.world or "maze"
    check_twin_files(args.robot, world)
    config = host_config(args.config)
    map_yaml = map_file(args.map)
    trials = args.trials if args.trials is not None else (10 if args.mission == "maze" else 15)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    runs = trials * len(CAMPAIGNS[args.mission])
    out = out_folder(args.out or Path("reports") / f"{stamp}-{args.mission}-x{runs}")
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
        lidar_mode=lidar_mode(args),
    )
    done = sum(1 for r in results if r["completed"])
    print((out / "summary.md").read_text())
    print(f"report: {out}/summary.md ({done}/{len(results)} runs reached the goal)")
    return 0 if done == len(results) else 1


def _cmd_campaign_faults(args: argparse.Namespace) -> int:
    """The fault campaign: each case's trials and the clean runs for false alarms."""
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
        check_twin_files(args.robot, WORLDS[mission])
    config = host_config(args.config)
    map_yaml = map_file(args.map)
    trials = args.trials if args.trials is not None else (3 if args.short else 10)
    hours = args.clean_hours if args.clean_hours is not None else (0.1 if args.short else 1.0)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out = out_folder(args.out or Path("reports") / f"{stamp}-faults-x{trials}")
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
    """The fidelity campaign: the twin against the paper's robot, stage by stage."""
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
    if lidar_mode(args) is not None:
        raise CliError("--lidar-mode: the fidelity campaign's maze reads the densest mode")
    stages = args.stages or STAGES
    worlds = {"square": "square_room", "figure8": "open_floor", "maze": "maze"}
    for stage in stages:
        check_twin_files(args.robot, worlds[stage])
    config = host_config(args.config if args.config is not None else BRINGUP_CONFIG)
    try:  # every check before anything runs or is written
        if args.notes is not None:
            option = "--notes"
            read_notes(args.notes)
        if args.docs is not None:
            option = "--docs"
            check_docs(args.docs)
        if args.ablation is not None:
            option = "--ablation:"
            ablate(MECHANISMS, args.robot, config, [])
    except FidelityError as exc:
        raise CliError(f"{option} {one_line(exc)}") from exc
    trials = args.trials if args.trials is not None else 10
    ablation_trials = args.ablation or None  # None: not asked, or the flag alone (0)
    if ablation_trials is not None and ablation_trials > trials:
        raise CliError(
            f"--ablation {ablation_trials}: at most the {trials} trials of --trials "
            "(the ablation runs on the report's first seeds)"
        )
    out = out_folder(args.out or Path("build/fidelity"))
    report = run_fidelity(
        trials,
        out,
        seed=args.seed,
        robot=args.robot,
        config=config,
        workers=args.workers,
        cluster=args.cluster,
        ablation=args.ablation is not None,
        stages=stages,
        docs=args.docs,
        notes=args.notes,
        ablation_trials=ablation_trials,
    )
    print((out / "fidelity.md").read_text())
    pages = f"; page: {args.docs}, {args.docs.with_suffix('.png')}" if args.docs else ""
    print(f"report: {out}/fidelity.md, {out}/fidelity.png, {out}/fidelity.json{pages}")
    nav = report.nav
    done = all(r.completed == r.attempted for r in report.figures)
    done = done and nav.completed == nav.attempted and nav.failure is None
    return 0 if done else 1
