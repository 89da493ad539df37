"""The ``jackson`` command: one entry point for every tool of the stack.

The parser is built from the subcommands' own modules (:mod:`jackson.commands` and the layers'
``cli`` modules); each subcommand imports what it needs when it runs, so ``jackson --help``
stays fast and the host never pulls in the twin. Errors a user can cause end as one line on
stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import os
import sys
import threading
from collections.abc import Sequence
from typing import NoReturn

from jackson import __version__
from jackson.common.args import OneLineParser, one_line
from jackson.common.errors import JacksonError
from jackson.common.threads import EXIT_STATUS, ThreadFailedError


def build_parser() -> argparse.ArgumentParser:
    """The ``jackson`` parser with every subcommand, in the order ``jackson --help`` lists them."""
    from jackson.calibration import cli as calibrate_cli
    from jackson.commands import bench, campaign, decode, fault_matrix, map_world, patrol, run
    from jackson.host import bag_cli
    from jackson.host import brake as brake_cli
    from jackson.host import cli as host_cli
    from jackson.sim import cli as sim_cli

    parser: argparse.ArgumentParser = OneLineParser(
        prog="jackson", description="Firmware-plus-host stack for differential-drive robots."
    )
    parser.add_argument("--version", action="version", version=f"jackson {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    bench.add_parser(sub)
    decode.add_parser(sub)
    run.add_parser(sub)
    campaign.add_parser(sub)
    calibrate_cli.add_parser(sub)
    host_cli.add_parsers(sub)
    bag_cli.add_parser(sub)
    brake_cli.add_parser(sub)
    sim_cli.add_parser(sub)
    sub.choices["sim"].set_defaults(func=sim_cli.run)
    map_world.add_parser(sub)
    fault_matrix.add_parser(sub)
    patrol.add_parser(sub)
    return parser


def _brake_parser() -> argparse.ArgumentParser:
    """``jackson brake`` alone: the command systemd runs after a crash must brake within a
    fraction of a second, not after importing every other command's modules."""
    from jackson.host import brake as brake_cli

    parser: argparse.ArgumentParser = OneLineParser(prog="jackson")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    brake_cli.add_parser(sub)
    return parser


BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")
"""What limits the BLAS libraries' thread pools (numpy's and scipy's OpenBLAS: pthreads, or
OpenMP in a distribution's build)."""


def one_blas_thread() -> None:
    """One BLAS thread for every process of the stack, unless the environment says otherwise.

    Every matrix here is small (the EKF's 7 x 7, DWB's tables), so a second BLAS thread never
    pays; but OpenBLAS's idle workers spin on a core after each call that woke them, and a
    navigating daemon spent about 5 % of its CPU so (numpy's and scipy's pools both), taken
    from the twin, the planner's worker and whatever else runs on a Jetson. Read by the
    libraries when they load, so set before numpy's first import; inherited by the processes
    the command starts.
    """
    for name in BLAS_THREADS:
        os.environ.setdefault(name, "1")


def main(argv: Sequence[str] | None = None, *, exit_fast: bool = False) -> int:
    """Parse the command line, run the subcommand, and turn a user's error into one line.

    Parameters
    ----------
    argv : sequence of str or None
        The arguments after ``jackson`` (None: ``sys.argv[1:]``).
    exit_fast : bool
        End the process (:func:`exit_now`) as soon as a subcommand whose parser sets
        ``exit_fast`` has returned, instead of returning (the installed command's
        :func:`entry`).

    Returns
    -------
    int
        The exit status: the subcommand's own, 2 for an error a user can cause, 130 when
        interrupted.
    """
    one_blas_thread()
    given = list(sys.argv[1:] if argv is None else argv)
    brake = given[:1] == ["brake"] and not {"-h", "--help"} & set(given)
    args = (_brake_parser() if brake else build_parser()).parse_args(given)
    try:
        rc: int = args.func(args)
    except OSError as exc:  # the machine refused: a full disk, a folder where a file goes, ...
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"jackson {args.command}: {where}{exc.strerror or one_line(exc)}", file=sys.stderr)
        return 2
    except ThreadFailedError as exc:  # a thread of the run died: stopped, braked, one line
        print(f"jackson {args.command}: {one_line(exc)}", file=sys.stderr)
        return EXIT_STATUS
    except JacksonError as exc:  # every error of the project's own: one line (common/errors.py)
        print(f"jackson {args.command}: {one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return 0
    if exit_fast and getattr(args, "exit_fast", False):
        exit_now(rc)
    return rc


def exit_now(rc: int) -> None:
    """End the process with status ``rc`` without the interpreter's teardown, when it is safe.

    A command whose every file and process is closed when it returns (``jackson run``: its run
    folder, bag and figure written, its twin and daemon stopped) gains nothing from the
    interpreter's teardown of its modules and objects, which took 0.1-0.2 s of the square's
    command. The exit handlers still run (logging's flush, ``tempfile``'s and
    ``multiprocessing``'s clean-up) and the standard streams are flushed; with any thread
    but this one still alive the process ends the usual way (it would be joined), so nothing
    is cut short.

    Parameters
    ----------
    rc : int
        The exit status.
    """
    if threading.active_count() != 1:
        return
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed or broken pipe: said all
            stream.flush()
    os._exit(rc)


def entry() -> NoReturn:
    """The installed ``jackson`` command: :func:`main`, ending fast where a command allows."""
    sys.exit(main(exit_fast=True))
