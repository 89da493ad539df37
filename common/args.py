"""Command-line arguments checked where they are parsed, for every ``jackson`` subcommand.

:class:`OneLineParser` answers a bad argument with one line on stderr (``jackson run: argument
--seed: expected an integer >= 0, got 'x' (see jackson run --help)``) and exit status 2, instead
of argparse's usage block. A negative number is a value, never an option: ``--start -0.5,1``,
``--duty -7e-1`` and ``jackson goal -1,2`` parse as the user means them. The ``*_float`` and
``*_int`` types refuse what a robot cannot use: NaN, infinities, zero or negative counts and
durations; :func:`pose_text` refuses a pose that is not two or three finite numbers.
:func:`output_folder` refuses a path that is a file, or a folder that already holds files,
before anything is written.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

NEGATIVE_NUMBER = re.compile(r"^-(?:[0-9]|\.[0-9]|inf|nan)", re.IGNORECASE)
"""An argument that starts like a negative number (``-0.5,1``, ``-7e-1``, ``-inf``): a value.
argparse's own matcher takes only ``-1`` and ``-0.5`` as values and anything else after a dash
as an option (``argument --start: expected one argument``); no ``jackson`` option starts with
a dash and a digit."""


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line on stderr and exit status 2, and which reads
    an argument starting like a negative number as a value (:data:`NEGATIVE_NUMBER`)."""

    def error(self, message: str) -> NoReturn:
        message = " ".join(message.split())
        self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")

    def _parse_optional(self, arg_string: str) -> Any:
        if NEGATIVE_NUMBER.match(arg_string):
            return None  # a positional value, or the value of the option before it
        return super()._parse_optional(arg_string)


def _number(
    kind: str, cast: Callable[[str], float], test: Callable[[float], bool]
) -> Callable[[str], float]:
    def parse(text: str) -> float:
        try:
            value = cast(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and test(value)):
            raise argparse.ArgumentTypeError(f"expected {kind}, got {text!r}")
        return value

    parse.__name__ = kind  # argparse names the type in some messages
    return parse


positive_float = _number("a number > 0", float, lambda v: v > 0)
nonneg_float = _number("a number >= 0", float, lambda v: v >= 0)
fraction = _number("a number in (0, 1]", float, lambda v: 0 < v <= 1)
nonzero_float = _number("a finite number other than 0", float, lambda v: v != 0)


def float_upto(hi: float, lo_open: float = 0.0) -> Callable[[str], float]:
    """A number type for argparse that accepts (``lo_open``, ``hi``]: a duration or an amount
    bounded by what can run (``--clean-hours 1e300`` is refused, not run until killed)."""
    return _number(f"a number in ({lo_open:g}, {hi:g}]", float, lambda v: lo_open < v <= hi)


def nonneg_upto(hi: float) -> Callable[[str], float]:
    """A number type for argparse that accepts [0, ``hi``]."""
    return _number(f"a number in [0, {hi:g}]", float, lambda v: 0 <= v <= hi)


MAX_TRIALS = 100_000  # a campaign's trials: about a month of the twin's time at 30 s each
MAX_WORKERS = 1024
MAX_HOURS = 1000.0  # [h] of driving a campaign may ask for
MAX_SECONDS = 1e7  # [s] about 116 days: the longest run, limit or timeout anything takes


def _int(text: str) -> float:
    """An integer as written (``12``, ``0x10``), or a number that is one (``1e3``, ``10.0``)."""
    try:
        return float(int(text, 0))
    except ValueError:
        value = float(text)
        return value if value.is_integer() else math.nan


def positive_int(text: str) -> int:
    return int(_number("an integer > 0", _int, lambda v: v > 0)(text))


def nonneg_int(text: str) -> int:
    return int(_number("an integer >= 0", _int, lambda v: v >= 0)(text))


def int_in(lo: int, hi: int) -> Callable[[str], int]:
    """An integer type for argparse that accepts ``lo``..``hi``."""
    check = _number(f"an integer in {lo}..{hi}", _int, lambda v: lo <= v <= hi)
    return lambda text: int(check(text))


def pose_text(text: str) -> str:
    """A pose option's type (``--goal``, ``--start``, ``--waypoint``): ``x,y`` or ``x,y,yaw``
    of finite numbers [m, m, rad], refused where it is parsed so that the line names the option.
    The text itself is returned: where the pose must lie is checked where it is used.

    Raises
    ------
    argparse.ArgumentTypeError
        Not two or three finite numbers separated by commas.
    """
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(
            f"expected x,y or x,y,yaw in metres and radians (e.g. -0.5,1.2,0), got {text!r}"
        )
    return text


def host_port(text: str) -> tuple[str, int]:
    """``[HOST:]PORT`` as (host, port) for a server to bind (``--live-view``); without a host,
    127.0.0.1: this machine only, a network is opened on purpose (``0.0.0.0:8765``). Port 0:
    any free one (the server says which).

    Raises
    ------
    argparse.ArgumentTypeError
        Not a port in 0-65535 after an optional host.
    """
    host, sep, port = text.rpartition(":")
    host = host.strip("[]") if sep else "127.0.0.1"
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not 0 <= number <= 65535 or (sep and not host):
        raise argparse.ArgumentTypeError(
            f"expected [HOST:]PORT with a port in 0-65535 (e.g. 8765 or 0.0.0.0:8765), got {text!r}"
        )
    return host, number


def output_folder(path: Path, option: str = "--out") -> Path:
    """``path`` as a place to write a new folder: refused if it is a file, lies under a file,
    or is a folder that already holds files (a run or report is never written over another).

    Raises
    ------
    ValueError
        One line naming the option and the path.
    """
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option} {path}: is a file, give a folder that does not exist yet")
    if path.is_dir() and any(path.iterdir()):
        raise ValueError(f"{option} {path}: folder is not empty, give a new one")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ValueError(f"{option} {path}: {parent} is a file, not a folder")
            break
    return path


def one_line(exc: BaseException) -> str:
    """An exception as one line (messages of libraries sometimes span several)."""
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def os_error_line(exc: OSError) -> str:
    """``path: reason`` of an OSError, as one line."""
    where = f"{exc.filename}: " if exc.filename else ""
    return where + (exc.strerror or one_line(exc))
