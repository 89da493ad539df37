"""``mcu_clock``: the robot's MCU time on /clock, for a graph run on it (``use_sim_time``).

By default the host daemon maps its stamps (MCU time, the unwrapped microsecond time of each
telemetry frame) onto the system clock, and the nodes run on that. With ``use_sim_time`` the
daemon stamps with MCU time itself, as against the twin, whose ``jackson sim --ros`` then
publishes that time on /clock; on the robot this node does it, republishing the stamp of each
/joint_states (one per telemetry frame, 20 Hz) as a rosgraph_msgs/Clock:

- a stamp that does not advance is dropped, so the clock never runs backwards by a frame
  (a stamp repeated or reordered on the way);
- a stamp more than :data:`RESTART_S` behind the last one is a new MCU clock (the daemon was
  started again) and is published: ROS time jumps back, and the nodes reset their TF buffers.

The node itself runs on the system clock (``use_sim_time`` false). /clock's QoS is that of
``rclcpp::ClockQoS`` (best effort, depth 1), as the twin publishes it.
"""

from __future__ import annotations

from typing import Any

RESTART_S = 1.0  # [s] a stamp this far behind the last one starts a new clock
JOINT_STATES_TOPIC = "/joint_states"
CLOCK_TOPIC = "/clock"


def next_clock_ns(last_ns: int | None, stamp_ns: int, restart_ns: int) -> int | None:
    """The time to publish for a /joint_states stamp, or None to publish nothing.

    Parameters
    ----------
    last_ns : int or None
        The last time published [ns]; None before the first.
    stamp_ns : int
        The stamp of the /joint_states just received [ns].
    restart_ns : int
        How far behind ``last_ns`` a stamp must be to count as a new clock [ns].

    Returns
    -------
    int or None
        ``stamp_ns`` when it advances the clock or starts a new one, else None.
    """
    if last_ns is None or stamp_ns > last_ns or stamp_ns < last_ns - restart_ns:
        return stamp_ns
    return None


class McuClock:
    """Subscribes /joint_states (reliable, depth 10, as the daemon publishes it) on ``node``
    and publishes /clock.

    Parameters
    ----------
    node : rclpy.node.Node
        The node to create the subscription and the publisher on.
    restart_s : float
        See :data:`RESTART_S`.
    """

    def __init__(self, node: Any, restart_s: float = RESTART_S) -> None:
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import JointState

        self.node = node
        self._clock_type = Clock
        self._restart_ns = round(restart_s * 1e9)
        self.last_ns: int | None = None
        self.published = 0
        self.publisher = node.create_publisher(
            Clock, CLOCK_TOPIC, QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
        )
        self.subscription = node.create_subscription(
            JointState,
            JOINT_STATES_TOPIC,
            self._on_joint_states,
            QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE),
        )

    def _on_joint_states(self, msg: Any) -> None:
        stamp_ns = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
        now_ns = next_clock_ns(self.last_ns, stamp_ns, self._restart_ns)
        if now_ns is None:
            return
        if self.last_ns is not None and now_ns < self.last_ns:
            self.node.get_logger().warning(
                f"MCU clock restarted: {self.last_ns / 1e9:.3f} s -> {now_ns / 1e9:.3f} s"
            )
        self.last_ns = now_ns
        clock = self._clock_type()
        clock.clock.sec, clock.clock.nanosec = divmod(now_ns, 1_000_000_000)
        self.publisher.publish(clock)
        self.published += 1


def main(args: list[str] | None = None) -> None:
    """Run the node until Ctrl-C or shutdown (``ros2 run jackson_bringup mcu_clock``)."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    rclpy.init(args=args)
    node = Node(
        "mcu_clock",
        parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, False)],
    )
    McuClock(node)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
