"""The host's computation: one telemetry frame in, odometry, EKF, a command and a heartbeat out.

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

What it computes goes to its :class:`CoreListener` s (the run recorder, the rosbag2, the ROS
bridge). :class:`jackson.host.daemon.Daemon` adds the serial transport and the process.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from jackson.host.actuation.deadband import wheel_duty
from jackson.host.actuation.kinematics import inverse
from jackson.host.actuation.limiter import VelocityLimiter
from jackson.host.actuation.output import MotorOutput
from jackson.host.actuation.watchdog import CommandWatchdog
from jackson.host.actuation.wheel_pi import WheelSpeedPi
from jackson.host.config import HostConfig
from jackson.host.control import Mission, NavState
from jackson.host.control.base import ScanMission
from jackson.host.control.guard import MissionGuard
from jackson.host.ekf import Ekf, EkfState, GyroBiasEstimator
from jackson.host.frontend import FrontEnd, Measurement
from jackson.host.health import HealthMonitor, Transition, Verdict
from jackson.host.lidar.rplidar import Revolution, RevolutionAssembler
from jackson.host.nav.types import Scan
from jackson.host.odometry import OdometryState, WheelOdometry
from jackson.host.recording import RunRecorder
from jackson.protocol import (
    Frame,
    Heartbeat,
    HostState,
    Info,
    Message,
    SetConfig,
    SetImuCalibration,
    SetRate,
    Telemetry,
    TelemetryFlags,
    check_peer,
    decode_message,
)

_IMU_OK = int(TelemetryFlags.IMU_OK)  # a plain int: IntFlag's & builds an enum member

ONE_WHEEL_VARIANCE_SCALE = 4.0  # R of v_x from one wheel and the gyro, relative to two wheels


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


UNCALIBRATED_HINT = (
    "the host config holds no calibration (imu.calibration is unset): on a robot other than "
    "the one it describes the sensors disagree with it and look faulty; calibrate this robot "
    "first (jackson calibrate, docs/calibration.md)"
)


class DutySource(Protocol):
    """Raw wheel duties per telemetry frame, on MCU time and unwrapped counts: the command source
    of calibration's staircases and steps, which bypass the actuation chain."""

    done: bool

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        """(left, right) signed duty to write after this frame."""
        ...


@dataclass(frozen=True)
class FrameResult:
    """What the core made of one telemetry frame, handed to every listener.

    Attributes
    ----------
    t_s : float
        The frame's unwrapped MCU time [s].
    telemetry : Telemetry
        The frame.
    odometry : OdometryState
        Wheel odometry after the frame.
    v_cmd, w_cmd : float
        The command before the limits [m/s, rad/s].
    v, w : float
        The command after the limits (0 when braked).
    duties : tuple of float
        The wheel duties sent to the motor output (0 when braked).
    braked : bool
        The motors were braked at this frame.
    """

    t_s: float
    telemetry: Telemetry
    odometry: OdometryState
    v_cmd: float
    w_cmd: float
    v: float
    w: float
    duties: tuple[float, float]
    braked: bool


class CoreListener:
    """Receives what the core computes (the run folder, the rosbag2, the ROS bridge); no-op
    defaults. Called on the core's thread, in the order the core works."""

    def on_command(self, v_m_s: float, w_rad_s: float, host_time_ns: int) -> None:
        """An external velocity command, taken at the telemetry frame that applies it."""

    def on_frame(self, frame: Frame, host_time_ns: int) -> None:
        """Every frame received, before it is handled."""

    def on_event(self, host_time_ns: int, text: str) -> None:
        """Something the operator should know (an MCU reset, an abort)."""

    def on_filtered(self, t_s: float, state: EkfState) -> None:
        """Each 30 Hz EKF output."""

    def on_lidar(self, data: bytes, host_time_ns: int) -> None:
        """Raw bytes from the LiDAR's port, as read (before the frame they preceded)."""

    def on_scan(self, core: HostCore, scan: Scan) -> None:
        """A LiDAR revolution, stamped with the MCU time of the frame it arrived before."""

    def on_result(self, core: HostCore, result: FrameResult) -> None:
        """After a telemetry frame was handled (odometry, EKF, command are current)."""

    def on_health(self, transition: Transition) -> None:
        """A sensor changed its health state (before the frame's :meth:`on_result`)."""


class RunFolderListener(CoreListener):
    """Writes the core's inputs and outputs into a run folder (:class:`RunRecorder`)."""

    def __init__(self, recorder: RunRecorder) -> None:
        self.recorder = recorder

    def on_command(self, v_m_s: float, w_rad_s: float, host_time_ns: int) -> None:
        self.recorder.command(host_time_ns, v_m_s, w_rad_s)

    def on_frame(self, frame: Frame, host_time_ns: int) -> None:
        self.recorder.rx(host_time_ns, frame.type, frame.seq, frame.payload)

    def on_event(self, host_time_ns: int, text: str) -> None:
        self.recorder.link(host_time_ns, text)

    def on_lidar(self, data: bytes, host_time_ns: int) -> None:
        self.recorder.lidar(host_time_ns, data)

    def on_filtered(self, t_s: float, s: EkfState) -> None:
        rec = self.recorder
        rec.row(
            rec.ekf,
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
                *s.pose_cross,
            ),
        )

    def on_result(self, core: HostCore, r: FrameResult) -> None:
        rec, odo, t = self.recorder, r.odometry, r.telemetry
        rec.row(rec.commands, (r.t_s, r.v, r.w, r.duties[0], r.duties[1], int(r.braked)))
        hm = core.health
        if hm is not None:
            rec.row(
                rec.health,
                (
                    r.t_s,
                    hm.nis["yaw_rate"],
                    hm.nis["window"],
                    hm.model.scale,
                    hm.model.per_metre,
                    *(state.value for state in hm.sensors.values()),
                    int(core.verdict is not None and core.verdict.stationary),
                    hm.lidar_roughness_m,
                ),
            )
        rec.row(
            rec.odometry,
            (r.t_s, odo.x_m, odo.y_m, odo.yaw_rad, odo.v_m_s, odo.w_rad_s, t.enc_left, t.enc_right),
        )
        rec.frame_done(r.t_s)


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
        duty_source: DutySource | None = None,
        imu_calibration: bool = True,
    ) -> None:
        self.cfg = cfg
        self.duty_source = duty_source  # raw duties instead of a velocity command
        self.imu_calibration = imu_calibration  # False: the device sends raw IMU registers
        # time, counts, odometry, gyro bias, lost frames, MCU-reset re-anchoring: one place
        self.frontend = FrontEnd(cfg)
        self.output = output
        self.send = send
        self.mission = mission
        self.guard = (
            MissionGuard(mission.name, mission_timeout_s, sensor_rules=not cfg.health.enabled)
            if mission is not None
            else None
        )
        self.abort_reason: str | None = None  # why the mission was aborted (braked for good)
        self.host_state = HostState.ACTIVE  # sent in every HEARTBEAT (SHUTDOWN drops the interlock)
        self._wheel_cmd: tuple[float, float] = (0.0, 0.0)  # [rad/s] commanded at the last frame
        self._rx_ns = 0
        # the config sections are the stages' own configs
        self.ekf = Ekf(cfg.ekf)
        self.health = HealthMonitor(cfg.health, cfg.robot) if cfg.health.enabled else None
        self.verdict: Verdict | None = None
        self.sensors_lost: str | None = None  # the health policy's reason to brake
        self._hinted = False  # the uncalibrated config's hint was given
        self._told = 0  # health transitions told
        self.limiter = VelocityLimiter(cfg.limits)
        self.deadband = cfg.deadband
        zero = cfg.deadband.zero_threshold_rad_s  # the PI brakes where the deadband stage does
        self.pi = (
            (
                WheelSpeedPi(cfg.wheel_pi, zero_threshold_rad_s=zero),
                WheelSpeedPi(cfg.wheel_pi, zero_threshold_rad_s=zero),
            )
            if cfg.wheel_pi.enabled
            else None
        )
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
        self.listeners: list[CoreListener] = [RunFolderListener(recorder)] if recorder else []
        self.last_result: FrameResult | None = None
        self.last_telemetry: Telemetry | None = None
        # the LiDAR's bytes (logged raw, so a replay rebuilds the same scans), decoded here
        self.lidar = RevolutionAssembler(streaming=True)
        self._revolutions: list[Revolution] = []
        self._lidar_received = 0  # LiDAR bytes read since the last frame
        self._lidar_skipped = 0  # the LiDAR decoder's malformed bytes at the last frame
        self.scans = 0
        self.last_scan: Scan | None = None

    @property
    def odometry(self) -> WheelOdometry:
        """The front end's wheel odometry."""
        return self.frontend.odometry

    @property
    def gyro_bias(self) -> GyroBiasEstimator:
        """The front end's gyro bias estimate."""
        return self.frontend.gyro_bias

    @property
    def mcu_resets(self) -> int:
        """INFO frames with another boot_id: counts and clock re-anchored."""
        return self.frontend.resets

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
            v, w, t_ns = self._taken
            for listener in self.listeners:
                listener.on_command(v, w, t_ns)
        for listener in self.listeners:
            listener.on_frame(frame, host_time_ns)
        self._rx_ns = host_time_ns
        self.frontend.frame_seq(frame.seq)
        msg = decode_message(frame)
        if isinstance(msg, Info):
            check_peer(msg)  # raises ProtocolMismatchError naming both versions
            if self.frontend.info(msg):
                # an MCU reset: its counts and clock restart; the next frame is a new origin
                assert self.info is not None
                self.event(f"mcu reset: boot_id {self.info.boot_id:#010x} -> {msg.boot_id:#010x}")
            self.info = msg
            self._configure_device()
        elif isinstance(msg, Telemetry):
            self._on_telemetry(msg, frame.seq)

    def on_lidar(self, data: bytes, host_time_ns: int = 0) -> None:
        """Bytes read from the LiDAR's port. The revolutions they complete reach the mission
        at the next telemetry frame, stamped with its MCU time (the twin writes a revolution
        before the frame that follows its end, so in lockstep the pairing is exact)."""
        if not data:
            return
        for listener in self.listeners:
            listener.on_lidar(data, host_time_ns)
        self._lidar_received += len(data)
        self._revolutions += self.lidar.feed(data)

    def lidar_gone(self, reason: str) -> None:
        """The LiDAR's port failed: the monitor excludes it at once, and a mission that
        navigates by it is aborted (braked) now, not after a silence."""
        t_s = self.t_s if self.t_s is not None else 0.0
        hm = self.health
        if hm is not None:
            hm.lidar_gone(t_s, reason)
            self._report_health(hm)
        if isinstance(self.mission, ScanMission) and not self.mission.done:
            self.abort(f"LiDAR lost: {reason}")
            self.brake()

    def event(self, text: str) -> None:
        """Something the operator should know, in the run's log (a link record)."""
        for listener in self.listeners:
            listener.on_event(self._rx_ns, text)

    def abort(self, reason: str) -> None:
        """Stop the mission for good: brake from now on; the daemon exits naming ``reason``."""
        if self.abort_reason is None:
            self.abort_reason = reason
            self.event(f"mission aborted: {reason}")

    def _configure_device(self) -> None:
        """Bring the device's rate, ranges, direction flags and failsafe to the config."""
        assert self.info is not None
        for msg in device_setup(self.cfg, self.info, calibration=self.imu_calibration):
            self.send(msg)

    # ------------------------------------------------------------------ the frame

    def _on_telemetry(self, t: Telemetry, seq: int) -> None:
        m = self.frontend.measure(t)
        t_s = self.t_s = m.t_s
        self.frames += 1
        odo = self.last_odometry = m.odometry
        ekf = self.ekf
        # 30 Hz outputs of MCU time up to this frame: prediction only between measurements
        period = 1.0 / self.cfg.ekf.frequency_hz
        if self._next_output_s is None:
            self._next_output_s = math.ceil(t_s / period) * period
        while self._next_output_s <= t_s + 1e-9:
            if ekf.initialized:
                self._record_ekf(self._next_output_s)
            self._next_output_s += period
        self._fuse(m)
        if self._revolutions:
            self._take_scans(t_s)
        # command and actuation
        if self.duty_source is not None:
            v_cmd = w_cmd = v = w = 0.0
            duties = self._raw_duties(t_s, m.counts)
            brake = duties == (0.0, 0.0)
        else:
            v_cmd, w_cmd, brake = self._command(t_s, odo, t)
            v, w, duties = self._actuate(t_s, v_cmd, w_cmd, brake, odo)
        self.send(Heartbeat(ack_seq=seq, host_state=self.host_state))
        self.last_telemetry = t
        result = FrameResult(t_s, t, odo, v_cmd, w_cmd, v, w, duties, brake)
        self.last_result = result
        for listener in self.listeners:
            listener.on_result(self, result)

    def _fuse(self, m: Measurement) -> None:
        """The EKF's measurements of this frame, as the health monitor allows (docs/health.md):
        both wheels' speed and the gyro; or one wheel and the gyro, or the wheels' yaw rate in
        place of the gyro; or, standing still, a zero-velocity update."""
        ekf = self.ekf
        t_s, odo, wz, dt_s = m.t_s, m.odometry, m.wz_rad_s, m.dt_s
        hm = self.health
        if hm is None:  # the paper's filter: every measurement
            ekf.update_wheel(t_s, odo.v_m_s, 0.0)
            if wz is not None:
                ekf.update_gyro(t_s, wz)
            return
        om = m.wheel_rad_s
        still_cmd = self.braked or self._wheel_cmd == (0.0, 0.0)
        hm.link(t_s, m.lost)
        v = self.verdict = hm.update(m.health_input(self._wheel_cmd, still_cmd))
        self._report_health(hm)
        if hm.remeasure_bias:
            self.frontend.remeasure_bias()  # measured again over the next standstill
        if v.lost is not None and self.sensors_lost is None:
            self.sensors_lost = v.lost
            if self._hinted:  # a wheel or the gyro was excluded on an uncalibrated config
                self.sensors_lost = f"{v.lost} ({UNCALIBRATED_HINT})"
            self.event(f"health: braking: {self.sensors_lost}")
        ekf.stationary = v.stationary
        if v.stationary:
            ekf.update_zero_velocity(t_s, self.cfg.health.zupt_variance)
            return
        r = self.cfg.robot
        if v.use_left and v.use_right:
            ekf.update_wheel(t_s, odo.v_m_s, 0.0)
        elif wz is not None and v.use_gyro and (v.use_left or v.use_right):
            # one wheel and the gyro: v = r_i omega_i -+ wz B / 2
            half = 0.5 * wz * r.wheel_separation_m
            if v.use_left:
                vx = r.wheel_radius_left_m * om[0] + half
            else:
                vx = r.wheel_radius_right_m * om[1] - half
            ekf.update_wheel(t_s, vx, 0.0, variance_scale=ONE_WHEEL_VARIANCE_SCALE)
        if wz is not None and v.use_gyro:
            ekf.update_gyro(t_s, wz)
        elif v.use_left and v.use_right and dt_s > 0.0:
            # the wheels' yaw rate through the model learned while the gyro was healthy
            w_e = (
                r.wheel_radius_right_m * om[1] - r.wheel_radius_left_m * om[0]
            ) / r.wheel_separation_m
            ekf.update_yaw_rate(t_s, hm.model.true_rate(w_e, odo.v_m_s), v.wheel_yaw_variance)

    def _report_health(self, hm: HealthMonitor) -> None:
        """Tell the operator and the listeners of the monitor's new transitions; with a config
        that holds no calibration, the first exclusion of a wheel or the gyro for disagreeing
        with the other (not a dead or stuck sensor) says so too."""
        for tr in hm.transitions[self._told :]:
            self.event(f"health: {tr.sensor} {tr.old.value} -> {tr.new.value}: {tr.reason}")
            for listener in self.listeners:
                listener.on_health(tr)
            if (
                tr.new.value == "excluded"
                and tr.sensor in ("imu", "encoder_left", "encoder_right")
                and "disagree" in tr.reason  # the wheels and the gyro against the config's robot
                and self.cfg.imu.calibration is None
                and not self._hinted
            ):
                self._hinted = True
                self.event(f"health: {UNCALIBRATED_HINT}")
        self._told = len(hm.transitions)

    def _take_scans(self, t_s: float) -> None:
        revolutions, self._revolutions = self._revolutions, []
        hm = self.health
        if hm is not None and self._lidar_received:
            skipped = self.lidar.decoder.malformed_bytes
            hm.lidar_bytes(t_s, self._lidar_received, skipped - self._lidar_skipped)
            self._lidar_skipped = skipped
            self._lidar_received = 0
        navigating = isinstance(self.mission, ScanMission)
        if hm is not None:
            hm.lidar_needed = navigating and self.mission is not None and not self.mission.done
        for rev in revolutions:
            scan = Scan(t_s, rev.angles_rad, rev.ranges_m)
            self.scans += 1
            self.last_scan = scan
            # a scan too noisy to trust, or from an excluded LiDAR, is published (the
            # listeners) but not navigated by
            use = hm.scan(t_s, rev.ranges_m, rev.angles_rad) if hm is not None else True
            if navigating and use:
                assert isinstance(self.mission, ScanMission)
                self.mission.on_scan(scan, self.nav_state())
            for listener in self.listeners:
                listener.on_scan(self, scan)
        if hm is not None:
            self._report_health(hm)

    def _record_ekf(self, t_s: float) -> None:
        """A 30 Hz output: the estimate predicted to ``t_s`` (the filter itself is not moved)."""
        self.ekf_outputs += 1
        self.last_output = s = self.ekf.state_at(t_s)
        for listener in self.listeners:
            listener.on_filtered(t_s, s)

    def _raw_duties(self, t_s: float, counts: tuple[int, int]) -> tuple[float, float]:
        """The duty source's duties, written to the output as they are (0, 0 brakes)."""
        assert self.duty_source is not None
        d_l, d_r = self.duty_source.step(t_s, counts[0], counts[1])
        self.output.set(d_l, d_r)
        self.braked = d_l == 0.0 and d_r == 0.0
        return d_l, d_r

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
            if self.sensors_lost is not None:
                self.abort(self.sensors_lost)
                return 0.0, 0.0, True
            # an IMU the health monitor excluded is not waited for: wheel-only yaw
            imu_out = self.health is not None and not self.health.state("imu").usable
            bias_known = self.frontend.bias_ever_known or imu_out
            if self.guard is not None and not self.mission.done:
                reason = self.guard.check(
                    t_s,
                    bool(t.flags & _IMU_OK),
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
            if self.health is not None and self.health.lidar_blind and not self.mission.done:
                return 0.0, 0.0, True  # no usable scan for too long: braked until one comes
            return v, w, self.mission.done
        if self.watchdog.expired(t_s) or self.sensors_lost is not None:
            return 0.0, 0.0, True
        return self.external[0], self.external[1], False

    def _actuate(
        self, t_s: float, v_cmd: float, w_cmd: float, brake: bool, odo: OdometryState
    ) -> tuple[float, float, tuple[float, float]]:
        """Limits, kinematics, PI, deadband, the motor output; (v, w, duties) as sent."""
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
        return v, w, duties

    def link_up(self) -> None:
        """The port was (re)opened: frames sent while nobody read it are not lost on the link,
        so SEQ gaps count again from this session's first frame."""
        self.frontend.link_up()

    def brake(self) -> None:
        """Brake now (link lost, shutdown)."""
        self.output.brake()
        self.braked = True
