"""A ROS 2 client in its own process that records topics as they arrive, as bytes.

Subscribes each ``--topic NAME=pkg/msg/Type:QOS`` (QOS ``reliable``, ``sensor`` or ``latched``)
with ``raw=True``, so what it keeps is the serialised message as delivered. Once every topic has
delivered a message (latched ones included) it listens ``--listen-s`` more seconds, then writes
one JSON line per message to ``--out``: the topic, the wall time it arrived [s] and the bytes in
hex. Exits 1 if a topic never delivered within ``--ready-timeout-s``.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import rclpy
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy


def qos(kind: str) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=1 if kind == "latched" else 100,
        reliability=ReliabilityPolicy.BEST_EFFORT
        if kind == "sensor"
        else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL
        if kind == "latched"
        else DurabilityPolicy.VOLATILE,
    )


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--topic", action="append", required=True)
    ap.add_argument("--listen-s", type=float, default=3.0)
    ap.add_argument("--ready-timeout-s", type=float, default=30.0)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args()

    rclpy.init()
    node = rclpy.create_node("jackson_record_client")
    got: list[tuple[str, float, bytes]] = []
    seen: set[str] = set()
    names = []
    for spec in a.topic:
        name, _, rest = spec.partition("=")
        ros_type, _, kind = rest.partition(":")
        pkg, _, cls = ros_type.split("/")
        msg_type: Any = getattr(importlib.import_module(f"{pkg}.msg"), cls)
        names.append(name)

        def on_msg(data: bytes, name: str = name) -> None:
            got.append((name, time.time(), bytes(data)))
            seen.add(name)

        node.create_subscription(msg_type, name, on_msg, qos(kind), raw=True)
    deadline = time.monotonic() + a.ready_timeout_s
    while len(seen) < len(names) and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    if len(seen) < len(names):
        print(f"never heard: {sorted(set(names) - seen)}", file=sys.stderr)
        return 1
    end = time.monotonic() + a.listen_s
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    with a.out.open("w") as f:
        for name, t, data in got:
            f.write(json.dumps({"topic": name, "t": t, "data": data.hex()}) + "\n")
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
