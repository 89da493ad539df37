"""What the daemon's own work costs: process CPU per robot-second and CPU per telemetry frame.

A host on a Jetson shares its cores with the ROS graph and the planner; the figure that says
whether the daemon fits is its CPU time over the robot's (MCU) time, from the first telemetry
frame to the end of the run, as a share of one core. Against a lockstep twin the daemon polls
the twin's links briefly before it blocks (:mod:`jackson.common.spin`); a robot's port and bus
are never polled, so that CPU is left out, here and per frame. Each frame's handling (LiDAR
bytes, the core, the bag and ROS messages it makes) is timed on the daemon's thread; the times
go into a histogram of fixed size, so the meter's memory stays flat however long the daemon runs.

:class:`CpuMeter` is what ``health.json``'s ``cpu`` entry and the daemon's last line report
(docs/host.md, "CPU"); ``jackson bench``'s ``daemon`` suite reads it from the real process.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from jackson.common.spin import contention

BINS_PER_DECADE = 50  # the histogram's resolution: 4.7 % of a value
LOWEST_US = 1.0  # [us] the first bin's lower edge
DECADES = 7  # [us] up to 10 s a frame


class CpuMeter:
    """Process CPU per robot-second and the distribution of CPU per frame.

    Attributes
    ----------
    frames : int
        Frames timed.
    max_us : float
        The longest frame [us].
    """

    def __init__(self) -> None:
        self._counts = np.zeros(BINS_PER_DECADE * DECADES + 1, dtype=np.int64)
        self.frames = 0
        self.max_us = 0.0
        self._first: tuple[float, float] | None = None  # (MCU time [s], process CPU [s])
        self._last: tuple[float, float] | None = None
        # the CPU time of the daemon's helper processes so far [s] (the planner server's
        # worker): counted with the process's own
        self.helpers: list[Callable[[], float]] = []

    def frame(self, cpu_us: float) -> None:
        """One frame's handling took ``cpu_us`` of the daemon thread's CPU."""
        self.frames += 1
        self.max_us = max(self.max_us, cpu_us)
        k = math.floor(math.log10(max(cpu_us, LOWEST_US) / LOWEST_US) * BINS_PER_DECADE)
        self._counts[min(k, len(self._counts) - 1)] += 1

    def robot_time(self, t_s: float | None) -> None:
        """The MCU time [s] of the frame just handled, with the process's CPU time now."""
        if t_s is None:
            return
        helpers = sum(helper() for helper in self.helpers) if self.helpers else 0.0
        now = (t_s, time.process_time() - contention.spun_s + helpers)
        if self._first is None:
            self._first = now
        self._last = now

    def percentile_us(self, q: float) -> float:
        """The ``q`` quantile (0-1) of CPU per frame [us]: the upper edge of its bin (at most
        :attr:`max_us`); 0 before any frame."""
        if self.frames == 0:
            return 0.0
        k = int(np.searchsorted(np.cumsum(self._counts), q * self.frames, side="left"))
        return min(LOWEST_US * math.pow(10.0, (k + 1) / BINS_PER_DECADE), self.max_us)

    @property
    def robot_s(self) -> float:
        """MCU time between the first and the last frame [s]."""
        if self._first is None or self._last is None:
            return 0.0
        return self._last[0] - self._first[0]

    @property
    def process_s(self) -> float:
        """The process's CPU over that span, every thread and its helper processes (the
        planner server's worker), less what it spent polling a lockstep twin's links [s]."""
        if self._first is None or self._last is None:
            return 0.0
        return self._last[1] - self._first[1]

    @property
    def share_of_core(self) -> float:
        """:attr:`process_s` over :attr:`robot_s` (0 before two frames)."""
        return self.process_s / self.robot_s if self.robot_s > 0 else 0.0

    def report(self, period_s: float) -> dict[str, Any]:
        """``health.json``'s ``cpu`` entry, the telemetry period being ``period_s``."""
        median = self.percentile_us(0.5)
        p99 = self.percentile_us(0.99)
        return {
            "robot_s": self.robot_s,
            "process_s": self.process_s,
            "share_of_core": self.share_of_core,
            "frames": self.frames,
            "frame_us": {"median": median, "p99": p99, "max": self.max_us},
            "frame_share_of_period": {
                "median": median * 1e-6 / period_s,
                "p99": p99 * 1e-6 / period_s,
            },
        }

    def line(self) -> str:
        """The operator's line: CPU as a share of a core, and per frame."""
        return (
            f"daemon: CPU {self.share_of_core * 100:.1f} % of a core over {self.robot_s:.1f} s "
            f"of robot time; per frame median {self.percentile_us(0.5) / 1e3:.2f} ms, p99 "
            f"{self.percentile_us(0.99) / 1e3:.2f} ms"
        )
