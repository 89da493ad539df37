"""The ROS 2 interface of the host daemon: an rclpy node fed by :class:`HostCore`.

The daemon computes; :class:`~jackson.host.ros.messages.RosOutput` builds each message once
(:class:`~jackson.host.ros.messages.MessageBuilder`) for this node and for the run's bag; this
node publishes their CDR bytes and hands ``/cmd_vel`` (and a navigation's inputs) back:

| topic              | type                            | when                         | QoS        |
|--------------------|---------------------------------|------------------------------|------------|
| /wheel/odom        | nav_msgs/Odometry               | every telemetry frame        | rel. 10    |
| /imu/data          | sensor_msgs/Imu                 | every frame with IMU_OK      | b. eff. 5  |
| /joint_states      | sensor_msgs/JointState          | every telemetry frame        | rel. 10    |
| /odometry/filtered | nav_msgs/Odometry               | each 30 Hz EKF output        | rel. 10    |
| /diagnostics       | diagnostic_msgs/DiagnosticArray | 1 Hz of MCU time             | rel. 10    |
| /tf                | tf2_msgs/TFMessage              | with the EKF (or the wheels) | rel. 100   |
| /tf_static         | tf2_msgs/TFMessage              | once                         | latched 1  |
| /scan              | sensor_msgs/LaserScan           | each LiDAR revolution        | b. eff. 5  |
| /map, /plan, /local_plan | nav_msgs                  | navigation missions          | docs       |
| /cmd_vel (in)      | geometry_msgs/Twist[Stamped]    | to ``core.submit_velocity``  | rel. 1     |
| /goal_pose (in)    | geometry_msgs/PoseStamped       | a navigation's next goal     | rel. 1     |
| /initialpose (in)  | geometry_msgs/PoseWithCov.St.   | the service: ``set_pose``    | rel. 1     |
| navigate_to_pose   | nav2_msgs/action/NavigateToPose | the service's goals (action) | default    |

With the navigation service (``jackson daemon --lidar --map``) ``/goal_pose`` and the
``navigate_to_pose`` action submit goals to it, ``/initialpose`` relocalises it, and
/diagnostics carries its state; a one-shot navigation (``--goal``) takes ``/goal_pose`` as its
next goal. Either way /plan, /local_plan, map -> odom and /map show its navigator
(:func:`~jackson.host.ros.messages.navigation_of`).

Stamps follow the node's ``use_sim_time``: true (the twin, which publishes /clock on MCU
time), MCU time itself; false (the robot), MCU time mapped onto the host's system clock
(:class:`~jackson.host.ros.messages.StampClock`), the clock a wall-stamped LiDAR driver uses.
A topic whose message package is missing (tf2_msgs on a bare install) is listed in
:attr:`RosBridge.missing` and named once by the daemon.

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
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, cast

from jackson.common.lazy import instance_of
from jackson.common.ros_env import missing_ros
from jackson.common.threads import guard
from jackson.host.ros import cdr, messages
from jackson.host.ros.live_parameters import (
    ParameterError,
    changed_settings,
    declare_live_parameters,
    declare_node_parameters,
)
from jackson.host.ros.messages import (
    TOPIC_TYPES,
    DiagnosticValues,
    NavigationValues,
    RosSettings,
    StampClock,
    navigation_of,
    planar_pose,
)
from jackson.host.ros.qos import (
    cmd_vel_qos,
    map_qos,
    odometry_qos,
    sensor_qos,
    tf_qos,
    tf_static_qos,
)
from jackson.protocol import Telemetry, TelemetryFlags

if TYPE_CHECKING:
    from jackson.host.config import HostConfig
    from jackson.host.control.base import Mission
    from jackson.host.core import HostCore
    from jackson.host.core.settings import LiveSettings
    from jackson.host.estimation.odometry import OdometryState
    from jackson.host.ros.navigate_action import NavigateToPoseServer
    from jackson.host.service.navigation import NavigationService

SPIN_TIMEOUT_S = 0.1  # [s] an executor wait; bounds how long stop() takes
# threads of the executor with the navigation service: the subscriptions' callbacks, and one
# per navigate_to_pose goal waiting for its end (a preempted one ends within a frame)
EXECUTOR_THREADS = 4
MAP_FRAME = "map"  # the frame of goals and initial poses (the service's map)

# The packages the bridge needs (import name -> what provides it with the PyPI wheels).
REQUIRED_MODULES = ("rclpy", "nav_msgs.msg", "sensor_msgs.msg", "geometry_msgs.msg")
OPTIONAL_MODULES = ("diagnostic_msgs.msg", "tf2_msgs.msg")


class CoreLike(Protocol):
    """What the bridge uses of the daemon's core (:class:`HostCore` is one): its configuration
    and state to read, and its front doors for velocity commands and live settings."""

    cfg: HostConfig

    @property
    def t_s(self) -> float | None: ...

    @property
    def last_odometry(self) -> OdometryState | None: ...

    @property
    def mission(self) -> Mission | None: ...

    @property
    def settings(self) -> LiveSettings: ...

    def submit_velocity(self, v_m_s: float, w_rad_s: float, host_time_ns: int = 0) -> None: ...

    def request_settings(self, settings: LiveSettings) -> None: ...


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
    q = messages.yaw_quaternion(yaw_rad)
    return q.x, q.y, q.z, q.w


def navigation_values(service: NavigationService) -> NavigationValues:
    """The navigation service's state for /diagnostics (its snapshots: any thread)."""
    st = service.status
    history = service.book.history()
    return NavigationValues(
        state=st.state.value,
        unavailable=st.unavailable,
        goal=st.goal,
        last=history[-1] if history else None,
        counts=tuple(service.book.counts.items()),
        eta_s=st.eta_s,
    )


class LinkFacts(Protocol):
    """What the diagnostics read of the daemon's link record (``jackson.host.daemon_link.
    LinkHealth``, a dataclass whose fields are all published)."""

    __dataclass_fields__: ClassVar[dict[str, Any]]

    @property
    def link_up(self) -> bool: ...

    @property
    def crc_errors(self) -> int: ...

    def problems(self) -> list[str]: ...


def diagnostic_values(
    core: HostCore, telemetry: Telemetry | None, *, link: LinkFacts
) -> DiagnosticValues:
    """The diagnostics of a running core; ``link`` is the daemon's ``LinkHealth``."""
    t_s = core.t_s or 0.0
    flags = telemetry.flags if telemetry is not None else 0
    hm = core.health
    service = (
        cast("NavigationService", core.mission)
        if instance_of(core.mission, "jackson.host.service.navigation", "NavigationService")
        else None
    )
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
        sensors=tuple((name, state.value) for name, state in hm.sensors.items())
        if hm is not None
        else (),
        reasons=tuple((name, hm.reason(name)) for name in hm.sensors) if hm is not None else (),
        lidar=(
            *hm.lidar_counts.items(),
            ("roughness_m", f"{hm.lidar_roughness_m:.4f}"),
            ("missing_fraction", f"{hm.lidar_missing:.3f}"),
        )
        if hm is not None
        else (),
        navigation=navigation_values(service) if service is not None else None,
    )


def _message_class(ros_type: str) -> Any:
    """The rclpy message class of ``pkg/msg/Type``, or None where its package is missing."""
    pkg, _, name = ros_type.split("/")
    module = _optional(f"{pkg}.msg")
    return getattr(module, name, None) if module is not None else None


# ---------------------------------------------------------------------------------- the node

BridgeParameters = RosSettings  # the node's parameters (docs/ros2.md)

QOS = {
    "reliable": odometry_qos,
    "sensor": sensor_qos,
    "latched": tf_static_qos,
    "map": map_qos,
}
INPUTS = ("cmd_vel", "goal_pose", "initialpose")  # topics it receives: recorded, not published
NOT_PUBLISHED = ("telemetry",)  # the raw frames are the bag's own record


CLOCK_DISCOVERY_S = 3.0  # [s] the node looks this long for a /clock publisher with no other node
# [s] the other nodes' publishers known and unchanged this long: no /clock. Longer than Fast
# DDS's 3 s participant announcement period, so a participant whose first announcements a
# loaded machine missed (the twin's, started before the daemon) is heard again within it
CLOCK_ENDPOINTS_S = 3.5
CLOCK_DISCOVERY_MAX_S = 15.0  # [s] the longest the search lasts while other nodes are found


class RosBridge:
    """The daemon's ROS 2 node: publishes the messages :class:`RosOutput` built, feeds the core
    /cmd_vel, and a navigation its goals (/goal_pose; with the service ``navigate_to_pose``
    and /initialpose too).

    A sink of :class:`~jackson.host.ros.messages.RosOutput`: :meth:`write` publishes a built
    message's CDR bytes on its topic, the same bytes' message the run's bag records. The rclpy
    node is :attr:`node` (the same API on Humble and Jazzy). It has its own rclpy context and
    installs no signal handlers: the daemon's SIGINT/SIGTERM handlers stay in charge and end
    with :meth:`stop`. :meth:`write` may be called from the daemon's thread while
    :meth:`start`'s executor thread runs the subscriptions' callbacks (with the service, a
    multi-threaded executor: each ``navigate_to_pose`` goal waits for its end on a thread).

    Parameters
    ----------
    core : CoreLike
        The daemon's core; its configuration gives the defaults of the covariances and the
        base_link height, and /cmd_vel goes to its ``submit_velocity``. A one-shot navigation
        mission of it (``--goal``) takes /goal_pose as its next goal.
    node_name, namespace : str
        Of the node.
    args : sequence of str, optional
        Command-line arguments for rclpy (``--ros-args -p cmd_vel_stamped:=true -r ...``).
    parameter_overrides : mapping, optional
        Parameter values that replace the defaults (tests, the daemon's configuration).
    service : NavigationService, optional
        The daemon's navigation service: /goal_pose and ``navigate_to_pose`` submit goals to
        it, /initialpose sets its pose.
    say : callable, optional
        One line for the operator (a goal or a pose refused); default: the node's logger.
        Such lines also go to the node's logger (/rosout).
    """

    def __init__(
        self,
        core: CoreLike,
        *,
        node_name: str = "jackson_host",
        namespace: str = "",
        args: Sequence[str] | None = None,
        parameter_overrides: Mapping[str, Any] | None = None,
        service: NavigationService | None = None,
        say: Callable[[str], None] | None = None,
    ) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        from rclpy.signals import SignalHandlerOptions

        from jackson.host.ros.msgtypes import typestore

        self.core = core
        self.service = service
        self._say = say
        self._stop = threading.Event()
        # messages received on the executor's threads, recorded on the core's (the bag's)
        self.received: deque[tuple[str, Any]] = deque()
        self.action: NavigateToPoseServer | None = None
        self._store = typestore()
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
            self.settings = declare_node_parameters(self.node, core.cfg)
            live = declare_live_parameters(self.node, core.settings)
            if live is not core.settings:  # given at start: in force from the first frame
                core.request_settings(live)
            self.node.add_on_set_parameters_callback(self._on_set_parameters)
            sim_time = bool(self.node.get_parameter("use_sim_time").value)
            self.notes: list[str] = []  # what the operator should know of the node's set-up
            given = any("use_sim_time" in str(a) for a in (args or ())) or (
                "use_sim_time" in (parameter_overrides or {})
            )
            self.discovery = ""  # what the /clock search saw (the operator's note without one)
            self._clock_given = given
            if not given and self._clock_published(CLOCK_DISCOVERY_S):
                # a simulator (jackson sim --ros) runs the clock: one clock for every stamp
                self.node.set_parameters([parameter("use_sim_time", value=True)])
                sim_time = True
                self.notes.append(
                    "ROS: /clock is published (a simulator): stamping with it "
                    "(use_sim_time true; give -p use_sim_time:=false to keep the system clock)"
                )
            elif not given and self.discovery:
                self.notes.append(f"ROS: no /clock publisher: {self.discovery}")
            self.clock = StampClock(sim_time=sim_time)
            self._create_interfaces()
        except BaseException:
            self.context.try_shutdown()
            raise
        self.executor: Any = (
            MultiThreadedExecutor(num_threads=EXECUTOR_THREADS, context=self.context)
            if self.action is not None
            else SingleThreadedExecutor(context=self.context)
        )
        self.executor.add_node(self.node)
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self.commands_received = 0
        self.published: dict[str, int] = {}

    # ------------------------------------------------------------------ set-up

    def _clock_published(self, wait_s: float) -> bool:
        """Whether some node publishes /clock, looked for during discovery: found as soon as
        it is known. Given up at ``wait_s`` when no other node appears at all; when others
        do, once every one of them has its publishers known (a node has at least /rosout and
        /parameter_events) and none was added for :data:`CLOCK_ENDPOINTS_S`, or at
        :data:`CLOCK_DISCOVERY_MAX_S` (a loaded machine discovers slowly: a simulator found
        late would leave the stamps on the wrong clock)."""
        start = time.monotonic()
        own = (self.node.get_name(), self.node.get_namespace())
        settled_since: float | None = None
        known: dict[tuple[str, str], int] = {}
        while True:
            if self.node.count_publishers("/clock") > 0:
                return True
            now = time.monotonic()
            others = {n for n in self.node.get_node_names_and_namespaces() if n != own}
            if not others:
                if now - start >= wait_s:
                    return False
            else:
                # every other node with its publishers known (at least /rosout), their count
                # unchanged for CLOCK_ENDPOINTS_S: discovery has settled without a /clock
                seen = {n: self._publishers_known(*n) for n in others}
                if not all(seen.values()) or seen != known:
                    settled_since = None
                elif settled_since is None:
                    settled_since = now
                known = seen
                ended = settled_since is not None and now - settled_since >= CLOCK_ENDPOINTS_S
                if ended or now - start >= CLOCK_DISCOVERY_MAX_S:
                    names = ", ".join(sorted(f"{ns.rstrip('/')}/{n}" for n, ns in others))
                    self.discovery = (
                        f"{len(others)} other node(s) ({names}) found in {now - start:.1f} s "
                        "of discovery, none publishing it: stamping with the system clock"
                    )
                    return False
            time.sleep(0.02)  # polls the ROS graph until the discovery deadline

    def _publishers_known(self, name: str, namespace: str) -> int:
        """How many publishers discovery has brought of the node (0 for one that vanished,
        which keeps the search going until the deadline)."""
        try:
            return len(self.node.get_publisher_names_and_types_by_node(name, namespace))
        except Exception:  # rclpy raises NodeNameNonExistentError and others
            return 0

    def _on_set_parameters(self, params: list[Any]) -> Any:
        """Run-time parameter changes (the executor's thread): the live settings changed
        (:func:`~jackson.host.ros.live_parameters.changed_settings`) go to the core's front
        door and take effect at the next telemetry frame; a refused change names the reason
        and changes nothing."""
        from rcl_interfaces.msg import SetParametersResult

        current = self.core.settings
        changes = [(p.name, p.value) for p in params]
        try:
            wanted = changed_settings(current, changes, RosSettings.__dataclass_fields__)
        except ParameterError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        if wanted is not current:
            self.core.request_settings(wanted)
        return SetParametersResult(successful=True)

    def _create_interfaces(self) -> None:
        p, node = self.settings, self.node
        self.publishers: dict[str, Any] = {}
        self.missing: list[str] = []  # message packages not installed (no such topic)
        self.subscriptions: dict[str, Any] = {}  # by topic key
        for key, (_, kind, _depth) in TOPIC_TYPES.items():
            if key in INPUTS or key in NOT_PUBLISHED:
                continue
            if key in ("tf", "tf_static") and not p.publish_tf:
                continue
            cls = _message_class(p.topic_type(key))
            if cls is None:
                self.missing.append(p.topic_type(key))
                continue
            qos = tf_qos() if key == "tf" else QOS[kind]()
            self.publishers[key] = node.create_publisher(cls, p.topic(key), qos)
        # a one-shot navigation (--goal) takes /goal_pose as its next goal; the service takes
        # goals from it, from navigate_to_pose and poses from /initialpose
        self.nav = navigation_of(self.core.mission) if self.service is None else None
        if self.nav is not None or self.service is not None:  # RViz's "2D Goal Pose"
            self.subscriptions["goal_pose"] = node.create_subscription(
                _message_class(p.topic_type("goal_pose")),
                p.topic("goal_pose"),
                self._on_goal,
                cmd_vel_qos(),
            )
        if self.service is not None:  # RViz's "2D Pose Estimate"
            self.subscriptions["initialpose"] = node.create_subscription(
                _message_class(p.topic_type("initialpose")),
                p.topic("initialpose"),
                self._on_initial_pose,
                cmd_vel_qos(),
            )
            if _optional("nav2_msgs.action") is None:
                self.missing.append("nav2_msgs/action/NavigateToPose")
            else:
                from jackson.host.ros.navigate_action import NavigateToPoseServer

                self.action = NavigateToPoseServer(
                    node, self.service, self.clock, self.say, self._stop
                )
        self.subscriptions["cmd_vel"] = node.create_subscription(
            _message_class(p.topic_type("cmd_vel")),
            p.cmd_vel_topic,
            self._on_cmd_vel,
            cmd_vel_qos(),
        )

    # ------------------------------------------------------------------ lifecycle

    def late_clock(self) -> bool:
        """A second look for /clock just before the first frame is stamped (the daemon calls
        it once it is set up, when discovery has had the set-up's time too): a simulator found
        now still gives every stamp its clock. True when it switched to it."""
        if self._clock_given or self.clock.sim_time:
            return False
        if self.node.count_publishers("/clock") == 0:
            return False
        from rclpy.parameter import Parameter

        parameter: Any = Parameter  # untyped in some rclpy releases
        self.node.set_parameters([parameter("use_sim_time", value=True)])
        self.clock.sim_time = True
        self.notes.append(
            "ROS: /clock is published (a simulator): stamping with it (found at a second look; "
            "use_sim_time true; give -p use_sim_time:=false to keep the system clock)"
        )
        return True

    def start(self) -> None:
        """Spin the executor (the subscriptions' callbacks) in a background thread."""
        if self._thread is not None:
            return
        self._thread = threading.Thread(
            target=guard(self._spin, "ros-bridge"), name="ros-bridge", daemon=True
        )
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
            if self.action is not None:
                self.action.destroy()
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
        twist = msg.twist if self.settings.cmd_vel_stamped else msg
        self.commands_received += 1
        self.core.submit_velocity(
            float(twist.linear.x), float(twist.angular.z), time.monotonic_ns()
        )

    def say(self, text: str) -> None:
        """One line for the operator (the daemon's console) and the node's log (/rosout)."""
        logger: Any = self.node.get_logger  # untyped in rclpy
        logger().warning(text)
        if self._say is not None:
            self._say(text)

    def _on_goal(self, msg: Any) -> None:
        """A goal from RViz's "2D Goal Pose" (map frame); the bag records it at the next frame.
        The service checks it at once (refused: one line with the reason) and takes it at the
        next frame, preempting the active goal; a one-shot navigator takes it at its next
        control tick."""
        pose = planar_pose(msg.pose)
        frame = msg.header.frame_id
        self.received.append(("goal_pose", (pose.x, pose.y, pose.yaw, frame)))
        if self.service is None:
            assert self.nav is not None
            self.nav.request_goal(pose)
            return
        where = f"({pose.x:.2f}, {pose.y:.2f})"
        if frame != MAP_FRAME:
            self.say(f"ROS: /goal_pose {where} refused: in frame {frame!r}, not {MAP_FRAME!r}")
            return
        rec = self.service.submit_goal(pose, "goal_pose")
        if rec.status.ended:
            self.say(f"ROS: /goal_pose {where} rejected: {rec.reason}")

    def _on_initial_pose(self, msg: Any) -> None:
        """A pose to localise from (RViz's "2D Pose Estimate", map frame): the service's
        localiser starts again there at the next frame; a pose off the map, in an obstacle or
        in another frame is refused with one line and changes nothing. Its covariance is
        recorded, not used: the localiser spreads its particles its own way."""
        from jackson.host.control.route import RouteError

        assert self.service is not None
        pose = planar_pose(msg.pose.pose)
        frame = msg.header.frame_id
        cov = tuple(float(c) for c in msg.pose.covariance)
        self.received.append(("initialpose", (pose.x, pose.y, pose.yaw, frame, cov)))
        where = f"({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f})"
        if frame != MAP_FRAME:
            self.say(f"ROS: /initialpose {where} refused: in frame {frame!r}, not {MAP_FRAME!r}")
            return
        try:
            self.service.set_pose(pose, "initialpose")
        except RouteError as exc:
            self.say(f"ROS: /initialpose {where} refused: {exc}")

    # ------------------------------------------------------------------ outputs

    def wants(self, key: str, t_s: float) -> bool:
        """Every message of a published topic is published."""
        return key in self.publishers and not self._stop.is_set()

    def write(self, key: str, t_s: float, msg: Any) -> None:
        """Publish a built message (its CDR bytes) on the topic with key ``key``; inputs and
        the raw frames are not published."""
        pub = self.publishers.get(key)
        if pub is None or self._stop.is_set():
            return
        if key == "tf_static" and not self.settings.publish_static_tf:
            return  # robot_state_publisher publishes the URDF's (the bag still records them)
        data = cdr.serialize(self._store, msg)  # rosbags' bytes, packed faster
        with self._lock:
            if self._stop.is_set():
                return
            pub.publish(data)
        self.published[key] = self.published.get(key, 0) + 1
