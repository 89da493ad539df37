"""Builds each ROS 2 message of a run from what the daemon's core computed: the typed
dataclasses of ``rosbags`` (ROS 2 Jazzy's types, which need no ROS installation; made from
:mod:`jackson.host.ros.msgtypes`), stamped by a
:class:`~jackson.host.ros.stamp_clock.StampClock` and named by
:class:`~jackson.host.ros.settings.RosSettings`."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from jackson.host.lidar.scan_timer import SCAN_PERIOD_S
from jackson.host.nav.types import Pose2D
from jackson.host.ros import msgtypes
from jackson.host.ros.diagnostics import DiagnosticValues, diagnostic_statuses
from jackson.host.ros.scan_bins import binned_ranges
from jackson.host.ros.settings import RosSettings
from jackson.host.ros.stamp_clock import NS_PER_S, StampClock
from jackson.protocol import Telemetry
from jackson.protocol.units import accel_m_s2, gyro_rad_s

if TYPE_CHECKING:
    from rosbags.typesys.stores import ros2_jazzy as jazzy  # the same classes, for mypy

    from jackson.host.estimation.ekf import EkfState
    from jackson.host.estimation.odometry import OdometryCovariance, OdometryState
    from jackson.host.nav.types import Scan
else:
    jazzy = msgtypes  # Jazzy's names, made from jackson's definitions (0.1 s less to import)

Header = jazzy.std_msgs__msg__Header
Time = jazzy.builtin_interfaces__msg__Time
Vector3 = jazzy.geometry_msgs__msg__Vector3
Quaternion = jazzy.geometry_msgs__msg__Quaternion
Point = jazzy.geometry_msgs__msg__Point
Pose = jazzy.geometry_msgs__msg__Pose
PoseStamped = jazzy.geometry_msgs__msg__PoseStamped
Transform = jazzy.geometry_msgs__msg__Transform
TransformStamped = jazzy.geometry_msgs__msg__TransformStamped
Twist = jazzy.geometry_msgs__msg__Twist
TwistStamped = jazzy.geometry_msgs__msg__TwistStamped
PoseWithCovariance = jazzy.geometry_msgs__msg__PoseWithCovariance
PoseWithCovarianceStamped = jazzy.geometry_msgs__msg__PoseWithCovarianceStamped
TwistWithCovariance = jazzy.geometry_msgs__msg__TwistWithCovariance
Odometry = jazzy.nav_msgs__msg__Odometry
Path = jazzy.nav_msgs__msg__Path
OccupancyGrid = jazzy.nav_msgs__msg__OccupancyGrid
MapMetaData = jazzy.nav_msgs__msg__MapMetaData
Imu = jazzy.sensor_msgs__msg__Imu
JointState = jazzy.sensor_msgs__msg__JointState
LaserScan = jazzy.sensor_msgs__msg__LaserScan
DiagnosticArray = jazzy.diagnostic_msgs__msg__DiagnosticArray
DiagnosticStatus = jazzy.diagnostic_msgs__msg__DiagnosticStatus
KeyValue = jazzy.diagnostic_msgs__msg__KeyValue
TFMessage = jazzy.tf2_msgs__msg__TFMessage
UInt8MultiArray = jazzy.std_msgs__msg__UInt8MultiArray
MultiArrayLayout = jazzy.std_msgs__msg__MultiArrayLayout
Clock = jazzy.rosgraph_msgs__msg__Clock

SCAN_RANGE_M = (0.15, 12.0)  # [m] the A1M8's range, as rplidar_ros publishes it


def planar_pose(pose: Any) -> Pose2D:
    """A geometry_msgs/Pose (any object with ``position`` and ``orientation``) as a planar
    pose: its x, y and its rotation's yaw."""
    q = pose.orientation
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    return Pose2D(float(pose.position.x), float(pose.position.y), yaw)


def yaw_quaternion(yaw_rad: float) -> Quaternion:
    """A rotation by ``yaw_rad`` about z."""
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw_rad / 2.0), w=math.cos(yaw_rad / 2.0))


def read_only(
    values: np.ndarray[Any, np.dtype[np.float64]],
) -> np.ndarray[Any, np.dtype[np.float64]]:
    """``values``, made read-only: an array that every message of a kind shares (its fixed
    covariance) cannot be changed through one of them."""
    values.flags.writeable = False
    return values


def planar_covariance(*diagonal: float) -> np.ndarray[Any, np.dtype[np.float64]]:
    """A row-major 6x6 covariance with (x, y, z, roll, pitch, yaw) ``diagonal``."""
    cov = np.zeros(36, dtype=np.float64)
    for i, v in enumerate(diagonal):
        cov[7 * i] = float(v)
    return cov


class MessageBuilder:
    """Builds each message of a run (module docstring).

    Parameters
    ----------
    settings : RosSettings
        Names, offsets, covariances.
    odometry : OdometryCovariance
        The /wheel/odom covariances (the config's ``odometry`` section).
    clock : StampClock
        MCU time to ROS time.
    hardware_id : str
        ``hardware_id`` of the /diagnostics statuses.
    """

    def __init__(
        self,
        settings: RosSettings,
        odometry: OdometryCovariance,
        clock: StampClock,
        hardware_id: str = "jackson",
    ) -> None:
        self.settings = settings
        self.clock = clock
        self.hardware_id = hardware_id
        # the fixed covariances, built once and shared by every message (read-only)
        self.odom_pose_cov = read_only(
            planar_covariance(odometry.pose_xy, odometry.pose_xy, 0.0, 0.0, 0.0, odometry.pose_yaw)
        )
        self.odom_twist_cov = read_only(
            planar_covariance(
                odometry.twist_vx, odometry.twist_vy, 0.0, 0.0, 0.0, odometry.twist_wz
            )
        )
        orientation_cov = np.zeros(9, dtype=np.float64)
        orientation_cov[0] = -1.0  # REP 145: no orientation estimate
        self.imu_orientation_cov = read_only(orientation_cov)
        self.imu_angular_velocity_cov = read_only(
            np.eye(3).ravel() * settings.imu_angular_velocity_covariance
        )
        self.imu_linear_acceleration_cov = read_only(
            np.eye(3).ravel() * settings.imu_linear_acceleration_covariance
        )

    def header(self, t_s: float, frame_id: str) -> Header:
        """A header stamped with the ROS time of MCU time ``t_s``."""
        sec, nanosec = divmod(self.clock.ns(t_s), NS_PER_S)
        return Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame_id)

    def odometry(
        self,
        t_s: float,
        x: float,
        y: float,
        yaw: float,
        twist: tuple[float, float, float],
        pose_cov: np.ndarray[Any, np.dtype[np.float64]],
        twist_cov: np.ndarray[Any, np.dtype[np.float64]],
    ) -> Any:
        """An Odometry odom -> base_footprint with (vx, vy, w) and the two covariances (the
        message holds them as given: the builder's fixed ones, read-only, or new ones)."""
        s = self.settings
        return Odometry(
            header=self.header(t_s, s.odom_frame),
            child_frame_id=s.base_frame,
            pose=PoseWithCovariance(
                pose=Pose(
                    position=Point(x=float(x), y=float(y), z=0.0),
                    orientation=yaw_quaternion(float(yaw)),
                ),
                covariance=pose_cov,
            ),
            twist=TwistWithCovariance(
                twist=Twist(
                    linear=Vector3(x=float(twist[0]), y=float(twist[1]), z=0.0),
                    angular=Vector3(x=0.0, y=0.0, z=float(twist[2])),
                ),
                covariance=twist_cov,
            ),
        )

    def wheel_odom(self, t_s: float, odo: OdometryState) -> Any:
        """/wheel/odom: the dead-reckoned pose and (v, 0, w), odom -> base_footprint."""
        return self.odometry(
            t_s,
            odo.x_m,
            odo.y_m,
            odo.yaw_rad,
            (odo.v_m_s, 0.0, odo.w_rad_s),
            self.odom_pose_cov,
            self.odom_twist_cov,
        )

    def filtered(self, t_s: float, state: EkfState) -> Any:
        """/odometry/filtered: the EKF's estimate; covariances from the diagonal of P."""
        d = state.covariance_diagonal  # x, y, yaw, vx, vy, vyaw, ax
        return self.odometry(
            t_s,
            state.x_m,
            state.y_m,
            state.yaw_rad,
            (state.vx_m_s, state.vy_m_s, state.vyaw_rad_s),
            planar_covariance(d[0], d[1], 0.0, 0.0, 0.0, d[2]),
            planar_covariance(d[3], d[4], 0.0, 0.0, 0.0, d[5]),
        )

    def imu(self, t_s: float, telemetry: Telemetry) -> Any:
        """/imu/data in imu_link: a frame's angular velocity and specific force (SI)."""
        return self.imu_si(t_s, gyro_rad_s(telemetry), accel_m_s2(telemetry))

    def imu_si(
        self, t_s: float, gyro: tuple[float, float, float], accel: tuple[float, float, float]
    ) -> Any:
        """/imu/data from SI values [rad/s, m/s^2], without orientation (REP 145)."""
        return Imu(
            header=self.header(t_s, self.settings.imu_frame),
            orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=self.imu_orientation_cov,
            angular_velocity=Vector3(x=float(gyro[0]), y=float(gyro[1]), z=float(gyro[2])),
            angular_velocity_covariance=self.imu_angular_velocity_cov,
            linear_acceleration=Vector3(x=float(accel[0]), y=float(accel[1]), z=float(accel[2])),
            linear_acceleration_covariance=self.imu_linear_acceleration_cov,
        )

    def joint_states(self, t_s: float, odo: OdometryState) -> Any:
        """/joint_states: the wheels' angles and speeds."""
        return self.wheels(
            t_s,
            (odo.wheel_angle_left_rad, odo.wheel_angle_right_rad),
            (odo.wheel_velocity_left_rad_s, odo.wheel_velocity_right_rad_s),
        )

    def wheels(self, t_s: float, angles: tuple[float, float], speeds: tuple[float, float]) -> Any:
        """/joint_states from (left, right) angles [rad] and speeds [rad/s]."""
        s = self.settings
        return JointState(
            header=self.header(t_s, ""),
            name=[s.left_wheel_joint, s.right_wheel_joint],
            position=np.array([float(angles[0]), float(angles[1])], dtype=np.float64),
            velocity=np.array([float(speeds[0]), float(speeds[1])], dtype=np.float64),
            effort=np.zeros(0, dtype=np.float64),
        )

    def transform(
        self, t_s: float, parent: str, child: str, xyz: Sequence[float], yaw: float = 0.0
    ) -> Any:
        """One transform stamped at ``t_s``."""
        return TransformStamped(
            header=self.header(t_s, parent),
            child_frame_id=child,
            transform=Transform(
                translation=Vector3(x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2])),
                rotation=yaw_quaternion(float(yaw)),
            ),
        )

    def tf(
        self, t_s: float, parent: str, child: str, xyz: Sequence[float], yaw: float = 0.0
    ) -> Any:
        """/tf with one transform (:meth:`transform`)."""
        return TFMessage(transforms=[self.transform(t_s, parent, child, xyz, yaw)])

    def odom_tf(self, t_s: float, x: float, y: float, yaw: float) -> Any:
        """/tf: odom -> base_footprint."""
        s = self.settings
        return self.tf(t_s, s.odom_frame, s.base_frame, (x, y, 0.0), yaw)

    def wheel_tf(self, t_s: float, odo: OdometryState) -> Any:
        """/tf: base_link -> each wheel's link, turned about +y by the wheel's angle (one header
        object shared, as :meth:`path`'s)."""
        s = self.settings
        header = self.header(t_s, s.base_link_frame)
        out = []
        for child, y, angle in (
            (s.left_wheel_frame, 0.5 * s.wheel_separation_m, odo.wheel_angle_left_rad),
            (s.right_wheel_frame, -0.5 * s.wheel_separation_m, odo.wheel_angle_right_rad),
        ):
            half = 0.5 * float(angle)
            out.append(
                TransformStamped(
                    header=header,
                    child_frame_id=child,
                    transform=Transform(
                        translation=Vector3(x=0.0, y=y, z=0.0),
                        rotation=Quaternion(x=0.0, y=math.sin(half), z=0.0, w=math.cos(half)),
                    ),
                )
            )
        return TFMessage(transforms=out)

    def static_tf(self, t_s: float) -> Any:
        """/tf_static: base_footprint -> base_link -> {imu_link, laser}."""
        s = self.settings
        return TFMessage(
            transforms=[
                self.transform(t_s, s.base_frame, s.base_link_frame, s.base_link_offset_m),
                self.transform(t_s, s.base_link_frame, s.imu_frame, s.imu_offset_m),
                self.transform(t_s, s.base_link_frame, s.laser_frame, s.laser_offset_m),
            ]
        )

    def scan(
        self, scan: Scan, start_s: float | None = None, period_s: float = SCAN_PERIOD_S
    ) -> Any:
        """/scan in the laser frame: one revolution binned by angle (:mod:`.scan_bins`), stamped
        with its first measurement's MCU time ``start_s`` (the LaserScan convention; default:
        one period before ``scan.t_s``) and timed by its revolution's ``period_s``."""
        n = len(scan.angles_rad)
        a0, a1 = float(scan.angles_rad[0]), float(scan.angles_rad[-1])
        start = scan.t_s - period_s if start_s is None else start_s
        return LaserScan(
            header=self.header(start, self.settings.laser_frame),
            angle_min=a0,
            angle_max=a1,
            angle_increment=(a1 - a0) / (n - 1),
            time_increment=period_s / n,
            scan_time=period_s,
            range_min=SCAN_RANGE_M[0],
            range_max=SCAN_RANGE_M[1],
            ranges=binned_ranges(scan.angles_rad, scan.ranges_m),  # each at its own angle
            intensities=np.zeros(0, dtype=np.float32),
        )

    def path(self, t_s: float, points: Any, frame: str = "map") -> Any:
        """/plan or /local_plan: (x, y[, yaw]) rows as poses in ``frame``, every pose stamped
        as the path (one header object shared: messages are never changed once built)."""
        header = self.header(t_s, frame)
        rows = np.asarray(points, np.float64).reshape(len(points), -1) if len(points) else None
        poses = []
        if rows is not None:
            yaws = rows[:, 2] if rows.shape[1] > 2 else np.zeros(len(rows))
            for x, y, yaw in zip(
                rows[:, 0].tolist(), rows[:, 1].tolist(), yaws.tolist(), strict=True
            ):
                poses.append(
                    PoseStamped(
                        header=header,
                        pose=Pose(position=Point(x=x, y=y, z=0.0), orientation=yaw_quaternion(yaw)),
                    )
                )
        return Path(header=header, poses=poses)

    def occupancy(self, t_s: float, grid: Any, frame: str = "map") -> Any:
        """/map: an occupancy grid (-1 unknown, 0-100 occupied)."""
        h = self.header(t_s, frame)
        return OccupancyGrid(
            header=h,
            info=MapMetaData(
                map_load_time=h.stamp,
                resolution=float(grid.resolution_m),
                width=int(grid.width),
                height=int(grid.height),
                origin=Pose(
                    position=Point(x=float(grid.origin_x_m), y=float(grid.origin_y_m), z=0.0),
                    orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
                ),
            ),
            data=np.asarray(grid.data, dtype=np.int8).ravel(),
        )

    def twist(self, t_s: float, v: float, w: float) -> Any:
        """A velocity command as /cmd_vel carries it (Twist, or TwistStamped in base_footprint
        with ``cmd_vel_stamped``)."""
        twist = Twist(
            linear=Vector3(x=float(v), y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=float(w))
        )
        if self.settings.cmd_vel_stamped:
            return TwistStamped(header=self.header(t_s, self.settings.base_frame), twist=twist)
        return twist

    def goal(self, t_s: float, x: float, y: float, yaw: float, frame: str = "map") -> Any:
        """A navigation goal as /goal_pose carries it."""
        return PoseStamped(
            header=self.header(t_s, frame),
            pose=Pose(
                position=Point(x=float(x), y=float(y), z=0.0), orientation=yaw_quaternion(yaw)
            ),
        )

    def initial_pose(
        self,
        t_s: float,
        x: float,
        y: float,
        yaw: float,
        covariance: Sequence[float],
        frame: str = "map",
    ) -> Any:
        """A pose to localise from as /initialpose carries it (RViz's "2D Pose Estimate"),
        with its 6 x 6 covariance, row-major."""
        return PoseWithCovarianceStamped(
            header=self.header(t_s, frame),
            pose=PoseWithCovariance(
                pose=Pose(
                    position=Point(x=float(x), y=float(y), z=0.0),
                    orientation=yaw_quaternion(yaw),
                ),
                covariance=np.asarray(covariance, dtype=np.float64).reshape(36),
            ),
        )

    def raw_frame(self, data: bytes) -> Any:
        """/jackson/telemetry: a received frame's bytes."""
        payload = np.frombuffer(bytes(data), dtype=np.uint8).copy()
        return UInt8MultiArray(layout=MultiArrayLayout(dim=[], data_offset=0), data=payload)

    def status(self, name: str, level: int, message: str, **kv: object) -> Any:
        """One diagnostic_msgs/DiagnosticStatus with key/values."""
        return DiagnosticStatus(
            level=level,
            name=name,
            message=message,
            hardware_id=self.hardware_id,
            values=[KeyValue(key=k, value=str(v)) for k, v in kv.items()],
        )

    def diagnostics(self, v: DiagnosticValues) -> Any:
        """/diagnostics: the serial link, one status per sensor (the IMU, the encoders, the
        LiDAR: their flags and the health monitor's states), the EKF, the command watchdog,
        the clock (robot time) and the navigation service."""
        statuses = diagnostic_statuses(v, self.status, self.clock)
        return DiagnosticArray(header=self.header(v.t_s, ""), status=statuses)
