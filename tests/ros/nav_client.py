"""A ROS 2 client in its own process, as RViz or a Nav2 user's node would be: it listens to the
daemon's Stage 3 topics. Subscribes /map (reliable, transient local), /plan and /local_plan
(reliable) and /scan (best effort) for ``--listen-s`` seconds, or until each has arrived
``--enough`` times, and prints one JSON object with the counts, the map's size and the longest
plan."""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import rclpy
from nav_msgs.msg import OccupancyGrid, Path
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import LaserScan


def qos(depth: int, reliable: bool, latched: bool = False) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--listen-s", type=float, default=40.0)
    ap.add_argument("--enough", type=int, default=10)
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("jackson_nav_client")
    report: dict[str, Any] = {"map": 0, "plan": 0, "local_plan": 0, "scan": 0}
    report.update(map_size=None, plan_points=0, scan_beams=0, map_frame="")

    def on_map(msg: Any) -> None:
        report["map"] += 1
        report["map_size"] = [msg.info.width, msg.info.height, round(msg.info.resolution, 3)]
        report["map_frame"] = msg.header.frame_id

    def on_plan(msg: Any) -> None:
        report["plan"] += 1
        report["plan_points"] = max(report["plan_points"], len(msg.poses))

    def on_local(msg: Any) -> None:
        report["local_plan"] += 1

    def on_scan(msg: Any) -> None:
        report["scan"] += 1
        report["scan_beams"] = len(msg.ranges)

    node.create_subscription(OccupancyGrid, "/map", on_map, qos(1, True, latched=True))
    node.create_subscription(Path, "/plan", on_plan, qos(10, True))
    node.create_subscription(Path, "/local_plan", on_local, qos(10, True))
    node.create_subscription(LaserScan, "/scan", on_scan, qos(5, False))
    print("ready", flush=True)
    deadline = time.monotonic() + args.listen_s
    keys = ("map", "plan", "local_plan", "scan")
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
        need = {"map": 1, "plan": 3}
        if all(report[k] >= need.get(k, args.enough) for k in keys):
            break
    print(json.dumps(report), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
