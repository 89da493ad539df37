"""The ``jackson`` command: one entry point for every tool of the stack.

Each subcommand imports what it needs when it runs, so ``jackson --help`` stays fast
and the host never pulls in the twin. Errors a user can cause end as one line on
stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any, BinaryIO

from jackson import __version__
from jackson.host.cli import HostCliError


class CliError(Exception):
    """A user-facing error: printed as one line, exit status 2."""


def _cmd_bench(args: argparse.Namespace) -> int:
    from jackson.benchmark import print_table, run_all, write_json

    results = run_all(quick=args.quick, only=args.suite)
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
        console.print(
            f"telemetry: {len(telemetry)} frames over {span_s:.2f} s of MCU time "
            f"({(len(telemetry) - 1) / span_s:.1f} Hz); encoder counts "
            f"left {first.enc_left} -> {last.enc_left}, right {first.enc_right} -> {last.enc_right}"
        )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
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

    from jackson.host import cli as host_cli
    from jackson.sim import cli as sim_cli

    host_cli.add_parsers(sub)

    sim_cli.add_parser(sub)
    sub.choices["sim"].set_defaults(func=sim_cli.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        rc: int = args.func(args)
    except (CliError, HostCliError) as exc:
        print(f"jackson {args.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return 0
    return rc
