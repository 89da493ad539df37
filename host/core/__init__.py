"""The host's computation: one telemetry frame in, odometry, EKF, a command and a heartbeat out.

:class:`HostCore` is everything the daemon computes, free of I/O but for its motor output and a
``send`` callable, so the same code runs on the robot, against the twin and in ``jackson
replay``. It is a pipeline of small stages, each its own class, run per telemetry frame on MCU
time (the unwrapped ``t_us``, never the wall clock):

0. live settings (:class:`~jackson.host.core.settings.LiveSettings`: limits and the command
   watchdog) requested since the last frame, logged and applied to every stage that holds
   them (the limiter, the watchdog, the navigator's DWB and recoveries);
1. the front end (:class:`~jackson.host.core.frontend.FrontEnd`): time, lost frames, counts, wheel
   odometry (Eq. 2, 3, 9), the gyro less its bias, MCU-reset re-anchoring; one frozen
   :class:`~jackson.host.core.frontend.Measurement`;
2. the measurement policy (:class:`~jackson.host.core.fusion.Fusion`): the EKF's outputs at 30 Hz of
   MCU time up to this frame (predict only), then the frame's measurements fused as the health
   monitor's :class:`~jackson.host.health.Verdict` allows (a gyro bias it asks to measure
   again goes back to the front end);
3. the LiDAR's revolutions completed since the last frame (:class:`~jackson.host.lidar.intake.
   ScanIntake`), judged by the monitor's LiDAR checks in the intake, to a navigating mission;
4. command arbitration (:class:`~jackson.host.control.arbiter.CommandArbiter`): the mission's
   command, or the newest external (``/cmd_vel``-style) one, which brakes once older than the
   watchdog (0.6 s);
5. the actuation chain (:class:`~jackson.host.core.chain.ActuationChain`): velocity and
   acceleration limits, inverse kinematics, optional wheel PI, per-wheel and per-direction
   deadband compensation, the motor output;
6. a HEARTBEAT acknowledging the frame (in lockstep, the twin advances on it).

What it computes goes to its :class:`CoreListener` s (the run recorder, the rosbag2, the ROS
bridge). :class:`jackson.host.daemon.Daemon` adds the serial transport and the process.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from jackson.host.actuation.limiter import VelocityLimiter
from jackson.host.actuation.output import MotorOutput
from jackson.host.actuation.watchdog import CommandWatchdog
from jackson.host.config import HostConfig
from jackson.host.control import Mission, NavState
from jackson.host.control.arbiter import CommandArbiter, Conditions
from jackson.host.control.base import LimitedMission, is_scan, is_service
from jackson.host.core.chain import ActuationChain
from jackson.host.core.frontend import FrontEnd
from jackson.host.core.fusion import Fusion
from jackson.host.core.results import CoreListener, FrameResult
from jackson.host.core.settings import LiveSettings, SettingsInbox
from jackson.host.estimation.ekf import Ekf, EkfState, GyroBiasEstimator
from jackson.host.estimation.odometry import OdometryState, WheelOdometry
from jackson.host.health import HealthMonitor, Transition, Verdict
from jackson.host.lidar.intake import ScanIntake
from jackson.host.lidar.rplidar import RevolutionAssembler
from jackson.host.nav.types import Scan
from jackson.host.recording import RunRecorder
from jackson.host.recording.snapshot import pickle_state, unpickle_state
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
REST_FRAMES = 3  # frames without an encoder count: the wheels stand still (0.15 s at 20 Hz)
SETTLE_LIMIT_S = 2.0  # [s] the longest a done mission waits, braked, for the robot to rest


def device_setup(cfg: HostConfig, info: Info, *, calibration: bool = True) -> list[Message]:
    """The commands that bring a device (its INFO) to the configuration: SET_RATE and SET_CONFIG
    where they differ, and SET_IMU_CALIBRATION when the config holds one (and ``calibration``)."""
    out: list[Message] = []
    if info.telemetry_rate_hz != cfg.serial.telemetry_rate_hz:
        out.append(SetRate(rate_hz=cfg.serial.telemetry_rate_hz))
    failsafe_ms = cfg.failsafe_ms
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


class DutySource(Protocol):
    """Raw wheel duties per telemetry frame, on MCU time and unwrapped counts: the command source
    of calibration's staircases and steps, which bypass the actuation chain."""

    done: bool

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        """(left, right) signed duty to write after this frame."""
        ...


class RunFolderListener(CoreListener):
    """Writes the core's inputs and outputs into a run folder (:class:`RunRecorder`); with the
    health monitor, its state at every frame (``health.csv``)."""

    def __init__(self, recorder: RunRecorder, health: HealthMonitor | None = None) -> None:
        self.recorder = recorder
        self.health = health

    def on_command(self, v_m_s: float, w_rad_s: float, host_time_ns: int) -> None:
        self.recorder.command(host_time_ns, v_m_s, w_rad_s)

    def on_frame(self, frame: Frame, host_time_ns: int) -> None:
        self.recorder.rx(host_time_ns, frame.type, frame.seq, frame.payload)

    def on_request(self, data: bytes, host_time_ns: int) -> None:
        self.recorder.request(host_time_ns, data)

    def on_settings(self, data: bytes, host_time_ns: int) -> None:
        self.recorder.settings(host_time_ns, data)

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

    def on_result(self, r: FrameResult) -> None:
        rec, odo, t = self.recorder, r.odometry, r.telemetry
        rec.row(rec.commands, (r.t_s, r.v, r.w, r.duties[0], r.duties[1], int(r.braked)))
        hm = self.health
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
                    int(r.verdict is not None and r.verdict.stationary),
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
        # limits, kinematics, PI, deadband, the motor output
        self.actuation = ActuationChain(cfg, output)
        self.send = send
        # the mission's command or the newest external one, the guard, the watchdog
        self.arbiter = CommandArbiter(
            cfg.cmd_vel_timeout_s, mission, mission_timeout_s, sensor_rules=not cfg.health.enabled
        )
        self.live = SettingsInbox(cfg)  # live settings: requested from any thread, taken at a frame
        self.abort_reason: str | None = None  # why the mission was aborted (braked for good)
        self.host_state = HostState.ACTIVE  # sent in every HEARTBEAT (SHUTDOWN drops the interlock)
        self._rx_ns = 0
        # the EKF fed as the sensors' health allows, its 30 Hz outputs
        self.fusion = Fusion(cfg, self.event, self._tell_transition)
        self.info: Info | None = None
        self.listeners: list[CoreListener] = (
            [RunFolderListener(recorder, self.fusion.health)] if recorder else []
        )
        self.last_result: FrameResult | None = None
        # the LiDAR's bytes (logged raw, so a replay rebuilds the same scans), decoded and
        # judged here (the monitor's LiDAR checks)
        hm = self.fusion.health
        self.intake = ScanIntake(hm.lidar if hm is not None else None)
        # a done mission's robot coming to rest: frames with unchanged counts, braked since
        self._counts: tuple[int, int] | None = None
        self._still_frames = 0
        self._braked_done_s: float | None = None
        self.finished = False  # the mission is done, braked, and the robot at rest

    @property
    def odometry(self) -> WheelOdometry:
        """The front end's wheel odometry."""
        return self.frontend.odometry

    @property
    def gyro_bias(self) -> GyroBiasEstimator:
        """The front end's gyro bias estimate."""
        return self.frontend.gyro_bias

    @property
    def output(self) -> MotorOutput:
        """The motor output the actuation chain writes."""
        return self.actuation.output

    @property
    def limiter(self) -> VelocityLimiter:
        """The actuation chain's velocity and acceleration limiter."""
        return self.actuation.limiter

    @property
    def braked(self) -> bool:
        """The motors were braked at the last frame (or since)."""
        return self.actuation.braked

    @property
    def lidar(self) -> RevolutionAssembler:
        """The LiDAR's decoder."""
        return self.intake.assembler

    @property
    def scans(self) -> int:
        """LiDAR scans taken."""
        return self.intake.scans

    @property
    def last_scan(self) -> Scan | None:
        """The newest LiDAR scan."""
        return self.intake.last_scan

    @property
    def mission(self) -> Mission | None:
        """The mission the daemon runs (None: external commands)."""
        return self.arbiter.mission

    @mission.setter
    def mission(self, mission: Mission | None) -> None:
        self.arbiter.mission = mission

    @property
    def watchdog(self) -> CommandWatchdog:
        """The external command's watchdog."""
        return self.arbiter.watchdog

    @property
    def external(self) -> tuple[float, float]:
        """The newest external command in force (v [m/s], w [rad/s])."""
        return self.arbiter.external

    @property
    def ekf(self) -> Ekf:
        """The filter."""
        return self.fusion.ekf

    @property
    def health(self) -> HealthMonitor | None:
        """The sensor health monitor (None: off)."""
        return self.fusion.health

    @property
    def verdict(self) -> Verdict | None:
        """The health monitor's verdict at the last frame."""
        return self.fusion.verdict

    @property
    def sensors_lost(self) -> str | None:
        """The health policy's reason to brake."""
        return self.fusion.sensors_lost

    @property
    def ekf_outputs(self) -> int:
        """The filter's 30 Hz outputs so far."""
        return self.fusion.outputs

    @property
    def last_output(self) -> EkfState | None:
        """The newest 30 Hz output."""
        return self.fusion.last_output

    @property
    def t_s(self) -> float | None:
        """The MCU time of the last telemetry frame [s] (None before one)."""
        return self.frontend.t_s

    @property
    def frames(self) -> int:
        """Telemetry frames handled."""
        return self.frontend.frames

    @property
    def last_odometry(self) -> OdometryState | None:
        """Wheel odometry after the last telemetry frame (None before one)."""
        return self.frontend.odometry.state if self.frontend.frames else None

    @property
    def last_telemetry(self) -> Telemetry | None:
        """The last telemetry frame handled (None before one)."""
        return self.last_result.telemetry if self.last_result is not None else None

    @property
    def mcu_resets(self) -> int:
        """INFO frames with another boot_id: counts and clock re-anchored."""
        return self.frontend.resets

    # ------------------------------------------------------------------ snapshot

    def snapshot(self) -> bytes:
        """The core's computing state, pickled between two frames (a run folder's split,
        docs/recording.md): every stage and the mission, without the I/O (the motor output,
        ``send``, the listeners), which :meth:`restore` is given anew. Requests and commands
        submitted and not yet taken stay out: the next frame takes them into the next folder.
        """
        return pickle_state(
            self, {"output": self.output, "send": self.send, "listeners": self.listeners}
        )

    @classmethod
    def restore(
        cls,
        pickled: bytes,
        output: MotorOutput,
        send: Callable[[Message], object],
        recorder: RunRecorder | None = None,
    ) -> HostCore:
        """The core :meth:`snapshot` pickled, with this output, ``send`` and a recorder.

        Raises
        ------
        Exception
            Whatever unpickling raises (a snapshot of another version); the caller names it.
        """
        core = unpickle_state(pickled, {"output": output, "send": send, "listeners": []})
        if not isinstance(core, cls):
            raise TypeError(f"the snapshot holds a {type(core).__name__}, not a HostCore")
        if recorder is not None:
            core.listeners.append(RunFolderListener(recorder, core.fusion.health))
        return core

    # ------------------------------------------------------------------ inputs

    def submit_velocity(self, v_m_s: float, w_rad_s: float, host_time_ns: int = 0) -> None:
        """An external velocity command (``/cmd_vel``); it takes effect, stamped on MCU time, at
        the next telemetry frame. Safe to call from another thread (the ROS executor)."""
        self.arbiter.submit(v_m_s, w_rad_s, host_time_ns)

    def request_settings(self, settings: LiveSettings) -> None:
        """New live settings (:mod:`jackson.host.core.settings`): the next telemetry frame takes
        them, logs them before it and hands them to every stage that holds a copy (the limiter,
        the watchdog, a navigator). Safe to call from another thread (the ROS executor)."""
        self.live.request(settings)

    @property
    def settings(self) -> LiveSettings:
        """The newest live settings requested, or those in force (what a change starts from)."""
        return self.live.latest

    def _take_settings(self, host_time_ns: int) -> None:
        """At a telemetry frame, before it: the live settings requested since the last one,
        logged (a replay applies them to the same frame) and handed to the stages."""
        settings = self.live.take()
        if settings is None:
            return
        data = settings.encode()
        for listener in self.listeners:
            listener.on_settings(data, host_time_ns)
        self.limiter.config = settings.limits
        self.watchdog.timeout_s = settings.cmd_vel_timeout_s
        if isinstance(self.mission, LimitedMission):
            self.mission.set_limits(self.live.navigation_limits())

    def on_frame(self, frame: Frame, host_time_ns: int = 0) -> None:
        """One decoded frame from the MCU."""
        telemetry = frame.type == Telemetry.TYPE
        if telemetry:
            self._take_settings(host_time_ns)
        mission = self.mission
        if telemetry and is_service(mission):
            # the service's requests this frame applies, logged before it (as commands are)
            for request in mission.take_requests():
                data = request.encode()
                for listener in self.listeners:
                    listener.on_request(data, host_time_ns)
        taken = self.arbiter.take(telemetry)
        if taken is not None:
            # taken once, on this thread; logged before the frame that applies it, so a replay
            # applies it to the same frame
            v, w, t_ns = taken
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
        self.intake.feed(data)

    def lidar_gone(self, reason: str) -> None:
        """The LiDAR's port failed: the intake's checks exclude it at once, and a mission that
        navigates by it is aborted (braked) now, not after a silence."""
        self.intake.gone(self.t_s if self.t_s is not None else 0.0, reason)
        self.fusion.report_health()
        if is_service(self.mission):
            self.mission.lidar_lost(reason)  # goals end and are refused; the service stays up
        elif is_scan(self.mission) and not self.mission.done:
            self.abort(f"LiDAR lost: {reason}")
            self.brake()

    def event(self, text: str) -> None:
        """Something the operator should know, in the run's log (a link record)."""
        for listener in self.listeners:
            listener.on_event(self._rx_ns, text)

    def host_stalled(self, stalled_s: float) -> None:
        """The daemon did not run for ``stalled_s`` wall seconds after the last frame (logged
        as a link record, so a replay applies it between the same frames): a sensor's silence
        that stall makes is not blamed on the sensor."""
        if self.t_s is not None:
            self.intake.host_stalled(self.t_s, stalled_s)

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
        t_s, odo = m.t_s, m.odometry
        # 30 Hz outputs of MCU time up to this frame: prediction only between measurements
        self.fusion.outputs_to(t_s, self._emit_filtered)
        act = self.actuation
        if not self.intake.pending:
            self.intake.unpaired(t_s)  # LiDAR bytes and no revolution: garbage before silence
        verdict = self.fusion.fuse(m, act.wheel_cmd, act.commanded_still)
        if verdict is not None and verdict.remeasure_gyro_bias:
            self.frontend.remeasure_bias()  # measured again over the next standstill
        if self.intake.pending:
            self._take_scans(t_s)
        # command and actuation
        if self.duty_source is not None:
            v_cmd = w_cmd = v = w = 0.0
            duties = self._raw_duties(t_s, m.counts)
            brake = duties == (0.0, 0.0)
        else:
            v_cmd, w_cmd, brake = self._command(t_s, t)
            v, w, duties = self.actuation.apply(
                t_s, v_cmd, w_cmd, brake, odo, external=self.arbiter.external_in_force
            )
        self.send(Heartbeat(ack_seq=seq, host_state=self.host_state))
        result = FrameResult(
            t_s, t, odo, v_cmd, w_cmd, v, w, duties, brake, self.frames, self.verdict,
            self.mission,
        )  # fmt: skip
        self.last_result = result
        for listener in self.listeners:
            listener.on_result(result)
        self._track_rest(t_s, (t.enc_left, t.enc_right))

    def _track_rest(self, t_s: float, counts: tuple[int, int]) -> None:
        """After a mission is done and braked, :attr:`finished` once the wheels stand still
        (``REST_FRAMES`` frames without a count), or ``SETTLE_LIMIT_S`` after the brake: the
        run's log then ends where the robot came to rest, its run-on after the stop in it."""
        self._still_frames = self._still_frames + 1 if counts == self._counts else 0
        self._counts = counts
        mission = self.mission
        if mission is None or not mission.done or not self.braked:
            self._braked_done_s = None
            return
        if self._braked_done_s is None:
            self._braked_done_s = t_s
        self.finished = (
            self._still_frames >= REST_FRAMES or t_s - self._braked_done_s >= SETTLE_LIMIT_S
        )

    def _tell_transition(self, tr: Transition) -> None:
        for listener in self.listeners:
            listener.on_health(tr)

    def _take_scans(self, t_s: float) -> None:
        mission = self.mission
        navigating = is_scan(mission)
        needed = (
            navigating
            and mission is not None
            and not mission.done
            and (not is_service(mission) or mission.navigating)
        )
        for rev in self.intake.take(t_s, needed):
            # a scan too noisy to trust, or from an excluded LiDAR, is published (the
            # listeners) but not navigated by
            scan, use = self.intake.scan(t_s, rev)
            if navigating and use:
                assert is_scan(self.mission)
                self.mission.on_scan(scan, self.nav_state())
            for listener in self.listeners:
                listener.on_scan(scan)
        self.fusion.report_health()

    def _emit_filtered(self, t_s: float, s: EkfState) -> None:
        """A 30 Hz output: the estimate predicted to ``t_s`` (the filter itself is not moved)."""
        for listener in self.listeners:
            listener.on_filtered(t_s, s)

    def _raw_duties(self, t_s: float, counts: tuple[int, int]) -> tuple[float, float]:
        """The duty source's duties, written to the output as they are (0, 0 brakes)."""
        assert self.duty_source is not None
        d_l, d_r = self.duty_source.step(t_s, counts[0], counts[1])
        return self.actuation.raw(d_l, d_r)

    def nav_state(self) -> NavState:
        e = self.ekf
        return NavState(self.t_s or 0.0, e.x_m, e.y_m, e.yaw_rad, e.vx_m_s, e.vyaw_rad_s)

    def _command(self, t_s: float, t: Telemetry) -> tuple[float, float, bool]:
        hm = self.health
        # an IMU the health monitor excluded is not waited for: wheel-only yaw
        imu_out = hm is not None and not hm.state("imu").usable
        conditions = Conditions(
            imu_ok=bool(t.flags & _IMU_OK),
            bias_known=self.frontend.bias_ever_known or imu_out,
            counts=(t.enc_left, t.enc_right),
            wheel_cmd=self.actuation.wheel_cmd,
            sensors_lost=self.sensors_lost,
            lidar_blind=hm is not None and hm.lidar_blind,
        )
        return self.arbiter.command(t_s, conditions, self.abort_reason, self.abort, self.nav_state)

    def link_up(self) -> None:
        """The port was (re)opened: frames sent while nobody read it are not lost on the link,
        so SEQ gaps count again from this session's first frame."""
        self.frontend.link_up()

    def brake(self) -> None:
        """Brake now (link lost, shutdown)."""
        self.actuation.brake()
