"""The robot's ROS names: topics and frames (Appendix C, REP 105), one source for the live
bridge (:mod:`jackson.host.ros.bridge`, whose parameters default to these) and the run's bag
(:mod:`jackson.host.ros.bag`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TopicNames:
    """The topics a bag holds (the bridge's names by default, Appendix C)."""

    wheel_odom: str = "/wheel/odom"
    imu: str = "/imu/data"
    filtered: str = "/odometry/filtered"
    joint_states: str = "/joint_states"
    diagnostics: str = "/diagnostics"
    tf: str = "/tf"
    tf_static: str = "/tf_static"
    telemetry: str = "/jackson/telemetry"


@dataclass(frozen=True)
class FrameIds:
    """Frame and joint names (REP 105; Appendix C's tree odom -> base_footprint -> base_link)."""

    odom: str = "odom"
    base_footprint: str = "base_footprint"
    base_link: str = "base_link"
    imu_link: str = "imu_link"
    laser: str = "laser"
    left_wheel_joint: str = "left_wheel_joint"
    right_wheel_joint: str = "right_wheel_joint"


TOPICS = TopicNames()
FRAMES = FrameIds()
