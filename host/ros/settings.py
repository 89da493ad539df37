"""The live node's ROS parameters, which the run's bag follows too: every topic a run has
(:data:`TOPIC_TYPES`), and :class:`RosSettings` (topic and frame names, mounting offsets,
covariances)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from jackson.host.ros.names import FRAMES, TOPICS

if TYPE_CHECKING:
    from jackson.host.config import HostConfig

# topic key -> (ROS type, QoS: "reliable" | "sensor" | "latched" | "map", depth)
TOPIC_TYPES: dict[str, tuple[str, str, int]] = {
    "wheel_odom": ("nav_msgs/msg/Odometry", "reliable", 10),
    "imu": ("sensor_msgs/msg/Imu", "sensor", 5),
    "filtered": ("nav_msgs/msg/Odometry", "reliable", 10),
    "joint_states": ("sensor_msgs/msg/JointState", "reliable", 10),
    "diagnostics": ("diagnostic_msgs/msg/DiagnosticArray", "reliable", 10),
    "tf": ("tf2_msgs/msg/TFMessage", "reliable", 100),
    "tf_static": ("tf2_msgs/msg/TFMessage", "latched", 1),
    "scan": ("sensor_msgs/msg/LaserScan", "sensor", 5),
    "map": ("nav_msgs/msg/OccupancyGrid", "map", 1),
    "plan": ("nav_msgs/msg/Path", "reliable", 10),
    "local_plan": ("nav_msgs/msg/Path", "reliable", 10),
    "cmd_vel": ("geometry_msgs/msg/Twist", "reliable", 1),
    "goal_pose": ("geometry_msgs/msg/PoseStamped", "reliable", 1),
    "initialpose": ("geometry_msgs/msg/PoseWithCovarianceStamped", "reliable", 1),
    "telemetry": ("std_msgs/msg/UInt8MultiArray", "reliable", 10),
}
"""Every topic a run has, by its key in :meth:`RosSettings.topic`."""


@dataclass(frozen=True)
class RosSettings:
    """The node's ROS parameters (``--ros-args -p name:=value``), which the bag follows too.

    Attributes
    ----------
    wheel_odom_topic, imu_topic, filtered_topic, joint_states_topic, diagnostics_topic : str
        Topic names (Appendix C).
    cmd_vel_topic : str
        The velocity command's topic (in).
    cmd_vel_stamped : bool
        /cmd_vel is ``geometry_msgs/TwistStamped`` (Nav2's ``enable_stamped_cmd_vel``)
        instead of ``Twist``.
    odom_frame, base_frame, base_link_frame, imu_frame, laser_frame : str
        Frame ids (REP 105).
    left_wheel_joint, right_wheel_joint : str
        Joint names on /joint_states (the URDF's).
    left_wheel_frame, right_wheel_frame : str
        The wheels' links (the URDF's), turning about their axle (+y) by the wheel's angle.
    wheel_separation_m : float
        Track width [m]: the wheels sit at y = ±B/2 of base_link.
    publish_tf : bool
        Publish (and record) /tf and /tf_static.
    publish_wheel_tf : bool
        Put base_link -> wheel links on /tf at every frame (false where robot_state_publisher
        turns /joint_states into them).
    publish_static_tf : bool
        Publish base_footprint -> base_link -> {imu_link, laser} on /tf_static (false where
        robot_state_publisher publishes the URDF's fixed joints: one publisher per transform).
        The run's bag records them either way.
    tf_source : str
        ``filtered`` (odom -> base_footprint from the EKF at 30 Hz) or ``wheel`` (every frame).
    base_link_offset_m, imu_offset_m, laser_offset_m : tuple of float
        Mounting translations [m] base_footprint -> base_link (the wheel radius: the axle
        height), base_link -> imu_link, base_link -> laser.
    imu_angular_velocity_covariance, imu_linear_acceleration_covariance : float
        Diagonals of the /imu/data covariances (Table 2's R_wz and R_a: what the paper's
        robot_localization fused them with).
    """

    wheel_odom_topic: str = TOPICS.wheel_odom
    imu_topic: str = TOPICS.imu
    filtered_topic: str = TOPICS.filtered
    joint_states_topic: str = TOPICS.joint_states
    diagnostics_topic: str = TOPICS.diagnostics
    cmd_vel_topic: str = "/cmd_vel"
    cmd_vel_stamped: bool = False
    odom_frame: str = FRAMES.odom
    base_frame: str = FRAMES.base_footprint
    base_link_frame: str = FRAMES.base_link
    imu_frame: str = FRAMES.imu_link
    laser_frame: str = FRAMES.laser
    left_wheel_joint: str = FRAMES.left_wheel_joint
    right_wheel_joint: str = FRAMES.right_wheel_joint
    left_wheel_frame: str = "left_wheel_link"
    right_wheel_frame: str = "right_wheel_link"
    wheel_separation_m: float = 0.198
    publish_tf: bool = True
    publish_wheel_tf: bool = True
    publish_static_tf: bool = True
    tf_source: str = "filtered"
    base_link_offset_m: tuple[float, ...] = (0.0, 0.0, 0.033)
    imu_offset_m: tuple[float, ...] = (0.0, 0.0, 0.0)
    laser_offset_m: tuple[float, ...] = (0.0, 0.0, 0.0)
    imu_angular_velocity_covariance: float = 0.0004
    imu_linear_acceleration_covariance: float = 0.01

    def __post_init__(self) -> None:
        if self.tf_source not in ("filtered", "wheel"):
            raise ValueError(f"tf_source must be 'filtered' or 'wheel', got {self.tf_source!r}")
        for name in ("base_link_offset_m", "imu_offset_m", "laser_offset_m"):
            if len(getattr(self, name)) != 3:
                raise ValueError(f"{name} must have 3 values (x, y, z in metres)")

    @classmethod
    def for_config(cls, cfg: HostConfig, **overrides: Any) -> RosSettings:
        """The defaults of a robot: the axle height is its wheel radius, the gyro's covariance
        its EKF's R_wz (then ``overrides``)."""
        values: dict[str, Any] = {
            "base_link_offset_m": (0.0, 0.0, cfg.robot.wheel_radius_left_m),
            "wheel_separation_m": cfg.robot.wheel_separation_m,
            "imu_angular_velocity_covariance": cfg.ekf.r_wz,
        }
        values.update(overrides)
        return cls(**values)

    def topic(self, key: str) -> str:
        """The name of the topic with key ``key`` (:data:`TOPIC_TYPES`)."""
        named = {
            "wheel_odom": self.wheel_odom_topic,
            "imu": self.imu_topic,
            "filtered": self.filtered_topic,
            "joint_states": self.joint_states_topic,
            "diagnostics": self.diagnostics_topic,
            "cmd_vel": self.cmd_vel_topic,
        }
        if key in named:
            return named[key]
        return {
            "tf": "/tf",
            "tf_static": "/tf_static",
            "scan": "/scan",
            "map": "/map",
            "plan": "/plan",
            "local_plan": "/local_plan",
            "goal_pose": "/goal_pose",
            "initialpose": "/initialpose",
            "telemetry": TOPICS.telemetry,
        }[key]

    def topic_type(self, key: str) -> str:
        """The ROS type of the topic with key ``key``."""
        if key == "cmd_vel" and self.cmd_vel_stamped:
            return "geometry_msgs/msg/TwistStamped"
        return TOPIC_TYPES[key][0]
