"""Stage 2: the figure-eight at constant speed, switching loops by integrated heading.

v = 0.08 m/s throughout; w = +0.16 rad/s (a counter-clockwise loop of radius 0.5 m) until the
heading turned since the start reaches 2 pi, then w = -0.16 rad/s (clockwise) until it is back to
0, then stop. Heading is the EKF yaw unwrapped step by step, so no stop is needed between loops.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from jackson.host.control.base import NavState, wrap_angle


@dataclass(frozen=True)
class FigureEightConfig:
    v_m_s: float = 0.08
    w_rad_s: float = 0.16


class FigureEight:
    """Open-loop velocity profile of the paper's Stage 2."""

    name = "figure8"

    def __init__(self, config: FigureEightConfig | None = None) -> None:
        self.cfg = config or FigureEightConfig()
        self.done = False
        self.turned_rad = 0.0  # heading integrated since the start
        self.loop = 1  # 1: counter-clockwise, 2: clockwise
        self._last_yaw: float | None = None

    def command(self, s: NavState) -> tuple[float, float]:
        if self.done:
            return 0.0, 0.0
        if self._last_yaw is not None:
            self.turned_rad += wrap_angle(s.yaw_rad - self._last_yaw)
        self._last_yaw = s.yaw_rad
        if self.loop == 1 and self.turned_rad >= 2.0 * math.pi:
            self.loop = 2
        if self.loop == 2 and self.turned_rad <= 0.0:
            self.done = True
            return 0.0, 0.0
        w = self.cfg.w_rad_s if self.loop == 1 else -self.cfg.w_rad_s
        return self.cfg.v_m_s, w
