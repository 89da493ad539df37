"""A ROS 2 client in its own process, as a user's node would be: it listens, drives, goes quiet.

Subscribes /wheel/odom and /odometry/filtered (reliable, depth 10), /imu/data (best effort,
depth 5) and /diagnostics; once the daemon's topics arrive it publishes /cmd_vel (reliable,
depth 1; geometry_msgs/Twist, or TwistStamped with ``--stamped``) at 20 Hz for ``--drive-s``
seconds, then stops and keeps listening for ``--after-s`` seconds. Prints one JSON object: the
message counts, the largest /wheel/odom speed, and the wall time from its last /cmd_vel to the
first /wheel/odom at rest.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu

REST_M_S = 0.01  # [m/s] |v| below this is at rest
CMD_PERIOD_S = 0.05  # [s] 20 Hz


def qos(depth: int, reliable: bool) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.VOLATILE,
    )


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--v", type=float, default=0.15)
    ap.add_argument("--drive-s", type=float, default=1.0)
    ap.add_argument("--after-s", type=float, default=2.0)
    ap.add_argument("--ready-timeout-s", type=float, default=20.0)
    ap.add_argument("--stamped", action="store_true", help="publish TwistStamped on /cmd_vel")
    a = ap.parse_args()

    rclpy.init()
    node = rclpy.create_node("jackson_test_client")
    counts = {"wheel_odom": 0, "imu": 0, "filtered": 0, "diagnostics": 0}
    odom: list[tuple[float, float]] = []  # (wall time received, v)
    max_v = 0.0

    def on_odom(msg: Any) -> None:
        nonlocal max_v
        counts["wheel_odom"] += 1
        v = float(msg.twist.twist.linear.x)
        odom.append((time.monotonic(), v))
        max_v = max(max_v, v)

    def counter(key: str) -> Any:
        def cb(msg: Any) -> None:
            counts[key] += 1

        return cb

    node.create_subscription(Odometry, "/wheel/odom", on_odom, qos(10, True))
    node.create_subscription(Odometry, "/odometry/filtered", counter("filtered"), qos(10, True))
    node.create_subscription(Imu, "/imu/data", counter("imu"), qos(5, False))
    node.create_subscription(DiagnosticArray, "/diagnostics", counter("diagnostics"), 10)
    cmd = node.create_publisher(TwistStamped if a.stamped else Twist, "/cmd_vel", qos(1, True))

    deadline = time.monotonic() + a.ready_timeout_s
    while counts["wheel_odom"] == 0 or cmd.get_subscription_count() == 0:
        if time.monotonic() > deadline:
            print(json.dumps({"error": "no /wheel/odom or no /cmd_vel subscriber", **counts}))
            return 1
        rclpy.spin_once(node, timeout_sec=0.05)

    sent = 0
    t_end = time.monotonic() + a.drive_s
    next_cmd = time.monotonic()
    while time.monotonic() < t_end:
        if time.monotonic() >= next_cmd:
            twist = Twist()
            twist.linear.x = a.v
            if a.stamped:
                stamped = TwistStamped()
                stamped.header.stamp = node.get_clock().now().to_msg()
                stamped.header.frame_id = "base_link"
                stamped.twist = twist
                cmd.publish(stamped)
            else:
                cmd.publish(twist)
            sent += 1
            next_cmd += CMD_PERIOD_S
        rclpy.spin_once(node, timeout_sec=0.005)
    t_last_cmd = time.monotonic()

    t_end = t_last_cmd + a.after_s
    while time.monotonic() < t_end:
        rclpy.spin_once(node, timeout_sec=0.02)
    at_rest = next((t for t, v in odom if t > t_last_cmd and abs(v) < REST_M_S), None)
    report = {
        **counts,
        "cmd_sent": sent,
        "max_v": max_v,
        "stop_latency_s": None if at_rest is None else at_rest - t_last_cmd,
    }
    print(json.dumps(report))
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
