"""The navigation service on ROS 2, as a Nav2 user drives it: ``navigate_to_pose``, /goal_pose,
/initialpose and /diagnostics.

One twin (``jackson sim --world hall_15m``, lockstep, its MCU and emulated RPLIDAR on ptys) and
one ``jackson daemon --ros --lidar --map --start --socket`` (the service) run as subprocesses for
the whole module, in a private ROS domain; this process is the ROS user: an rclpy node with an
action client of nav2_msgs' NavigateToPose (built by ``make setup``), publishers of /goal_pose
and /initialpose and subscriptions to /diagnostics and /wheel/odom. What the service did is
read back over its control socket (``jackson status``). Every wait is for a condition (a
message, a result, a state), never for a fixed time; the twin runs as fast as the daemon does.
"""

from __future__ import annotations

import json
import math
import platform
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

if platform.machine() != "x86_64":
    pytest.importorskip("rclpy")
    pytest.importorskip("nav2_msgs")

from jackson.experiments.stage3 import world_grid
from jackson.sim.config import load_world

from ..sil import harness
from .conftest import private_ros_env

# lark (pulled in by rosidl's parser) imports the deprecated sre_parse
pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")

JACKSON = str(Path(sys.executable).parent / "jackson")
WORLD = "hall_15m"
START = (1.5, 1.5, 0.55)  # the world's start pose, in the map frame (the world's)
DEADLINE_S = 60.0  # [s] of wall time for one condition: generous on a loaded machine
# RIHS01 type hash of nav2_msgs/action/NavigateToPose in ROS 2 Jazzy (nav2_msgs 1.3): a Nav2
# client of a system ROS 2 matches the daemon's action only when the hashes agree
NAVIGATE_TO_POSE_HASH = "RIHS01_a56dba8a3234a1215e610180dc703ae25bbf406dded8b54887891c9732857eab"


# ---------------------------------------------------------------------------------- processes


@dataclass
class Service:
    """The twin and the daemon, and what the daemon said so far."""

    sim: subprocess.Popen[str]
    daemon: subprocess.Popen[str]
    socket_path: Path
    map_size: tuple[int, int]
    lines: list[str] = field(default_factory=list)

    def said(self, text: str) -> bool:
        """Whether the daemon has printed a line containing ``text``."""
        return any(text in line for line in list(self.lines))

    def request(self, **req: Any) -> dict[str, Any]:
        """One request on the control socket (docs/host.md); its answer."""
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
            s.settimeout(10.0)
            s.connect(str(self.socket_path))
            s.sendall((json.dumps(req) + "\n").encode())
            answer: dict[str, Any] = json.loads(s.makefile().readline())
        assert answer["ok"], answer
        return answer

    def status(self) -> dict[str, Any]:
        status: dict[str, Any] = self.request(op="status")["status"]
        return status


def _read(stream: Any, lines: list[str]) -> None:
    for line in stream:
        lines.append(line.rstrip("\n"))


def wait_for(condition: Callable[[], bool], what: str, timeout_s: float = DEADLINE_S) -> None:
    """:func:`tests.sil.harness.wait_for` with this module's deadline."""
    harness.wait_for(condition, timeout_s=timeout_s, what=what)


@pytest.fixture(scope="module")
def ros_env(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, str]]:
    """A private ROS domain on the loopback interface, for this module and its children."""
    with pytest.MonkeyPatch.context() as mp:
        yield private_ros_env(mp, tmp_path_factory.mktemp("ros"), 1, 100)


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory, ros_env: dict[str, str]) -> Iterator[Service]:
    tmp = tmp_path_factory.mktemp("service")
    grid = world_grid(load_world(WORLD))
    grid.save(tmp / "map.yaml")
    sim = subprocess.Popen(
        [
            *(JACKSON, "sim", "--world", WORLD),
            *("--link", str(tmp / "mcu"), "--lidar-link", str(tmp / "lidar")),
            *("--i2c", str(tmp / "i2c.sock")),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    assert sim.stdout is not None
    for line in sim.stdout:  # its ports, then "twin: ... waiting for HELLO"
        if line.startswith("twin:"):
            break
    daemon = subprocess.Popen(
        [
            *(JACKSON, "daemon", "--ros", "--port", str(tmp / "mcu")),
            *("--i2c", f"unix:{tmp / 'i2c.sock'}", "--lidar", str(tmp / "lidar")),
            *("--map", str(tmp / "map.yaml"), "--start", ",".join(map(str, START))),
            *("--socket", str(tmp / "d.sock"), "--run-dir", str(tmp / "run")),
            # the twin publishes no /clock here: no need to look for one
            *("--ros-args", "-p", "use_sim_time:=false"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=ros_env,
    )
    svc = Service(sim, daemon, tmp / "d.sock", (int(grid.width), int(grid.height)))
    threading.Thread(target=_read, args=(daemon.stdout, svc.lines), daemon=True).start()
    try:
        wait_for(
            lambda: svc.said("taking goals") or daemon.poll() is not None, "the daemon's start"
        )
        assert daemon.poll() is None, "\n".join(svc.lines)
        yield svc
    finally:
        daemon.send_signal(signal.SIGTERM)
        try:
            daemon.wait(timeout=30)
        finally:
            sim.send_signal(signal.SIGTERM)
            sim.communicate(timeout=30)


# ---------------------------------------------------------------------------------- the ROS user


class RosUser:
    """This process's rclpy node: an action client, two publishers, two subscriptions."""

    def __init__(self) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
        from nav2_msgs.action import NavigateToPose
        from nav_msgs.msg import OccupancyGrid, Odometry, Path
        from rclpy.action import ActionClient
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from tf2_msgs.msg import TFMessage

        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("service_test_user", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.action = NavigateToPose
        self.client = ActionClient(self.node, NavigateToPose, "navigate_to_pose")
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.goal_pub = self.node.create_publisher(PoseStamped, "/goal_pose", reliable)
        self.pose_pub = self.node.create_publisher(
            PoseWithCovarianceStamped, "/initialpose", reliable
        )
        self.diagnostics: list[Any] = []
        self.odometry: list[Any] = []
        self.node.create_subscription(
            DiagnosticArray, "/diagnostics", self.diagnostics.append, reliable
        )
        self.node.create_subscription(Odometry, "/wheel/odom", self.odometry.append, reliable)
        # the navigation topics, as RViz's Nav2 view subscribes them
        self.plans: list[Any] = []
        self.local_plans: list[Any] = []
        self.maps: list[Any] = []
        self.map_to_odom: list[Any] = []
        latched = QoSProfile(
            depth=1,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        self.node.create_subscription(Path, "/plan", self.plans.append, reliable)
        self.node.create_subscription(Path, "/local_plan", self.local_plans.append, reliable)
        self.node.create_subscription(OccupancyGrid, "/map", self.maps.append, latched)

        def on_tf(msg: Any) -> None:
            self.map_to_odom += [t for t in msg.transforms if t.header.frame_id == "map"]

        self.node.create_subscription(
            TFMessage, "/tf", on_tf, QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        )

    def spin_until(self, condition: Callable[[], bool], what: str) -> None:
        """Spin the node until ``condition`` holds; fail naming ``what``."""
        deadline = time.monotonic() + DEADLINE_S
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out after {DEADLINE_S:g} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.05)

    def send_goal(self, x: float, y: float, frame: str = "map") -> Goal:
        """A NavigateToPose goal, accepted (as the daemon accepts every goal)."""
        goal = self.action.Goal()
        goal.pose.header.frame_id = frame
        goal.pose.pose.position.x, goal.pose.pose.position.y = x, y
        goal.pose.pose.orientation.w = 1.0
        sent = Goal()
        self.spin_until(lambda: self.client.server_is_ready(), "the navigate_to_pose server")
        future = self.client.send_goal_async(goal, feedback_callback=sent.feedback.append)
        self.spin_until(future.done, "the goal's acceptance")
        sent.handle = future.result()
        assert sent.handle.accepted
        sent.result = sent.handle.get_result_async()
        return sent

    def result(self, goal: Goal) -> Any:
        """The goal's GetResult response (status and result)."""
        self.spin_until(goal.result.done, "the goal's result")
        return goal.result.result()

    def pose(self, x: float, y: float, yaw: float, frame: str = "map") -> Any:
        """A PoseStamped (for /goal_pose and the action)."""
        from geometry_msgs.msg import PoseStamped

        msg = PoseStamped()
        msg.header.frame_id = frame
        msg.pose.position.x, msg.pose.position.y = x, y
        msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        return msg

    def publish(self, pub: Any, msg: Any) -> None:
        """Publish once the daemon's subscription is matched (a volatile topic keeps nothing
        for a subscriber that comes later)."""
        self.spin_until(lambda: pub.get_subscription_count() > 0, f"a subscriber of {pub.topic}")
        pub.publish(msg)

    def close(self) -> None:
        self.client.destroy()
        self.node.destroy_node()
        self.context.try_shutdown()


@dataclass
class Goal:
    """An action goal as the client sees it."""

    handle: Any = None
    result: Any = None
    feedback: list[Any] = field(default_factory=list)


@pytest.fixture(scope="module")
def ros(service: Service) -> Iterator[RosUser]:
    user = RosUser()
    yield user
    user.close()


def _at_rest(odom: Any) -> bool:
    return odom.twist.twist.linear.x == 0.0 and odom.twist.twist.angular.z == 0.0


# ---------------------------------------------------------------------------------- the tests


def test_the_action_type_is_jazzys_nav2_msgs() -> None:
    from nav2_msgs.action import NavigateToPose
    from rclpy.type_support import check_for_type_support

    check_for_type_support(NavigateToPose)
    assert NavigateToPose.Feedback.get_fields_and_field_types() == {
        "current_pose": "geometry_msgs/PoseStamped",
        "navigation_time": "builtin_interfaces/Duration",
        "estimated_time_remaining": "builtin_interfaces/Duration",
        "number_of_recoveries": "int16",
        "distance_remaining": "float",
    }
    assert NavigateToPose.Result.get_fields_and_field_types() == {
        "error_code": "uint16",
        "error_msg": "string",
    }
    assert NavigateToPose.Result.NONE == 0
    share = Path(sys.prefix) / "share" / "nav2_msgs" / "action" / "NavigateToPose.json"
    hashes = json.loads(share.read_text())["type_hashes"]
    assert hashes[0] == {
        "type_name": "nav2_msgs/action/NavigateToPose",
        "hash_string": NAVIGATE_TO_POSE_HASH,
    }


def test_navigate_to_pose_reaches_the_goal_with_feedback(service: Service, ros: RosUser) -> None:
    from action_msgs.msg import GoalStatus

    goal_xy = (7.5, 5.0)  # 6.9 m across the hall, about 27 s of MCU time
    goal = ros.send_goal(*goal_xy)
    response = ros.result(goal)
    st = service.status()
    seen = (response, st, service.lines[-10:])
    assert response.status == GoalStatus.STATUS_SUCCEEDED, seen
    assert (response.result.error_code, response.result.error_msg) == (0, ""), seen
    last = st["last_goal"]
    assert (last["source"], last["status"], last["reason"]) == (
        "navigate_to_pose",
        "succeeded",
        "goal reached",
    )
    assert math.dist(goal_xy, (st["pose"]["x"], st["pose"]["y"])) < 0.3, seen
    # feedback as Nav2's: the robot's pose in map, times from the goal's start, the plan left
    fb = [f.feedback for f in goal.feedback]
    assert fb, seen
    assert all(f.current_pose.header.frame_id == "map" for f in fb)
    # stamped on MCU time: never zero, never back in time (a busy machine may send a goal
    # within the MCU's first second, so not necessarily past one second)
    stamps = [s.sec + 1e-9 * s.nanosec for s in (f.current_pose.header.stamp for f in fb)]
    assert all(t > 0 for t in stamps) and stamps == sorted(stamps), stamps
    times = [f.navigation_time.sec + 1e-9 * f.navigation_time.nanosec for f in fb]
    assert times == sorted(times) and times[-1] <= last["navigation_time_s"] + 1e-6
    assert all(f.number_of_recoveries >= 0 for f in fb)
    first = fb[0].current_pose.pose.position
    assert math.dist((first.x, first.y), START[:2]) < 0.5  # where the robot started
    planned = [f for f in fb if f.distance_remaining > 0.0]
    assert planned, [f.distance_remaining for f in fb]
    for f in planned:  # the plan from where it is to the goal: at least the straight line
        here = f.current_pose.pose.position
        assert f.distance_remaining >= math.dist((here.x, here.y), goal_xy) - 0.3
        assert f.distance_remaining <= math.dist(START[:2], goal_xy) * 1.5 + 0.5
    assert any(f.estimated_time_remaining.sec > 0 for f in planned)


def test_the_service_publishes_the_navigation_topics(service: Service, ros: RosUser) -> None:
    """/plan and /map in map, /local_plan in odom, map -> odom on /tf: as for a one-shot
    navigation, from the service's navigator."""
    from action_msgs.msg import GoalStatus

    wait_for(lambda: service.status()["state"] == "idle", "the service idle")  # braked, not
    here = service.status()["pose"]  # on its way to an earlier test's goal
    target = max([(7.5, 5.0), (3.0, 3.0)], key=lambda g: math.dist(g, (here["x"], here["y"])))
    n_plans, n_local, n_tf = len(ros.plans), len(ros.local_plans), len(ros.map_to_odom)

    def to_target(plan: Any) -> bool:
        end = plan.poses[-1].pose.position if plan.poses else None
        return end is not None and math.dist((end.x, end.y), target) < 0.3

    goal = ros.send_goal(*target)
    # (a /plan of the earlier goal may still be on its way when this one is sent)
    ros.spin_until(
        lambda: (
            any(to_target(p) for p in ros.plans[n_plans:])
            and len(ros.local_plans) > n_local
            and len(ros.map_to_odom) > n_tf
            and bool(ros.maps)
        ),
        "/plan, /local_plan, map -> odom on /tf and /map",
    )
    asked = goal.handle.cancel_goal_async()
    ros.spin_until(asked.done, "the cancel's answer")
    assert ros.result(goal).status in (GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_SUCCEEDED)
    # the goal's first plan (later ones shrink as the robot drives)
    plan = next(p for p in ros.plans[n_plans:] if to_target(p))
    assert plan.header.frame_id == "map" and len(plan.poses) > 10
    assert {p.header.frame_id for p in ros.local_plans[n_local:]} == {"odom"}
    assert {t.child_frame_id for t in ros.map_to_odom[n_tf:]} == {"odom"}
    grid = ros.maps[-1]
    assert grid.header.frame_id == "map" and abs(grid.info.resolution - 0.05) < 1e-6
    assert (grid.info.width, grid.info.height) == (service.map_size)


def test_a_goal_the_service_refuses_is_aborted_with_the_reason(
    service: Service, ros: RosUser
) -> None:
    from action_msgs.msg import GoalStatus

    in_pillar = ros.result(ros.send_goal(8.0, 2.0))  # a cylinder of the hall
    assert in_pillar.status == GoalStatus.STATUS_ABORTED
    assert "obstacle" in in_pillar.result.error_msg, in_pillar.result.error_msg
    in_odom = ros.result(ros.send_goal(5.0, 5.0, frame="odom"))
    assert in_odom.status == GoalStatus.STATUS_ABORTED
    assert "'odom'" in in_odom.result.error_msg, in_odom.result.error_msg
    wait_for(lambda: service.said("navigate_to_pose goal refused"), "the refusal's line")
    assert service.status()["state"] == "idle"


def test_a_newer_goal_preempts_and_a_cancel_brakes(service: Service, ros: RosUser) -> None:
    from action_msgs.msg import GoalStatus

    first = ros.send_goal(12.0, 2.0)
    ros.spin_until(lambda: len(first.feedback) >= 1, "the first goal's feedback: active")
    second = ros.send_goal(2.0, 8.0)
    preempted = ros.result(first)
    # as Nav2's action server ends a goal a newer one preempts: aborted
    assert preempted.status == GoalStatus.STATUS_ABORTED, preempted
    assert "preempted by goal" in preempted.result.error_msg, preempted.result.error_msg
    ros.spin_until(lambda: len(second.feedback) >= 1, "the second goal's feedback")
    asked = second.handle.cancel_goal_async()
    ros.spin_until(asked.done, "the cancel's answer")
    assert len(asked.result().goals_canceling) == 1
    canceled = ros.result(second)
    assert canceled.status == GoalStatus.STATUS_CANCELED, canceled
    assert "canceled by navigate_to_pose" in canceled.result.error_msg
    wait_for(lambda: service.status()["state"] == "idle", "the service idle")
    n = len(ros.odometry)  # the robot slows down and stands braked
    ros.spin_until(lambda: any(_at_rest(o) for o in ros.odometry[n:]), "the robot at rest")
    last = service.status()["last_goal"]
    assert (last["status"], last["source"]) == ("canceled", "navigate_to_pose")


def test_goal_pose_starts_a_goal_and_another_frame_is_refused(
    service: Service, ros: RosUser
) -> None:
    here = service.status()["pose"]
    # a goal away from the robot, so that it is seen active
    x, y = max([(7.5, 5.0), (3.0, 3.0)], key=lambda g: math.dist(g, (here["x"], here["y"])))
    ros.publish(ros.goal_pub, ros.pose(x, y, 0.0, frame="odom"))
    wait_for(lambda: service.said(f"ROS: /goal_pose ({x:.2f}, {y:.2f}) refused"), "the refusal")
    assert service.status()["goal"] is None
    ros.publish(ros.goal_pub, ros.pose(x, y, 0.0))

    def navigating() -> bool:
        st = json.loads(
            subprocess.run(
                [JACKSON, "status", "--json", "--socket", str(service.socket_path)],
                capture_output=True,
                text=True,
                check=True,
            ).stdout
        )
        return st["state"] == "navigating" and st["goal"]["source"] == "goal_pose"

    wait_for(navigating, "the /goal_pose goal active")
    goal = service.status()["goal"]
    assert (goal["x"], goal["y"]) == (x, y)
    ended = service.request(op="cancel")["goal"]
    wait_for(lambda: service.status()["state"] == "idle", "idle after the cancel")
    assert service.status()["last_goal"]["id"] == ended["id"]


def test_initialpose_moves_the_pose_and_a_bad_one_is_refused(
    service: Service, ros: RosUser
) -> None:
    from geometry_msgs.msg import PoseWithCovarianceStamped

    def initial_pose(x: float, y: float, yaw: float) -> Any:
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = "map"
        msg.pose.pose = ros.pose(x, y, yaw).pose
        msg.pose.covariance[0] = msg.pose.covariance[7] = 0.25**2
        msg.pose.covariance[35] = 0.1**2
        return msg

    pose = service.status()["pose"]
    x0, y0, yaw0 = pose["x"], pose["y"], pose["yaw"]
    told = len(service.lines)
    ros.publish(ros.pose_pub, initial_pose(x0 + 0.6, y0, yaw0))  # as RViz's 2D Pose Estimate
    wait_for(
        lambda: any("(initialpose)" in line for line in service.lines[told:]),
        "the daemon localising from /initialpose",
    )
    wait_for(  # the status shows the estimate of a frame after the request was taken
        lambda: _near(service.status()["pose"], (x0 + 0.6, y0)), "the pose moved by 0.6 m"
    )
    ros.publish(ros.pose_pub, initial_pose(8.0, 2.0, 0.0))  # in a pillar
    wait_for(lambda: service.said("ROS: /initialpose (8.00, 2.00, 0.00) refused"), "the refusal")
    told = len(service.lines)
    ros.publish(ros.pose_pub, initial_pose(x0, y0, yaw0))  # back where the robot stands
    wait_for(
        lambda: any("(initialpose)" in line for line in service.lines[told:]),
        "the daemon localising from /initialpose again",
    )
    wait_for(lambda: _near(service.status()["pose"], (x0, y0)), "the pose back where it was")


def _near(pose: dict[str, Any], xy: tuple[float, float]) -> bool:
    return math.dist((pose["x"], pose["y"]), xy) < 0.2


def test_diagnostics_name_each_sensor_the_link_and_the_navigation(
    service: Service, ros: RosUser
) -> None:
    names = {
        "jackson: link",
        "jackson: imu",
        "jackson: encoders",
        "jackson: lidar",
        "jackson: navigation",
    }
    assert service.status()["state"] == "idle"

    def newest() -> dict[str, Any]:
        """The statuses of the newest /diagnostics, by name."""
        return {s.name: s for s in ros.diagnostics[-1].status} if ros.diagnostics else {}

    def idle() -> bool:
        got = newest()
        nav = got.get("jackson: navigation")
        return names <= set(got) and nav is not None and nav.message.startswith("idle")

    # the samples of the frames before the service went idle may still be on their way
    ros.spin_until(idle, f"/diagnostics with {sorted(names)} and the service idle")
    got = newest()
    values = {name: {kv.key: kv.value for kv in got[name].values} for name in names}
    assert got["jackson: link"].message.startswith("up"), got["jackson: link"]
    assert values["jackson: link"]["health"] == "ok"
    assert values["jackson: imu"]["health"] == "ok"
    assert (values["jackson: encoders"]["left"], values["jackson: encoders"]["right"]) == (
        "ok",
        "ok",
    )
    assert got["jackson: lidar"].message.startswith("ok, "), got["jackson: lidar"]
    assert int(values["jackson: lidar"]["scans"]) > 0
    nav = values["jackson: navigation"]
    assert nav["state"] == "idle", nav
    assert {"goals_succeeded", "goals_aborted", "goals_canceled", "goals_rejected"} <= set(nav)
    counts = service.status()["goals"]
    assert int(nav["goals_succeeded"]) <= counts["succeeded"]
    levels = {name: ord(got[name].level) for name in names}  # a byte in rclpy
    assert levels["jackson: navigation"] == 0 or nav.get("last_status") == "aborted", got
    assert levels["jackson: encoders"] == levels["jackson: lidar"] == 0, got
