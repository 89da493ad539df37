"""A ROS 2 client in its own process that checks the clocks of a twin and a daemon: it hears
/clock (the twin's), the daemon's /scan, /odometry/filtered, /wheel/odom, /imu/data, /tf and
/local_plan, and who publishes /tf_static, until ``--listen-s`` seconds pass or ``--until``
names a file that exists (the test creates it when the daemon has exited). Prints one JSON
object: per topic the stamps [ns] in arrival order, the frames seen, the /clock values and the
/tf_static publishers' node names."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import rclpy
from nav_client import qos  # the same QoS profiles (this folder is on the path)
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as NavPath
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, LaserScan
from tf2_msgs.msg import TFMessage


def ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--listen-s", type=float, default=120.0)
    ap.add_argument("--until", type=Path, required=True)
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("jackson_stamp_client")
    report: dict[str, Any] = {"clock": [], "frames": {}, "scan_timing": [], "static_publishers": []}
    stamps: dict[str, list[int]] = {}

    def keep(topic: str) -> Any:
        stamps[topic] = []

        def on(msg: Any) -> None:
            if isinstance(msg, TFMessage):
                for t in msg.transforms:
                    stamps[topic].append(ns(t.header.stamp))
                    report["frames"].setdefault(topic, set()).add(
                        f"{t.header.frame_id}->{t.child_frame_id}"
                    )
                return
            stamps[topic].append(ns(msg.header.stamp))
            report["frames"].setdefault(topic, set()).add(msg.header.frame_id)
            if isinstance(msg, LaserScan):
                report["scan_timing"].append([msg.time_increment, msg.scan_time, len(msg.ranges)])

        return on

    node.create_subscription(
        Clock, "/clock", lambda m: report["clock"].append(ns(m.clock)), qos(100, False)
    )
    node.create_subscription(LaserScan, "/scan", keep("/scan"), qos(100, False))
    node.create_subscription(
        Odometry, "/odometry/filtered", keep("/odometry/filtered"), qos(100, True)
    )
    node.create_subscription(Odometry, "/wheel/odom", keep("/wheel/odom"), qos(100, True))
    node.create_subscription(Imu, "/imu/data", keep("/imu/data"), qos(100, False))
    node.create_subscription(TFMessage, "/tf", keep("/tf"), qos(100, True))
    node.create_subscription(NavPath, "/local_plan", keep("/local_plan"), qos(100, True))
    print("ready", flush=True)
    deadline = time.monotonic() + args.listen_s
    while time.monotonic() < deadline and not args.until.exists():
        rclpy.spin_once(node, timeout_sec=0.05)
        info = node.get_publishers_info_by_topic("/tf_static")
        if info:  # the latest look (a node's name may be discovered after its endpoint)
            report["static_publishers"] = sorted(i.node_name for i in info)
    for _ in range(20):  # what is still in flight
        rclpy.spin_once(node, timeout_sec=0.05)
    report["stamps"] = stamps
    report["frames"] = {k: sorted(v) for k, v in report["frames"].items()}
    print(json.dumps(report), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
