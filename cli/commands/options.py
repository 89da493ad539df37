"""The arguments ``jackson run`` and ``jackson campaign`` share: the mission, the map, the
twin's robot and world, the RPLIDAR scan mode, the seed, the host YAML and the output folder."""

from __future__ import annotations

import argparse
from pathlib import Path

from jackson.common.args import nonneg_int


def lidar_mode_arg(text: str) -> str:
    """A scan mode the twin's A1M8 has (any case), ``densest`` or ``standard``."""
    from jackson.sim.rplidar import A1M8_SCAN_MODES

    names = ["densest", "standard", *(m.name.lower() for m in A1M8_SCAN_MODES[1:])]
    if text.lower() not in names:
        raise argparse.ArgumentTypeError(
            f"{text!r} is no scan mode of the twin's RPLIDAR (one of: {', '.join(names)})"
        )
    return text.lower()


def add_mission(p: argparse.ArgumentParser, missions: list[str]) -> None:
    """The mission to drive (one of ``missions``) and ``--map``."""
    p.add_argument("mission", choices=missions)
    p.add_argument(
        "--map",
        type=Path,
        help="maze (and the fault campaign's maze cases): a map (map_server YAML) instead "
        "of mapping first",
    )


def add_twin_options(p: argparse.ArgumentParser) -> None:
    """``--robot``, ``--world``, ``--lidar-mode``, ``--seed``, ``--config`` and ``--out``."""
    p.add_argument(
        "--robot",
        help="twin robot file (default jackson_physical; campaign worlds: a comma list, "
        "default both shipped robots in turn)",
    )
    p.add_argument(
        "--world",
        help="world (default: square_room / open_floor / maze; campaign worlds: a comma "
        "list, default all six of its worlds)",
    )
    p.add_argument(
        "--lidar-mode",
        type=lidar_mode_arg,
        default="densest",
        metavar="MODE",
        help="maze, ofat, robustness: the twin's RPLIDAR scan mode the host reads: densest "
        "(the default, as the daemon: Sensitivity), standard, express, boost, stability, "
        "sensitivity",
    )
    p.add_argument("--seed", type=nonneg_int, default=0, help="noise seed (deterministic)")
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="host YAML the robot runs with, e.g. one jackson calibrate --write made "
        "(default: the paper's robot; campaign fidelity: host/config/jackson_bringup.yaml)",
    )
    p.add_argument(
        "--out", type=Path, help="output folder (campaign fidelity: default build/fidelity)"
    )
