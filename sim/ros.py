"""The twin's own ROS 2 publisher (``jackson sim --ros``): its LiDAR, its ground truth, its clock.

| topic              | type                  | when                       | QoS            |
|--------------------|-----------------------|----------------------------|----------------|
| /twin/scan         | sensor_msgs/LaserScan | every LiDAR scan (7.43 Hz) | best effort, 5 |
| /ground_truth/odom | nav_msgs/Odometry     | 20 Hz of sim time          | reliable, 10   |
| /clock             | rosgraph_msgs/Clock   | every advance of sim time  | best effort, 1 |

All volatile, keep last. The twin's own scans go on ``/twin/scan``, not ``/scan``: the host
daemon (``--lidar``) or Slamtec's sllidar_ros2 reads the emulated RPLIDAR's port and publishes
``/scan`` from it, and one topic has one publisher. ``/clock`` uses the profile of
``rclcpp::ClockQoS`` (best effort, depth 1), the one ROS 2's own time source subscribes with
(rclpy's ``TimeSource`` and rclcpp's) and rosbag2's player publishes with; a subscriber that
asks for reliable does not match it.

Every stamp is sim time, which is the MCU time the host runs on: the MCU stamps telemetry with
the twin's microsecond clock (``Twin.t_us``, on the wire modulo 2^32, unwrapped by the host), so
the host's own stamps and a node with ``use_sim_time`` reading this ``/clock`` share one clock.

The LaserScan follows the A1M8 specification of :class:`~jackson.sim.lidar.LidarSpec` (frame
``laser``, 1080 beams at 0.005807 rad from -pi, ``time_increment = scan_period / beams``,
``scan_time`` 0.13465 s, 0.15-12 m; ``inf`` for no return) and is stamped with the sim time of
the scan. The ground truth is the twin's true pose, in the frame ``odom`` anchored at the
world's start pose (where the host's odometry starts at zero), child ``base_footprint``, with
the body-frame twist (vx, vy, wz).

rclpy is imported only when a :class:`TwinRosPublisher` is built or :func:`ros_available` is
called. The node has its own rclpy context and installs no signal handlers (``jackson sim``'s
SIGINT/SIGTERM handlers stay in charge). It only publishes, so it needs no executor. This module
never imports ``jackson.host``.
"""

from __future__ import annotations

import array
import importlib
import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jackson.common.geometry import angle_of
from jackson.common.ros_env import missing_ros
from jackson.sim.lidar import LidarSpec
from jackson.sim.twin import Twin

__all__ = ["GROUND_TRUTH_PERIOD_S", "TwinRosPublisher", "ros_available"]

GROUND_TRUTH_PERIOD_S = 0.05  # [s] of sim time: /ground_truth/odom at 20 Hz
SCAN_DEPTH = 5  # /twin/scan: best effort, volatile (Appendix C)
SCAN_TOPIC = "/twin/scan"  # /scan is the daemon's (or sllidar_ros2's), read from the LiDAR port
ODOMETRY_DEPTH = 10  # /ground_truth/odom: reliable, volatile (as /wheel/odom)
CLOCK_DEPTH = 1  # /clock: best effort, volatile (rclcpp::ClockQoS)

REQUIRED_MODULES = (
    "rclpy",
    "builtin_interfaces.msg",
    "sensor_msgs.msg",
    "nav_msgs.msg",
    "rosgraph_msgs.msg",
)


def ros_available() -> str | None:
    """None when rclpy and the message packages import, else one line naming what to do."""
    return missing_ros(REQUIRED_MODULES)


def stamp_parts_us(t_us: int) -> tuple[int, int]:
    """Sim time [us] as builtin_interfaces/Time (sec, nanosec); negative times clamp to 0."""
    t_us = max(0, t_us)
    return t_us // 1_000_000, (t_us % 1_000_000) * 1000


def _qos(depth: int, *, reliable: bool) -> Any:
    from rclpy import qos

    profile: Any = qos.QoSProfile  # untyped in some rclpy releases
    return profile(
        history=qos.HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=(
            qos.ReliabilityPolicy.RELIABLE if reliable else qos.ReliabilityPolicy.BEST_EFFORT
        ),
        durability=qos.DurabilityPolicy.VOLATILE,
    )


class TwinRosPublisher:
    """Publishes /twin/scan, /ground_truth/odom and /clock of one :class:`Twin`.

    Call :meth:`on_advance` after every advance of the twin's clock (``TwinRunner``'s
    ``observer``); it publishes the scans taken since the previous call, the ground truth when
    20 Hz of sim time are due, and /clock. :meth:`close` destroys the node and shuts its
    context down.
    """

    def __init__(
        self,
        twin: Twin,
        *,
        node_name: str = "jackson_twin",
        namespace: str = "",
        laser_frame: str = "laser",
        odom_frame: str = "odom",
        base_frame: str = "base_footprint",
    ) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.node import Node
        from rclpy.signals import SignalHandlerOptions

        time_msg: Any = importlib.import_module("builtin_interfaces.msg")
        sensor_msgs: Any = importlib.import_module("sensor_msgs.msg")
        nav_msgs: Any = importlib.import_module("nav_msgs.msg")
        rosgraph_msgs: Any = importlib.import_module("rosgraph_msgs.msg")
        self._Time: Any = time_msg.Time
        self._LaserScan: Any = sensor_msgs.LaserScan
        self._Odometry: Any = nav_msgs.Odometry
        self._Clock: Any = rosgraph_msgs.Clock

        self.twin = twin
        self.laser_frame, self.odom_frame, self.base_frame = laser_frame, odom_frame, base_frame
        lidar = twin._lidar
        self.lidar_spec: LidarSpec | None = lidar.spec if lidar is not None else None
        self._origin = twin.world_spec.start_pose
        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        try:
            self.node: Any = Node(node_name, namespace=namespace, context=self.context)
            self.scan_pub: Any = (
                self.node.create_publisher(
                    self._LaserScan, SCAN_TOPIC, _qos(SCAN_DEPTH, reliable=False)
                )
                if self.lidar_spec is not None
                else None
            )
            self.odom_pub: Any = self.node.create_publisher(
                self._Odometry, "/ground_truth/odom", _qos(ODOMETRY_DEPTH, reliable=True)
            )
            self.clock_pub: Any = self.node.create_publisher(
                self._Clock, "/clock", _qos(CLOCK_DEPTH, reliable=False)
            )
        except BaseException:
            self.context.try_shutdown()
            raise
        self._scans_done = twin.scans_taken
        self._next_truth_us: int | None = None
        self._last_clock_us: int | None = None
        self._closed = False
        self.published = {"scan": 0, "ground_truth": 0, "clock": 0}

    # ------------------------------------------------------------------ publishing

    def on_advance(self, twin: Twin) -> None:
        """After an advance of sim time: new scans, the due ground truth, then /clock."""
        if self._closed:
            return
        t_us = twin.t_us
        new = twin.scans_taken - self._scans_done
        if self.scan_pub is not None and new > 0:
            # the twin keeps only its newest scans (jackson sim: SCAN_HISTORY); an observer
            # called after every advance never falls that far behind
            for scan in list(twin.scans)[-new:]:
                self.publish_scan(round(scan.t_s * 1e6), scan.ranges)
        self._scans_done = twin.scans_taken
        if self._next_truth_us is None or t_us >= self._next_truth_us:
            self.publish_ground_truth(twin)
            period_us = round(GROUND_TRUTH_PERIOD_S * 1e6)
            self._next_truth_us = (t_us // period_us + 1) * period_us
        if self._last_clock_us is None or t_us > self._last_clock_us:
            self.publish_clock(t_us)
            self._last_clock_us = t_us

    def _stamp(self, t_us: int) -> Any:
        sec, nanosec = stamp_parts_us(t_us)
        return self._Time(sec=sec, nanosec=nanosec)

    def publish_scan(self, t_us: int, ranges: NDArray[np.float32]) -> None:
        """One LaserScan of the twin's LiDAR taken at ``t_us``."""
        spec = self.lidar_spec
        assert spec is not None and self.scan_pub is not None
        msg = self._LaserScan()
        msg.header.stamp = self._stamp(t_us)
        msg.header.frame_id = self.laser_frame
        msg.angle_min = float(spec.angle_min_rad)
        msg.angle_max = float(spec.angle_max_rad)
        msg.angle_increment = float(spec.angle_increment_rad)
        msg.time_increment = float(spec.time_increment_s)
        msg.scan_time = float(spec.scan_period_s)
        msg.range_min = float(spec.range_min_m)
        msg.range_max = float(spec.range_max_m)
        values = array.array("f")
        values.frombytes(np.ascontiguousarray(ranges, dtype=np.float32).tobytes())
        msg.ranges = values  # inf stays inf: no return
        self.scan_pub.publish(msg)
        self.published["scan"] += 1

    def publish_ground_truth(self, twin: Twin) -> None:
        """The true pose (relative to the start pose) and body-frame twist, now."""
        truth = twin.truth()
        x0, y0, yaw0 = self._origin
        c, s = math.cos(yaw0), math.sin(yaw0)
        dx, dy = truth.x - x0, truth.y - y0
        yaw = angle_of(truth.yaw - yaw0)
        msg = self._Odometry()
        msg.header.stamp = self._stamp(twin.t_us)
        msg.header.frame_id = self.odom_frame
        msg.child_frame_id = self.base_frame
        pose = msg.pose.pose
        pose.position.x = c * dx + s * dy
        pose.position.y = -s * dx + c * dy
        pose.orientation.z = math.sin(yaw / 2.0)
        pose.orientation.w = math.cos(yaw / 2.0)
        twist = msg.twist.twist
        twist.linear.x = float(truth.vx)
        twist.linear.y = float(truth.vy)
        twist.angular.z = float(truth.wz)
        self.odom_pub.publish(msg)
        self.published["ground_truth"] += 1

    def publish_clock(self, t_us: int) -> None:
        msg = self._Clock()
        msg.clock = self._stamp(t_us)
        self.clock_pub.publish(msg)
        self.published["clock"] += 1

    # ------------------------------------------------------------------ lifecycle

    def close(self) -> None:
        """Destroy the node and shut its context down; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self.node.destroy_node()
        self.context.try_shutdown()

    def __enter__(self) -> TwinRosPublisher:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
