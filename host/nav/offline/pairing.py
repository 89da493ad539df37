"""Pairing each LiDAR revolution of a bag with the odometry pose at its time (the package
docstring: which instant of a revolution, and why)."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from jackson.host.nav.types import Pose2D, Scan

POSE_FRACTION = 1.0  # where in a revolution its pose is taken: 0 first return, 1 last
STAMP_SLACK_S = 1e-6  # [s] a pose time this far past the odometry's ends is at them (ns stamps)
NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class OdomSample:
    """One odometry pose at ``t_s`` (the bag's clock [s])."""

    t_s: float
    pose: Pose2D


def stamp_s(header: Any) -> float:
    """A ROS header's stamp [s]."""
    return float(header.stamp.sec) + float(header.stamp.nanosec) / NS_PER_S


def laser_scan(msg: Any, pose_fraction: float = POSE_FRACTION) -> tuple[float, Scan]:
    """A sensor_msgs/LaserScan as a :class:`Scan` and the time its pose is taken at.

    Parameters
    ----------
    msg : LaserScan
        One revolution: stamped with its first measurement, ``scan_time`` long, its angles
        ``angle_min + i * angle_increment``.
    pose_fraction : float
        Where in the revolution the pose is taken: 0 its first, 1 its last measurement.

    Returns
    -------
    tuple of (float, Scan)
        The pose time [s] and the scan (stamped with its last measurement, as the host's).
    """
    start = stamp_s(msg.header)
    period = float(msg.scan_time)
    ranges = np.asarray(msg.ranges, dtype=np.float64)
    steps = np.arange(len(ranges), dtype=np.float64)
    angles = np.asarray(float(msg.angle_min) + float(msg.angle_increment) * steps, np.float64)
    scan = Scan(start + period, angles, ranges, float(msg.range_min), float(msg.range_max))
    return start + pose_fraction * period, scan


def interpolate(a: OdomSample, b: OdomSample, t_s: float) -> Pose2D:
    """The pose at ``t_s`` between two samples: position linearly, yaw along the shorter arc."""
    span = b.t_s - a.t_s
    f = 0.0 if span <= 0.0 else (t_s - a.t_s) / span
    turn = math.remainder(b.pose.yaw - a.pose.yaw, math.tau)
    return Pose2D(
        a.pose.x + f * (b.pose.x - a.pose.x),
        a.pose.y + f * (b.pose.y - a.pose.y),
        math.remainder(a.pose.yaw + f * turn, math.tau),
    )


class OdometryTrack:
    """The odometry since the oldest revolution still waiting, for interpolating at its time."""

    def __init__(self) -> None:
        self._samples: deque[OdomSample] = deque()

    def add(self, sample: OdomSample) -> None:
        """Append a sample (a stamp not after the last one's is dropped: time only advances)."""
        if self._samples and sample.t_s <= self._samples[-1].t_s:
            return
        self._samples.append(sample)

    @property
    def first_s(self) -> float:
        """The first sample kept [s] (inf when empty)."""
        return self._samples[0].t_s if self._samples else math.inf

    @property
    def last_s(self) -> float:
        """The last sample [s] (-inf when empty)."""
        return self._samples[-1].t_s if self._samples else -math.inf

    def trim(self, before_s: float) -> None:
        """Drop the samples no time at or after ``before_s`` needs (the one just before it
        stays, for interpolating)."""
        s = self._samples
        while len(s) >= 2 and s[1].t_s <= before_s:
            s.popleft()

    def pose_at(self, t_s: float) -> Pose2D | None:
        """The interpolated pose at ``t_s``; None outside the samples' span. Samples before
        the pair around ``t_s`` are dropped (callers ask in time order)."""
        s = self._samples
        if not s or t_s < s[0].t_s - STAMP_SLACK_S or t_s > s[-1].t_s + STAMP_SLACK_S:
            return None
        t_s = min(max(t_s, s[0].t_s), s[-1].t_s)
        self.trim(t_s)
        return s[0].pose if len(s) == 1 else interpolate(s[0], s[1], t_s)
