"""What the commands check before anything runs, and the error a user can cause.

The twin's robot and world files, output folders, map files, host YAML files and routes are
read and checked first, so a wrong name ends as one line (:class:`CliError`, exit status 2)
before a process starts or a file is written.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from jackson.common.args import one_line, output_folder
from jackson.common.errors import JacksonError
from jackson.common.fields import ConfigError

DEFAULT_ROBOT = "jackson_physical"  # the twin robot of run and campaign
STAGE3 = ("maze", "ofat", "robustness")


class CliError(JacksonError):
    """A user-facing error: printed as one line, exit status 2."""


def check_twin_files(robot: str, world: str) -> None:
    """Read the robot and world files before anything is written or started."""
    from jackson.sim.config import load_robot, load_world
    from jackson.sim.twin import Twin

    Twin(load_world(world), load_robot(robot), lidar=False)  # refuses a blocked start pose


def out_folder(path: Path, option: str = "--out") -> Path:
    """An output folder the user named (or the default), refused early if it cannot be one."""
    try:
        return output_folder(path, option)
    except ValueError as exc:
        raise CliError(str(exc)) from exc


def map_file(path: Path | None) -> Path | None:
    """A map_server YAML the user named, checked before anything runs."""
    if path is None:
        return None
    from jackson.host.nav.grid import MapFileError, OccupancyGrid

    try:
        OccupancyGrid.load(path)
    except MapFileError as exc:
        raise CliError(f"--map: {exc}") from exc
    return path


def host_config(path: Path | None) -> Path | None:
    """A host YAML the user named (``--config``), read and checked before anything runs."""
    if path is None:
        return None
    from jackson.host.config import load_config

    try:
        load_config(path)
    except ConfigError as exc:
        raise CliError(f"--config: {one_line(exc)}") from exc
    return path.resolve()  # the campaign's worker processes read it too


def refuse_bad_route(check: Callable[[], None], against: str) -> None:
    """Run a route check; its RouteError becomes one line naming what it was checked against."""
    from jackson.host.control.navigator import RouteError

    try:
        check()
    except RouteError as exc:
        raise CliError(f"{exc} ({against})") from exc


def lidar_mode(args: argparse.Namespace) -> str | None:
    """The RPLIDAR scan mode ``--lidar-mode`` names (None: the densest)."""
    from jackson.host.lidar.rplidar import start_mode

    return start_mode(args.lidar_mode)
