"""QoS profiles of the ROS 2 interface (Appendix C).

| topic                             | reliability | durability      | depth |
|-----------------------------------|-------------|-----------------|-------|
| /scan, /imu/data                  | best effort | volatile        | 5     |
| /wheel/odom, /odometry/filtered   | reliable    | volatile        | 10    |
| /cmd_vel                          | reliable    | volatile        | 1     |
| /tf                               | reliable    | volatile        | 100   |
| /tf_static, map                   | reliable    | transient local | 1     |

All keep the last ``depth`` samples. A subscriber must ask for no more than the publisher
offers: a reliable subscription does not match the best-effort /imu/data, and a transient-local
one does not match a volatile publisher. rclpy is imported when a profile is built, never at
module import, so this module costs nothing without ``--ros``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile

SENSOR_DEPTH = 5  # /scan, /imu/data
ODOMETRY_DEPTH = 10  # /wheel/odom, /odometry/filtered
CMD_VEL_DEPTH = 1  # only the newest command counts (the watchdog brakes after 0.6 s)
TF_DEPTH = 100
LATCHED_DEPTH = 1  # /tf_static, map


def _profile(depth: int, *, reliable: bool, transient_local: bool = False) -> QoSProfile:
    from rclpy import qos

    profile: Any = qos.QoSProfile  # untyped in some rclpy releases
    DurabilityPolicy, HistoryPolicy, ReliabilityPolicy = (  # noqa: N806 - enum classes
        qos.DurabilityPolicy,
        qos.HistoryPolicy,
        qos.ReliabilityPolicy,
    )
    result: QoSProfile = profile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=(
            DurabilityPolicy.TRANSIENT_LOCAL if transient_local else DurabilityPolicy.VOLATILE
        ),
    )
    return result


def sensor_qos() -> QoSProfile:
    """/scan and /imu/data: best effort, volatile, depth 5."""
    return _profile(SENSOR_DEPTH, reliable=False)


def odometry_qos() -> QoSProfile:
    """/wheel/odom and /odometry/filtered: reliable, volatile, depth 10."""
    return _profile(ODOMETRY_DEPTH, reliable=True)


def cmd_vel_qos() -> QoSProfile:
    """/cmd_vel: reliable, volatile, depth 1."""
    return _profile(CMD_VEL_DEPTH, reliable=True)


def tf_qos() -> QoSProfile:
    """/tf: reliable, volatile, depth 100."""
    return _profile(TF_DEPTH, reliable=True)


def tf_static_qos() -> QoSProfile:
    """/tf_static and map: reliable, transient local, depth 1 (late joiners get the last one)."""
    return _profile(LATCHED_DEPTH, reliable=True, transient_local=True)


def map_qos() -> QoSProfile:
    """map: reliable, transient local, depth 1."""
    return _profile(LATCHED_DEPTH, reliable=True, transient_local=True)


def joint_states_qos() -> QoSProfile:
    """/joint_states (not in Appendix C): reliable, volatile, depth 10, like robot_state_publisher
    expects."""
    return _profile(ODOMETRY_DEPTH, reliable=True)


def diagnostics_qos() -> QoSProfile:
    """/diagnostics (not in Appendix C): reliable, volatile, depth 10 (diagnostic_updater's)."""
    return _profile(ODOMETRY_DEPTH, reliable=True)
