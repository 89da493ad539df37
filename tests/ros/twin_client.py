"""A ROS 2 client in its own process that listens to the twin (``jackson sim --ros``).

Subscribes /twin/scan (best effort, depth 5), /ground_truth/odom (reliable, depth 10) and /clock
(best effort, depth 1, as ROS 2's time source does). Once every topic has arrived it listens for
``--listen-s`` more seconds, then prints one JSON object: the counts, the first LaserScan's
geometry, the /clock range, whether /clock and the scan stamps never went back, and the largest
ground-truth speed.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from typing import Any

import rclpy
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan


def qos(depth: int, reliable: bool) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.VOLATILE,
    )


def seconds(stamp: Any) -> float:
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--listen-s", type=float, default=2.0)
    ap.add_argument("--ready-timeout-s", type=float, default=15.0)
    a = ap.parse_args()

    rclpy.init()
    node = rclpy.create_node("jackson_twin_test_client")
    counts = {"scan": 0, "ground_truth": 0, "clock": 0}
    report: dict[str, Any] = {}
    clocks: list[float] = []
    scan_stamps: list[float] = []
    max_v = 0.0

    def on_scan(msg: Any) -> None:
        counts["scan"] += 1
        scan_stamps.append(seconds(msg.header.stamp))
        if "scan" not in report:
            ranges = list(msg.ranges)
            finite = [r for r in ranges if math.isfinite(r)]
            report["scan"] = {
                "frame_id": msg.header.frame_id,
                "beams": len(ranges),
                "angle_min": msg.angle_min,
                "angle_max": msg.angle_max,
                "angle_increment": msg.angle_increment,
                "time_increment": msg.time_increment,
                "scan_time": msg.scan_time,
                "range_min": msg.range_min,
                "range_max": msg.range_max,
                "finite": len(finite),
                "finite_in_limits": all(msg.range_min <= r <= msg.range_max for r in finite),
            }

    def on_truth(msg: Any) -> None:
        nonlocal max_v
        counts["ground_truth"] += 1
        max_v = max(max_v, float(msg.twist.twist.linear.x))
        if "ground_truth" not in report:
            report["ground_truth"] = {
                "frame_id": msg.header.frame_id,
                "child_frame_id": msg.child_frame_id,
            }

    def on_clock(msg: Any) -> None:
        counts["clock"] += 1
        clocks.append(seconds(msg.clock))

    node.create_subscription(LaserScan, "/twin/scan", on_scan, qos(5, False))
    node.create_subscription(Odometry, "/ground_truth/odom", on_truth, qos(10, True))
    node.create_subscription(Clock, "/clock", on_clock, qos(1, False))

    deadline = time.monotonic() + a.ready_timeout_s
    while min(counts.values()) == 0:
        if time.monotonic() > deadline:
            print(json.dumps({"error": "not every topic arrived", **counts}))
            return 1
        rclpy.spin_once(node, timeout_sec=0.05)
    t_end = time.monotonic() + a.listen_s
    while time.monotonic() < t_end:
        rclpy.spin_once(node, timeout_sec=0.02)

    report.update(
        counts=counts,
        clock_first=clocks[0],
        clock_last=clocks[-1],
        clock_monotonic=all(q > p for p, q in itertools.pairwise(clocks)),
        scan_stamps_monotonic=all(q > p for p, q in itertools.pairwise(scan_stamps)),
        scan_stamp_last=scan_stamps[-1],
        max_v=max_v,
    )
    print(json.dumps(report))
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
