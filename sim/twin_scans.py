"""The twin's LiDAR scans: one a scan period, taken at the first physics step at or after its
instant, each beam from the pose at its own instant of the turn (from the pose at the scan
before to the pose now: :meth:`~jackson.sim.lidar.Lidar.scan_moving`), with the twin's faults
applied; the newest kept."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from jackson.sim.faults import FaultInjector
from jackson.sim.lidar import Lidar, Obstacles


@dataclass(frozen=True)
class Scan:
    """One LiDAR scan that ended at ``t_s`` (ranges in metres, inf for no return), and the
    ranges ``ahead``: what the beams of the next turn's beginning read just after it ended
    (:meth:`~jackson.sim.lidar.Lidar.scan_moving`; None: the same as ``ranges``)."""

    t_s: float
    ranges: NDArray[np.float32]
    ahead: NDArray[np.float32] | None = None


class TwinScans:
    """The twin's LiDAR model and the scans it took.

    Parameters
    ----------
    lidar : Lidar or None
        The LiDAR model (None: the twin has none, and takes no scans).
    obstacles : Obstacles
        The world's obstacles (replaced when a trigger changes them).
    history : int or None
        Scans kept (None: all of them, about 115 MB per hour).

    Attributes
    ----------
    kept : deque of Scan
        The newest scans.
    taken : int
        Every scan delivered, kept or not (a lost one is neither).
    lost : deque of float
        When each scan a ``lidar_dropout`` lost was due [s] (the newest).
    lost_count : int
        Scans lost.
    next_s : float
        When the next scan is due [s].
    """

    def __init__(self, lidar: Lidar | None, obstacles: Obstacles, history: int | None) -> None:
        self.lidar = lidar
        self.obstacles = obstacles
        self.period_s = math.inf if lidar is None else lidar.spec.scan_period_s
        self.next_s = 0.0
        self.kept: deque[Scan] = deque(maxlen=history)
        self.taken = 0
        self.lost: deque[float] = deque(maxlen=history)
        self.lost_count = 0
        self._last_pose: tuple[float, float, float] | None = None  # at the scan before

    def take(
        self, t_s: float, x: float, y: float, yaw: float, faults: FaultInjector | None
    ) -> None:
        """The scan of the turn that ends at ``t_s`` with the base at ``(x, y, yaw)``, moved
        there from its pose at the scan before (the first: from where it is); a fault may
        change or lose it."""
        lidar = self.lidar
        assert lidar is not None
        end = (x, y, yaw)
        start, self._last_pose = self._last_pose or end, end
        ranges, moved_ahead = lidar.scan_moving(start, end, self.obstacles)
        ahead: NDArray[np.float32] | None = moved_ahead
        self.next_s += self.period_s
        if faults is not None:
            spec = lidar.spec
            faulty = faults.scan(t_s, ranges, spec.range_min_m, spec.range_max_m)
            if faulty is None:
                self.lost.append(t_s)
                self.lost_count += 1
                return
            if faulty is not ranges:
                ahead = None  # a fault's scan, as the turn's own
            ranges = faulty
        self.kept.append(Scan(t_s, ranges, ahead))
        self.taken += 1
