"""What the daemon serves beside its frame loop, and how each is built: the ROS 2 node and the
messages it shares with the run's rosbag2, the navigation service's control socket (``jackson
goal``/``status``), the live view (Foxglove WebSocket), systemd's notifications, and the
operator's lines on a sensor's health.

Each is optional; :class:`Outlets` starts them once the daemon is set up and stops them first
on the way out.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from jackson.host.config import HostConfig
from jackson.host.core import HostCore
from jackson.host.core.results import CoreListener
from jackson.host.daemon_folders import RunFolders

if TYPE_CHECKING:  # rclpy, the bag and foxglove-sdk load only when asked for
    from jackson.host.health import Transition
    from jackson.host.liveview import LiveView
    from jackson.host.ros.bridge import RosBridge
    from jackson.host.ros.messages import RosOutput
    from jackson.host.sdnotify import Notifier
    from jackson.host.service.control import ControlServer
    from jackson.host.service.navigation import NavigationService
    from jackson.host.service.settings import LiveViewSettings


class OperatorListener(CoreListener):
    """Tells the operator when a sensor's health changes (printed, kept for health.json; the
    core has already logged it in the run)."""

    def __init__(self, say: Callable[[str], None]) -> None:
        self.say = say

    def on_health(self, transition: Transition) -> None:
        tr = transition
        self.say(
            f"health: {tr.sensor} {tr.old.value} -> {tr.new.value} at {tr.t_s:.2f} s: {tr.reason}"
        )

    def on_event(self, host_time_ns: int, text: str) -> None:
        if text.startswith(("health: braking", "health: the host config holds no calibration")):
            self.say(text)


def ros_outlets(
    cfg: HostConfig,
    core: HostCore,
    folders: RunFolders,
    ros_args: list[str] | None,
    service: NavigationService | None,
    say: Callable[[str], None],
) -> tuple[RosBridge | None, RosOutput | None]:
    """The ROS 2 node (``ros_args`` given: ``--ros``) and the run folder's rosbag2, fed by one
    :class:`~jackson.host.ros.messages.RosOutput` listening to the core (None with neither).

    The bag records what the node publishes: its names, offsets and clock. What the node
    cannot publish (a message package missing) is said once.
    """
    from jackson.host.ros.messages import MessageBuilder, RosOutput, RosSettings

    bridge = None
    if ros_args is not None:  # --ros: rclpy is imported only here
        from jackson.host.ros.bridge import RosBridge

        bridge = RosBridge(
            core,
            args=ros_args,
            # the service takes /goal_pose, navigate_to_pose and /initialpose
            service=service,
            say=say,
        )
        for note in bridge.notes:
            say(note)
        if bridge.missing:
            say(
                "ROS: not published (message package missing): "
                + ", ".join(sorted(set(bridge.missing)))
            )
    if folders.run_folder is not None:  # every run folder holds a rosbag2 (MCAP) of the run
        folders.start_bag(
            bridge.settings if bridge is not None else RosSettings.for_config(cfg),
            bridge.clock if bridge is not None else None,
        )
    bag = folders.bag
    sinks = [x for x in (bag, bridge) if x is not None]
    if not sinks:
        return bridge, None
    if bag is not None:
        builder = bag.builder
    else:
        assert bridge is not None  # one of the two is a sink
        builder = MessageBuilder(bridge.settings, cfg.odometry, bridge.clock)
    ros = RosOutput(
        builder,
        sinks,
        telemetry=bag is not None,
        received=bridge.received if bridge is not None else None,
    )
    core.listeners.append(ros)
    return bridge, ros


def live_view(
    settings: LiveViewSettings,
    core: HostCore,
    service: NavigationService | None,
    *,
    sensors: Callable[[], Mapping[str, str]],
    problems: Callable[[], list[str]],
    tell: Callable[[str], None],
    say: Callable[[str], None],
) -> LiveView | None:
    """The live view's listener on the core (not serving yet), or None with one line when
    it cannot be (no navigation service, foxglove-sdk missing)."""
    if service is None:
        say("live view: needs the navigation service (--lidar and --map); not served")
        return None
    try:
        from jackson.common.liveview import LiveServer
        from jackson.host.liveview import LiveView
    except ImportError as exc:  # a broken install: the robot goes on without it
        say(f"live view: cannot load foxglove-sdk ({exc}); make setup installs it")
        return None
    server = LiveServer("jackson daemon", settings.host, settings.port)
    live = LiveView(service, server, sensors=sensors, problems=problems, tell=tell)
    core.listeners.append(live)
    return live


class Outlets:
    """The daemon's outlets, each None when not asked for.

    Parameters
    ----------
    core : HostCore
        The core the ROS messages and the live view listen to.
    service : NavigationService or None
        The navigation service: its goals end when the daemon stops.
    bridge : RosBridge or None
        The ROS 2 node (``--ros``).
    ros : RosOutput or None
        The ROS messages of the node and the bag (/diagnostics published from the frame loop).
    control : ControlServer or None
        The control socket.
    live : LiveView or None
        The live view.
    notifier : Notifier or None
        systemd's sd_notify (host/sdnotify.py).
    say : callable
        One line for the operator (printed, kept for health.json).
    """

    def __init__(
        self,
        core: HostCore,
        service: NavigationService | None,
        *,
        bridge: RosBridge | None,
        ros: RosOutput | None,
        control: ControlServer | None,
        live: LiveView | None,
        notifier: Notifier | None,
        say: Callable[[str], None],
    ) -> None:
        self.core = core
        self.service = service
        self.bridge = bridge
        self.ros = ros
        self.control = control
        self.live = live
        self.notifier = notifier
        self.say = say

    def start(self) -> None:
        """Serve: the ROS node spins, the control socket and the live view listen, systemd
        hears READY. A live view that cannot serve is dropped with one line."""
        if self.bridge is not None:
            if self.bridge.late_clock():  # before the first frame is stamped
                self.say(self.bridge.notes[-1])
            self.bridge.start()
        if self.control is not None:
            self.control.start()
            self.say(f"taking goals on {self.control.path} (jackson goal X,Y)")
        if self.live is not None:
            from jackson.common.liveview import LiveViewError

            try:
                url = self.live.start()
            except LiveViewError as exc:  # the robot goes on without it
                self.core.listeners.remove(self.live)
                self.live = None
                self.say(f"{exc}; going on without it")
            else:
                self.say(f"live view on {url} (Foxglove: Open connection, Foxglove WebSocket)")
        if self.notifier is not None:
            self.notifier.ready()

    def alive(self) -> None:
        """The frame loop goes round: systemd's watchdog is pinged."""
        if self.notifier is not None:
            self.notifier.watchdog()

    def stop(self) -> None:
        """systemd hears STOPPING, the sockets close, the service's goals end, the node
        stops."""
        if self.notifier is not None:
            self.notifier.stopping()
        if self.control is not None:
            self.control.stop()
        if self.live is not None:
            self.live.stop()
        if self.service is not None:
            self.service.book.end_all("the daemon stopped")
        if self.bridge is not None:
            self.bridge.stop()
