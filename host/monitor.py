"""``jackson monitor``: a live view of the link for the first-boot check.

Works against the robot and the twin alike: it sends HELLO, then shows the device's identity,
the frame rate, CRC errors and sequence gaps, encoder counts, the IMU in SI units and the
health bits. It sends heartbeats (so the device's failsafe stays calm) and no motor commands.

It also runs the daemon's sensor health monitor (:mod:`jackson.host.health`) on the frames:
each sensor's state, the yaw-rate NIS and the last transition. The robot stands still (the
monitor commands nothing), so the gyro's bias is checked at once; push the robot by hand and
the wheels and the gyro are checked against each other.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from rich.console import Group
from rich.live import Live
from rich.table import Table

from jackson.host.config import HostConfig
from jackson.host.daemon import VERSION_SILENCE_S
from jackson.host.ekf import GyroBiasEstimator
from jackson.host.health import HealthInput, HealthMonitor
from jackson.host.odometry import WheelOdometry, tick_delta
from jackson.host.transport import LinkEvent, SerialTransport
from jackson.protocol import (
    PROTOCOL_VERSION,
    FrameVersionError,
    Heartbeat,
    HostState,
    Info,
    Log,
    Status,
    Telemetry,
    TelemetryFlags,
    TimestampUnwrapper,
    check_peer,
    decode_message,
)
from jackson.protocol.units import accel_m_s2, gyro_rad_s, temperature_c, yaw_rate_rad_s


def imu_si(t: Telemetry) -> tuple[tuple[float, ...], tuple[float, ...], float]:
    """(accel m/s^2, gyro rad/s, die temperature deg C) of a frame."""
    return accel_m_s2(t), gyro_rad_s(t), temperature_c(t)


def flag_names(flags: int) -> str:
    names = [f.name or "" for f in TelemetryFlags if flags & f]
    return " ".join(names) or "-"


class SensorWatch:
    """The health monitor on a robot that is not driven (module docstring)."""

    def __init__(self, cfg: HostConfig | None = None) -> None:
        cfg = cfg if cfg is not None else HostConfig()
        self.health = HealthMonitor(cfg.health, cfg.robot)
        self.odometry = WheelOdometry(cfg.robot)
        self.bias = GyroBiasEstimator(window_s=cfg.ekf.gyro_bias_window_s)
        self.unwrapper = TimestampUnwrapper()
        self._prev: tuple[float, int, int] | None = None
        self._seq: int | None = None

    def feed(self, t: Telemetry, seq: int | None = None) -> None:
        """One telemetry frame (and its SEQ, for the link's frame loss)."""
        t_s = self.unwrapper.unwrap(t.t_us) / 1e6
        lost = 0
        if seq is not None:
            if self._seq is not None:
                lost = (seq - self._seq - 1) & 0xFF
            self._seq = seq
        self.health.link(t_s, lost)
        odo = self.odometry.update(t_s, t.enc_left, t.enc_right)
        om = (odo.wheel_velocity_left_rad_s, odo.wheel_velocity_right_rad_s)
        imu_ok = bool(t.flags & TelemetryFlags.IMU_OK)
        wz = None
        if imu_ok:
            raw = yaw_rate_rad_s(t)
            self.bias.add(t_s, raw, om == (0.0, 0.0))
            if self.bias.bias_rad_s is not None:
                wz = raw - self.bias.bias_rad_s
        prev = self._prev if self._prev is not None else (t_s, t.enc_left, t.enc_right)
        self._prev = (t_s, t.enc_left, t.enc_right)
        self.health.update(
            HealthInput(
                t_s=t_s,
                imu_ok=imu_ok,
                imu_raw=(*t.accel, *t.gyro, t.temp),
                wz_rad_s=wz,
                wheel_rad_s=om,
                ticks=(tick_delta(prev[1], t.enc_left), tick_delta(prev[2], t.enc_right)),
                dt_s=t_s - prev[0],
                wheel_cmd_rad_s=(0.0, 0.0),
                commanded_still=True,
            )
        )
        if self.health.remeasure_bias:
            self.bias.reset()

    def line(self) -> str:
        """The states, the NIS and the last transition, for the live view."""
        h = self.health
        states = ", ".join(
            f"{name} {state.value}"
            for name, state in h.sensors.items()
            if name != "lidar" or h.lidar_counts["scans"]  # a LiDAR it never saw
        )
        text = f"{states}; yaw-rate NIS {h.nis['yaw_rate']:.1f}"
        if h.transitions:
            tr = h.transitions[-1]
            text += f"; last: {tr.sensor} -> {tr.new.value} at {tr.t_s:.1f} s ({tr.reason})"
        return text


@dataclass
class MonitorState:
    info: Info | None = None
    status: Status | None = None
    last: Telemetry | None = None
    frames: int = 0
    times: list[float] = field(default_factory=list)  # host receive times, last 2 s
    logs: list[str] = field(default_factory=list)
    link: str = "connecting"
    sensors: SensorWatch = field(default_factory=SensorWatch)

    def rate_hz(self) -> float:
        span = self.times[-1] - self.times[0] if self.times else 0.0
        if span <= 0.0:  # one frame, or a burst read at once after a stall
            return 0.0
        return (len(self.times) - 1) / span


def render(s: MonitorState, transport: SerialTransport) -> Group:
    c = transport.decoder.counters
    head = Table.grid(padding=(0, 2))
    if s.info is not None:
        i = s.info
        fw = ".".join(str(v) for v in i.firmware_version)
        head.add_row(
            "device",
            f"firmware {fw}, protocol v{i.protocol_version}, "
            f"schema {i.schema_hash:#010x}, {i.telemetry_rate_hz} Hz, failsafe "
            f"{i.failsafe_ms} ms",
        )
    head.add_row("link", f"{s.link}; {s.frames} telemetry frames, {s.rate_hz():.1f} Hz")
    head.add_row(
        "receive",
        f"CRC errors {c.crc_errors}, SEQ gaps {c.seq_gaps} "
        f"({c.seq_lost} lost), bytes skipped {c.bytes_skipped}, timeouts {c.timeouts}",
    )
    if s.last is not None:
        t = s.last
        accel, gyro, temp = imu_si(t)
        head.add_row("encoders", f"left {t.enc_left}, right {t.enc_right} ticks")
        head.add_row("accel", " ".join(f"{v:+7.3f}" for v in accel) + " m/s^2")
        head.add_row("gyro", " ".join(f"{v:+8.4f}" for v in gyro) + f" rad/s   {temp:.1f} C")
        head.add_row("health", flag_names(t.flags))
        head.add_row("sensors", s.sensors.line())
    if s.status is not None:
        st = s.status
        head.add_row(
            "device counts",
            f"rx ok {st.rx_frames_ok}, rx CRC {st.rx_crc_errors}, "
            f"bad commands {st.rx_bad_commands}, tx dropped {st.tx_dropped}, "
            f"I2C errors {st.i2c_errors}",
        )
    for line in s.logs[-3:]:
        head.add_row("log", line)
    return Group(head)


def _check_version(s: MonitorState, transport: SerialTransport, started_s: float) -> None:
    """Frames of another frame version and nothing decodable for a second: one clear error."""
    dec = transport.decoder
    if s.info is not None or s.frames or dec.counters.unknown_version == 0:
        return
    if time.monotonic() - started_s >= VERSION_SILENCE_S:
        where = f"device on {transport.port_name}"
        raise FrameVersionError(dec.last_unknown_version, PROTOCOL_VERSION, where)


def run_monitor(port: str, baudrate: int = 921600, duration_s: float | None = None) -> MonitorState:
    """Show the live view until Ctrl-C (or ``duration_s``); returns the final state."""
    transport = SerialTransport(port, baudrate)
    transport.open(reader_thread=False)
    s = MonitorState()
    started = time.monotonic()
    end = None if duration_s is None else started + duration_s
    try:
        with Live(render(s, transport), refresh_per_second=4, transient=False) as live:
            while end is None or time.monotonic() < end:
                _check_version(s, transport, started)
                item = transport.get(0.25)
                if item is None:
                    live.update(render(s, transport))
                    continue
                if isinstance(item, LinkEvent):
                    s.link = "up" if item.kind == "up" else f"down ({item.detail}), retrying"
                    continue
                rx_ns, frame = item
                msg = decode_message(frame)
                if isinstance(msg, Telemetry):
                    s.frames += 1
                    s.last = msg
                    s.sensors.feed(msg, frame.seq)
                    now = rx_ns / 1e9
                    s.times = [t for t in s.times if t > now - 2.0] + [now]
                    transport.send(Heartbeat(ack_seq=frame.seq, host_state=HostState.IDLE))
                elif isinstance(msg, Info):
                    check_peer(msg)
                    s.info = msg
                elif isinstance(msg, Status):
                    s.status = msg
                elif isinstance(msg, Log):
                    s.logs.append(msg.text)
                live.update(render(s, transport))
    finally:
        transport.send(Heartbeat(ack_seq=0, host_state=HostState.SHUTDOWN))
        transport.close()
    return s
