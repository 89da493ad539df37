"""Latency of the ROS 2 bridge (run by ``jackson bench``).

From the moment a telemetry frame is received to the delivery of the /odometry/filtered message
it produces at a local subscriber (another rclpy context in this process, the paper's reliable
depth-10 QoS). Frames of a 20 s drive in the twin are fed through the daemon's core with the
bridge attached, a few milliseconds apart. Reported: median and p99 as shares of the 50 ms
command-transport latency the paper observed on its robot (target: below it), the machine's
reference loop timed beside them.
"""

from __future__ import annotations

import os
import statistics
import threading
import time
from typing import Any

from jackson.common.bench import BenchResult, reference_loop_us
from jackson.host.actuation.output import NullOutput
from jackson.host.config import HostConfig
from jackson.host.core import HostCore
from jackson.protocol import FrameDecoder


def _isolated_ros_env() -> None:
    os.environ.setdefault("ROS_DOMAIN_ID", str(150 + os.getpid() % 80))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_STATIC_PEERS", "127.0.0.1")


def filtered_latencies(seconds: float) -> list[float]:
    from jackson.bench.host import telemetry_stream
    from jackson.host.ros.bridge import RosBridge, ros_available
    from jackson.host.ros.messages import MessageBuilder, RosOutput
    from jackson.host.ros.qos import odometry_qos

    problem = ros_available()
    if problem is not None:
        raise RuntimeError(problem)
    _isolated_ros_env()
    import rclpy
    from nav_msgs.msg import Odometry
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor

    frames = telemetry_stream(seconds)
    core = HostCore(HostConfig(), NullOutput(), lambda m: None)
    # MCU-time stamps (use_sim_time), so a message is matched to the frame that produced it
    bridge = RosBridge(core, parameter_overrides={"use_sim_time": True})
    builder = MessageBuilder(bridge.settings, core.cfg.odometry, bridge.clock)
    core.listeners.append(RosOutput(builder, [bridge], telemetry=False))
    ctx = Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node("jackson_bench_listener", context=ctx)
    received: dict[int, int] = {}  # stamp [ns] -> receive time [ns]

    def on_msg(msg: Any) -> None:
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        received[stamp] = time.monotonic_ns()

    node.create_subscription(Odometry, "/odometry/filtered", on_msg, odometry_qos())
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)

    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    produced: dict[int, int] = {}  # stamp of each output -> receipt of the frame producing it
    decoder = FrameDecoder()
    try:
        deadline = time.monotonic() + 10.0
        while node.count_publishers("/odometry/filtered") == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)  # discovery settles
        for raw in frames:
            t_rx = time.monotonic_ns()
            before = core.ekf_outputs
            for frame in decoder.feed(raw):
                core.on_frame(frame, t_rx)
            out = core.last_output
            if core.ekf_outputs != before and out is not None and out.t_s is not None:
                produced[round(out.t_s * 1e9)] = t_rx
            time.sleep(0.004)
        time.sleep(0.5)
    finally:
        stop.set()
        thread.join(timeout=2)
        bridge.stop()
        listener: Any = node
        listener.destroy_node()
        rclpy.shutdown(context=ctx)
    return [(received[s] - t) / 1e9 for s, t in produced.items() if s in received]


PAPER_TRANSPORT_MS = 50.0


def run(quick: bool = False) -> list[BenchResult]:
    """The ROS 2 bridge's figures for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        A 10 s drive instead of 30 s.

    Returns
    -------
    list[BenchResult]
        Median and p99 latency as shares of the paper's 50 ms.
    """
    loop_us = reference_loop_us()
    lat = sorted(filtered_latencies(10.0 if quick else 30.0))
    loop_us = min(loop_us, reference_loop_us())
    p50_ms = statistics.median(lat) * 1e3
    p99_ms = lat[min(len(lat) - 1, int(0.99 * len(lat)))] * 1e3
    what = "the paper's 50 ms command transport on its robot"
    return [
        BenchResult(
            f"ros.frame_to_filtered_{q}_share",
            ms / PAPER_TRANSPORT_MS,
            "of 50 ms",
            1.0,
            "lower",
            what,
            ms,
            "ms",
            None,
            loop_us,
        )
        for q, ms in (("p50", p50_ms), ("p99", p99_ms))
    ]
