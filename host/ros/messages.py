"""The ROS 2 messages of a run, built once for the live topics and for the run's bag.

One :class:`MessageBuilder` turns what the daemon's core computed into ROS 2 Jazzy messages
(the typed dataclasses of ``rosbags``, which need no ROS installation) and one
:class:`RosOutput` hands each message to every sink: the run's rosbag2
(:class:`~jackson.host.ros.bag.BagRecorder`) and, with ``--ros``, the live node
(:class:`~jackson.host.ros.bridge.RosBridge`, which publishes the message's CDR bytes). The bag
therefore holds what was published, message for message, with the same stamps, frames and
covariances, and the node's parameters (:class:`RosSettings`: topic and frame names, mounting
offsets, covariances) apply to both.

Stamps come from a :class:`StampClock`: MCU time itself (``use_sim_time``: the twin publishes
/clock on MCU time), or MCU time mapped onto the host's system clock (the robot: what a
wall-clock-stamped driver such as sllidar_ros2 stamps its scans with). docs/ros2.md, "Time".

This module gathers their names in one place; each piece is a module of its own beside it:

- :mod:`~jackson.host.ros.settings`: :class:`RosSettings` and every topic (:data:`TOPIC_TYPES`);
- :mod:`~jackson.host.ros.stamp_clock`: :class:`StampClock`, MCU time to ROS time;
- :mod:`~jackson.host.lidar.scan_timer`: :class:`ScanTimer`, when each LiDAR revolution was
  measured;
- :mod:`~jackson.host.ros.diagnostics`: what /diagnostics says (:class:`DiagnosticValues`,
  :class:`NavigationValues`, the statuses);
- :mod:`~jackson.host.ros.builder`: :class:`MessageBuilder`, each message from plain values;
- :mod:`~jackson.host.ros.output`: :class:`RosOutput`, the core's listener feeding the sinks.
"""

from jackson.host.lidar.scan_timer import SCAN_PERIOD_S, ScanTimer
from jackson.host.ros.builder import (
    SCAN_RANGE_M,
    MessageBuilder,
    planar_covariance,
    planar_pose,
    yaw_quaternion,
)
from jackson.host.ros.diagnostics import (
    HEALTH_LEVELS,
    LEVEL_ERROR,
    LEVEL_OK,
    LEVEL_WARN,
    DiagnosticValues,
    NavigationValues,
    navigation_status,
)
from jackson.host.ros.output import (
    DIAGNOSTICS_PERIOD_S,
    MAP_PERIOD_S,
    RosOutput,
    RosSink,
    navigation_of,
    wire_bytes,
)
from jackson.host.ros.settings import TOPIC_TYPES, RosSettings
from jackson.host.ros.stamp_clock import CLOCK_SLEW, CLOCK_WINDOW_S, NS_PER_S, StampClock

__all__ = [
    "CLOCK_SLEW",
    "CLOCK_WINDOW_S",
    "DIAGNOSTICS_PERIOD_S",
    "HEALTH_LEVELS",
    "LEVEL_ERROR",
    "LEVEL_OK",
    "LEVEL_WARN",
    "MAP_PERIOD_S",
    "NS_PER_S",
    "SCAN_PERIOD_S",
    "SCAN_RANGE_M",
    "TOPIC_TYPES",
    "DiagnosticValues",
    "MessageBuilder",
    "NavigationValues",
    "RosOutput",
    "RosSettings",
    "RosSink",
    "ScanTimer",
    "StampClock",
    "navigation_of",
    "navigation_status",
    "planar_covariance",
    "planar_pose",
    "wire_bytes",
    "yaw_quaternion",
]
