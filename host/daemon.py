"""The host daemon: one telemetry frame in, odometry, EKF, a command and a heartbeat out.

:class:`HostCore` is everything the daemon computes, free of I/O but for its motor output and a
``send`` callable, so the same code runs on the robot, against the twin and in ``jackson
replay``. Per telemetry frame, on MCU time (the unwrapped ``t_us``, never the wall clock):

1. wheel odometry (Eq. 2, 3, 9) from the cumulative counts;
2. the EKF: outputs at 30 Hz of MCU time up to this frame (predict only), then predict to the
   frame and fuse wheel ``vx`` with ``vy = 0`` and the IMU yaw rate less the start-up gyro bias;
3. a command: from the mission, or the newest external (``/cmd_vel``-style) command, which
   brakes once older than the watchdog (0.6 s);
4. the actuation chain: velocity and acceleration limits, inverse kinematics, optional wheel
   PI, per-wheel and per-direction deadband compensation, the motor output;
5. a HEARTBEAT acknowledging the frame (in lockstep, the twin advances on it).

:class:`Daemon` adds the serial transport, the recorder and the process lifecycle.
"""

from __future__ import annotations

import dataclasses
import json
import math
import queue
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

from jackson.host.actuation.deadband import DeadbandConfig, wheel_duty
from jackson.host.actuation.kinematics import inverse
from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter
from jackson.host.actuation.output import MotorOutput
from jackson.host.actuation.watchdog import CommandWatchdog
from jackson.host.actuation.wheel_pi import WheelPiConfig, WheelSpeedPi
from jackson.host.commands import CommandError, CommandTracker
from jackson.host.config import HostConfig
from jackson.host.control import MISSIONS, Mission, NavState
from jackson.host.control.guard import MissionGuard
from jackson.host.ekf import Ekf, EkfConfig, EkfState, GyroBiasEstimator
from jackson.host.odometry import OdometryConfig, OdometryState, WheelOdometry
from jackson.host.recording import RunRecorder
from jackson.protocol import (
    PROTOCOL_VERSION,
    Frame,
    FrameVersionError,
    Heartbeat,
    HostState,
    Info,
    Message,
    SetConfig,
    SetImuCalibration,
    SetRate,
    Telemetry,
    TelemetryFlags,
    TimestampUnwrapper,
    check_peer,
    decode_message,
)
from jackson.protocol.units import yaw_rate_rad_s


def odometry_config(cfg: HostConfig) -> OdometryConfig:
    r, c = cfg.robot, cfg.odometry
    return OdometryConfig(
        wheel_radius_left_m=r.wheel_radius_left_m,
        wheel_radius_right_m=r.wheel_radius_right_m,
        wheel_separation_m=r.wheel_separation_m,
        ticks_per_rev_left=r.ticks_per_rev_left,
        ticks_per_rev_right=r.ticks_per_rev_right,
        twist_covariance_vx=c.twist_vx,
        twist_covariance_vy=c.twist_vy,
        twist_covariance_wz=c.twist_wz,
        pose_covariance_xy=c.pose_xy,
        pose_covariance_yaw=c.pose_yaw,
    )


def ekf_config(cfg: HostConfig) -> EkfConfig:
    e = cfg.ekf
    q = e.process_noise
    return EkfConfig(
        process_noise=(q.x, q.y, q.yaw, q.vx, q.vy, q.vyaw, q.ax),
        initial_covariance=e.initial_covariance,
        r_vx=e.r_vx,
        r_vy=e.r_vy,
        r_wz=e.r_wz,
        sensor_timeout_s=e.sensor_timeout_s,
        output_rate_hz=e.frequency_hz,
        mahalanobis_threshold_wheel=e.mahalanobis_wheel or None,
        mahalanobis_threshold_imu=e.mahalanobis_imu or None,
    )


def device_setup(cfg: HostConfig, info: Info, *, calibration: bool = True) -> list[Message]:
    """The commands that bring a device (its INFO) to the configuration: SET_RATE and SET_CONFIG
    where they differ, and SET_IMU_CALIBRATION when the config holds one (and ``calibration``)."""
    out: list[Message] = []
    if info.telemetry_rate_hz != cfg.serial.telemetry_rate_hz:
        out.append(SetRate(rate_hz=cfg.serial.telemetry_rate_hz))
    failsafe_ms = round(cfg.watchdog_s * 1000)
    wanted = (cfg.imu.accel_fs, cfg.imu.gyro_fs, cfg.imu.direction_flags, failsafe_ms)
    if (info.accel_fs, info.gyro_fs, info.direction_flags, info.failsafe_ms) != wanted:
        out.append(
            SetConfig(
                accel_fs=wanted[0],
                gyro_fs=wanted[1],
                direction_flags=wanted[2],
                failsafe_ms=failsafe_ms,
                persist=0,
            )
        )
    cal = cfg.imu.calibration
    if calibration and cal is not None:
        out.append(
            SetImuCalibration(
                imu_rotation=cal.rotation,
                gyro_bias=cal.gyro_bias_rad_s,
                accel_scale=cal.accel_scale,
                persist=0,
            )
        )
    return out


class CoreListener:
    """Receives what the core computes (the ROS bridge, the rosbag2 recorder); no-op defaults."""

    def on_frame(self, frame: Frame, host_time_ns: int) -> None:
        """Every frame received, before it is handled."""

    def on_telemetry(self, core: HostCore, telemetry: Telemetry) -> None:
        """After a telemetry frame was handled (odometry, EKF, command are current)."""

    def on_filtered(self, t_s: float, state: EkfState) -> None:
        """Each 30 Hz EKF output."""


class _BridgeListener(CoreListener):
    """Hands what the core computes to the ROS bridge."""

    def __init__(self, bridge: Any) -> None:
        self.bridge = bridge

    def on_telemetry(self, core: HostCore, telemetry: Telemetry) -> None:
        self.bridge.on_telemetry(core, telemetry)

    def on_filtered(self, t_s: float, state: EkfState) -> None:
        self.bridge.on_filtered(t_s, state)


class HostCore:
    """The daemon's computation; see the module docstring for the order of work per frame."""

    def __init__(
        self,
        cfg: HostConfig,
        output: MotorOutput,
        send: Callable[[Message], object],
        *,
        mission: Mission | None = None,
        recorder: RunRecorder | None = None,
        mission_timeout_s: float | None = None,
    ) -> None:
        self.cfg = cfg
        self.output = output
        self.send = send
        self.mission = mission
        self.recorder = recorder
        self.guard = MissionGuard(mission.name, mission_timeout_s) if mission is not None else None
        self.abort_reason: str | None = None  # why the mission was aborted (braked for good)
        self.mcu_resets = 0  # INFO with another boot_id: counts and clock re-anchored
        self.host_state = HostState.ACTIVE  # sent in every HEARTBEAT (SHUTDOWN drops the interlock)
        self._reanchor = False
        self._wheel_cmd: tuple[float, float] = (0.0, 0.0)  # [rad/s] commanded at the last frame
        self._rx_ns = 0
        self.unwrapper = TimestampUnwrapper()
        self.odometry = WheelOdometry(odometry_config(cfg))
        self.ekf = Ekf(ekf_config(cfg))
        self.gyro_bias = GyroBiasEstimator(window_s=cfg.ekf.gyro_bias_window_s)
        lim = cfg.limits
        self.limiter = VelocityLimiter(
            LimiterConfig(
                lim.max_v_m_s,
                lim.max_w_rad_s,
                lim.max_accel_m_s2,
                lim.max_decel_m_s2,
                lim.max_alpha_rad_s2,
                lim.max_alpha_decel_rad_s2,
            )
        )
        d = cfg.deadband
        self.deadband = DeadbandConfig(
            d.forward_left,
            d.reverse_left,
            d.forward_right,
            d.reverse_right,
            d.max_wheel_rad_s,
            d.zero_threshold_rad_s,
            d.gain_left,
            d.gain_right,
        )
        pi = cfg.wheel_pi
        pi_cfg = WheelPiConfig(
            kp=pi.kp,
            ki=pi.ki,
            integral_limit=pi.integral_limit,
            zero_threshold_rad_s=d.zero_threshold_rad_s,
        )
        self.pi = (WheelSpeedPi(pi_cfg), WheelSpeedPi(pi_cfg)) if pi.enabled else None
        self.watchdog = CommandWatchdog(cfg.watchdog_s)
        self.info: Info | None = None
        self.t_s: float | None = None
        self.last_odometry: OdometryState | None = None
        self.external: tuple[float, float] = (0.0, 0.0)
        self._external_pending: tuple[float, float, int] | None = None
        self._taken: tuple[float, float, int] | None = None
        self._next_output_s: float | None = None
        self.frames = 0
        self.braked = True
        self.ekf_outputs = 0
        self.last_output: EkfState | None = None
        self.listeners: list[CoreListener] = []
        self.last_telemetry: Telemetry | None = None

    # ------------------------------------------------------------------ inputs

    def submit_velocity(self, v_m_s: float, w_rad_s: float, host_time_ns: int = 0) -> None:
        """An external velocity command (``/cmd_vel``); it takes effect, stamped on MCU time, at
        the next telemetry frame. Safe to call from another thread (the ROS executor)."""
        if not (math.isfinite(v_m_s) and math.isfinite(w_rad_s)):
            return  # a NaN must never become a duty
        self._external_pending = (v_m_s, w_rad_s, host_time_ns)

    def on_frame(self, frame: Frame, host_time_ns: int = 0) -> None:
        """One decoded frame from the MCU."""
        self._taken = None
        if frame.type == Telemetry.TYPE and self._external_pending is not None:
            # taken once, on this thread; logged before the frame that applies it, so a replay
            # applies it to the same frame
            self._taken, self._external_pending = self._external_pending, None
            if self.recorder is not None:
                v, w, t_ns = self._taken
                self.recorder.command(t_ns, v, w)
        if self.recorder is not None:
            self.recorder.rx(host_time_ns, frame.type, frame.seq, frame.payload)
        for listener in self.listeners:
            listener.on_frame(frame, host_time_ns)
        self._rx_ns = host_time_ns
        msg = decode_message(frame)
        if isinstance(msg, Info):
            check_peer(msg)  # raises ProtocolMismatchError naming both versions
            if self.info is not None and msg.boot_id != self.info.boot_id:
                # an MCU reset: its counts and clock restart; the next frame is a new origin
                self.mcu_resets += 1
                self._reanchor = True
                self.event(f"mcu reset: boot_id {self.info.boot_id:#010x} -> {msg.boot_id:#010x}")
            self.info = msg
            self._configure_device()
        elif isinstance(msg, Telemetry):
            self._on_telemetry(msg, frame.seq)

    def event(self, text: str) -> None:
        """Something the operator should know, in the run's log (a link record)."""
        if self.recorder is not None:
            self.recorder.link(self._rx_ns, text)

    def abort(self, reason: str) -> None:
        """Stop the mission for good: brake from now on; the daemon exits naming ``reason``."""
        if self.abort_reason is None:
            self.abort_reason = reason
            self.event(f"mission aborted: {reason}")

    def _configure_device(self) -> None:
        """Bring the device's rate, ranges, direction flags and failsafe to the config."""
        assert self.info is not None
        for msg in device_setup(self.cfg, self.info):
            self.send(msg)

    # ------------------------------------------------------------------ the frame

    def _on_telemetry(self, t: Telemetry, seq: int) -> None:
        if self._reanchor:
            self._reanchor = False
            self.unwrapper.reanchor()
            self.odometry.reanchor()
        t_s = self.unwrapper.unwrap(t.t_us) / 1e6
        self.t_s = t_s
        self.frames += 1
        odo = self.odometry.update(t_s, t.enc_left, t.enc_right)
        self.last_odometry = odo
        ekf = self.ekf
        # 30 Hz outputs of MCU time up to this frame: prediction only between measurements
        period = 1.0 / self.cfg.ekf.frequency_hz
        if self._next_output_s is None:
            self._next_output_s = math.ceil(t_s / period) * period
        while self._next_output_s <= t_s + 1e-9:
            if ekf.initialized:
                self._record_ekf(self._next_output_s)
            self._next_output_s += period
        ekf.update_wheel(t_s, odo.v_m_s, 0.0)
        if t.flags & TelemetryFlags.IMU_OK:
            wz = yaw_rate_rad_s(t)
            still = odo.wheel_velocity_left_rad_s == 0 and odo.wheel_velocity_right_rad_s == 0
            self.gyro_bias.add(t_s, wz, still)
            bias = self.gyro_bias.bias_rad_s
            if bias is not None:
                ekf.update_gyro(t_s, wz - bias)
        # command and actuation
        v_cmd, w_cmd, brake = self._command(t_s, odo, t)
        self._actuate(t_s, v_cmd, w_cmd, brake, odo)
        self.send(Heartbeat(ack_seq=seq, host_state=self.host_state))
        self.last_telemetry = t
        for listener in self.listeners:
            listener.on_telemetry(self, t)
        if self.recorder is not None:
            self.recorder.row(
                self.recorder.odometry,
                (
                    t_s,
                    odo.x_m,
                    odo.y_m,
                    odo.yaw_rad,
                    odo.v_m_s,
                    odo.w_rad_s,
                    t.enc_left,
                    t.enc_right,
                ),
            )
            self.recorder.frame_done()

    def _record_ekf(self, t_s: float) -> None:
        """A 30 Hz output: the estimate predicted to ``t_s`` (the filter itself is not moved)."""
        self.ekf_outputs += 1
        self.last_output = s = self.ekf.state_at(t_s)
        for listener in self.listeners:
            listener.on_filtered(t_s, s)
        if self.recorder is None:
            return
        self.recorder.row(
            self.recorder.ekf,
            (
                t_s,
                s.x_m,
                s.y_m,
                s.yaw_rad,
                s.vx_m_s,
                s.vy_m_s,
                s.vyaw_rad_s,
                s.ax_m_s2,
                s.p_xx,
                s.p_yy,
                s.p_yawyaw,
            ),
        )

    def nav_state(self) -> NavState:
        e = self.ekf
        return NavState(self.t_s or 0.0, e.x_m, e.y_m, e.yaw_rad, e.vx_m_s, e.vyaw_rad_s)

    def _command(self, t_s: float, odo: OdometryState, t: Telemetry) -> tuple[float, float, bool]:
        if self._taken is not None:
            self.external = (self._taken[0], self._taken[1])
            self._taken = None
            self.watchdog.feed(t_s)
        if self.mission is not None:
            if self.abort_reason is not None:
                return 0.0, 0.0, True
            bias_known = self.gyro_bias.bias_rad_s is not None
            if self.guard is not None and not self.mission.done:
                reason = self.guard.check(
                    t_s,
                    bool(t.flags & TelemetryFlags.IMU_OK),
                    bias_known,
                    (t.enc_left, t.enc_right),
                    self._wheel_cmd,
                )
                if reason is not None:
                    self.abort(reason)
                    return 0.0, 0.0, True
            if not bias_known:
                return 0.0, 0.0, True  # stand still until the gyro bias is known
            v, w = self.mission.command(self.nav_state())
            return v, w, self.mission.done
        if self.watchdog.expired(t_s):
            return 0.0, 0.0, True
        return self.external[0], self.external[1], False

    def _actuate(
        self, t_s: float, v_cmd: float, w_cmd: float, brake: bool, odo: OdometryState
    ) -> None:
        if brake:
            self.limiter.reset()
            if self.pi is not None:
                for pi in self.pi:
                    pi.reset()
            self.output.brake()
            self.braked = True
            duties = (0.0, 0.0)
            v = w = 0.0
            self._wheel_cmd = (0.0, 0.0)
        else:
            v, w = self.limiter.limit(v_cmd, w_cmd, t_s)
            r = self.cfg.robot
            om_l, om_r = inverse(
                v, w, r.wheel_radius_left_m, r.wheel_radius_right_m, r.wheel_separation_m
            )
            self._wheel_cmd = (om_l, om_r)
            d_l = wheel_duty(om_l, "left", self.deadband)
            d_r = wheel_duty(om_r, "right", self.deadband)
            if self.pi is not None:
                d_l = max(
                    -1.0,
                    min(
                        1.0,
                        d_l
                        + self.pi[0].update(
                            om_l, odo.wheel_velocity_left_rad_s, t_s, feedforward_duty=d_l
                        ),
                    ),
                )
                d_r = max(
                    -1.0,
                    min(
                        1.0,
                        d_r
                        + self.pi[1].update(
                            om_r, odo.wheel_velocity_right_rad_s, t_s, feedforward_duty=d_r
                        ),
                    ),
                )
            self.output.set(d_l, d_r)
            self.braked = False
            duties = (d_l, d_r)
        if self.recorder is not None:
            self.recorder.row(self.recorder.commands, (t_s, v, w, duties[0], duties[1], int(brake)))

    def brake(self) -> None:
        """Brake now (link lost, shutdown)."""
        self.output.brake()
        self.braked = True


class DaemonError(RuntimeError):
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
    speaks another protocol raises :class:`DaemonError` (or ProtocolMismatchError)."""

    def __init__(
        self,
        cfg: HostConfig,
        output_factory: Callable[[Callable[[Message], object]], MotorOutput],
        transport: Any,
        *,
        mission_name: str | None = None,
        run_folder: Path | None = None,
        meta: dict[str, Any] | None = None,
        ros_args: list[str] | None = None,
        mission_timeout_s: float | None = None,
        notifier: Any = None,
    ) -> None:
        self.cfg = cfg
        self.transport = transport
        self.run_folder = run_folder
        self.recorder = RunRecorder(run_folder, meta or {}) if run_folder is not None else None
        self.commands = CommandTracker(transport.encode, self._send_frame)
        mission = MISSIONS[mission_name]() if mission_name else None
        self.output = output_factory(self._send)
        self.core = HostCore(
            cfg,
            self.output,
            self._send,
            mission=mission,
            recorder=self.recorder,
            mission_timeout_s=mission_timeout_s,
        )
        self.notifier = notifier  # systemd sd_notify (host/sdnotify.py), or None
        # a silent port gets HELLO again after three telemetry periods (at least 0.5 s)
        transport.silence_s = max(0.5, 3.0 / cfg.serial.telemetry_rate_hz)
        self.events: list[str] = []  # what the operator was told, in order
        self._repairer: threading.Thread | None = None
        self.bag: Any = None
        if run_folder is not None:  # every run folder holds a rosbag2 (MCAP) of the run
            from jackson.host.ros.bag import BagRecorder
            from jackson.host.ros.bag_listener import BagListener

            # earlier runs' unfinished bags are repaired beside the running daemon: READY and
            # the watchdog's pings must not wait for a long repair
            self._repairer = threading.Thread(
                target=self._repair_earlier_runs, args=(run_folder,), name="bag-repair", daemon=True
            )
            max_bytes = int(cfg.bag_max_mb * 1e6) if cfg.bag_max_mb > 0 else None
            self.bag = BagRecorder(run_folder / "bag", max_bytes=max_bytes)
            self.core.listeners.append(BagListener(self.bag))
        self.bridge: Any = None
        if ros_args is not None:  # --ros: rclpy is imported only here
            from jackson.host.ros.bridge import RosBridge

            self.bridge = RosBridge(self.core, args=ros_args)
            self.core.listeners.append(_BridgeListener(self.bridge))
        self.stop = threading.Event()
        self.link_downs = 0

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
        out = self.output
        h = out.health() if hasattr(out, "health") else None
        last = self.core.last_telemetry
        return LinkHealth(
            link_up=bool(self.transport.link_up),
            reconnects=self.transport.reconnects,
            silences=getattr(self.transport, "silences", 0),
            frames_lost=c.seq_lost,
            crc_errors=c.crc_errors,
            resyncs=c.timeouts,
            unknown_version=c.unknown_version,
            mcu_resets=self.core.mcu_resets,
            nacks=self.commands.counters.nacked,
            retries=self.commands.counters.retried,
            unanswered_motor=self.commands.counters.motor_unacked,
            i2c_errors=getattr(h, "i2c_errors", 0),
            i2c_reinits=getattr(h, "reinits", 0),
            i2c_foreign_writes=getattr(h, "foreign_writes", 0),
            i2c_bus_up=not getattr(h, "bus_down", False),
            motor_enable=bool(last is not None and last.flags & TelemetryFlags.MOTOR_ENABLE),
        )

    def _check_version(self, started_s: float) -> None:
        """Frames of another frame version and no INFO for a second: say so, once."""
        dec = self.transport.decoder
        if self.core.info is not None or dec.counters.unknown_version == 0:
            return
        if time.monotonic() - started_s < VERSION_SILENCE_S:
            return
        where = f"device on {getattr(self.transport, 'port_name', 'the link')}"
        raise FrameVersionError(getattr(dec, "last_unknown_version", None), PROTOCOL_VERSION, where)

    def _motor_path(self, was_up: bool) -> bool:
        """Follow the PCA9685 path's health; while its bus is down the heartbeats say SHUTDOWN,
        so the MCU drops the interlock line and the bridge brakes without the bus."""
        h = self.output.health() if hasattr(self.output, "health") else None
        up = not getattr(h, "bus_down", False)
        if up != was_up:
            if up:
                self.core.host_state = HostState.ACTIVE
                self.tell("PCA9685 bus back: motor output re-initialised")
            else:
                self.core.host_state = HostState.SHUTDOWN
                err = getattr(h, "last_error", "")
                self.tell(f"PCA9685 bus down ({err}): braking through the MCU interlock")
        return up

    def run(self, max_s: float | None = None) -> int:
        from jackson.host.transport import LinkEvent

        core = self.core
        started = time.monotonic()
        deadline = None if max_s is None else started + max_s
        bus_up = True
        if self.bridge is not None:
            self.bridge.start()
        if self.notifier is not None:
            self.notifier.ready()
        if self._repairer is not None and not self._repairer.is_alive():
            self._repairer.start()
        try:
            while not self.stop.is_set():
                if deadline is not None and time.monotonic() > deadline:
                    break
                if self.notifier is not None:
                    self.notifier.watchdog()
                try:
                    self.commands.poll()
                except CommandError as exc:
                    raise DaemonError(str(exc)) from exc
                self._check_version(started)
                bus_up = self._motor_path(bus_up)
                try:
                    item = self.transport.items.get(timeout=0.1)
                except queue.Empty:
                    continue
                if isinstance(item, LinkEvent):
                    if item.kind == "down":
                        self.link_downs += 1
                        core.brake()
                        self.tell(f"serial link down ({item.detail}): braked, reconnecting")
                    elif item.kind == "up":
                        self.commands.forget()
                        if self.link_downs:
                            self.tell("serial link up again")
                    elif self.recorder is not None:
                        self.recorder.link(item.rx_time_ns, f"{item.kind} {item.detail}")
                    continue
                rx_ns, frame = item
                try:
                    self.commands.on_frame(frame)
                except CommandError as exc:
                    raise DaemonError(str(exc)) from exc
                resets = core.mcu_resets
                core.on_frame(frame, rx_ns)
                if core.mcu_resets != resets:
                    self.tell(
                        "the MCU was reset: odometry and time re-anchored, device set up again"
                    )
                if core.abort_reason is not None:
                    self.tell(f"mission aborted: {core.abort_reason}")
                    break
                if self.bridge is not None and core.last_telemetry is not None:
                    from jackson.host.ros.bridge import diagnostic_values

                    self.bridge.diagnostics(
                        diagnostic_values(core, core.last_telemetry, link=self.health())
                    )
                if core.mission is not None and core.mission.done and core.braked:
                    break
        finally:
            core.brake()
            if self.notifier is not None:
                self.notifier.stopping()
            if self.bridge is not None:
                self.bridge.stop()
            self._send(Heartbeat(ack_seq=0, host_state=HostState.SHUTDOWN))
            if self._repairer is not None and self._repairer.is_alive():
                self._repairer.join()  # a repair replaces the bag only once complete
            if self.recorder is not None:
                self._write_health()
                self.recorder.close()
            if self.bag is not None:
                try:
                    self.bag.close()
                except Exception as exc:
                    print(f"daemon: the run's bag did not close cleanly: {exc}", flush=True)
        return 1 if core.abort_reason is not None else 0

    def _write_health(self) -> None:
        assert self.run_folder is not None
        h = self.health()
        doc = {
            "link": dataclasses.asdict(h),
            "problems": h.problems(),
            "abort_reason": self.core.abort_reason,
            "events": self.events,
            "commands": {
                "acked": self.commands.counters.acked,
                "nacked": self.commands.counters.nacked,
                "retried": self.commands.counters.retried,
                "errors": self.commands.counters.errors,
            },
        }
        try:
            (self.run_folder / "health.json").write_text(json.dumps(doc, indent=2) + "\n")
        except OSError as exc:
            print(f"daemon: cannot write health.json: {exc.strerror}", flush=True)


def with_port(cfg: HostConfig, port: str | None) -> HostConfig:
    """The config with ``serial.port`` replaced (``--port``)."""
    if port is None:
        return cfg
    return dataclasses.replace(cfg, serial=dataclasses.replace(cfg.serial, port=port))
