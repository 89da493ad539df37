"""Command sources of the daemon: the paper's Stage 1 square and Stage 2 figure-eight."""

from __future__ import annotations

from typing import TYPE_CHECKING

from jackson.host.control.base import Mission, NavState, wrap_angle
from jackson.host.control.figure8 import FigureEight, FigureEightConfig
from jackson.host.control.square import SquareConfig, SquareMission

if TYPE_CHECKING:
    from jackson.host.config import HostConfig

MISSIONS = {"square": SquareMission, "figure8": FigureEight}


def make_mission(name: str, cfg: HostConfig) -> Mission:
    """The mission ``name`` (a key of MISSIONS) with its section of the host configuration."""
    if name == "square":
        return SquareMission(cfg.square)
    if name == "figure8":
        return FigureEight(cfg.figure8)
    raise KeyError(name)


__all__ = [
    "MISSIONS",
    "FigureEight",
    "FigureEightConfig",
    "Mission",
    "NavState",
    "SquareConfig",
    "SquareMission",
    "make_mission",
    "wrap_angle",
]
