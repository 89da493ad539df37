"""Command sources of the daemon: the paper's Stage 1 square and Stage 2 figure-eight."""

from jackson.host.control.base import Mission, NavState, wrap_angle
from jackson.host.control.figure8 import FigureEight
from jackson.host.control.square import SquareMission

MISSIONS = {"square": SquareMission, "figure8": FigureEight}

__all__ = ["MISSIONS", "FigureEight", "Mission", "NavState", "SquareMission", "wrap_angle"]
