"""``jackson faults``: the fault matrix, each fault injected into the twin under the daemon."""

from __future__ import annotations

import argparse
from pathlib import Path

from jackson.commands.checks import CliError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson faults``."""
    p = sub.add_parser(
        "faults",
        help="the fault matrix: each fault injected into the twin under the real daemon, a report",
    )
    p.add_argument("--short", action="store_true", help="repeated faults 2-3 times, not 10/100")
    p.add_argument("--out", type=Path, default=Path("build/faults"), help="report folder")
    p.set_defaults(func=_cmd_faults)


def _cmd_faults(args: argparse.Namespace) -> int:
    """Run the fault matrix into ``--out``; exit 1 when a row failed."""
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
