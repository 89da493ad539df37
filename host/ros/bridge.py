"""The ROS 2 interface of the host daemon: an rclpy node fed by :class:`HostCore`.

The daemon computes; this node only publishes what it computed and hands ``/cmd_vel`` back:

| topic              | type                            | when                        | QoS        |
|--------------------|---------------------------------|-----------------------------|------------|
| /wheel/odom        | nav_msgs/Odometry               | every telemetry frame       | rel. 10    |
| /imu/data          | sensor_msgs/Imu                 | every frame with IMU_OK     | b. eff. 5  |
| /joint_states      | sensor_msgs/JointState          | every telemetry frame       | rel. 10    |
| /odometry/filtered | nav_msgs/Odometry               | each 30 Hz EKF output       | rel. 10    |
| /diagnostics       | diagnostic_msgs/DiagnosticArray | 1 Hz of MCU time            | rel. 10    |
| /tf                | tf2_msgs/TFMessage              | with the EKF (or the wheels) | rel. 100   |
| /tf_static         | tf2_msgs/TFMessage              | once                        | latched 1  |
| /cmd_vel (in)      | geometry_msgs/Twist[Stamped]    | to ``core.submit_velocity`` | rel. 1     |

Every stamp is the MCU time of the data (the host runs on MCU time, never the wall clock), so
a consumer sees the timing of the sensors, not of the USB link or the scheduler. /tf and
/tf_static are published only where tf2_msgs imports (a system ROS 2 install; the PyPI wheels
do not include it).

rclpy is imported only when a :class:`RosBridge` is built or :func:`ros_available` is called:
importing this module without ``--ros`` loads nothing from ROS.

With the PyPI wheels (the ``ros`` extra) the ROS libraries live in the virtual environment and
must be on ``LD_LIBRARY_PATH`` when the interpreter starts; the wheels' own ``.pth`` bootstrapper
re-executes every interpreter of the environment with it set (``_ROS_WHEELS_BOOTSTRAP_COMPLETE``
marks the second start). Nothing else is needed: no ``AMENT_PREFIX_PATH``, and Fast DDS
(``rmw_fastrtps_cpp``, the wheels' only RMW) is the default ``RMW_IMPLEMENTATION``.
:func:`ros_available` names what is missing when the import fails.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import math
import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from jackson.common.ros_env import missing_ros
from jackson.host.ros.names import FRAMES, TOPICS
from jackson.host.ros.qos import (
    cmd_vel_qos,
    diagnostics_qos,
    joint_states_qos,
    map_qos,
    odometry_qos,
    sensor_qos,
    tf_qos,
    tf_static_qos,
)
from jackson.protocol import Telemetry, TelemetryFlags
from jackson.protocol.units import accel_m_s2, gyro_rad_s

if TYPE_CHECKING:
    from jackson.host.config import HostConfig
    from jackson.host.core import HostCore
    from jackson.host.ekf import EkfState
    from jackson.host.odometry import OdometryState

DIAGNOSTICS_PERIOD_S = 1.0  # [s] of MCU time
SPIN_TIMEOUT_S = 0.1  # [s] an executor wait; bounds how long stop() takes

# The packages the bridge needs (import name -> what provides it with the PyPI wheels).
REQUIRED_MODULES = ("rclpy", "nav_msgs.msg", "sensor_msgs.msg", "geometry_msgs.msg")
OPTIONAL_MODULES = ("diagnostic_msgs.msg", "tf2_msgs.msg")

# Diagonal indices of a row-major 6x6 covariance (x, y, z, roll, pitch, yaw).
COV_X, COV_Y, COV_Z, COV_ROLL, COV_PITCH, COV_YAW = 0, 7, 14, 21, 28, 35

# diagnostic_msgs/DiagnosticStatus levels
LEVEL_OK, LEVEL_WARN, LEVEL_ERROR = 0, 1, 2


class CoreLike(Protocol):
    """What the bridge reads from the daemon's core (:class:`HostCore` is one)."""

    cfg: HostConfig
    t_s: float | None
    last_odometry: OdometryState | None

    def submit_velocity(self, v_m_s: float, w_rad_s: float, host_time_ns: int = 0) -> None: ...


# ---------------------------------------------------------------------------------- availability


def ros_available() -> str | None:
    """None when rclpy and the message packages import, else one line naming what to install."""
    return missing_ros(REQUIRED_MODULES)


def _optional(module: str) -> Any:
    """A message module, or None where it is not installed (tf2_msgs with the PyPI wheels)."""
    if importlib.util.find_spec(module.split(".")[0]) is None:
        return None
    try:
        return importlib.import_module(module)
    except ImportError:
        return None


# ---------------------------------------------------------------------------------- pure helpers


def stamp_parts(t_s: float) -> tuple[int, int]:
    """MCU time [s] as builtin_interfaces/Time (sec, nanosec); negative times clamp to 0."""
    ns = max(0, round(t_s * 1e9))
    return ns // 1_000_000_000, ns % 1_000_000_000


def yaw_quaternion(yaw_rad: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``yaw_rad`` about z."""
    return 0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0)


def imu_si(t: Telemetry) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Angular velocity [rad/s] and linear acceleration [m/s^2] of a frame, at the full-scale
    ranges its flags name (bits 8-9 ACCEL_FS, bits 10-11 GYRO_FS)."""
    return gyro_rad_s(t), accel_m_s2(t)


def diagonal_covariance(*diagonal: float) -> list[float]:
    """A row-major 6x6 covariance with ``diagonal`` (6 values) on its diagonal."""
    cov = [0.0] * 36
    for i, v in enumerate(diagonal):
        cov[7 * i] = float(v)
    return cov


@dataclass(frozen=True)
class DiagnosticValues:
    """One /diagnostics sample, on MCU time.

    Attributes
    ----------
    t_s : float
        MCU time [s].
    link_up : bool
        The serial link to the MCU is open and delivering frames.
    frames : int
        Telemetry frames processed.
    crc_errors : int
        Frames the host's decoder dropped for a bad CRC.
    imu_ok, imu_calibrated : bool
        The IMU_OK and IMU_CALIBRATED bits of the last telemetry frame.
    rejected : tuple of (str, int)
        Measurements the EKF's Mahalanobis gate rejected, per sensor.
    watchdog_expired : bool
        No external velocity command within the watchdog time (0.6 s).
    braked : bool
        The motors are braked.
    link : tuple of (str, object)
        The link's and motor path's counters (``LinkHealth`` of the daemon), as key/values.
    problems : tuple of str
        What the operator should look at (empty when all is well).
    """

    t_s: float
    link_up: bool
    frames: int
    crc_errors: int
    imu_ok: bool
    imu_calibrated: bool
    rejected: tuple[tuple[str, int], ...] = field(default=())
    watchdog_expired: bool = True
    braked: bool = True
    link: tuple[tuple[str, object], ...] = field(default=())
    problems: tuple[str, ...] = field(default=())


def diagnostic_values(
    core: HostCore, telemetry: Telemetry | None, *, link: Any
) -> DiagnosticValues:
    """The diagnostics of a running core; ``link`` is the daemon's ``LinkHealth``."""
    t_s = core.t_s or 0.0
    flags = telemetry.flags if telemetry is not None else 0
    return DiagnosticValues(
        t_s=t_s,
        link_up=link.link_up,
        frames=core.frames,
        crc_errors=link.crc_errors,
        imu_ok=bool(flags & TelemetryFlags.IMU_OK),
        imu_calibrated=bool(flags & TelemetryFlags.IMU_CALIBRATED),
        rejected=tuple(sorted(core.ekf.rejected.items())),
        watchdog_expired=core.watchdog.expired(t_s),
        braked=core.braked,
        link=tuple(dataclasses.asdict(link).items()),
        problems=tuple(link.problems()),
    )


# ---------------------------------------------------------------------------------- the node


@dataclass(frozen=True)
class BridgeParameters:
    """The node's ROS parameters (``--ros-args -p name:=value`` or ``parameter_overrides``)."""

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
    publish_tf: bool = True
    tf_source: str = "filtered"  # "filtered" (the EKF, at 30 Hz) or "wheel" (every frame)
    base_link_offset_m: tuple[float, ...] = (0.0, 0.0, 0.033)  # base_footprint -> base_link
    imu_offset_m: tuple[float, ...] = (0.0, 0.0, 0.0)  # base_link -> imu_link
    laser_offset_m: tuple[float, ...] = (0.0, 0.0, 0.0)  # base_link -> laser
    imu_angular_velocity_covariance: float = 0.0004  # [(rad/s)^2], the EKF's R_wz
    imu_linear_acceleration_covariance: float = 0.01  # [(m/s^2)^2]


class RosBridge:
    """The daemon's ROS 2 node: publishes what :class:`HostCore` computed, feeds it /cmd_vel.

    The rclpy node is :attr:`node` (the same API on Humble and Jazzy). It has its own rclpy
    context and installs no signal handlers: the daemon's SIGINT/SIGTERM handlers stay in
    charge and end with :meth:`stop`. The ``publish`` methods may be called from the daemon's
    thread while :meth:`start`'s executor thread runs the /cmd_vel callback.

    Parameters
    ----------
    core : CoreLike
        The daemon's core; its configuration gives the defaults of the covariances and the
        base_link height, and /cmd_vel goes to its ``submit_velocity``.
    node_name, namespace : str
        Of the node.
    args : sequence of str, optional
        Command-line arguments for rclpy (``--ros-args -p cmd_vel_stamped:=true -r ...``).
    parameter_overrides : mapping, optional
        Parameter values that replace the defaults (tests, the daemon's configuration).
    """

    def __init__(
        self,
        core: CoreLike,
        *,
        node_name: str = "jackson_host",
        namespace: str = "",
        args: Sequence[str] | None = None,
        parameter_overrides: Mapping[str, Any] | None = None,
    ) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        from rclpy.signals import SignalHandlerOptions

        self.core = core
        self._msgs = _Messages()
        self.context = Context()
        rclpy.init(
            args=list(args) if args is not None else None,
            context=self.context,
            signal_handler_options=SignalHandlerOptions.NO,
        )
        parameter: Any = Parameter  # untyped in some rclpy releases
        overrides = [
            parameter(k, value=list(v) if isinstance(v, tuple) else v)
            for k, v in (parameter_overrides or {}).items()
        ]
        try:
            self.node = Node(
                node_name,
                namespace=namespace,
                context=self.context,
                parameter_overrides=overrides,
            )
            self.params = self._declare_parameters(core)
            self._create_interfaces()
        except BaseException:
            self.context.try_shutdown()
            raise
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self._next_diagnostics_s: float | None = None
        self.commands_received = 0
        self.published: dict[str, int] = {}
        self.publish_static_transforms()

    # ------------------------------------------------------------------ set-up

    def _declare_parameters(self, core: CoreLike) -> BridgeParameters:
        defaults = BridgeParameters(
            base_link_offset_m=(0.0, 0.0, core.cfg.robot.wheel_radius_left_m),
            imu_angular_velocity_covariance=core.cfg.ekf.r_wz,
        )
        values: dict[str, Any] = {}
        for name, default in vars(defaults).items():
            initial = [float(c) for c in default] if isinstance(default, tuple) else default
            value = self.node.declare_parameter(name, initial).value
            values[name] = tuple(float(c) for c in value) if isinstance(default, tuple) else value
        params = BridgeParameters(**values)
        if params.tf_source not in ("filtered", "wheel"):
            raise ValueError(f"tf_source must be 'filtered' or 'wheel', got {params.tf_source!r}")
        for name in ("base_link_offset_m", "imu_offset_m", "laser_offset_m"):
            if len(getattr(params, name)) != 3:
                raise ValueError(f"{name} must have 3 values (x, y, z in metres)")
        return params

    def _create_interfaces(self) -> None:
        p, m, node = self.params, self._msgs, self.node
        self.wheel_odom_pub = node.create_publisher(m.Odometry, p.wheel_odom_topic, odometry_qos())
        self.filtered_pub = node.create_publisher(m.Odometry, p.filtered_topic, odometry_qos())
        self.imu_pub = node.create_publisher(m.Imu, p.imu_topic, sensor_qos())
        self.joint_pub = node.create_publisher(
            m.JointState, p.joint_states_topic, joint_states_qos()
        )
        self.diagnostics_pub: Any = (
            node.create_publisher(m.DiagnosticArray, p.diagnostics_topic, diagnostics_qos())
            if m.DiagnosticArray is not None
            else None
        )
        self.tf_pub: Any = None
        self.tf_static_pub: Any = None
        if p.publish_tf and m.TFMessage is not None:
            self.tf_pub = node.create_publisher(m.TFMessage, "/tf", tf_qos())
            self.tf_static_pub = node.create_publisher(m.TFMessage, "/tf_static", tf_static_qos())
        self.scan_pub = node.create_publisher(m.LaserScan, "/scan", sensor_qos())
        self.nav: Any = getattr(self.core, "mission", None)
        if not hasattr(self.nav, "navigator"):
            self.nav = None
        self._map_sent_s: float | None = None
        self._plan_version = -1
        if self.nav is not None:  # Stage 3: Nav2's topics (docs/stage3.md)
            self.map_pub = node.create_publisher(m.OccupancyGrid, "/map", map_qos())
            self.plan_pub = node.create_publisher(m.Path, "/plan", odometry_qos())
            self.local_plan_pub = node.create_publisher(m.Path, "/local_plan", odometry_qos())
            self.goal_sub = node.create_subscription(
                m.PoseStamped, "/goal_pose", self._on_goal, cmd_vel_qos()
            )
        cmd_type = m.TwistStamped if p.cmd_vel_stamped else m.Twist
        self.cmd_vel_sub = node.create_subscription(
            cmd_type, p.cmd_vel_topic, self._on_cmd_vel, cmd_vel_qos()
        )

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        """Spin the executor (the /cmd_vel callback) in a background thread."""
        if self._thread is not None:
            return
        self._thread = threading.Thread(target=self._spin, name="ros-bridge", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set() and self.context.ok():
            self.executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)

    def stop(self) -> None:
        """Stop spinning, destroy the node and shut the context down; safe to call twice."""
        if self._stop.is_set():
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        with self._lock:
            self.executor.shutdown(timeout_sec=1.0)
            node: Any = self.node
            node.destroy_node()
            self.context.try_shutdown()

    def __enter__(self) -> RosBridge:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ inputs

    def _on_cmd_vel(self, msg: Any) -> None:
        twist = msg.twist if self.params.cmd_vel_stamped else msg
        self.commands_received += 1
        self.core.submit_velocity(
            float(twist.linear.x), float(twist.angular.z), time.monotonic_ns()
        )

    def _on_goal(self, msg: Any) -> None:
        """A goal from RViz's "2D Goal Pose" (map frame): the navigator takes it at the next
        control tick."""
        from jackson.host.nav.types import Pose2D

        q = msg.pose.orientation
        yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        self.nav.request_goal(Pose2D(float(msg.pose.position.x), float(msg.pose.position.y), yaw))

    # ------------------------------------------------------------------ outputs

    def on_scan(self, t_s: float, angles_rad: Sequence[float], ranges_m: Sequence[float]) -> None:
        """A LiDAR revolution the host read (the robot's RPLIDAR) as /scan in the laser frame."""
        if self._stop.is_set() or len(angles_rad) < 2:
            return
        msg = self._msgs.LaserScan()
        msg.header.stamp = self._stamp(t_s)
        msg.header.frame_id = self.params.laser_frame
        msg.angle_min = float(angles_rad[0])
        msg.angle_max = float(angles_rad[-1])
        msg.angle_increment = float((angles_rad[-1] - angles_rad[0]) / (len(angles_rad) - 1))
        msg.scan_time = SCAN_PERIOD_S
        msg.time_increment = SCAN_PERIOD_S / len(angles_rad)
        msg.range_min = 0.15
        msg.range_max = 8.0
        msg.ranges = [float(r) for r in ranges_m]
        self._publish("scan", self.scan_pub, msg)

    def on_navigation(self, t_s: float) -> None:
        """After a control tick of a navigation mission: /plan (each new global plan),
        /local_plan (the trajectory DWB chose), map -> odom, and /map (once on a known map;
        every 5 s of MCU time while mapping)."""
        nav = self.nav
        if nav is None or self._stop.is_set():
            return
        stamp = self._stamp(t_s)
        frame = "map"
        replans = nav.navigator.replans
        new_plan = replans != self._plan_version
        self._plan_version = replans
        for key, pub, points in (
            ("plan", self.plan_pub, nav.navigator.plan if new_plan else ()),
            ("local_plan", self.local_plan_pub, nav.navigator.local_plan),
        ):
            if len(points) == 0:  # a new global plan; a trajectory DWB chose
                continue
            path = self._msgs.Path()
            path.header.stamp = stamp
            path.header.frame_id = frame
            poses = []
            for row in points:
                ps = self._msgs.PoseStamped()
                ps.header = path.header
                ps.pose.position.x, ps.pose.position.y = float(row[0]), float(row[1])
                yaw = float(row[2]) if len(row) > 2 else 0.0
                q = ps.pose.orientation
                q.x, q.y, q.z, q.w = yaw_quaternion(yaw)
                poses.append(ps)
            path.poses = poses
            self._publish(key, pub, path)
        if self.tf_pub is not None:
            c = nav.map_to_odom
            start = nav.config.start
            corr = c.compose(start)  # map -> odom: the odometry frame starts at the start pose
            msg = self._msgs.TFMessage()
            msg.transforms = [
                self._transform(stamp, frame, self.params.odom_frame, corr.x, corr.y, 0.0, corr.yaw)
            ]
            self._publish("tf", self.tf_pub, msg)
        mapping = nav.mapper is not None
        due = self._map_sent_s is None or (mapping and t_s - self._map_sent_s >= MAP_PERIOD_S)
        grid = nav.built_map() if mapping else nav.static_map
        if due and grid is not None:
            self._map_sent_s = t_s
            msg = self._msgs.OccupancyGrid()
            msg.header.stamp = stamp
            msg.header.frame_id = frame
            info = msg.info
            info.resolution = float(grid.resolution_m)
            info.width, info.height = grid.width, grid.height
            info.origin.position.x = float(grid.origin_x_m)
            info.origin.position.y = float(grid.origin_y_m)
            info.origin.orientation.w = 1.0
            msg.data = grid.data.ravel().tolist()
            self._publish("map", self.map_pub, msg)

    def on_telemetry(self, core: CoreLike, telemetry: Telemetry) -> None:
        """After each telemetry frame: /wheel/odom, /imu/data, /joint_states (and /tf when
        ``tf_source`` is ``wheel``), stamped with the frame's MCU time."""
        odo, t_s = core.last_odometry, core.t_s
        if odo is None or t_s is None or self._stop.is_set():
            return
        p, m = self.params, self._msgs
        stamp = self._stamp(t_s)
        odom_cfg = core.cfg.odometry
        msg = m.Odometry()
        msg.header.stamp = stamp
        msg.header.frame_id = p.odom_frame
        msg.child_frame_id = p.base_frame
        self._set_pose(msg, odo.x_m, odo.y_m, odo.yaw_rad)
        msg.pose.covariance = diagonal_covariance(
            odom_cfg.pose_xy, odom_cfg.pose_xy, 0.0, 0.0, 0.0, odom_cfg.pose_yaw
        )
        msg.twist.twist.linear.x = float(odo.v_m_s)
        msg.twist.twist.linear.y = 0.0
        msg.twist.twist.angular.z = float(odo.w_rad_s)
        msg.twist.covariance = diagonal_covariance(
            odom_cfg.twist_vx, odom_cfg.twist_vy, 0.0, 0.0, 0.0, odom_cfg.twist_wz
        )
        self._publish("wheel_odom", self.wheel_odom_pub, msg)

        if telemetry.flags & TelemetryFlags.IMU_OK:
            (gx, gy, gz), (ax, ay, az) = imu_si(telemetry)
            imu = m.Imu()
            imu.header.stamp = stamp
            imu.header.frame_id = p.imu_frame
            imu.orientation_covariance[0] = -1.0  # no orientation estimate
            imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z = gx, gy, gz
            w_cov = p.imu_angular_velocity_covariance
            imu.angular_velocity_covariance = [w_cov, 0.0, 0.0, 0.0, w_cov, 0.0, 0.0, 0.0, w_cov]
            acc = imu.linear_acceleration
            acc.x, acc.y, acc.z = ax, ay, az
            a_cov = p.imu_linear_acceleration_covariance
            imu.linear_acceleration_covariance = [a_cov, 0.0, 0.0, 0.0, a_cov, 0.0, 0.0, 0.0, a_cov]
            self._publish("imu", self.imu_pub, imu)

        joints = m.JointState()
        joints.header.stamp = stamp
        joints.name = [p.left_wheel_joint, p.right_wheel_joint]
        joints.position = [float(odo.wheel_angle_left_rad), float(odo.wheel_angle_right_rad)]
        joints.velocity = [
            float(odo.wheel_velocity_left_rad_s),
            float(odo.wheel_velocity_right_rad_s),
        ]
        self._publish("joint_states", self.joint_pub, joints)

        if p.tf_source == "wheel":
            self._publish_odom_tf(stamp, odo.x_m, odo.y_m, odo.yaw_rad)

    def on_filtered(self, t_s: float, state: EkfState) -> None:
        """For each 30 Hz EKF output: /odometry/filtered (and /tf when ``tf_source`` is
        ``filtered``), stamped ``t_s``; covariances are the diagonal of P."""
        if not state.initialized or self._stop.is_set():
            return
        p, m = self.params, self._msgs
        stamp = self._stamp(t_s)
        d = state.covariance_diagonal  # x, y, yaw, vx, vy, vyaw, ax
        msg = m.Odometry()
        msg.header.stamp = stamp
        msg.header.frame_id = p.odom_frame
        msg.child_frame_id = p.base_frame
        self._set_pose(msg, state.x_m, state.y_m, state.yaw_rad)
        msg.pose.covariance = diagonal_covariance(d[0], d[1], 0.0, 0.0, 0.0, d[2])
        msg.twist.twist.linear.x = float(state.vx_m_s)
        msg.twist.twist.linear.y = float(state.vy_m_s)
        msg.twist.twist.angular.z = float(state.vyaw_rad_s)
        msg.twist.covariance = diagonal_covariance(d[3], d[4], 0.0, 0.0, 0.0, d[5])
        self._publish("filtered", self.filtered_pub, msg)
        if p.tf_source == "filtered":
            self._publish_odom_tf(stamp, state.x_m, state.y_m, state.yaw_rad)

    def diagnostics(self, values: DiagnosticValues) -> bool:
        """Publish /diagnostics at most once per second of MCU time; True when it did.

        Four statuses: the link (its state, frames lost, CRC errors, resyncs, MCU resets, NACKs,
        I2C errors, the interlock: WARN naming what went wrong since the start, ERROR when
        down), the IMU, the EKF (rejected measurements) and the command watchdog.
        """
        m = self._msgs
        if self.diagnostics_pub is None or self._stop.is_set():
            return False
        if self._next_diagnostics_s is not None and values.t_s < self._next_diagnostics_s - 1e-9:
            return False
        self._next_diagnostics_s = values.t_s + DIAGNOSTICS_PERIOD_S
        hw = "jackson"
        if not values.link_up:
            link_level, link_text = LEVEL_ERROR, "down"
        elif values.problems:
            link_level, link_text = LEVEL_WARN, "up; " + "; ".join(values.problems)
        else:
            link_level, link_text = LEVEL_OK, "up"
        link = self._status(
            "jackson: link",
            hw,
            link_level,
            link_text,
            frames=values.frames,
            crc_errors=values.crc_errors,
            **{k: v for k, v in values.link if k not in ("crc_errors",)},
        )
        imu_level = (
            LEVEL_ERROR
            if not values.imu_ok
            else (LEVEL_OK if values.imu_calibrated else LEVEL_WARN)
        )
        imu_text = "ok" if values.imu_ok else "no data"
        if values.imu_ok and not values.imu_calibrated:
            imu_text = "not calibrated"
        imu = self._status(
            "jackson: imu",
            hw,
            imu_level,
            imu_text,
            imu_ok=values.imu_ok,
            imu_calibrated=values.imu_calibrated,
        )
        rejected = sum(n for _, n in values.rejected)
        ekf = self._status(
            "jackson: ekf",
            hw,
            LEVEL_OK if rejected == 0 else LEVEL_WARN,
            f"{rejected} rejected measurements",
            **{f"rejected_{name}": n for name, n in values.rejected},
        )
        watchdog = self._status(
            "jackson: command watchdog",
            hw,
            LEVEL_OK,
            "expired: braked" if values.watchdog_expired else "commanded",
            expired=values.watchdog_expired,
            braked=values.braked,
        )
        arr = m.DiagnosticArray()
        arr.header.stamp = self._stamp(values.t_s)
        arr.status = [link, imu, ekf, watchdog]
        self._publish("diagnostics", self.diagnostics_pub, arr)
        return True

    def publish_static_transforms(self) -> None:
        """base_footprint -> base_link -> {imu_link, laser}, latched on /tf_static."""
        if self.tf_static_pub is None:
            return
        p = self.params
        zero = self._stamp(0.0)
        msg = self._msgs.TFMessage()
        msg.transforms = [
            self._transform(zero, p.base_frame, p.base_link_frame, *p.base_link_offset_m),
            self._transform(zero, p.base_link_frame, p.imu_frame, *p.imu_offset_m),
            self._transform(zero, p.base_link_frame, p.laser_frame, *p.laser_offset_m),
        ]
        self._publish("tf_static", self.tf_static_pub, msg)

    # ------------------------------------------------------------------ helpers

    def _stamp(self, t_s: float) -> Any:
        sec, nanosec = stamp_parts(t_s)
        return self._msgs.Time(sec=sec, nanosec=nanosec)

    @staticmethod
    def _set_pose(msg: Any, x_m: float, y_m: float, yaw_rad: float) -> None:
        pose = msg.pose.pose
        pose.position.x, pose.position.y = float(x_m), float(y_m)
        q = yaw_quaternion(float(yaw_rad))
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = q

    def _transform(
        self,
        stamp: Any,
        parent: str,
        child: str,
        x_m: float,
        y_m: float,
        z_m: float,
        yaw_rad: float = 0.0,
    ) -> Any:
        tf = self._msgs.TransformStamped()
        tf.header.stamp = stamp
        tf.header.frame_id = parent
        tf.child_frame_id = child
        tr = tf.transform.translation
        tr.x, tr.y, tr.z = float(x_m), float(y_m), float(z_m)
        rot = tf.transform.rotation
        rot.x, rot.y, rot.z, rot.w = yaw_quaternion(yaw_rad)
        return tf

    def _publish_odom_tf(self, stamp: Any, x_m: float, y_m: float, yaw_rad: float) -> None:
        if self.tf_pub is None:
            return
        msg = self._msgs.TFMessage()
        p = self.params
        msg.transforms = [
            self._transform(stamp, p.odom_frame, p.base_frame, x_m, y_m, 0.0, yaw_rad)
        ]
        self._publish("tf", self.tf_pub, msg)

    def _status(self, name: str, hardware_id: str, level: int, message: str, **kv: object) -> Any:
        m = self._msgs
        status = m.DiagnosticStatus()
        status.level = bytes([level])
        status.name = name
        status.hardware_id = hardware_id
        status.message = message
        status.values = [m.KeyValue(key=k, value=str(v)) for k, v in kv.items()]
        return status

    def _publish(self, key: str, publisher: Any, msg: Any) -> None:
        with self._lock:
            if self._stop.is_set():
                return
            publisher.publish(msg)
        self.published[key] = self.published.get(key, 0) + 1


SCAN_PERIOD_S = 0.13465  # [s] the A1M8's turn (REFERENCE: LiDAR)
MAP_PERIOD_S = 5.0  # [s] of MCU time between /map messages while mapping


class _Messages:
    """The message classes, imported when the bridge is built (tf2_msgs and diagnostic_msgs are
    optional)."""

    def __init__(self) -> None:
        from builtin_interfaces.msg import Time
        from geometry_msgs.msg import PoseStamped, TransformStamped, Twist, TwistStamped
        from nav_msgs.msg import OccupancyGrid, Odometry, Path
        from sensor_msgs.msg import Imu, JointState, LaserScan

        self.Time: Any = Time
        self.Odometry: Any = Odometry
        self.Imu: Any = Imu
        self.JointState: Any = JointState
        self.Twist: Any = Twist
        self.TwistStamped: Any = TwistStamped
        self.TransformStamped: Any = TransformStamped
        self.PoseStamped: Any = PoseStamped
        self.OccupancyGrid: Any = OccupancyGrid
        self.Path: Any = Path
        self.LaserScan: Any = LaserScan
        diagnostic = _optional("diagnostic_msgs.msg")
        tf2 = _optional("tf2_msgs.msg")
        self.DiagnosticArray: Any = diagnostic.DiagnosticArray if diagnostic else None
        self.DiagnosticStatus: Any = diagnostic.DiagnosticStatus if diagnostic else None
        self.KeyValue: Any = diagnostic.KeyValue if diagnostic else None
        self.TFMessage: Any = tf2.TFMessage if tf2 else None
