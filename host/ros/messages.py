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
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from rosbags.typesys.stores import ros2_jazzy as jazzy

from jackson.host.core.results import CoreListener, FrameResult
from jackson.host.nav.types import Pose2D
from jackson.host.ros.names import FRAMES, TOPICS
from jackson.protocol import PROTOCOL_VERSION, Frame, Telemetry, TelemetryFlags, crc32c
from jackson.protocol.rplidar import A1M8_SCAN_PERIOD_S
from jackson.protocol.units import accel_m_s2, gyro_rad_s

if TYPE_CHECKING:
    from jackson.host.config import HostConfig
    from jackson.host.control.base import Mission
    from jackson.host.control.navigate import NavigateMission
    from jackson.host.estimation.ekf import EkfState
    from jackson.host.estimation.odometry import OdometryCovariance, OdometryState
    from jackson.host.nav.types import Scan
    from jackson.host.service.goals import GoalRecord

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

NS_PER_S = 1_000_000_000
LEVEL_OK, LEVEL_WARN, LEVEL_ERROR = 0, 1, 2  # diagnostic_msgs/DiagnosticStatus levels
# a sensor's health state (docs/health.md) as a diagnostic level
HEALTH_LEVELS = {
    "ok": LEVEL_OK,
    "recovered": LEVEL_OK,
    "suspect": LEVEL_WARN,
    "excluded": LEVEL_ERROR,
}
SCAN_PERIOD_S = A1M8_SCAN_PERIOD_S  # [s] the A1M8's turn (protocol/rplidar.py)
SCAN_RANGE_M = (0.15, 8.0)  # [m] the A1M8's minimum and the robot's software cap
CLOCK_WINDOW_S = 10.0  # [s] of MCU time over which the least transport delay is found
CLOCK_SLEW = 0.1  # the offset in use moves at most this fraction of the MCU time passed
SCAN_TIMER_WINDOW = 200  # revolutions the LiDAR's sample period is fitted over (about 27 s)
SCAN_TIMER_MIN = 30  # revolutions before the fitted period replaces the A1M8's nominal one: the
# frames' 50 ms quantisation then errs by about 0.2 % of it
SCAN_TIMER_SLEW_S = 0.003  # [s] a revolution's end moves at most this far from back to back
SCAN_TIMER_DRIFT_S = 0.0002  # [s] per revolution: how far earlier windows' bounds loosen

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
    sensors : tuple of (str, str)
        Each sensor's health state (docs/health.md), empty without the monitor.
    reasons : tuple of (str, str)
        Why each sensor is in its state ('' while it never left ``ok``).
    lidar : tuple of (str, object)
        The LiDAR's counters as the monitor keeps them (scans, unused, roughness, missing).
    navigation : NavigationValues or None
        The navigation service's state (None without the service).
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
    sensors: tuple[tuple[str, str], ...] = field(default=())
    reasons: tuple[tuple[str, str], ...] = field(default=())
    lidar: tuple[tuple[str, object], ...] = field(default=())
    navigation: NavigationValues | None = None


@dataclass(frozen=True)
class NavigationValues:
    """The navigation service's part of a /diagnostics sample.

    Attributes
    ----------
    state : str
        ``idle``, ``navigating`` or ``teleop``.
    unavailable : str or None
        Why goals are refused now, else None.
    goal : GoalRecord or None
        The active goal.
    last : GoalRecord or None
        The goal that ended last (its status and reason: the last result).
    counts : tuple of (str, int)
        Goals ended so far, per end (succeeded, aborted, canceled, rejected).
    eta_s : float
        Estimated time remaining of the active goal [s] (nan without one).
    """

    state: str
    unavailable: str | None = None
    goal: GoalRecord | None = None
    last: GoalRecord | None = None
    counts: tuple[tuple[str, int], ...] = field(default=())
    eta_s: float = math.nan


def navigation_status(n: NavigationValues) -> tuple[int, str, dict[str, object]]:
    """The ``jackson: navigation`` status: (level, message, key/values). An error while goals
    are refused (sensors or the LiDAR lost), a warning while the last goal's end was an abort
    and no goal is active, else OK."""
    kv: dict[str, object] = {"state": n.state}
    level = LEVEL_OK
    if n.unavailable is not None:
        level, text = LEVEL_ERROR, f"goals refused: {n.unavailable}"
    elif n.goal is not None:
        g = n.goal
        text = f"navigating to goal {g.goal_id} ({g.pose.x:.2f}, {g.pose.y:.2f}) from {g.source}"
    elif n.state == "teleop":
        text = "teleop: velocity commands drive the robot"
    else:
        text = "idle, braked"
    if n.goal is not None:
        g = n.goal
        kv.update(
            goal_id=g.goal_id,
            goal=f"{g.pose.x:.3f}, {g.pose.y:.3f}, {g.pose.yaw:.3f}",
            goal_source=g.source,
            navigation_time_s=f"{g.navigation_time_s:.1f}",
            distance_remaining_m=f"{g.distance_remaining_m:.2f}",
            eta_s=f"{n.eta_s:.1f}",
            recoveries=g.recoveries,
        )
    if n.last is not None:
        last = n.last
        text += f"; last goal {last.goal_id} {last.status.value}: {last.reason}"
        if n.goal is None and last.status.value == "aborted":
            level = max(level, LEVEL_WARN)
        kv.update(
            last_goal_id=last.goal_id,
            last_status=last.status.value,
            last_reason=last.reason,
        )
    kv.update({f"goals_{end}": count for end, count in n.counts})
    return level, text, kv


class StampClock:
    """MCU time to ROS time.

    With ``sim_time`` the stamp is MCU time itself (the twin's /clock is MCU time). Otherwise
    it is MCU time plus an offset onto the host's system clock: the least of
    ``host_receive - mcu`` over the last :data:`CLOCK_WINDOW_S` of MCU time (the transport
    delay only adds, so the least offset is the frame that waited least, and the window
    follows the two clocks' drift). The offset in use moves towards that target by at most
    :data:`CLOCK_SLEW` of the MCU time that passed, so ROS time runs monotonic with MCU time
    (no repeated or reversed stamps) while it settles. :attr:`jitter_s` holds the last
    frames' delays beyond the least one (what a per-frame receive stamp would have carried).

    Parameters
    ----------
    sim_time : bool
        Stamp with MCU time (``use_sim_time``).
    """

    def __init__(self, sim_time: bool) -> None:
        self.sim_time = sim_time
        self._window: deque[tuple[float, int]] = deque()  # (mcu t_s, offset ns), ascending
        self._offset_ns: float | None = None  # in use
        self._at_s = 0.0  # MCU time of the last offset update
        self.jitter_s: deque[float] = deque(maxlen=1000)

    @property
    def offset_s(self) -> float | None:
        """The offset in use, ROS time less MCU time [s] (None before the first frame)."""
        return None if self._offset_ns is None else self._offset_ns / NS_PER_S

    def observe(self, t_s: float, host_ns: int) -> None:
        """A frame of MCU time ``t_s`` received at ``host_ns`` of the host's system clock."""
        if self.sim_time:
            return
        off = host_ns - round(t_s * NS_PER_S)
        w = self._window
        while w and w[-1][1] >= off:  # a monotonic deque: the minimum is at the front
            w.pop()
        w.append((t_s, off))
        while w[0][0] < t_s - CLOCK_WINDOW_S:
            w.popleft()
        target = float(w[0][1])
        if self._offset_ns is None:
            self._offset_ns = target
        else:
            room = CLOCK_SLEW * max(0.0, t_s - self._at_s) * NS_PER_S
            self._offset_ns += min(room, max(-room, target - self._offset_ns))
        self._at_s = max(self._at_s, t_s)
        self.jitter_s.append((off - target) / NS_PER_S)

    @property
    def ready(self) -> bool:
        """Whether MCU time maps onto ROS time yet (always with ``sim_time``)."""
        return self.sim_time or self._offset_ns is not None

    def ns(self, t_s: float) -> int:
        """The ROS time [ns] of MCU time ``t_s`` (0 before the first frame on the robot)."""
        mcu = max(0, round(t_s * NS_PER_S))
        if self.sim_time:
            return mcu
        if self._offset_ns is None:
            return 0
        return mcu + round(self._offset_ns)


class ScanTimer:
    """When each LiDAR revolution was measured, on MCU time.

    The host reads the LiDAR's port at each telemetry frame, so a revolution that arrives alone
    with a frame is known to have ended between the previous frame and that one (its window):
    on the twin in lockstep exactly, on the robot give or take the bytes' way over USB. A
    spinning LiDAR's revolutions follow each other back to back, each lasting its samples
    times the sample period, so the timer keeps a timeline of their ends and lets the windows
    correct only its phase, a little at a time:

    - the sample period is the least-squares slope of the windows' ends over the samples
      counted, over the last :data:`SCAN_TIMER_WINDOW` revolutions that came alone since the
      last gap, once :data:`SCAN_TIMER_MIN` have (the frames' quantisation averages out);
      before the first fit, a revolution lasts the A1M8's :data:`SCAN_PERIOD_S`;
    - each end is predicted as the previous end plus this revolution's duration; the windows
      of the last revolutions are intersected (each bounds where the timeline's phase may be,
      loosened by :data:`SCAN_TIMER_DRIFT_S` a revolution), and the prediction moves towards
      the middle of what they allow by at most :data:`SCAN_TIMER_SLEW_S`: consecutive stamps
      are one revolution apart within it from the first, while the phase settles;
    - a window half a period or more past the prediction (revolutions lost: nothing came for
      them) moves the timeline on by whole revolutions, and the revolution after the gap lasts
      as the one before it (its first samples may be the lost turn's); windows that disagree
      with all before (the robot's bytes late) start the intersection again;
    - revolutions that arrive together with one frame cannot all have ended in its window:
      the pairing is lost (a lockstep twin that ran on in real time while the host was kept
      from reading, a port read late); they follow back to back and tell nothing of the phase.
      Before the timeline has a phase (the first revolutions, or a first frame that brought
      several) they are held, and stamped back to back before the first revolution that comes
      alone in a window; held revolutions that cannot have followed each other up to it (the
      first would have started before the MCU's clock did, at time 0: some were lost between
      them) start at the frame the first of them came with instead, so no stamp is 0.

    The stamp (the LaserScan convention) is the revolution's first measurement: its end less
    its duration.
    """

    def __init__(self) -> None:
        self._points: deque[tuple[float, int]] = deque(maxlen=SCAN_TIMER_WINDOW)
        self._sample_s = 0.0  # the last fit of the sample period [s] (0: none yet)
        self._last_duration_s = SCAN_PERIOD_S  # the last revolution's
        self._samples = 0  # samples of the revolutions stamped (the fit's abscissa)
        self._end_s: float | None = None  # the last revolution's end on the timeline
        self._held: list[int] = []  # samples of revolutions waiting for the timeline's phase
        self._held_since_s = 0.0  # the frame the first of them came with
        # the corrections of the last end that the windows allow (low, high) [s]; None: unknown
        self._allowed: tuple[float, float] | None = None

    def sample_s(self) -> float:
        """The sample period [s]: fitted over the revolutions that came alone since the last
        gap once :data:`SCAN_TIMER_MIN` have, else the fit before the gap (0: none yet)."""
        pts = self._points
        if len(pts) >= SCAN_TIMER_MIN:
            t = np.fromiter((p[0] for p in pts), np.float64, len(pts))
            n = np.fromiter((p[1] for p in pts), np.float64, len(pts))
            n -= n.mean()
            spread = float(n @ n)
            if spread > 0.0:
                self._sample_s = float(n @ (t - t.mean())) / spread
        return self._sample_s

    def _gap(self) -> None:
        """Revolutions lost, or their pairing with the frames: the sample count no longer
        tells the time since the earlier windows, whose fit is kept until a new one has
        enough."""
        self._points.clear()
        self._allowed = None

    def _duration(self, samples: int) -> float:
        per = self.sample_s()
        return per * samples if per > 0.0 else SCAN_PERIOD_S

    def stamp(
        self, samples: Sequence[int], arrived_s: float, since_s: float | None
    ) -> list[tuple[float, float]]:
        """(start [s], duration [s]) of each revolution held so far and of ``samples``, the
        revolutions that arrived with the frame of MCU time ``arrived_s`` (their sample
        counts, in order), the previous frame being at ``since_s`` (None: none); empty while
        they are held."""
        if not samples:
            return []
        alone = len(samples) == 1 and since_s is not None and since_s < arrived_s
        if self._end_s is None:
            if not self._held:
                self._held_since_s = arrived_s
            self._held += samples
            return self._anchor(arrived_s, since_s) if alone else []
        out = []
        for n in samples:
            duration = self._duration(n)
            end = self._end_s + duration
            if alone:
                assert since_s is not None
                end, duration = self._correct(end, duration, n, since_s, arrived_s)
                self._points.append((arrived_s, self._samples + n))
            else:  # the window said nothing true
                self._gap()
            self._samples += n
            self._end_s, self._last_duration_s = end, duration
            out.append((end - duration, duration))
        return out

    def _anchor(self, arrived_s: float, since_s: float | None) -> list[tuple[float, float]]:
        """The first revolution alone in a window ends at the window's end; the revolutions
        held before it end back to back before it."""
        durations = [self._duration(n) for n in self._held]
        ends = arrived_s - np.concatenate((np.cumsum(durations[:0:-1])[::-1], [0.0]))
        first_start = float(ends[0]) - durations[0]
        if first_start <= 0.0:  # they cannot all have followed each other: some were lost
            ends += max(self._held_since_s, first_start) - first_start
        lo = since_s if since_s is not None else -math.inf
        self._allowed = (lo - arrived_s, 0.0)
        self._samples = sum(self._held)
        if ends[-1] == arrived_s:
            self._points.append((arrived_s, self._samples))
        else:
            self._gap()
        self._end_s, self._last_duration_s = float(ends[-1]), durations[-1]
        self._held = []
        return [(float(e) - d, d) for e, d in zip(ends, durations, strict=True)]

    def _correct(
        self, end: float, duration: float, samples: int, since_s: float, arrived_s: float
    ) -> tuple[float, float]:
        """(end, duration) of a revolution alone in the window (since_s, arrived_s], predicted
        to end at ``end``."""
        low, high = since_s - end, arrived_s - end  # the corrections this window allows
        if low >= 0.5 * duration:  # revolutions lost: the timeline moves on by whole turns
            # the samples before the gap that this revolution holds (the lost turn's first,
            # sent with the turn before it) are not this turn's: it lasts as the one before
            turn = self._last_duration_s
            lost = math.floor(low / turn + 0.5)
            end += lost * turn + turn - duration
            duration = turn
            low, high = since_s - end, arrived_s - end
            self._gap()
        if self._allowed is not None:
            a_low = self._allowed[0] - SCAN_TIMER_DRIFT_S
            a_high = self._allowed[1] + SCAN_TIMER_DRIFT_S
            if max(low, a_low) <= min(high, a_high):
                low, high = max(low, a_low), min(high, a_high)
        step = min(SCAN_TIMER_SLEW_S, max(-SCAN_TIMER_SLEW_S, 0.5 * (low + high)))
        self._allowed = (low - step, high - step)
        return end + step, duration


def planar_pose(pose: Any) -> Pose2D:
    """A geometry_msgs/Pose (any object with ``position`` and ``orientation``) as a planar
    pose: its x, y and its rotation's yaw."""
    q = pose.orientation
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    return Pose2D(float(pose.position.x), float(pose.position.y), yaw)


def yaw_quaternion(yaw_rad: float) -> Quaternion:
    """A rotation by ``yaw_rad`` about z."""
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw_rad / 2.0), w=math.cos(yaw_rad / 2.0))


def planar_covariance(*diagonal: float) -> np.ndarray[Any, np.dtype[np.float64]]:
    """A row-major 6x6 covariance with (x, y, z, roll, pitch, yaw) ``diagonal``."""
    cov = np.zeros(36, dtype=np.float64)
    for i, v in enumerate(diagonal):
        cov[7 * i] = float(v)
    return cov


def wire_bytes(frame: Frame) -> bytes:
    """The frame as it was on the wire (a delivered frame has this version and a valid CRC)."""
    import struct

    body = bytes((PROTOCOL_VERSION, frame.type, frame.seq, len(frame.payload))) + frame.payload
    return b"\xa5\x5a" + body + struct.pack("<I", crc32c(body))


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
        self.odom_pose_cov = planar_covariance(
            odometry.pose_xy, odometry.pose_xy, 0.0, 0.0, 0.0, odometry.pose_yaw
        )
        self.odom_twist_cov = planar_covariance(
            odometry.twist_vx, odometry.twist_vy, 0.0, 0.0, 0.0, odometry.twist_wz
        )

    def header(self, t_s: float, frame_id: str) -> Header:
        """A header stamped with the ROS time of MCU time ``t_s``."""
        ns = self.clock.ns(t_s)
        return Header(stamp=Time(sec=ns // NS_PER_S, nanosec=ns % NS_PER_S), frame_id=frame_id)

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
        """An Odometry odom -> base_footprint with (vx, vy, w) and the two covariances."""
        s = self.settings
        return Odometry(
            header=self.header(t_s, s.odom_frame),
            child_frame_id=s.base_frame,
            pose=PoseWithCovariance(
                pose=Pose(
                    position=Point(x=float(x), y=float(y), z=0.0),
                    orientation=yaw_quaternion(float(yaw)),
                ),
                covariance=pose_cov.copy(),
            ),
            twist=TwistWithCovariance(
                twist=Twist(
                    linear=Vector3(x=float(twist[0]), y=float(twist[1]), z=0.0),
                    angular=Vector3(x=0.0, y=0.0, z=float(twist[2])),
                ),
                covariance=twist_cov.copy(),
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
        s = self.settings
        orientation_cov = np.zeros(9, dtype=np.float64)
        orientation_cov[0] = -1.0  # REP 145: no orientation estimate
        return Imu(
            header=self.header(t_s, s.imu_frame),
            orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=orientation_cov,
            angular_velocity=Vector3(x=float(gyro[0]), y=float(gyro[1]), z=float(gyro[2])),
            angular_velocity_covariance=np.eye(3).ravel() * s.imu_angular_velocity_covariance,
            linear_acceleration=Vector3(x=float(accel[0]), y=float(accel[1]), z=float(accel[2])),
            linear_acceleration_covariance=np.eye(3).ravel() * s.imu_linear_acceleration_covariance,
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

    def odom_tf(self, t_s: float, x: float, y: float, yaw: float) -> Any:
        """/tf: odom -> base_footprint."""
        s = self.settings
        return TFMessage(
            transforms=[self.transform(t_s, s.odom_frame, s.base_frame, (x, y, 0.0), yaw)]
        )

    def wheel_tf(self, t_s: float, odo: OdometryState) -> Any:
        """/tf: base_link -> each wheel's link, turned about +y by the wheel's angle."""
        s = self.settings
        out = []
        for child, y, angle in (
            (s.left_wheel_frame, 0.5 * s.wheel_separation_m, odo.wheel_angle_left_rad),
            (s.right_wheel_frame, -0.5 * s.wheel_separation_m, odo.wheel_angle_right_rad),
        ):
            half = 0.5 * float(angle)
            out.append(
                TransformStamped(
                    header=self.header(t_s, s.base_link_frame),
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
        """/scan in the laser frame: one revolution, evenly spread over its angles, stamped
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
            ranges=np.asarray(scan.ranges_m, dtype=np.float32),
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
        health, reasons = dict(v.sensors), dict(v.reasons)

        def judged(sensor: str) -> tuple[int, str]:
            """The monitor's level of a sensor and what to say of it ('' while it is ok)."""
            state = health.get(sensor)
            if state is None or state == "ok":
                return LEVEL_OK, ""
            why = reasons.get(sensor, "")
            return HEALTH_LEVELS.get(state, LEVEL_WARN), f"{state}: {why}" if why else state

        if not v.link_up:
            link_level, link_text = LEVEL_ERROR, "down"
        elif v.problems:
            link_level, link_text = LEVEL_WARN, "up; " + "; ".join(v.problems)
        else:
            link_level, link_text = LEVEL_OK, "up"
        level, text = judged("link")
        link_level, link_text = max(link_level, level), link_text + (f"; {text}" if text else "")
        imu_level = LEVEL_ERROR if not v.imu_ok else (LEVEL_OK if v.imu_calibrated else LEVEL_WARN)
        imu_text = "ok" if v.imu_ok else "no data"
        if v.imu_ok and not v.imu_calibrated:
            imu_text = "not calibrated"
        level, text = judged("imu")
        imu_level, imu_text = max(imu_level, level), imu_text + (f"; {text}" if text else "")
        monitor = {"health": health["link"]} if "link" in health else {}
        rejected = sum(n for _, n in v.rejected)
        statuses = [
            self.status(
                "jackson: link",
                link_level,
                link_text,
                frames=v.frames,
                crc_errors=v.crc_errors,
                **{k: x for k, x in v.link if k != "crc_errors"},
                **monitor,
            ),
            self.status(
                "jackson: imu",
                imu_level,
                imu_text,
                imu_ok=v.imu_ok,
                imu_calibrated=v.imu_calibrated,
                **({"health": health["imu"]} if "imu" in health else {}),
            ),
        ]
        if "encoder_left" in health:  # the monitor runs
            sides = [(side, *judged(f"encoder_{side}")) for side in ("left", "right")]
            said = [f"{side} {text}" for side, _, text in sides if text]
            statuses.append(
                self.status(
                    "jackson: encoders",
                    max(level for _, level, _ in sides),
                    "; ".join(said) if said else "ok",
                    left=health["encoder_left"],
                    right=health["encoder_right"],
                )
            )
        if "lidar" in health:
            level, text = judged("lidar")
            counts = dict(v.lidar)
            if not text:
                scans = counts.get("scans", 0)
                text = f"ok, {scans} scans" if scans else "no scans (no LiDAR read)"
            statuses.append(
                self.status("jackson: lidar", level, text, health=health["lidar"], **counts)
            )
        statuses += [
            self.status(
                "jackson: ekf",
                LEVEL_OK if rejected == 0 else LEVEL_WARN,
                f"{rejected} rejected measurements",
                **{f"rejected_{name}": n for name, n in v.rejected},
            ),
            self.status(
                "jackson: command watchdog",
                LEVEL_OK,
                "expired: braked" if v.watchdog_expired else "commanded",
                expired=v.watchdog_expired,
                braked=v.braked,
            ),
        ]
        clock = self.clock
        if not clock.sim_time and clock.offset_s is not None and clock.jitter_s:
            jitter = np.asarray(clock.jitter_s) * 1e3
            p50, p99 = (float(x) for x in np.percentile(jitter, [50, 99]))
            statuses.append(
                self.status(
                    "jackson: clock",
                    LEVEL_OK,
                    f"MCU time + {clock.offset_s:.6f} s; receive jitter p50 {p50:.2f} ms, "
                    f"p99 {p99:.2f} ms",
                    offset_s=f"{clock.offset_s:.6f}",
                    jitter_p50_ms=f"{p50:.3f}",
                    jitter_p99_ms=f"{p99:.3f}",
                    jitter_max_ms=f"{float(jitter.max()):.3f}",
                )
            )
        if v.navigation is not None:
            level, text, kv = navigation_status(v.navigation)
            statuses.append(self.status("jackson: navigation", level, text, **kv))
        return DiagnosticArray(header=self.header(v.t_s, ""), status=statuses)


def navigation_of(mission: Mission | None) -> NavigateMission | None:
    """The navigation a mission drives with, whose plans, map -> odom and map the navigation
    topics show: a one-shot navigation (``--goal``) is its own; the navigation service keeps
    one for its whole run (``NavigationService.nav``); other missions have none."""
    from jackson.host.control.navigate import NavigateMission
    from jackson.host.service.navigation import NavigationService

    if isinstance(mission, NavigationService):
        return mission.nav
    if isinstance(mission, NavigateMission):
        return mission
    return None


class RosSink(Protocol):
    """Where :class:`RosOutput` sends each message: a bag, the live node."""

    def write(self, key: str, t_s: float, msg: Any) -> None:
        """One message of the topic with key ``key`` (:data:`TOPIC_TYPES`) at MCU time."""
        ...


class RosOutput(CoreListener):
    """The core's listener that builds every message once and sends it to every sink.

    Parameters
    ----------
    builder : MessageBuilder
        The messages' builder.
    sinks : sequence of RosSink
        The bag, the live node (either may be absent).
    telemetry : bool
        Also send each received frame's bytes (/jackson/telemetry: the bag's raw record).
    received : deque or None
        Messages the live node received on its own thread, ``(key, value)``, recorded here on
        the core's: ``("goal_pose", (x, y, yaw, frame))``, ``("initialpose", (x, y, yaw,
        frame, covariance))``.
    """

    def __init__(
        self,
        builder: MessageBuilder,
        sinks: Sequence[RosSink],
        *,
        telemetry: bool = True,
        received: deque[tuple[str, Any]] | None = None,
    ) -> None:
        self.builder = builder
        self.sinks = list(sinks)
        self.telemetry = telemetry
        self.received = received
        self._pending: list[bytes] = []
        self._static_sent = False
        self._frame_scans: list[Scan] = []  # this frame's scans, stamped at its result
        self._held_scans: list[Scan] = []  # scans the timer holds until it knows their phase
        self._frames = 0  # frames seen (on_result)
        self.scan_timer = ScanTimer()
        self._plan_version = -1
        self._map_sent_s: float | None = None
        self._t_s = 0.0
        self._t_prev_s: float | None = None  # the frame before the last one
        self._next_diagnostics_s: float | None = None
        self._mission: Mission | None = None  # the last frame's mission
        self._nav: NavigateMission | None = None  # its navigation (navigation_of)

    def send(self, key: str, t_s: float, msg: Any) -> None:
        """Hand one message to every sink."""
        for sink in self.sinks:
            sink.write(key, t_s, msg)

    def _static(self, t_s: float) -> None:
        if not self._static_sent and self.builder.settings.publish_tf:
            self._static_sent = True
            self.send("tf_static", t_s, self.builder.static_tf(t_s))

    def on_frame(self, frame: Frame, host_time_ns: int) -> None:
        if self.telemetry:
            self._pending.append(wire_bytes(frame))

    def on_command(self, v_m_s: float, w_rad_s: float, host_time_ns: int) -> None:
        # taken at the frame that applies it: stamped with the last frame's time
        self.send("cmd_vel", self._t_s, self.builder.twist(self._t_s, v_m_s, w_rad_s))

    def on_result(self, result: FrameResult) -> None:
        b, t_s, odo, t = self.builder, result.t_s, result.odometry, result.telemetry
        self._t_prev_s = self._t_s if self._frames else None
        self._t_s = t_s
        self._frames += 1
        b.clock.observe(t_s, time.time_ns())
        self._static(t_s)
        self._send_scans(t_s)
        while self.received:
            key, value = self.received.popleft()
            if key == "goal_pose":
                x, y, yaw, frame = value
                self.send(key, t_s, b.goal(t_s, x, y, yaw, frame or "map"))
            elif key == "initialpose":
                x, y, yaw, frame, cov = value
                self.send(key, t_s, b.initial_pose(t_s, x, y, yaw, cov, frame or "map"))
        for raw in self._pending:
            self.send("telemetry", t_s, b.raw_frame(raw))
        self._pending.clear()
        if odo is not None:
            self.send("wheel_odom", t_s, b.wheel_odom(t_s, odo))
        if t.flags & TelemetryFlags.IMU_OK:
            self.send("imu", t_s, b.imu(t_s, t))
        if odo is not None:
            self.send("joint_states", t_s, b.joint_states(t_s, odo))
            if b.settings.publish_tf and b.settings.tf_source == "wheel":
                self.send("tf", t_s, b.odom_tf(t_s, odo.x_m, odo.y_m, odo.yaw_rad))
            if b.settings.publish_tf and b.settings.publish_wheel_tf:
                self.send("tf", t_s, b.wheel_tf(t_s, odo))
        self._navigation(result, t_s)

    def on_filtered(self, t_s: float, state: EkfState) -> None:
        if not state.initialized:
            return
        b = self.builder
        self._static(t_s)
        self.send("filtered", t_s, b.filtered(t_s, state))
        if b.settings.publish_tf and b.settings.tf_source == "filtered":
            self.send("tf", t_s, b.odom_tf(t_s, state.x_m, state.y_m, state.yaw_rad))

    def on_scan(self, scan: Scan) -> None:
        if len(scan.angles_rad) >= 2:
            self._frame_scans.append(scan)  # before this frame's result

    def _send_scans(self, t_s: float) -> None:
        """This frame's scans (and those held), stamped together: once the clock is set, and
        knowing how many came with the frame (:class:`ScanTimer`)."""
        if not self._frame_scans:
            return
        since = self._t_prev_s  # the frame before this one (None: this is the first)
        scans, self._frame_scans = self._frame_scans, []
        self._held_scans += scans
        stamps = self.scan_timer.stamp([len(s.angles_rad) for s in scans], t_s, since)
        if not stamps:
            return
        for scan, (start_s, period_s) in zip(self._held_scans, stamps, strict=True):
            self.send("scan", scan.t_s, self.builder.scan(scan, start_s, period_s))
        self._held_scans.clear()

    def diagnostics_due(self, t_s: float) -> bool:
        """Whether :meth:`diagnostics` would send at MCU time ``t_s`` (the daemon gathers the
        values only then: once per second, not every frame).

        Parameters
        ----------
        t_s : float
            MCU time [s].

        Returns
        -------
        bool
            True once :data:`DIAGNOSTICS_PERIOD_S` has passed since the last summary.
        """
        due = self._next_diagnostics_s
        return due is None or t_s >= due - 1e-9

    def diagnostics(self, values: DiagnosticValues) -> bool:
        """The daemon's summary, at most once per :data:`DIAGNOSTICS_PERIOD_S` of MCU time;
        True when it was sent."""
        if not self.diagnostics_due(values.t_s):
            return False
        self._next_diagnostics_s = values.t_s + DIAGNOSTICS_PERIOD_S
        self.send("diagnostics", values.t_s, self.builder.diagnostics(values))
        return True

    def _navigation(self, result: FrameResult, t_s: float) -> None:
        """After a control tick of a navigation mission: /plan (each new global plan),
        /local_plan, map -> odom on /tf, and /map (once on a known map; every
        :data:`MAP_PERIOD_S` while mapping)."""
        if result.mission is not self._mission:  # a new mission: look once what it navigates with
            self._mission = result.mission
            self._nav = navigation_of(result.mission)
        nav = self._nav
        if nav is None:
            return
        b = self.builder
        replans = nav.navigator.replans
        if replans != self._plan_version and len(nav.navigator.plan):
            self.send("plan", t_s, b.path(t_s, nav.navigator.plan))
        self._plan_version = replans
        corr = nav.map_to_odom.compose(nav.config.start)  # odom starts at the start pose
        local = nav.navigator.published_local_plan
        if len(local):  # in odom, as Nav2's controller publishes it: map -> odom undone
            c, s_ = math.cos(corr.yaw), math.sin(corr.yaw)
            dx, dy = local[:, 0] - corr.x, local[:, 1] - corr.y
            in_odom = np.column_stack((c * dx + s_ * dy, -s_ * dx + c * dy, local[:, 2] - corr.yaw))
            self.send("local_plan", t_s, b.path(t_s, in_odom, b.settings.odom_frame))
        if b.settings.publish_tf:
            msg = TFMessage(
                transforms=[
                    b.transform(t_s, "map", b.settings.odom_frame, (corr.x, corr.y, 0.0), corr.yaw)
                ]
            )
            self.send("tf", t_s, msg)
        mapping = nav.mapper is not None
        due = self._map_sent_s is None or (mapping and t_s - self._map_sent_s >= MAP_PERIOD_S)
        grid = nav.built_map() if mapping else nav.static_map
        if due and grid is not None:
            self._map_sent_s = t_s
            self.send("map", t_s, b.occupancy(t_s, grid))


MAP_PERIOD_S = 5.0  # [s] of MCU time between /map messages while mapping
DIAGNOSTICS_PERIOD_S = 1.0  # [s] of MCU time between /diagnostics messages
