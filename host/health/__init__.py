"""Sensor health: one check per module, their findings moving a state per sensor, and the
degraded-mode policy that tells the EKF what it may use.

The EKF fuses the wheels' forward speed and the gyro's yaw rate (Table 2); neither alone can
tell when it is wrong. :class:`HealthMonitor` watches them against each other and against the
command, per telemetry frame and on MCU time, and says which measurements the EKF may use.
Every check has one interface (:class:`~jackson.host.health.check.Check`: observe an input,
return :class:`Finding` s), as DWB's critics score a trajectory and diagnostic_updater's tasks
fill a status; the monitor runs them in order and applies their findings:

================  =============================================================================
module            what it holds
================  =============================================================================
``check``         the :class:`~jackson.host.health.check.Check` interface
``config``        :class:`HealthConfig` (the ``health:`` section), ``POLICIES``
``types``         :class:`Health`, :class:`HealthInput`, :class:`FrameFacts`, :class:`Finding`,
                  :class:`Verdict`, :class:`Transition` and the LiDAR's and link's inputs
``imu_silence``   no ``IMU_OK`` for ``imu_silence_s``: a dead IMU
``imu_stuck``     raw registers frozen for ``stuck_s``: a stuck IMU
``still_bias``    a gyro that does not read zero standing still: a bias to measure again
``encoder_stuck`` a wheel with no count while the other and the gyro say it turns
``yaw_check``     the wheels' yaw rate against the gyro's: per-sample gate, spikes, the window
``wheel_yaw``     the wheel yaw model w_e = s w_g + c v and its prior
``wheels``        the wheels' yaw rate, speed and quantisation as the checks read them
``isolation``     who a disagreement is charged to: witnesses, speed gap, ambiguity
``link``          frames lost on the serial line
``lidar_noise``   a revolution's range noise
``lidar_silence`` revolutions missing, silence, and the hold of a navigating robot
``lidar_garbage`` malformed bytes and revolutions that are not a turn
``lidar``         the LiDAR's checks together, run by the LiDAR's intake
``standstill``    commanded still without a count: zero-velocity updates
``states``        a state per sensor with its hysteresis, the transitions record
``policy``        the :class:`Verdict`: what the EKF may use, when to stop
``monitor``       :class:`HealthMonitor`: the checks of a frame in order, their findings applied
================  =============================================================================

docs/health.md has the details and the figures.
"""

from __future__ import annotations

from jackson.host.health.config import POLICIES, HealthConfig
from jackson.host.health.monitor import HealthMonitor
from jackson.host.health.types import (
    SENSORS,
    Finding,
    FrameFacts,
    Health,
    HealthInput,
    Transition,
    Verdict,
)
from jackson.host.health.wheel_yaw import WheelYawModel, WheelYawPrior, wheel_yaw_prior

__all__ = [
    "POLICIES",
    "SENSORS",
    "Finding",
    "FrameFacts",
    "Health",
    "HealthConfig",
    "HealthInput",
    "HealthMonitor",
    "Transition",
    "Verdict",
    "WheelYawModel",
    "WheelYawPrior",
    "wheel_yaw_prior",
]
