"""tf2_msgs (``make setup`` builds it with tools/build_ros_msgs.py) carries /tf between processes.

The PyPI wheels of the ``ros`` extra have no tf2_msgs; ``make setup`` generates and compiles it
from its interface definitions. A publisher in a subprocess and an rclpy subscriber in this
process (a private ROS domain on the loopback) must exchange TFMessages with the type hash of
ROS 2 Jazzy's own tf2_msgs, and ``jackson daemon --ros`` against the twin must then publish the
REP 105 tree: /tf odom -> base_footprint, /tf_static base_footprint -> base_link ->
{imu_link, laser}.

On x86_64 ``make setup`` installs rclpy and builds tf2_msgs, so there a missing one fails;
elsewhere the module is skipped unless a system ROS 2 provides both.
"""

from __future__ import annotations

import contextlib
import json
import math
import platform
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

if platform.machine() != "x86_64":
    pytest.importorskip("rclpy")
    pytest.importorskip("tf2_msgs")

from jackson.host.ros.names import FRAMES
from jackson.host.ros.qos import tf_qos, tf_static_qos

from ..sil.harness import TwinThread
from .conftest import private_ros_env

# lark (pulled in by rosidl's parser) imports the deprecated sre_parse
pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")

JACKSON = str(Path(sys.executable).parent / "jackson")
# RIHS01 type hash of tf2_msgs/msg/TFMessage in ROS 2 Jazzy: a node of a system ROS 2 (RViz,
# tf2_ros) matches ours only when the hashes agree.
TFMESSAGE_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"
DEADLINE_S = 60.0  # [s] generous: discovery and the daemon's start on a loaded machine

# Publishes a two-transform TFMessage on /tf at 20 Hz until the stop file appears, then prints
# how many it sent.
PUBLISHER = """
import json, os, sys, time
import rclpy
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

stop_file, deadline = sys.argv[1], time.monotonic() + float(sys.argv[2])
rclpy.init()
node = rclpy.create_node("tf2_msgs_publisher")
pub = node.create_publisher(TFMessage, "/tf", 100)

def transform(parent, child, x_m, seq):
    t = TransformStamped()
    t.header.stamp.sec = seq
    t.header.frame_id, t.child_frame_id = parent, child
    t.transform.translation.x = x_m
    t.transform.rotation.w = 1.0
    return t

sent = 0
while not os.path.exists(stop_file) and time.monotonic() < deadline:
    pub.publish(TFMessage(transforms=[
        transform("odom", "base_footprint", 1.25, sent),
        transform("base_footprint", "base_link", 0.05, sent),
    ]))
    sent += 1
    rclpy.spin_once(node, timeout_sec=0.05)  # the 20 Hz pace
node.destroy_node()
rclpy.shutdown()
print(json.dumps({"sent": sent}))
"""


@pytest.fixture
def ros_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> dict[str, str]:
    """A private ROS domain on the loopback interface, for this process and its children."""
    return private_ros_env(monkeypatch, tmp_path, 215, 17)


class Listener:
    """An rclpy node in this process that keeps every /tf and /tf_static message it hears."""

    def __init__(self, node: Any, executor: Any) -> None:
        from tf2_msgs.msg import TFMessage

        self.node, self.executor = node, executor
        self.tf: list[Any] = []
        self.tf_static: list[Any] = []
        node.create_subscription(TFMessage, "/tf", self.tf.append, tf_qos())
        node.create_subscription(TFMessage, "/tf_static", self.tf_static.append, tf_static_qos())

    def spin_until(self, condition: Callable[[], bool], what: str) -> None:
        """Spin until ``condition`` holds; fail naming ``what`` after :data:`DEADLINE_S`."""
        deadline = time.monotonic() + DEADLINE_S
        while not condition():
            if time.monotonic() > deadline:
                pytest.fail(f"no {what} within {DEADLINE_S:.0f} s")
            self.executor.spin_once(timeout_sec=0.1)


@contextlib.contextmanager
def listener() -> Iterator[Listener]:
    """A :class:`Listener` in its own rclpy context, shut down on exit."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node: Any = rclpy.create_node("tf2_msgs_listener", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        yield Listener(node, executor)
    finally:
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        context.try_shutdown()


def frames(messages: list[Any]) -> set[tuple[str, str]]:
    """The (parent, child) pairs the messages carry."""
    return {(t.header.frame_id, t.child_frame_id) for m in messages for t in m.transforms}


def test_tf2_msgs_has_its_messages_service_and_action() -> None:
    from tf2_msgs.action import LookupTransform
    from tf2_msgs.msg import TF2Error, TFMessage
    from tf2_msgs.srv import FrameGraph

    assert TFMessage.get_fields_and_field_types() == {
        "transforms": "sequence<geometry_msgs/TransformStamped>"
    }
    assert (TF2Error.NO_ERROR, TF2Error.TRANSFORM_ERROR) == (0, 6)
    assert FrameGraph.Response.get_fields_and_field_types() == {"frame_yaml": "string"}
    assert "fixed_frame" in LookupTransform.Goal.get_fields_and_field_types()


def test_tf_message_crosses_processes_with_the_jazzy_type_hash(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    """A TFMessage published by another process arrives whole, its type hash Jazzy's."""
    stop = tmp_path / "stop"
    publisher = subprocess.Popen(
        [sys.executable, "-c", PUBLISHER, str(stop), str(DEADLINE_S)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    try:
        with listener() as ear:
            ear.spin_until(lambda: len(ear.tf) >= 5, "5 TFMessages on /tf")
            infos = ear.node.get_publishers_info_by_topic("/tf")
        stop.touch()
        out, err = publisher.communicate(timeout=30)
    finally:
        if publisher.poll() is None:
            publisher.kill()
            publisher.communicate()
    assert publisher.returncode == 0, err
    sent = json.loads(out.strip().splitlines()[-1])["sent"]
    assert sent >= len(ear.tf) >= 5

    msg = ear.tf[-1]
    assert [(t.header.frame_id, t.child_frame_id) for t in msg.transforms] == [
        ("odom", "base_footprint"),
        ("base_footprint", "base_link"),
    ]
    assert [t.transform.translation.x for t in msg.transforms] == [1.25, 0.05]
    assert msg.transforms[0].transform.rotation.w == 1.0
    seqs = [m.transforms[0].header.stamp.sec for m in ear.tf]
    assert seqs == sorted(seqs)  # reliable and in order

    assert len(infos) == 1, infos
    assert infos[0].topic_type == "tf2_msgs/msg/TFMessage"
    type_hash = infos[0].topic_type_hash
    assert f"RIHS{type_hash.version:02d}_{type_hash.value.hex()}" == TFMESSAGE_HASH


def test_daemon_publishes_odom_tf_and_the_static_mounting_tree(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    """``jackson daemon --ros`` on the twin: /tf odom -> base_footprint with each EKF output,
    /tf_static (latched) base_footprint -> base_link -> {imu_link, laser} in one message."""
    twin = TwinThread(tmp_path, world="open_floor", lockstep=False)
    daemon = subprocess.Popen(
        [
            JACKSON,
            "daemon",
            "--ros",
            "--port",
            twin.serial,
            "--i2c",
            twin.i2c,
            "--run-dir",
            str(tmp_path / "run"),
            "--max-seconds",
            str(DEADLINE_S),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    static = {
        (FRAMES.base_footprint, FRAMES.base_link),
        (FRAMES.base_link, FRAMES.imu_link),
        (FRAMES.base_link, FRAMES.laser),
    }
    try:
        with listener() as ear:
            ear.spin_until(lambda: len(ear.tf) >= 20, "20 TFMessages on /tf from the daemon")
            ear.spin_until(lambda: frames(ear.tf_static) >= static, "the tree on /tf_static")
    finally:
        daemon.send_signal(signal.SIGTERM)
        _, err = daemon.communicate(timeout=30)
        twin.stop()
    assert daemon.returncode == 0, err

    # odom -> base_footprint from the EKF, and the wheels turning on base_link
    assert frames(ear.tf) == {
        (FRAMES.odom, FRAMES.base_footprint),
        (FRAMES.base_link, "left_wheel_link"),
        (FRAMES.base_link, "right_wheel_link"),
    }
    stamps = [
        t.header.stamp for m in ear.tf for t in m.transforms if t.header.frame_id == FRAMES.odom
    ]
    ns = [s.sec * 1_000_000_000 + s.nanosec for s in stamps]
    assert ns == sorted(ns) and ns[-1] > ns[0], ns  # the bridge's stamps never go back
    for m in ear.tf + ear.tf_static:
        for t in m.transforms:
            q = t.transform.rotation
            assert math.isclose(math.hypot(q.x, q.y, q.z, q.w), 1.0, abs_tol=1e-9)
    assert frames(ear.tf_static) == static
    assert len(ear.tf_static) == 1  # one latched message holds the whole tree
