"""Planar geometry every layer uses."""

from __future__ import annotations

import math


def wrap_angle(angle_rad: float) -> float:
    """The angle in [-pi, pi) [rad] (for arrays: ``jackson.calibration.metrics.wrap_angle``)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi
