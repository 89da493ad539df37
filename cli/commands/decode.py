"""``jackson decode``: a captured byte stream's messages and the decoder's counters."""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from typing import Any, BinaryIO

from jackson.commands.checks import CliError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson decode``."""
    p = sub.add_parser(
        "decode", help="decode a captured byte stream (file or -) and print messages and counters"
    )
    p.add_argument("input", help="file with raw serial bytes, or - for standard input")
    p.add_argument("-q", "--quiet", action="store_true", help="print only the counters")
    p.add_argument(
        "--summary", action="store_true", help="a table of message counts instead of each message"
    )
    p.set_defaults(func=_cmd_decode)


def _open_input(name: str) -> BinaryIO:
    """The capture to read: a file, or standard input for ``-``."""
    if name == "-":
        return sys.stdin.buffer
    try:
        return open(name, "rb")
    except OSError as exc:
        raise CliError(f"cannot read {name}: {exc.strerror}") from exc


def _cmd_decode(args: argparse.Namespace) -> int:
    """Decode the stream chunk by chunk; each message (or a summary), then the counters."""
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
    """The message counts and the telemetry's span, rate and encoder counts."""
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
