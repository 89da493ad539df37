"""Stage 1: the 1 m square, driven by waypoints on the EKF estimate.

From the start pose the robot visits (1, 0), (1, 1), (0, 1), (0, 0) in its start frame
(counter-clockwise, 4 m of path). At each corner it turns in place to the next side's heading
with closed-loop heading alignment, then drives the side with a deceleration bound
(v <= sqrt(2 a_dec d) for the distance d left) and a proportional heading correction towards
the line. After the last side it aligns with the start heading and reports done.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from jackson.host.control.base import NavState, wrap_angle


@dataclass(frozen=True)
class SquareConfig:
    side_m: float = 1.0
    v_max_m_s: float = 0.15
    v_min_m_s: float = 0.02  # keeps creeping to the corner instead of stalling in the deadband
    a_dec_m_s2: float = 0.15
    w_max_rad_s: float = 0.6
    alpha_dec_rad_s2: float = 0.8
    w_min_rad_s: float = 0.08
    k_heading: float = 2.0  # [1/s] rotation rate per rad of heading error
    k_cross: float = 3.0  # [rad/m] heading correction per m of cross-track error
    corner_tolerance_m: float = 0.003
    heading_tolerance_rad: float = 0.005
    settle_rad_s: float = 0.03


class SquareMission:
    """Waypoint controller of the paper's Stage 1."""

    name = "square"

    def __init__(self, config: SquareConfig | None = None) -> None:
        self.cfg = config or SquareConfig()
        self.done = False
        self._start: tuple[float, float, float] | None = None
        self._waypoints: list[tuple[float, float]] = []
        self._leg = 0
        self._phase = "align"  # align -> drive -> align ... -> final -> done

    def _setup(self, s: NavState) -> None:
        c, si = math.cos(s.yaw_rad), math.sin(s.yaw_rad)
        side = self.cfg.side_m
        self._start = (s.x_m, s.y_m, s.yaw_rad)
        self._waypoints = [
            (s.x_m + c * px - si * py, s.y_m + si * px + c * py)
            for px, py in ((side, 0.0), (side, side), (0.0, side), (0.0, 0.0))
        ]

    def _leg_line(self) -> tuple[float, float, float, float]:
        assert self._start is not None
        x0, y0 = (
            (self._start[0], self._start[1]) if self._leg == 0 else self._waypoints[self._leg - 1]
        )
        x1, y1 = self._waypoints[self._leg]
        return x0, y0, x1, y1

    def _turn(self, err: float, w_now: float) -> tuple[float, bool]:
        cfg = self.cfg
        w = max(-cfg.w_max_rad_s, min(cfg.w_max_rad_s, cfg.k_heading * err))
        w_bound = math.sqrt(2.0 * cfg.alpha_dec_rad_s2 * abs(err))  # stop at the heading
        w = math.copysign(min(abs(w), w_bound), w)
        if abs(err) > cfg.heading_tolerance_rad:
            w = math.copysign(max(abs(w), cfg.w_min_rad_s), err)
            return w, False
        return 0.0, abs(w_now) < cfg.settle_rad_s

    def command(self, s: NavState) -> tuple[float, float]:
        if self.done:
            return 0.0, 0.0
        if self._start is None:
            self._setup(s)
        cfg = self.cfg
        if self._phase == "final":
            assert self._start is not None
            w, aligned = self._turn(wrap_angle(self._start[2] - s.yaw_rad), s.w_rad_s)
            if aligned:
                self.done = True
            return 0.0, w
        x0, y0, x1, y1 = self._leg_line()
        heading = math.atan2(y1 - y0, x1 - x0)
        if self._phase == "align":
            w, aligned = self._turn(wrap_angle(heading - s.yaw_rad), s.w_rad_s)
            if aligned:
                self._phase = "drive"
            return 0.0, w
        # drive along the leg
        ux, uy = math.cos(heading), math.sin(heading)
        remaining = (x1 - s.x_m) * ux + (y1 - s.y_m) * uy
        cross = -(s.x_m - x0) * uy + (s.y_m - y0) * ux  # left of the line is positive
        if remaining <= cfg.corner_tolerance_m:
            self._leg += 1
            if self._leg == len(self._waypoints):
                self._phase = "final"
            else:
                self._phase = "align"
            return 0.0, 0.0
        v = min(cfg.v_max_m_s, math.sqrt(2.0 * cfg.a_dec_m_s2 * remaining))
        v = max(v, cfg.v_min_m_s)
        target = heading - max(-0.5, min(0.5, cfg.k_cross * cross))
        err = wrap_angle(target - s.yaw_rad)
        w = max(-cfg.w_max_rad_s, min(cfg.w_max_rad_s, cfg.k_heading * err))
        return v, w
