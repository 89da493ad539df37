"""``jackson bag repair|info RUN``: a run's rosbag2 after a kill, like ``ros2 bag reindex``."""

from __future__ import annotations

import argparse
from pathlib import Path

from jackson.host.cli import HostCliError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson bag`` and its actions on the subcommand parsers ``sub``."""
    p = sub.add_parser("bag", help="the rosbag2 of a run folder: repair a killed run's, or list it")
    actions = p.add_subparsers(dest="bag_command", metavar="ACTION", required=True)
    r = actions.add_parser(
        "repair",
        help="make the unfinished bags of a run (killed, power lost) readable, like ros2 bag "
        "reindex: every message that reached the disk whole is kept",
    )
    r.add_argument("run", type=Path, help="run folder (or one bag folder)")
    r.set_defaults(func=cmd_bag_repair)
    i = actions.add_parser("info", help="topics, message counts, time span and size of its bags")
    i.add_argument("run", type=Path, help="run folder (or one bag folder)")
    i.set_defaults(func=cmd_bag_info)


def bags_of(run: Path) -> list[Path]:
    """The bag folders ``run`` names: itself if it holds an MCAP file, else its bag folders.

    Raises
    ------
    HostCliError
        ``run`` does not exist, is a file, or holds no bag.
    """
    from jackson.host.ros.bag import bag_folders

    if not run.is_dir():
        what = "does not exist" if not run.exists() else "is a file"
        raise HostCliError(f"{run}: {what}; give a run folder or a bag folder")
    if any(run.glob("*.mcap")):
        return [run]
    bags = bag_folders(run)
    if not bags:
        raise HostCliError(
            f"{run}: no bag in it; give a run folder (holding bag/) or a bag folder (*.mcap)"
        )
    return bags


def cmd_bag_repair(args: argparse.Namespace) -> int:
    """Repair every unfinished bag of ``args.run`` and show what each holds."""
    from jackson.host.recording import run_in_progress
    from jackson.host.ros.bag import BagError, needs_repair, repair_bag

    for bag in bags_of(args.run):
        if run_in_progress(bag.parent) or run_in_progress(bag):
            raise HostCliError(
                f"{bag}: its run is being recorded by a running daemon; repair it after it ends"
            )
        _refuse_not_mcap(bag)
        if not needs_repair(bag):
            print(f"{bag}: complete (has metadata.yaml), nothing to repair")
        else:
            try:
                n = repair_bag(bag)
            except BagError as exc:
                raise HostCliError(f"{exc}; the bag is left as it was") from exc
            print(f"{bag}: repaired, {n} messages recovered")
        _show(bag, args.run, repairing=True)
    return 0


def _refuse_not_mcap(bag: Path) -> None:
    """Raise when a file of ``bag`` does not start with MCAP's magic: that is no bag a writer
    left unfinished, and no repair can make it one."""
    from jackson.host.ros.bag import BagError
    from jackson.host.ros.bag.repair import whole_records

    for file in sorted(bag.glob("*.mcap")):
        try:
            next(iter(whole_records(file)), None)
        except BagError as exc:
            why = f"{exc}, so not a bag: no repair can make it one (left as it was)"
            raise HostCliError(why) from exc
        except OSError as exc:
            raise HostCliError(f"{file}: {exc.strerror}") from exc


def cmd_bag_info(args: argparse.Namespace) -> int:
    """Topics, counts, time span and size of every bag of ``args.run``."""
    from jackson.host.ros.bag import needs_repair

    for bag in bags_of(args.run):
        _refuse_not_mcap(bag)
        if needs_repair(bag):
            raise HostCliError(
                f"{bag}: unfinished (no metadata.yaml); run: jackson bag repair {args.run}"
            )
        _show(bag, args.run)
    return 0


def _show(bag: Path, run: Path, *, repairing: bool = False) -> None:
    from jackson.host.ros.bag import BagError, bag_info

    try:
        info = bag_info(bag)
    except BagError as exc:
        hint = "no repair can read it" if repairing else f"try: jackson bag repair {run}"
        raise HostCliError(f"{exc}; {hint}") from exc
    if info.start_ns is None or info.end_ns is None:
        span = "no messages"
    else:
        t0, t1 = info.start_ns / 1e9, info.end_ns / 1e9
        span = f"{t0:.3f} s to {t1:.3f} s ({t1 - t0:.3f} s)"
    files = ", ".join(f.name for f in info.files)
    size_mb = info.size_bytes / 1e6
    print(f"{bag}: {info.message_count} messages, {span}, {size_mb:.1f} MB in {files}")
    for topic, n in sorted(info.counts.items()):
        print(f"  {topic}: {n}")
