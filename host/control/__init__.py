"""Command sources of the daemon: the paper's Stage 1 square and Stage 2 figure-eight."""

from __future__ import annotations

from jackson.host.control.base import Mission, NavState, wrap_angle
from jackson.host.control.figure8 import FigureEight, FigureEightConfig
from jackson.host.control.square import SquareConfig, SquareMission

MISSIONS = {"square": SquareMission, "figure8": FigureEight}


def make_mission(name: str, square: SquareConfig, figure8: FigureEightConfig) -> Mission:
    """The mission ``name`` (a key of MISSIONS) with its section of the host configuration
    (``HostConfig.square`` or ``HostConfig.figure8``)."""
    if name == "square":
        return SquareMission(square)
    if name == "figure8":
        return FigureEight(figure8)
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
