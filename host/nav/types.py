"""The types Stage 3 shares: a planar pose and one LiDAR scan."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import angle_of

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Pose2D:
    """A planar pose.

    Attributes
    ----------
    x, y : float
        Position [m].
    yaw : float
        Heading [rad], counter-clockwise from +x (REP 103).
    """

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def compose(self, other: Pose2D) -> Pose2D:
        """``self ⊕ other``: ``other`` (given in this pose's frame) in the parent frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            angle_of(self.yaw + other.yaw),
        )

    def inverse(self) -> Pose2D:
        """The pose whose composition with this one is the identity."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(-c * self.x - s * self.y, s * self.x - c * self.y, -self.yaw)

    def distance(self, other: Pose2D) -> float:
        """Euclidean distance of the positions [m]."""
        return math.hypot(other.x - self.x, other.y - self.y)


@dataclass(frozen=True)
class Scan:
    """One LiDAR revolution in the sensor frame (x forward, angles counter-clockwise).

    Attributes
    ----------
    t_s : float
        MCU time of the scan's last measurement [s] (the host maps the sensor's receive time
        onto MCU time).
    angles_rad : ndarray of float
        Angle of each measurement in the sensor frame [rad].
    ranges_m : ndarray of float
        Range of each measurement [m]; ``inf`` where there was no return in range.
    range_min_m, range_max_m : float
        Readings outside [range_min_m, range_max_m] are no returns [m] (the A1M8: 0.15 m to
        12 m; navigation caps it at 8 m itself, AMCL's ``laser_max_range``, as the paper's robot
        did, while the mapper uses the whole range).
    """

    t_s: float
    angles_rad: FloatArray
    ranges_m: FloatArray
    range_min_m: float = 0.15
    range_max_m: float = 12.0

    def __post_init__(self) -> None:
        if self.angles_rad.shape != self.ranges_m.shape or self.angles_rad.ndim != 1:
            raise ValueError(
                f"Scan: angles {self.angles_rad.shape} and ranges {self.ranges_m.shape} "
                "must be 1-D of one length"
            )

    @property
    def valid(self) -> npt.NDArray[np.bool_]:
        """Which measurements are returns inside [range_min_m, range_max_m]."""
        r = self.ranges_m
        return np.isfinite(r) & (r >= self.range_min_m) & (r <= self.range_max_m)

    def points(self, pose: Pose2D, mount: Pose2D = Pose2D()) -> FloatArray:
        """The valid returns as (N, 2) points in the frame ``pose`` is given in.

        Parameters
        ----------
        pose : Pose2D
            The robot's base pose.
        mount : Pose2D
            The sensor's pose on the robot (base frame).
        """
        sensor = pose.compose(mount)
        ok = self.valid
        a = self.angles_rad[ok] + sensor.yaw
        r = self.ranges_m[ok]
        return np.column_stack((sensor.x + r * np.cos(a), sensor.y + r * np.sin(a)))
