"""``jackson bench``: run the benchmark suites, print a table, write build/bench.json."""

from __future__ import annotations

import argparse
from pathlib import Path

from jackson.bench.suites import SUITES
from jackson.commands.checks import CliError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson bench`` (naming the suites imports none of them)."""
    p = sub.add_parser("bench", help="run the benchmarks, print a table, write build/bench.json")
    p.add_argument("--out", type=Path, default=Path("build/bench.json"), help="JSON output path")
    p.add_argument("--quick", action="store_true", help="smaller workloads (seconds, noisier)")
    p.add_argument(
        "--suite",
        action="append",
        choices=list(SUITES),
        help="run only this suite (repeatable; default: all)",
    )
    p.set_defaults(func=_cmd_bench)


def _cmd_bench(args: argparse.Namespace) -> int:
    """Run the suites ``--suite`` names (all by default); the table, then the JSON file."""
    from jackson.bench.report import print_table, write_json
    from jackson.bench.runner import run_all

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
