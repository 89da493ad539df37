"""The core's listener that hands every ROS 2 message of a run to every sink: the run's bag
and, with ``--ros``, the live node (:class:`RosOutput`)."""

from __future__ import annotations

import math
import struct
import time
from collections import deque
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol, cast

import numpy as np
import numpy.typing as npt

from jackson.common.lazy import instance_of
from jackson.host.core.results import CoreListener, FrameResult
from jackson.host.lidar.scan_timer import ScanTimer
from jackson.host.ros.builder import MessageBuilder
from jackson.host.ros.diagnostics import DiagnosticValues
from jackson.host.ros.packed import FramePacker
from jackson.protocol import PROTOCOL_VERSION, Frame, TelemetryFlags, crc32c

if TYPE_CHECKING:
    from jackson.host.control.base import Mission
    from jackson.host.control.navigate import NavigateMission
    from jackson.host.estimation.ekf import EkfState
    from jackson.host.nav.types import Pose2D, Scan
    from jackson.host.service.navigation import NavigationService

MAP_PERIOD_S = 5.0  # [s] of MCU time between /map messages while mapping
DIAGNOSTICS_PERIOD_S = 1.0  # [s] of MCU time between /diagnostics messages
_CRC = struct.Struct("<I")  # a frame's CRC-32C, after its body
_IMU_OK = int(TelemetryFlags.IMU_OK)  # as a plain int: an IntFlag's ``&`` builds a member


def wire_bytes(frame: Frame) -> bytes:
    """The frame as it was on the wire (a delivered frame has this version and a valid CRC)."""
    body = bytes((PROTOCOL_VERSION, frame.type, frame.seq, len(frame.payload))) + frame.payload
    return b"\xa5\x5a" + body + _CRC.pack(crc32c(body))


def navigation_of(mission: Mission | None) -> NavigateMission | None:
    """The navigation a mission drives with, whose plans, map -> odom and map the navigation
    topics show: a one-shot navigation (``--goal``) is its own; the navigation service keeps
    one for its whole run (``NavigationService.nav``); other missions have none."""
    if instance_of(mission, "jackson.host.service.navigation", "NavigationService"):
        return cast("NavigationService", mission).nav
    if instance_of(mission, "jackson.host.control.navigate", "NavigateMission"):
        return cast("NavigateMission", mission)
    return None


class RosSink(Protocol):
    """Where :class:`RosOutput` sends each message: a bag, the live node."""

    def write(self, key: str, t_s: float, msg: Any) -> None:
        """One message of the topic with key ``key``
        (:data:`~jackson.host.ros.settings.TOPIC_TYPES`) at MCU time."""
        ...

    def wants(self, key: str, t_s: float) -> bool:
        """Whether a message of the topic with key ``key`` at MCU time ``t_s`` would be kept
        (a thinned topic between two of its messages: not), so one nobody keeps is not built."""
        ...


class RosOutput(CoreListener):
    """The core's listener that builds every message once and sends it to every sink.

    Parameters
    ----------
    builder : MessageBuilder
        The messages' builder.
    sinks : sequence of RosSink
        The bag, the live node (either may be absent).
    telemetry : bool
        Also send each received frame's bytes (/jackson/telemetry: the bag's raw record).
    received : deque or None
        Messages the live node received on its own thread, ``(key, value)``, recorded here on
        the core's: ``("goal_pose", (x, y, yaw, frame))``, ``("initialpose", (x, y, yaw,
        frame, covariance))``.
    """

    def __init__(
        self,
        builder: MessageBuilder,
        sinks: Sequence[RosSink],
        *,
        telemetry: bool = True,
        received: deque[tuple[str, Any]] | None = None,
    ) -> None:
        self.builder = builder
        self.sinks = list(sinks)
        self.telemetry = telemetry
        self.received = received
        self._pending: list[bytes] = []
        self._static_sent = False
        self._frame_scans: list[Scan] = []  # this frame's scans, stamped at its result
        self._held_scans: list[Scan] = []  # scans the timer holds until it knows their phase
        self._frames = 0  # frames seen (on_result)
        self.scan_timer = ScanTimer()
        self._plan_version = -1
        self._map_sent_s: float | None = None
        self._t_s = 0.0
        self._t_prev_s: float | None = None  # the frame before the last one
        self._next_diagnostics_s: float | None = None
        self._mission: Mission | None = None  # the last frame's mission
        self._nav: NavigateMission | None = None  # its navigation (navigation_of)
        self.pack = FramePacker(builder)  # the frame's messages, packed with its names

    def send(self, key: str, t_s: float, msg: Any) -> None:
        """Hand one message to every sink."""
        for sink in self.sinks:
            sink.write(key, t_s, msg)

    def _static(self, t_s: float) -> None:
        if not self._static_sent and self.builder.settings.publish_tf:
            self._static_sent = True
            self.send("tf_static", t_s, self.builder.static_tf(t_s))

    def on_frame(self, frame: Frame, host_time_ns: int) -> None:
        if self.telemetry:
            self._pending.append(wire_bytes(frame))

    def on_command(self, v_m_s: float, w_rad_s: float, host_time_ns: int) -> None:
        # taken at the frame that applies it: stamped with the last frame's time
        self.send("cmd_vel", self._t_s, self.pack.twist(self._t_s, v_m_s, w_rad_s))

    def on_result(self, result: FrameResult) -> None:
        b, t_s, odo, t = self.builder, result.t_s, result.odometry, result.telemetry
        self._t_prev_s = self._t_s if self._frames else None
        self._t_s = t_s
        self._frames += 1
        b.clock.observe(t_s, time.time_ns())
        self._static(t_s)
        self._send_scans(t_s)
        while self.received:
            key, value = self.received.popleft()
            if key == "goal_pose":
                x, y, yaw, frame = value
                self.send(key, t_s, b.goal(t_s, x, y, yaw, frame or "map"))
            elif key == "initialpose":
                x, y, yaw, frame, cov = value
                self.send(key, t_s, b.initial_pose(t_s, x, y, yaw, cov, frame or "map"))
        pack = self.pack
        for raw in self._pending:
            self.send("telemetry", t_s, pack.raw_frame(raw))
        self._pending.clear()
        if odo is not None:
            self.send("wheel_odom", t_s, pack.wheel_odom(t_s, odo))
        if t.flags & _IMU_OK:
            self.send("imu", t_s, pack.imu(t_s, t))
        if odo is not None:
            self.send("joint_states", t_s, pack.joint_states(t_s, odo))
            if b.settings.publish_tf and b.settings.tf_source == "wheel":
                self.send("tf", t_s, pack.odom_tf(t_s, odo.x_m, odo.y_m, odo.yaw_rad))
            if b.settings.publish_tf and b.settings.publish_wheel_tf:
                self.send("tf", t_s, pack.wheel_tf(t_s, odo))
        self._navigation(result, t_s)

    def on_filtered(self, t_s: float, state: EkfState) -> None:
        if not state.initialized:
            return
        b = self.builder
        self._static(t_s)
        pack = self.pack
        self.send("filtered", t_s, pack.filtered(t_s, state))
        if b.settings.publish_tf and b.settings.tf_source == "filtered":
            self.send("tf", t_s, pack.odom_tf(t_s, state.x_m, state.y_m, state.yaw_rad))

    def on_scan(self, scan: Scan) -> None:
        if len(scan.angles_rad) >= 2:
            self._frame_scans.append(scan)  # before this frame's result

    def _send_scans(self, t_s: float) -> None:
        """This frame's scans (and those held), stamped together: once the clock is set, and
        knowing how many came with the frame (:class:`ScanTimer`)."""
        if not self._frame_scans:
            return
        since = self._t_prev_s  # the frame before this one (None: this is the first)
        scans, self._frame_scans = self._frame_scans, []
        self._held_scans += scans
        stamps = self.scan_timer.stamp([len(s.angles_rad) for s in scans], t_s, since)
        if not stamps:
            return
        for scan, (start_s, period_s) in zip(self._held_scans, stamps, strict=True):
            self.send("scan", scan.t_s, self.builder.scan(scan, start_s, period_s))
        self._held_scans.clear()

    def diagnostics_due(self, t_s: float) -> bool:
        """Whether :meth:`diagnostics` would send at MCU time ``t_s`` (the daemon gathers the
        values only then: once per second, not every frame).

        Parameters
        ----------
        t_s : float
            MCU time [s].

        Returns
        -------
        bool
            True once :data:`DIAGNOSTICS_PERIOD_S` has passed since the last summary.
        """
        due = self._next_diagnostics_s
        return due is None or t_s >= due - 1e-9

    def diagnostics(self, values: DiagnosticValues) -> bool:
        """The daemon's summary, at most once per :data:`DIAGNOSTICS_PERIOD_S` of MCU time;
        True when it was sent."""
        if not self.diagnostics_due(values.t_s):
            return False
        self._next_diagnostics_s = values.t_s + DIAGNOSTICS_PERIOD_S
        self.send("diagnostics", values.t_s, self.builder.diagnostics(values))
        return True

    def _local_plan(self, t_s: float, local: npt.NDArray[np.float64], corr: Pose2D) -> None:
        """/local_plan in odom, as Nav2's controller publishes it: map -> odom undone."""
        if len(local):
            b = self.builder
            c, s_ = math.cos(corr.yaw), math.sin(corr.yaw)
            dx, dy = local[:, 0] - corr.x, local[:, 1] - corr.y
            in_odom = np.column_stack((c * dx + s_ * dy, -s_ * dx + c * dy, local[:, 2] - corr.yaw))
            self.send("local_plan", t_s, b.path(t_s, in_odom, b.settings.odom_frame))

    def _navigation(self, result: FrameResult, t_s: float) -> None:
        """After a control tick of a navigation mission: /plan (each new global plan),
        /local_plan, map -> odom on /tf, and /map (once on a known map; every
        :data:`MAP_PERIOD_S` while mapping)."""
        if result.mission is not self._mission:  # a new mission: look once what it navigates with
            self._mission = result.mission
            self._nav = navigation_of(result.mission)
        nav = self._nav
        if nav is None:
            return
        b = self.builder
        replans = nav.navigator.replans
        if replans != self._plan_version and len(nav.navigator.plan):
            self.send("plan", t_s, b.path(t_s, nav.navigator.plan))
        self._plan_version = replans
        corr = nav.map_to_odom.compose(nav.config.start)  # odom starts at the start pose
        # built only when a sink keeps it (the bag thins it, recording.bag_topic_hz)
        if any(sink.wants("local_plan", t_s) for sink in self.sinks):
            self._local_plan(t_s, nav.navigator.published_local_plan, corr)
        if b.settings.publish_tf:
            odom, xyz = b.settings.odom_frame, (corr.x, corr.y, 0.0)
            self.send("tf", t_s, self.pack.transform(t_s, "map", odom, xyz, corr.yaw))
        mapping = nav.mapper is not None
        due = self._map_sent_s is None or (mapping and t_s - self._map_sent_s >= MAP_PERIOD_S)
        grid = nav.built_map() if mapping else nav.static_map
        if due and grid is not None:
            self._map_sent_s = t_s
            self.send("map", t_s, b.occupancy(t_s, grid))
