"""The base's pose at a frame from the EKF's pose there, which trails the base by a frame.

The EKF (robot_localization's order, :mod:`jackson.host.estimation.ekf`) predicts its pose to
each frame's time with the twist it held before and only then corrects the twist with the
frame's wheel and gyro measurements, which are means over the interval that just ended. Its
pose at a frame is therefore where the base was at the frame before: in a twin survey's bag,
/odometry/filtered's heading changes over 0.5 s agree with the true ones best 50 ms (one
frame at 20 Hz) before its stamps, 0.09 degrees RMS, against 0.56 degrees at the stamps.
Anything that pairs a pose with a measurement's time (the mapper pairing a LiDAR revolution
with the pose at its end) takes :func:`base_pose`: the EKF's pose carried on by its own
corrected twist over that interval (0.125 degrees RMS at the stamps). What the EKF publishes
(/odometry/filtered, the bag, the controller's pose) is left as robot_localization has it.
"""

from __future__ import annotations

import math

from jackson.host.nav.types import Pose2D
from jackson.protocol.messages import TELEMETRY_RATE_HZ_DEFAULT

FRAME_PERIOD_S = 1.0 / TELEMETRY_RATE_HZ_DEFAULT  # [s] the MCU's telemetry interval
MAX_LAG_S = 2.0 * FRAME_PERIOD_S  # [s] the longest interval the twist is carried over


def base_pose(ekf_pose: Pose2D, v_m_s: float, w_rad_s: float, period_s: float) -> Pose2D:
    """The base's pose at the time of the EKF's ``ekf_pose``: carried on along an arc by the
    EKF's twist (forward ``v_m_s`` [m/s], yaw rate ``w_rad_s`` [rad/s]) over the frame interval
    ``period_s`` [s] that ended there (clamped to [0, ``MAX_LAG_S``])."""
    dt = min(max(period_s, 0.0), MAX_LAG_S)
    turn = w_rad_s * dt
    d = v_m_s * dt
    return ekf_pose.compose(Pose2D(d * math.cos(0.5 * turn), d * math.sin(0.5 * turn), turn))
