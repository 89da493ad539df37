"""The host daemon: the serial transport, the run folder and the process around
:class:`jackson.host.core.HostCore` (which computes everything per frame, see there): link
health, commands acknowledged, the motor path watched, systemd told, signals handled.

The pieces live beside it: the run folders, their split and budget
(:mod:`jackson.host.daemon_folders`), the link and motor-path watch
(:mod:`jackson.host.daemon_link`), what is served beside the frame loop
(:mod:`jackson.host.daemon_outlets`) and what the daemon reports of itself
(:mod:`jackson.host.daemon_reports`).
"""

from __future__ import annotations

import dataclasses
import gc
import math
import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, cast

from jackson.common.errors import JacksonError
from jackson.common.lazy import instance_of
from jackson.common.liveness import STALL_EXIT
from jackson.common.spin import contention
from jackson.common.threads import Watch
from jackson.host.actuation.output import MotorOutput
from jackson.host.commands import CommandError, CommandTracker
from jackson.host.config import HostConfig
from jackson.host.control import Mission, make_mission
from jackson.host.core import DutySource, HostCore
from jackson.host.cpu import CpuMeter
from jackson.host.daemon_folders import FolderSplit, RunFolders
from jackson.host.daemon_latency import LatencyMeter
from jackson.host.daemon_link import VERSION_SILENCE_S, LinkHealth, LinkWatch
from jackson.host.daemon_outlets import OperatorListener, Outlets, live_view, ros_outlets
from jackson.host.daemon_reports import health_doc, sensor_states, status_doc
from jackson.host.recording.split import SplitPolicy
from jackson.protocol import Frame, Heartbeat, HostState, Message, Telemetry

if TYPE_CHECKING:  # the seams' types only: the serial port and the LiDAR load when used
    from jackson.host.lidar.rplidar import LidarSource
    from jackson.host.liveview import LiveView
    from jackson.host.ros.messages import RosOutput
    from jackson.host.sdnotify import Notifier
    from jackson.host.service.control import ControlServer
    from jackson.host.service.navigation import NavigationService
    from jackson.host.service.settings import LiveViewSettings
    from jackson.host.transport import Link, LinkEvent

__all__ = [
    "EVENTS_KEPT",
    "GC_GEN0_THRESHOLD",
    "VERSION_SILENCE_S",
    "Daemon",
    "DaemonError",
    "GcSettled",
    "LinkHealth",
    "lidar_meta",
    "with_port",
]

EVENTS_KEPT = 1000  # operator lines a daemon keeps for health.json
GC_GEN0_THRESHOLD = 20_000  # young objects allocated (less freed) between two collections


class GcSettled:
    """The garbage collector set for the frame loop: what set-up allocated (imports, the
    config, the core, the bag's schemas) frozen out of every later collection, and young
    objects collected 20 000 allocations apart instead of 700.

    Per frame almost everything dies by reference count (about two tracked objects survive a
    frame), so young collections become rare (one per ~10^4 frames) and scan only what the
    run made. Unfrozen, an older generation's collection walks the ~10^5 objects of the
    imports: 0.5-2 ms, several frames' work, at a frame the allocator picks. :meth:`restore`
    puts the collector back as it was, for a process that goes on after the daemon.
    """

    def __init__(self) -> None:
        self._threshold = gc.get_threshold()
        gc.collect()
        gc.freeze()
        gc.set_threshold(GC_GEN0_THRESHOLD, self._threshold[1], self._threshold[2])

    def restore(self) -> None:
        """Unfreeze and the previous thresholds."""
        gc.set_threshold(*self._threshold)
        gc.unfreeze()


class DaemonError(JacksonError, RuntimeError):
    """The daemon cannot go on (a device that refuses its commands, another protocol)."""


class Daemon:
    """The process: transport, core, recorder, signals. ``run()`` returns an exit status:
    0 when it stopped as asked or the mission is done, 75 on a lockstep stall, 1 when the
    mission was aborted otherwise
    (:attr:`HostCore.abort_reason`). A device that refuses a command, never answers one, or
    speaks another protocol raises :class:`DaemonError` (or ProtocolMismatchError).

    On a twin's pty the link watches for a lockstep stall (:mod:`jackson.host.transport`):
    ``stall_s`` wall seconds of waiting without a telemetry frame (default: the transport's own
    setting, else :data:`~jackson.host.transport.STALL_S`; ``math.inf``: never), after which
    the twin's liveness decides: a twin that works is waited for. A stall ends the run on the
    abort path (braked, SHUTDOWN heartbeat, exit status 75, ``EX_TEMPFAIL``: an infrastructure
    failure, not the robot's) with one line, ``lockstep stalled: the host waited 10.5 s for a
    telemetry frame after frame N (MCU time T s): the twin process is stopped``, kept in
    :attr:`stalled` and in the run's log, where ``jackson replay`` finds it.

    With ``rotate`` (``jackson daemon``: a robot's daemon runs for hours), the recording
    splits into run folders as ``recording.split`` says (a navigation service, or a daemon
    without a mission) and the recording folder is kept under ``recording.budget_mb``
    (docs/recording.md); without it (a trial's, a calibration's daemon) it writes its one run
    folder and deletes nothing.
    """

    def __init__(
        self,
        cfg: HostConfig,
        output_factory: Callable[[Callable[[Message], object]], MotorOutput],
        transport: Link,
        *,
        mission_name: str | None = None,
        run_folder: Path | None = None,
        meta: dict[str, Any] | None = None,
        rotate: bool = False,
        ros_args: list[str] | None = None,
        mission_timeout_s: float | None = None,
        notifier: Notifier | None = None,
        duty_source: DutySource | None = None,
        imu_calibration: bool = True,
        mission: Mission | None = None,
        lidar: LidarSource | None = None,
        stall_s: float | None = None,
        control_socket: Path | None = None,
        live_view: LiveViewSettings | None = None,
    ) -> None:
        self.cfg = cfg
        self.transport = transport
        _set_stall(transport, stall_s)
        self.stalled: str | None = None  # the stall line, when a lockstep stall ended the run
        self.wall_limit_hit = False  # run(max_s) ended on its wall-clock limit
        self.folders = RunFolders(
            cfg, run_folder, {**(meta or {}), **lidar_meta(lidar)}, rotate, self._say
        )
        # an answer is late only once everything the device sent after the command was heard
        self.commands = CommandTracker(transport.encode, self._send_frame, heard=transport.heard_s)
        if mission is None and mission_name:
            mission = make_mission(mission_name, cfg.square, cfg.figure8)
        self.lidar = lidar  # a started RplidarDriver (its raw bytes go to the core), or None
        self._lidar_lost: str | None = None  # the LiDAR's port failed before this frame
        self.output = output_factory(self._send)
        self.core = HostCore(
            cfg,
            self.output,
            self._send,
            mission=mission,
            recorder=self.folders.recorder,
            mission_timeout_s=mission_timeout_s,
            duty_source=duty_source,
            imu_calibration=imu_calibration,
        )
        if lidar is not None:  # the core decodes the stream of the mode the driver started
            self.core.lidar.expect(lidar.answer_type)
        # a silent port gets HELLO again after three telemetry periods (at least 0.5 s)
        transport.silence_s = max(0.5, 3.0 / cfg.serial.telemetry_rate_hz)
        # what the operator was told, in order (the newest EVENTS_KEPT: a service runs for days)
        self.events: deque[str] = deque(maxlen=EVENTS_KEPT)
        self.cpu = CpuMeter()  # the daemon's own CPU per robot-second and per frame
        from jackson.host.ros.output import navigation_of

        nav = navigation_of(mission)
        if nav is not None:  # the planner server's worker process counts as the daemon's
            planner = nav.navigator.planning.planner
            self.cpu.helpers.append(lambda: planner.cpu_s)
        self.latency = LatencyMeter()  # telemetry read to its HEARTBEAT written, per frame
        self.link = LinkWatch(transport, self.output, self.core, self.commands, self.tell)
        # the navigation service: goal after goal, the control socket (jackson goal/status)
        self.service = (
            cast("NavigationService", mission)
            if instance_of(mission, "jackson.host.service.navigation", "NavigationService")
            else None
        )
        bridge, ros = ros_outlets(cfg, self.core, self.folders, ros_args, self.service, self._say)
        self.core.listeners.append(OperatorListener(self._say))
        self.stop = threading.Event()
        self.split = self._split_policy(rotate, mission, duty_source, ros)
        control: ControlServer | None = None
        if self.service is not None:
            self.service.tell = self.tell  # called on the frame loop's thread
            if control_socket is not None:
                from jackson.host.service.control import ControlServer

                control = ControlServer(control_socket, self.service, self.status, self._drive)
        # the live view (Foxglove WebSocket): served from run(), published from the frame loop
        live = None
        if live_view is not None and live_view.enabled:
            live = self._live_view(live_view)
        self.outlets = Outlets(
            self.core,
            self.service,
            bridge=bridge,
            ros=ros,
            control=control,
            live=live,
            notifier=notifier,
            say=self._say,
        )

    def _split_policy(
        self,
        rotate: bool,
        mission: Mission | None,
        duty_source: DutySource | None,
        ros: RosOutput | None,
    ) -> FolderSplit | None:
        """How the recording splits into run folders: with ``rotate``, for teleop or the
        service; else never."""
        # teleop or the service: a mission ends by itself, a duty source is a calibration's
        teleop_or_service = mission is None or self.service is not None
        recording = rotate and self.folders.run_folder is not None
        if not (recording and duty_source is None and teleop_or_service):
            return None
        return FolderSplit(
            SplitPolicy(self.cfg.recording_split, self.cfg.recording_split_s),
            self.folders,
            self.core,
            ros,
            self.service,
            self._health_doc,
            self.events,
            self.tell,
        )

    def _live_view(self, settings: LiveViewSettings) -> LiveView | None:
        return live_view(
            settings,
            self.core,
            self.service,
            sensors=self.sensor_states,
            problems=lambda: self.health().problems(),
            tell=self.tell,
            say=self._say,
        )

    # ------------------------------------------------------------------ state

    @property
    def run_folder(self) -> Path | None:
        """The run folder being written (the last one of a split run; None: no recording)."""
        return self.folders.run_folder

    @property
    def link_downs(self) -> int:
        """Times the serial link went down."""
        return self.link.downs

    def health(self) -> LinkHealth:
        """The link's and the motor path's state now."""
        return self.link.health()

    def sensor_states(self) -> dict[str, str]:
        """Each sensor's health state now (empty with the monitor off)."""
        return sensor_states(self.core)

    def status(self) -> dict[str, Any]:
        """What ``jackson status`` shows: the service's state, goal, pose with covariance,
        sensor health, link problems, CPU and the recording folder's disk use. Safe from
        another thread (it reads snapshots)."""
        return status_doc(
            self.core, self.service, self.health(), self.cpu, self.disk(), self.latency
        )

    def disk(self) -> dict[str, Any]:
        """The recording folder's use and budget [MB] and the free space on its disk [MB]."""
        return self.folders.disk()

    def _health_doc(self) -> dict[str, Any]:
        """health.json of the run folder being written."""
        return health_doc(
            self.core,
            self.health(),
            self.events,
            self.cpu,
            self.commands.counters,
            1.0 / self.cfg.serial.telemetry_rate_hz,
            self.latency,
        )

    # ------------------------------------------------------------------ the frame loop

    def run(self, max_s: float | None = None) -> int:
        """Serve until stopped (:attr:`stop`, a signal), the mission ends, the link stalls or
        ``max_s`` wall seconds pass; the exit status (1: aborted; :data:`~jackson.common.
        liveness.STALL_EXIT`, 75: a lockstep stall, an infrastructure failure)."""
        started = time.monotonic()
        deadline = None if max_s is None else started + max_s
        self.link.started(started)
        self.outlets.start()
        self.folders.start()
        settled = GcSettled()
        try:
            with Watch() as watch:  # a thread of this process that dies ends the run
                self._loop(deadline, watch)
        finally:
            self._shut_down()
            settled.restore()
        if self.stalled is not None:
            return STALL_EXIT
        return 1 if self.core.abort_reason is not None else 0

    def _loop(self, deadline: float | None, watch: Watch) -> None:
        from jackson.host.transport import LinkEvent

        while not self.stop.is_set():
            if watch.first is not None:  # the abort path brakes and says SHUTDOWN
                self.tell(watch.first.line)
                self.core.abort(watch.first.line)
                return
            if deadline is not None and time.monotonic() > deadline:
                self.wall_limit_hit = True
                return
            self.outlets.alive()
            self.link.turn(time.monotonic())  # a stall of the daemon itself is told
            try:
                self.commands.poll()
            except CommandError as exc:
                raise DaemonError(str(exc)) from exc
            self.link.check_version()
            self.link.motor_path()
            item = self.transport.get(0.1)
            if item is None:
                continue
            if isinstance(item, LinkEvent):
                if self._on_link_event(item):
                    return
                continue
            rx_ns, frame = item
            if self._on_frame(frame, rx_ns):
                return

    def _on_link_event(self, event: LinkEvent) -> bool:
        """The link went down or up, stalled or fell silent; True: the run ends."""
        core = self.core
        if event.kind == "down":
            self.link.downs += 1
            core.brake()
            if core.mission is not None and core.mission.done:
                # nothing left to drive: not waiting for the robot to rest
                self.tell(f"serial link down ({event.detail}) after the mission")
                return True
            self.tell(f"serial link down ({event.detail}): braked, reconnecting")
        elif event.kind == "up":
            core.link_up()
            self.commands.forget()
            if self.link.downs:
                self.tell("serial link up again")
        elif event.kind == "stalled":
            self._stall(event.detail)
            return True
        elif event.kind == "silent" and core.info is None:
            self.link.unanswered(event.detail)
        elif self.folders.recorder is not None:
            self.folders.recorder.link(event.rx_time_ns, f"{event.kind} {event.detail}")
        return False

    def _stall(self, detail: str) -> None:
        """The twin stopped: the abort path brakes and says SHUTDOWN on the way out."""
        core = self.core
        when = (
            f"after frame {core.frames} (MCU time {core.t_s:.2f} s)"
            if core.t_s is not None
            else "before the first frame"
        )
        waited, _, why = detail.partition(": ")
        self.stalled = f"lockstep stalled: {waited} {when}" + (f": {why}" if why else "")
        self.tell(self.stalled)
        core.abort(self.stalled)

    def _on_frame(self, frame: Frame, rx_ns: int) -> bool:
        """One frame through the core (a telemetry frame after the split and the LiDAR's
        bytes), /diagnostics when due, its CPU counted; True: the run ends."""
        core = self.core
        cpu0 = time.thread_time_ns() - round(contention.spun_s * 1e9)
        if frame.type == Telemetry.TYPE:
            self.latency.arrived(rx_ns)
        if self.split is not None and frame.type == Telemetry.TYPE:
            self._split_if_due()
        if self.lidar is not None and frame.type == Telemetry.TYPE:
            self._read_lidar()
        try:
            self.commands.on_frame(frame)
        except CommandError as exc:
            raise DaemonError(str(exc)) from exc
        resets = core.mcu_resets
        core.on_frame(frame, rx_ns)
        if self._lidar_lost is not None:
            core.lidar_gone(self._lidar_lost)
            self._lidar_lost = None
        if core.mcu_resets != resets:
            self.tell("the MCU was reset: odometry and time re-anchored, device set up again")
        self.link.foreign_write()  # told; a running mission aborted with the reason
        if core.abort_reason is not None:
            self.tell(f"mission aborted: {core.abort_reason}")
            return True
        ros = self.outlets.ros
        if (
            ros is not None
            and core.last_telemetry is not None
            and ros.diagnostics_due(core.t_s or 0.0)
        ):
            from jackson.host.ros.bridge import diagnostic_values

            ros.diagnostics(diagnostic_values(core, core.last_telemetry, link=self.health()))
        if frame.type == Telemetry.TYPE:
            # less any polling of a lockstep twin's links (jackson.host.cpu)
            spun_ns = round(contention.spun_s * 1e9)
            self.cpu.frame((time.thread_time_ns() - spun_ns - cpu0) / 1e3)
            self.cpu.robot_time(core.t_s)
            if self.split is not None:
                self.split.frame(core.t_s)
        if core.finished:  # the mission done, braked, the robot at rest
            return True
        return core.duty_source is not None and core.duty_source.done

    def _shut_down(self) -> None:
        """Braked, the outlets stopped, SHUTDOWN said to the MCU, the run folder finished."""
        self.core.brake()
        self.outlets.stop()
        self._send(Heartbeat(ack_seq=0, host_state=HostState.SHUTDOWN))
        self.folders.close(self._health_doc)

    def _split_if_due(self) -> None:
        """Before a telemetry frame (and its LiDAR bytes): the next run folder starts now if
        ``recording.split`` says so; a recording that cannot split goes on unsplit."""
        split = self.split
        assert split is not None
        reason = split.due()
        if reason is None:
            return
        try:
            split.split(reason)
        except Exception as exc:  # a recording that cannot split must not stop the robot
            self.split = None
            self.tell(
                f"recording: cannot split ({type(exc).__name__}: {exc}); recording goes on in "
                f"{self.run_folder}, unsplit"
            )

    def _read_lidar(self) -> None:
        """The LiDAR's bytes that arrived before this telemetry frame, to the core. A LiDAR
        that goes away ends a mission that needs it (braked), and is not read again."""
        from jackson.host.lidar.rplidar import LidarError

        assert self.lidar is not None
        try:
            data = self.lidar.read()
        except LidarError as exc:
            self.lidar = None
            self.tell(f"LiDAR lost: {exc}")
            # excluded, and a navigation braked and aborted, right after this frame (on its
            # MCU time: the port failed before it)
            self._lidar_lost = str(exc)
            return
        self.core.on_lidar(data, time.monotonic_ns())

    # ------------------------------------------------------------------ I/O and the operator

    def _drive(self, v_m_s: float, w_rad_s: float) -> None:
        """A velocity command from the control socket, as one on /cmd_vel."""
        self.core.submit_velocity(v_m_s, w_rad_s, time.monotonic_ns())

    def _send(self, msg: Message) -> object:
        if isinstance(msg, Heartbeat):
            sent = self._send_frame(self.transport.encode(msg))
            self.latency.written(time.monotonic_ns())  # after the frame's motor command
            return sent
        return self.commands.send(msg)

    def _send_frame(self, frame: bytes) -> object:
        recorder = self.folders.recorder
        if recorder is not None:
            recorder.tx(time.monotonic_ns(), frame)
        return self.transport.send_raw(frame)

    def install_signals(self) -> None:
        """SIGINT and SIGTERM stop the frame loop (the run ends braked, as asked)."""

        def on_signal(signum: int, frame: FrameType | None) -> None:
            self.stop.set()

        signal.signal(signal.SIGINT, on_signal)
        signal.signal(signal.SIGTERM, on_signal)

    def _say(self, text: str) -> None:
        """:meth:`tell` from another thread: printed and kept, not written into the run's log
        (the main loop owns it)."""
        self.events.append(text)
        print(f"daemon: {text}", flush=True)

    def tell(self, text: str) -> None:
        """One line for the operator: printed, and in the run's log."""
        self.events.append(text)
        print(f"daemon: {text}", flush=True)
        recorder = self.folders.recorder
        if recorder is not None:
            recorder.link(time.monotonic_ns(), text)


def _set_stall(transport: Link, stall_s: float | None) -> None:
    """The link's lockstep stall limit: ``stall_s`` (``math.inf``: never), else the
    transport's own, else :data:`~jackson.host.transport.STALL_S` on a twin's pty."""
    from jackson.host.transport import STALL_S

    if stall_s is not None:
        transport.stall_s = None if math.isinf(stall_s) else stall_s
    elif transport.stall_s is None and transport.on_pty:
        transport.stall_s = STALL_S  # a twin's pty: lockstep can stall


def lidar_meta(lidar: LidarSource | None) -> dict[str, Any]:
    """What a run folder's meta.json records of a started RPLIDAR driver (none without one):
    the device, its scan mode and the stream's answer type, which a replay decodes the logged
    bytes as (docs/recording.md)."""
    if lidar is None or lidar.mode is None:
        return {}
    info = lidar.info
    return {
        "lidar": {
            "device": None
            if info is None
            else f"{info.model_name} firmware {info.firmware_major}.{info.firmware_minor:02d} "
            f"hardware {info.hardware}",
            "mode": lidar.mode.name,
            "answer_type": int(lidar.answer_type),
            "us_per_sample": float(lidar.mode.us_per_sample),
        }
    }


def with_port(cfg: HostConfig, port: str | None) -> HostConfig:
    """The config with ``serial.port`` replaced (``--port``)."""
    if port is None:
        return cfg
    return dataclasses.replace(cfg, serial=dataclasses.replace(cfg.serial, port=port))
