"""The host daemon: the serial transport, the run folder and the process around
:class:`jackson.host.core.HostCore` (which computes everything per frame, see there): link
health, commands acknowledged, the motor path watched, systemd told, signals handled.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import gc
import math
import shutil
import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

from jackson.common.errors import JacksonError
from jackson.common.spin import contention
from jackson.host.actuation.output import MotorOutput
from jackson.host.commands import CommandError, CommandTracker
from jackson.host.config import HostConfig
from jackson.host.control import Mission, make_mission
from jackson.host.core import DutySource, HostCore
from jackson.host.core.results import CoreListener
from jackson.host.cpu import CpuMeter
from jackson.host.estimation.health import Transition
from jackson.host.recording import RunRecorder, run_in_progress, write_json
from jackson.host.recording.budget import Deleted, DiskUse, folder_bytes, prune
from jackson.host.recording.snapshot import SNAPSHOT_NAME, encode_snapshot, write_snapshot
from jackson.host.recording.split import FolderWorker, SplitPolicy, carry_files, part_folder
from jackson.protocol import (
    PROTOCOL_VERSION,
    FrameVersionError,
    Heartbeat,
    HostState,
    Message,
    Telemetry,
    TelemetryFlags,
)

if TYPE_CHECKING:  # the seams' types only: the serial port and the LiDAR load when used
    from jackson.host.lidar.rplidar import LidarSource
    from jackson.host.liveview import LiveView
    from jackson.host.sdnotify import Notifier
    from jackson.host.service.control import ControlServer
    from jackson.host.service.settings import LiveViewSettings
    from jackson.host.transport import Link

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


class _OperatorListener(CoreListener):
    """Tells the operator when a sensor's health changes (printed, kept for health.json; the
    core has already logged it in the run)."""

    def __init__(self, daemon: Daemon) -> None:
        self.daemon = daemon

    def on_health(self, transition: Transition) -> None:
        tr = transition
        self.daemon._say(
            f"health: {tr.sensor} {tr.old.value} -> {tr.new.value} at {tr.t_s:.2f} s: {tr.reason}"
        )

    def on_event(self, host_time_ns: int, text: str) -> None:
        if text.startswith(("health: braking", "health: the host config holds no calibration")):
            self.daemon._say(text)


class DaemonError(JacksonError, RuntimeError):
    """The daemon cannot go on (a device that refuses its commands, another protocol)."""


@dataclass(frozen=True)
class LinkHealth:
    """What the link and the motor path went through, for /diagnostics and the run folder.

    Attributes
    ----------
    link_up : bool
        The serial port is open.
    reconnects, silences : int
        Port reopened after a loss; HELLO re-sent after a silent second on an open port.
    frames_lost, crc_errors, resyncs, unknown_version : int
        From the host's decoder: frames missing by SEQ, candidates failing their CRC, partial
        frames dropped after 20 ms of silence, candidates of another frame version.
    mcu_resets : int
        INFO with another boot_id (counts and clock re-anchored).
    nacks, retries, unanswered_motor : int
        Commands refused, sent again, MOTOR_PWM without an ACK.
    i2c_errors, i2c_reinits, i2c_foreign_writes : int
        The PCA9685 path's faults (0 with the MCU driving the motors).
    i2c_bus_up : bool
        The PCA9685 path is working.
    motor_enable : bool
        The MCU's interlock line (telemetry MOTOR_ENABLE).
    """

    link_up: bool = False
    reconnects: int = 0
    silences: int = 0
    frames_lost: int = 0
    crc_errors: int = 0
    resyncs: int = 0
    unknown_version: int = 0
    mcu_resets: int = 0
    nacks: int = 0
    retries: int = 0
    unanswered_motor: int = 0
    i2c_errors: int = 0
    i2c_reinits: int = 0
    i2c_foreign_writes: int = 0
    i2c_bus_up: bool = True
    motor_enable: bool = False

    def problems(self) -> list[str]:
        """What an operator should look at, one phrase each (empty when all is well)."""
        out = [] if self.link_up else ["serial link down"]
        for name, text in (
            ("frames_lost", "frames lost"),
            ("crc_errors", "CRC errors"),
            ("resyncs", "partial frames dropped"),
            ("mcu_resets", "MCU resets"),
            ("nacks", "commands refused"),
            ("i2c_errors", "I2C errors"),
            ("i2c_foreign_writes", "PCA9685 registers changed by someone else"),
        ):
            n = getattr(self, name)
            if n:
                out.append(f"{n} {text}")
        if not self.i2c_bus_up:
            out.append("PCA9685 bus down: braked by the MCU interlock")
        return out


VERSION_SILENCE_S = 1.0  # [s] frames of another version and no INFO: report the mismatch


class Daemon:
    """The process: transport, core, recorder, signals. ``run()`` returns an exit status:
    0 when it stopped as asked or the mission is done, 1 when the mission was aborted
    (:attr:`HostCore.abort_reason`). A device that refuses a command, never answers one, or
    speaks another protocol raises :class:`DaemonError` (or ProtocolMismatchError).

    On a twin's pty the link watches for a lockstep stall (:mod:`jackson.host.transport`):
    ``stall_s`` wall seconds of waiting without a telemetry frame (default: the transport's own
    setting, else :data:`~jackson.host.transport.STALL_S`; ``math.inf``: never). A stall ends
    the run on the abort path (braked, SHUTDOWN heartbeat, exit status 1) with one line,
    ``lockstep stalled: the host waited 10.0 s for a telemetry frame after frame N (MCU time
    T s)``, kept in :attr:`stalled` and in the run's log, where ``jackson replay`` finds it.

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
        from jackson.host.service.navigation import NavigationService
        from jackson.host.transport import STALL_S

        self.cfg = cfg
        self.transport = transport
        if stall_s is not None:
            transport.stall_s = None if math.isinf(stall_s) else stall_s
        elif transport.stall_s is None and transport.on_pty:
            transport.stall_s = STALL_S  # a twin's pty: lockstep can stall
        self.stalled: str | None = None  # the stall line, when a lockstep stall ended the run
        self.wall_limit_hit = False  # run(max_s) ended on its wall-clock limit
        self.run_folder = run_folder
        meta = {**(meta or {}), **lidar_meta(lidar)}
        self.recorder = RunRecorder(run_folder, meta) if run_folder is not None else None
        # the run folders of a daemon that runs for hours (rotate): split, kept under a budget
        self.first_folder = run_folder
        self.disk_use = DiskUse(run_folder.parent if run_folder else cfg.recording_folder)
        self.split: SplitPolicy | None = None
        self.budget_bytes = round(cfg.recording_budget_mb * 1e6) if rotate else 0
        self._room_bytes = 0  # kept free for the folder being written: the largest closed one
        self.folders = FolderWorker(self._say)
        self._part = 1  # the run folder's number (1: the first)
        self.commands = CommandTracker(transport.encode, self._send_frame)
        if mission is None and mission_name:
            mission = make_mission(mission_name, cfg.square, cfg.figure8)
        self.lidar = lidar  # a started RplidarDriver (its raw bytes go to the core), or None
        self.output = output_factory(self._send)
        self.core = HostCore(
            cfg,
            self.output,
            self._send,
            mission=mission,
            recorder=self.recorder,
            mission_timeout_s=mission_timeout_s,
            duty_source=duty_source,
            imu_calibration=imu_calibration,
        )
        if lidar is not None:  # the core decodes the stream of the mode the driver started
            self.core.lidar.expect(lidar.answer_type)
        self.notifier = notifier  # systemd sd_notify (host/sdnotify.py), or None
        # a silent port gets HELLO again after three telemetry periods (at least 0.5 s)
        transport.silence_s = max(0.5, 3.0 / cfg.serial.telemetry_rate_hz)
        # what the operator was told, in order (the newest EVENTS_KEPT: a service runs for days)
        self.events: deque[str] = deque(maxlen=EVENTS_KEPT)
        self.cpu = CpuMeter()  # the daemon's own CPU per robot-second and per frame
        self._hello_retries = 0  # HELLOs re-sent before the first INFO
        self._i2c_told = (0, 0)  # the PCA9685 path's (errors, re-inits) told so far
        self._i2c_failing = False  # an I2C outage was told and has not ended
        self._lidar_lost: str | None = None  # the LiDAR's port failed before this frame
        self._repairer: threading.Thread | None = None
        self.bag: Any = None
        self.bridge: Any = None
        self.ros: Any = None  # the RosOutput feeding the bag and the bridge
        from jackson.host.ros.messages import MessageBuilder, RosOutput, RosSettings

        if ros_args is not None:  # --ros: rclpy is imported only here
            from jackson.host.ros.bridge import RosBridge

            self.bridge = RosBridge(
                self.core,
                args=ros_args,
                # the service takes /goal_pose, navigate_to_pose and /initialpose
                service=mission if isinstance(mission, NavigationService) else None,
                say=self._say,
            )
            for note in self.bridge.notes:
                self._say(note)
            if self.bridge.missing:
                self._say(
                    "ROS: not published (message package missing): "
                    + ", ".join(sorted(set(self.bridge.missing)))
                )
        if run_folder is not None:  # every run folder holds a rosbag2 (MCAP) of the run
            # earlier runs' unfinished bags are repaired beside the running daemon: READY and
            # the watchdog's pings must not wait for a long repair
            self._repairer = threading.Thread(
                target=self._repair_earlier_runs, args=(run_folder,), name="bag-repair", daemon=True
            )
            # the bag records what the node publishes: its names, offsets and clock
            self.bag = self._open_bag(
                run_folder,
                self.bridge.settings if self.bridge is not None else RosSettings.for_config(cfg),
                self.bridge.clock if self.bridge is not None else None,
            )
            if self.recorder is not None:
                self.recorder.flush_with.append(self.bag)
        sinks = [x for x in (self.bag, self.bridge) if x is not None]
        if sinks:
            builder = (
                self.bag.builder
                if self.bag is not None
                else MessageBuilder(self.bridge.settings, cfg.odometry, self.bridge.clock)
            )
            self.ros = RosOutput(
                builder,
                sinks,
                telemetry=self.bag is not None,
                received=self.bridge.received if self.bridge is not None else None,
            )
            self.core.listeners.append(self.ros)
        self.core.listeners.append(_OperatorListener(self))
        self.stop = threading.Event()
        self.link_downs = 0
        # the navigation service: goal after goal, the control socket (jackson goal/status)
        self.service = mission if isinstance(mission, NavigationService) else None
        # teleop or the service: a mission ends by itself, a duty source is a calibration's
        teleop_or_service = mission is None or self.service is not None
        if rotate and run_folder is not None and duty_source is None and teleop_or_service:
            self.split = SplitPolicy(cfg.recording_split, cfg.recording_split_s)
        self.control: ControlServer | None = None
        if self.service is not None:
            self.service.tell = self.tell  # called on the frame loop's thread
            if control_socket is not None:
                from jackson.host.service.control import ControlServer

                self.control = ControlServer(control_socket, self.service, self.status, self._drive)
        # the live view (Foxglove WebSocket): served from run(), published from the frame loop
        self.live: LiveView | None = None
        if live_view is not None and live_view.enabled:
            self.live = self._live_view(live_view)

    def _live_view(self, settings: LiveViewSettings) -> LiveView | None:
        """The live view's listener on the core (not serving yet), or None with one line when
        it cannot be (no navigation service, foxglove-sdk missing)."""
        if self.service is None:
            self._say("live view: needs the navigation service (--lidar and --map); not served")
            return None
        try:
            from jackson.common.liveview import LiveServer
            from jackson.host.liveview import LiveView
        except ImportError as exc:  # a broken install: the robot goes on without it
            self._say(f"live view: cannot load foxglove-sdk ({exc}); make setup installs it")
            return None
        server = LiveServer("jackson daemon", settings.host, settings.port)
        live = LiveView(
            self.service,
            server,
            sensors=self.sensor_states,
            problems=lambda: self.health().problems(),
            tell=self.tell,
        )
        self.core.listeners.append(live)
        return live

    def _drive(self, v_m_s: float, w_rad_s: float) -> None:
        """A velocity command from the control socket, as one on /cmd_vel."""
        self.core.submit_velocity(v_m_s, w_rad_s, time.monotonic_ns())

    def status(self) -> dict[str, Any]:
        """What ``jackson status`` shows: the service's state, goal, pose with covariance,
        sensor health, link problems, CPU and the recording folder's disk use. Safe from
        another thread (it reads snapshots)."""
        out: dict[str, Any] = {"t_s": self.core.t_s, "frames": self.core.frames}
        svc = self.service
        if svc is not None:
            st = svc.status
            out.update(
                state=st.state.value,
                unavailable=st.unavailable,
                pose={
                    "x": st.pose.x,
                    "y": st.pose.y,
                    "yaw": st.pose.yaw,
                    "covariance": list(st.covariance),
                },
                goal=None if st.goal is None else st.goal.as_dict(),
                eta_s=None if math.isnan(st.eta_s) else st.eta_s,
                goals=dict(svc.book.counts),
                last_goal=(lambda h: h[-1].as_dict() if h else None)(svc.book.history()),
            )
        out["sensors"] = self.sensor_states()
        out["problems"] = self.health().problems()
        out["cpu"] = {
            "share_of_core": self.cpu.share_of_core,
            "robot_s": self.cpu.robot_s,
            "frame_p99_ms": self.cpu.percentile_us(0.99) / 1e3,
        }
        out["disk"] = self.disk()
        return out

    def sensor_states(self) -> dict[str, str]:
        """Each sensor's health state now (empty with the monitor off)."""
        hm = self.core.health
        return {name: state.value for name, state in hm.sensors.items()} if hm is not None else {}

    def disk(self) -> dict[str, Any]:
        """The recording folder's use and budget [MB] and the free space on its disk [MB]. Cheap
        (:class:`~jackson.host.recording.budget.DiskUse`): the folder is walked after each split
        and once a minute, the run folder being written at each call."""
        folder = self.disk_use.root
        used = self.disk_use.used_bytes(self.run_folder)
        try:
            free = shutil.disk_usage(folder).free
        except OSError:
            free = 0
        budget = self.budget_bytes / 1e6
        return {
            "folder": str(folder),
            "recording": self.run_folder is not None,
            "used_mb": used / 1e6,
            "budget_mb": budget,
            "left_mb": max(0.0, budget - used / 1e6) if budget > 0 else None,
            "free_mb": free / 1e6,
        }

    def _open_bag(self, folder: Path, settings: Any, clock: Any) -> Any:
        """The rosbag2 (MCAP) of the run folder ``folder``, with the node's names, offsets and
        clock (``clock`` None: MCU time)."""
        from jackson.host.ros.bag import BagRecorder

        cfg = self.cfg
        return BagRecorder(
            folder / "bag",
            settings,
            odometry=cfg.odometry,
            clock=clock,
            max_bytes=int(cfg.bag_max_mb * 1e6) if cfg.bag_max_mb > 0 else None,
            compression=cfg.bag_compression,
            flush_interval_s=None,  # flushed with the run folder's files, on MCU time
        )

    def _split_if_due(self) -> None:
        """Before a telemetry frame (and its LiDAR bytes): the next run folder starts now if
        ``recording.split`` says so (:mod:`jackson.host.recording.split`)."""
        split = self.split
        assert split is not None
        goal = self.service.stage() if self.service is not None and split.by_goal else None
        reason = split.reason(self.core.t_s, goal)
        if reason is None:
            return
        try:
            self._split(reason)
        except Exception as exc:  # a recording that cannot split must not stop the robot
            self.split = None
            self.tell(
                f"recording: cannot split ({type(exc).__name__}: {exc}); recording goes on in "
                f"{self.run_folder}, unsplit"
            )

    def _split(self, reason: str) -> None:
        """Start the next run folder between two telemetry frames (docs/recording.md). Here,
        on the frame loop: the core's snapshot pickled, the new folder's recorder and bag
        swapped in. On :attr:`folders`' thread: the snapshot compressed and written, the
        config and the map copied, the previous folder closed, the budget kept."""
        from jackson.host.core import RunFolderListener

        t0, cpu0 = time.perf_counter(), time.thread_time()
        core, old_rec, old_bag = self.core, self.recorder, self.bag
        first, split = self.first_folder, self.split
        assert old_rec is not None and first is not None and split is not None
        pickled = core.snapshot()
        pickle_ms = (time.perf_counter() - t0) * 1e3
        old = old_rec.folder
        new = part_folder(first, self._part + 1)
        at = {"reason": reason, "part": self._part + 1, "t_s": core.t_s, "frames": core.frames}
        meta = {k: v for k, v in old_rec.meta.items() if k not in ("next", "split")}
        meta.update(
            started=dt.datetime.now().isoformat(),
            previous=old.name,
            split=at,
            snapshot=SNAPSHOT_NAME,
        )
        rec = RunRecorder(new, meta)
        try:
            bag = (
                None
                if old_bag is None
                else self._open_bag(new, old_bag.settings, old_bag.builder.clock)
            )
            if bag is not None and self.ros is not None and self.service is not None:
                # the latched /map again (/tf_static: the bag itself): each bag plays alone
                t_s = core.t_s or 0.0
                grid = self.service.nav.static_map
                bag.write("map", t_s, self.ros.builder.occupancy(t_s, grid))
        except Exception:
            rec.close()
            shutil.rmtree(new, ignore_errors=True)
            raise
        # nothing fails from here on: the new folder takes over
        self._part += 1
        health = self._health_doc()
        self.events.clear()
        for listener in core.listeners:
            if isinstance(listener, RunFolderListener):
                listener.recorder = rec
        self.recorder, self.run_folder = rec, new
        if bag is not None:
            self.bag = bag
            rec.flush_with.append(bag)
            if self.ros is not None:
                self.ros.sinks = [bag if s is old_bag else s for s in self.ros.sinks]
        split.started()
        old_rec.meta["next"] = new.name
        old_rec.link(time.monotonic_ns(), f"recording: continued in {new.name} ({reason})")
        data = {"frames": core.frames, "t_s": core.t_s, "reason": reason}
        self.folders.submit(
            f"the snapshot of {new}",
            lambda: write_snapshot(new / SNAPSHOT_NAME, encode_snapshot(pickled, data)),
        )
        self.folders.submit(f"copying {old}'s files", lambda: carry_files(old, new))
        self.folders.submit(f"closing {old}", lambda: self._close_folder(old_rec, old_bag, health))
        self.folders.submit(
            "the recording folder's budget", lambda: self._keep_budget(new, folder_bytes(old))
        )
        ms, cpu_ms = (time.perf_counter() - t0) * 1e3, (time.thread_time() - cpu0) * 1e3
        self.tell(
            f"recording: {new} ({reason}), after {old.name}; split in {ms:.1f} ms on the "
            f"frame loop ({cpu_ms:.1f} ms CPU; snapshot {len(pickled) / 1e6:.1f} MB pickled in "
            f"{pickle_ms:.1f} ms)"
        )

    def _close_folder(self, rec: RunRecorder, bag: Any, health: dict[str, Any]) -> None:
        """A split's previous folder finished (on :attr:`folders`' thread): its bag, health.json,
        meta.json with ``next``, its log's end record."""
        try:
            if bag is not None:
                bag.close()
        finally:  # a bag that did not finish (jackson bag repair) leaves the rest complete
            try:
                write_json(rec.folder / "health.json", health)
                rec.write_meta()
            finally:
                rec.close()  # complete now: its lock released

    def _keep_budget_at_start(self) -> None:
        if self._repairer is not None:
            self._repairer.join()
        self._keep_budget(self.run_folder)

    def _keep_budget(self, keep: Path | None, closed_bytes: int = 0) -> None:
        """Delete the oldest complete run folders until the recording folder is under
        ``recording.budget_mb`` (on :attr:`folders`' thread), one line each. After a split the
        folder just closed (``closed_bytes``) is room kept free for the new one to grow into, up
        to half the budget: the folder stays under its budget while the next folder is written,
        not only at the splits."""
        budget = self.budget_bytes
        if budget <= 0 or keep is None:
            return
        self._room_bytes = max(self._room_bytes, min(closed_bytes, budget // 2))

        def told(d: Deleted) -> None:
            self._say(
                f"recording: deleted {d.folder.name} ({d.size_bytes / 1e6:.0f} MB) to stay "
                f"under the {budget / 1e6:g} MB budget"
            )

        total = prune(keep.parent, budget - self._room_bytes, keep, told)
        self.disk_use.others(total, keep)

    def _send(self, msg: Message) -> object:
        if isinstance(msg, Heartbeat):
            return self._send_frame(self.transport.encode(msg))
        return self.commands.send(msg)

    def _send_frame(self, frame: bytes) -> object:
        if self.recorder is not None:
            self.recorder.tx(time.monotonic_ns(), frame)
        return self.transport.send_raw(frame)

    def install_signals(self) -> None:
        def on_signal(signum: int, frame: FrameType | None) -> None:
            self.stop.set()

        signal.signal(signal.SIGINT, on_signal)
        signal.signal(signal.SIGTERM, on_signal)

    def _repair_earlier_runs(self, run_folder: Path) -> None:
        """Bags of earlier runs in the recording folder that a kill or a power loss left
        unfinished are repaired now (as ``jackson bag repair``); a failure is reported, never
        fatal."""
        from jackson.host.ros.bag import bag_folders, needs_repair, repair_bag

        root = run_folder.parent
        if not root.is_dir():
            return
        for run in sorted(p for p in root.iterdir() if p.is_dir() and p != run_folder):
            if run_in_progress(run):
                continue  # another daemon (a campaign's other trial) is recording it now
            for bag in bag_folders(run):
                if not needs_repair(bag):
                    continue
                try:
                    n = repair_bag(bag)
                except Exception as exc:  # a damaged old bag must not keep the robot down
                    self._say(f"could not repair the unfinished bag {bag}: {exc}")
                else:
                    self._say(f"repaired the unfinished bag {bag}: {n} messages recovered")

    def _say(self, text: str) -> None:
        """:meth:`tell` from another thread: printed and kept, not written into the run's log
        (the main loop owns it)."""
        self.events.append(text)
        print(f"daemon: {text}", flush=True)

    def tell(self, text: str) -> None:
        """One line for the operator: printed, and in the run's log."""
        self.events.append(text)
        print(f"daemon: {text}", flush=True)
        if self.recorder is not None:
            self.recorder.link(time.monotonic_ns(), text)

    def health(self) -> LinkHealth:
        """The link's and the motor path's state now."""
        c = self.transport.decoder.counters
        h = self.output.health()
        last = self.core.last_telemetry
        return LinkHealth(
            link_up=bool(self.transport.link_up),
            reconnects=self.transport.reconnects,
            silences=self.transport.silences,
            frames_lost=c.seq_lost,
            crc_errors=c.crc_errors,
            resyncs=c.timeouts,
            unknown_version=c.unknown_version,
            mcu_resets=self.core.mcu_resets,
            nacks=self.commands.counters.nacked,
            retries=self.commands.counters.retried,
            unanswered_motor=self.commands.counters.motor_unacked,
            i2c_errors=h.i2c_errors,
            i2c_reinits=h.reinits,
            i2c_foreign_writes=h.foreign_writes,
            i2c_bus_up=not h.bus_down,
            motor_enable=bool(last is not None and last.flags & TelemetryFlags.MOTOR_ENABLE),
        )

    def _check_version(self, started_s: float) -> None:
        """Frames of another frame version and no INFO for a second: say so, once."""
        dec = self.transport.decoder
        if self.core.info is not None or dec.counters.unknown_version == 0:
            return
        if time.monotonic() - started_s < VERSION_SILENCE_S:
            return
        where = f"device on {self.transport.port_name}"
        raise FrameVersionError(dec.last_unknown_version, PROTOCOL_VERSION, where)

    def _unanswered(self, detail: str) -> None:
        """HELLO got no INFO yet: one line at once, then one per retry that doubles the count
        (1, 2, 4, 8, ... retries), so the operator sees the retries without a flood."""
        self._hello_retries += 1
        n = self._hello_retries
        port = self.transport.port_name
        if n == 1:
            self.tell(
                f"no answer on {port}: is the firmware flashed? (make flash); is it the MCU's "
                f"port? HELLO is sent again every {self.transport.silence_s:g} s ({detail})"
            )
        elif n & (n - 1) == 0:
            self.tell(f"still no answer on {port}: HELLO sent {n + 1} times ({detail})")

    def _motor_path(self, was_up: bool) -> bool:
        """Follow the PCA9685 path's health; while its bus is down the heartbeats say SHUTDOWN,
        so the MCU drops the interlock line and the bridge brakes without the bus."""
        h = self.output.health()
        up = not h.bus_down
        errors, reinits = h.i2c_errors, h.reinits
        if errors > self._i2c_told[0] and not self._i2c_failing:
            # the first failed write of an outage: say it at once, not only in health.json
            self._i2c_failing = True
            self.tell(
                f"I2C: PCA9685 write failed ({h.last_error}): retrying; the "
                "MCU interlock brakes if it lasts 0.5 s"
            )
        if reinits > self._i2c_told[1] and self._i2c_failing:
            self._i2c_failing = False
            self.tell(
                f"I2C: PCA9685 back and re-initialised ({errors - self._i2c_told[0]} failed writes)"
            )
            self._i2c_told = (errors, reinits)
        if up != was_up:
            if up:
                self.core.host_state = HostState.ACTIVE
                self.tell("PCA9685 bus back: motor output re-initialised")
            else:
                self.core.host_state = HostState.SHUTDOWN
                self.tell(f"PCA9685 bus down ({h.last_error}): braking through the MCU interlock")
        return up

    def run(self, max_s: float | None = None) -> int:
        from jackson.host.transport import LinkEvent

        core = self.core
        started = time.monotonic()
        deadline = None if max_s is None else started + max_s
        bus_up = True
        if self.bridge is not None:
            if self.bridge.late_clock():  # before the first frame is stamped
                self._say(self.bridge.notes[-1])
            self.bridge.start()
        if self.control is not None:
            self.control.start()
            self._say(f"taking goals on {self.control.path} (jackson goal X,Y)")
        if self.live is not None:
            from jackson.common.liveview import LiveViewError

            try:
                url = self.live.start()
            except LiveViewError as exc:  # the robot goes on without it
                self.core.listeners.remove(self.live)
                self.live = None
                self._say(f"{exc}; going on without it")
            else:
                self._say(f"live view on {url} (Foxglove: Open connection, Foxglove WebSocket)")
        if self.notifier is not None:
            self.notifier.ready()
        if self._repairer is not None and not self._repairer.is_alive():
            self._repairer.start()
        if self.budget_bytes > 0:  # at start-up, once the earlier runs' bags are repaired
            self.folders.submit("the recording folder's budget", self._keep_budget_at_start)
        settled = GcSettled()
        try:
            while not self.stop.is_set():
                if deadline is not None and time.monotonic() > deadline:
                    self.wall_limit_hit = True
                    break
                if self.notifier is not None:
                    self.notifier.watchdog()
                try:
                    self.commands.poll()
                except CommandError as exc:
                    raise DaemonError(str(exc)) from exc
                self._check_version(started)
                bus_up = self._motor_path(bus_up)
                item = self.transport.get(0.1)
                if item is None:
                    continue
                if isinstance(item, LinkEvent):
                    if item.kind == "down":
                        self.link_downs += 1
                        core.brake()
                        if core.mission is not None and core.mission.done:
                            # nothing left to drive: not waiting for the robot to rest
                            self.tell(f"serial link down ({item.detail}) after the mission")
                            break
                        self.tell(f"serial link down ({item.detail}): braked, reconnecting")
                    elif item.kind == "up":
                        core.link_up()
                        self.commands.forget()
                        if self.link_downs:
                            self.tell("serial link up again")
                    elif item.kind == "stalled":
                        # the twin stopped: the abort path brakes and says SHUTDOWN on the way out
                        when = (
                            f"after frame {core.frames} (MCU time {core.t_s:.2f} s)"
                            if core.t_s is not None
                            else "before the first frame"
                        )
                        self.stalled = f"lockstep stalled: {item.detail} {when}"
                        self.tell(self.stalled)
                        core.abort(self.stalled)
                        break
                    elif item.kind == "silent" and core.info is None:
                        self._unanswered(item.detail)
                    elif self.recorder is not None:
                        self.recorder.link(item.rx_time_ns, f"{item.kind} {item.detail}")
                    continue
                rx_ns, frame = item
                cpu0 = time.thread_time_ns() - round(contention.spun_s * 1e9)
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
                    self.tell(
                        "the MCU was reset: odometry and time re-anchored, device set up again"
                    )
                if core.abort_reason is not None:
                    self.tell(f"mission aborted: {core.abort_reason}")
                    break
                if (
                    self.ros is not None
                    and core.last_telemetry is not None
                    and self.ros.diagnostics_due(core.t_s or 0.0)
                ):
                    from jackson.host.ros.bridge import diagnostic_values

                    self.ros.diagnostics(
                        diagnostic_values(core, core.last_telemetry, link=self.health())
                    )
                if frame.type == Telemetry.TYPE:
                    # less any polling of a lockstep twin's links (jackson.host.cpu)
                    spun_ns = round(contention.spun_s * 1e9)
                    self.cpu.frame((time.thread_time_ns() - spun_ns - cpu0) / 1e3)
                    self.cpu.robot_time(core.t_s)
                    if self.split is not None:
                        self.split.frame(core.t_s)
                if core.finished:  # the mission done, braked, the robot at rest
                    break
                if core.duty_source is not None and core.duty_source.done:
                    break
        finally:
            core.brake()
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
            self._send(Heartbeat(ack_seq=0, host_state=HostState.SHUTDOWN))
            if self._repairer is not None and self._repairer.is_alive():
                self._repairer.join()  # a repair replaces the bag only once complete
            self.folders.join()  # earlier run folders closed, snapshots written
            if self.recorder is not None:
                self._write_health()
            # the bag is finished before the recorder lets go of the run's lock: until then
            # another daemon in the same recording folder (a campaign's next trial) must not
            # take the closing bag for a killed run's and repair it under the writer's feet
            if self.bag is not None:
                try:
                    self.bag.close()
                except Exception as exc:
                    print(f"daemon: the run's bag did not close cleanly: {exc}", flush=True)
            if self.recorder is not None:
                self.recorder.close()
            settled.restore()
        return 1 if core.abort_reason is not None else 0

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

    def _sensor_health(self) -> dict[str, Any]:
        """The health monitor's verdict for health.json: states now and every transition."""
        hm = self.core.health
        if hm is None:
            return {"monitor": "off"}
        return {
            "states": {name: state.value for name, state in hm.sensors.items()},
            "transitions": [
                {
                    "t_s": tr.t_s,
                    "sensor": tr.sensor,
                    "from": tr.old.value,
                    "to": tr.new.value,
                    "reason": tr.reason,
                }
                for tr in hm.transitions
            ],
            "counts": dict(hm.counts),
            "lidar": {
                **hm.lidar_counts,
                "roughness_m": hm.lidar_roughness_m,
                "missing_fraction": hm.lidar_missing,
            },
            "wheel_yaw_scale": hm.model.scale,
            "wheel_yaw_per_m": hm.model.per_metre,
        }

    def _write_health(self) -> None:
        assert self.run_folder is not None
        try:
            write_json(self.run_folder / "health.json", self._health_doc())
        except OSError as exc:
            print(f"daemon: cannot write health.json: {exc.strerror}", flush=True)

    def _health_doc(self) -> dict[str, Any]:
        """health.json of the run folder being written: the link, the sensors, what the
        operator was told, CPU, commands."""
        h = self.health()
        return {
            "link": dataclasses.asdict(h),
            "problems": h.problems(),
            "abort_reason": self.core.abort_reason,
            "sensors": self._sensor_health(),
            "events": list(self.events),
            "cpu": self.cpu.report(1.0 / self.cfg.serial.telemetry_rate_hz),
            "commands": {
                "acked": self.commands.counters.acked,
                "nacked": self.commands.counters.nacked,
                "retried": self.commands.counters.retried,
                "errors": self.commands.counters.errors,
            },
        }


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
