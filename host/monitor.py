"""``jackson monitor``: a live view of the link for the first-boot check.

Works against the robot and the twin alike: it sends HELLO, then shows the device's identity,
the frame rate, CRC errors and sequence gaps, encoder counts, the IMU in SI units and the
health bits. It sends heartbeats (so the device's failsafe stays calm) and no motor commands.
On a terminal the view is a live table; piped (``| tee log``, a file, journald) it is one plain
line a second instead (and the device's identity once). SIGINT (Ctrl-C) and SIGTERM end it
within the next wait of :data:`POLL_S`: a SHUTDOWN heartbeat, the port closed, exit status 0.

It also runs the daemon's sensor health monitor (:mod:`jackson.host.health`) on the
frames: each sensor's state, the yaw-rate NIS and the last transition. The robot stands still (the
monitor commands nothing), so the gyro's bias is checked at once; push the robot by hand and
the wheels and the gyro are checked against each other.
"""

from __future__ import annotations

import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import FrameType
from typing import TextIO

from rich.console import Console, Group
from rich.live import Live
from rich.table import Table

from jackson.host.config import HostConfig
from jackson.host.core.frontend import FrontEnd
from jackson.host.daemon import VERSION_SILENCE_S
from jackson.host.health import HealthMonitor
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
    check_peer,
    decode_message,
)
from jackson.protocol.units import accel_m_s2, gyro_rad_s, temperature_c


def imu_si(t: Telemetry) -> tuple[tuple[float, ...], tuple[float, ...], float]:
    """(accel m/s^2, gyro rad/s, die temperature deg C) of a frame."""
    return accel_m_s2(t), gyro_rad_s(t), temperature_c(t)


def flag_names(flags: int) -> str:
    names = [f.name or "" for f in TelemetryFlags if flags & f]
    return " ".join(names) or "-"


class SensorWatch:
    """The health monitor on a robot that is not driven (module docstring), fed by the daemon's
    own front end (:class:`jackson.host.core.frontend.FrontEnd`)."""

    def __init__(self, cfg: HostConfig | None = None) -> None:
        cfg = cfg if cfg is not None else HostConfig()
        self.health = HealthMonitor(cfg.health, cfg.robot)
        self.frontend = FrontEnd(cfg)

    def frame(self, seq: int) -> None:
        """A frame other than telemetry (its SEQ counts for the link's frame loss)."""
        self.frontend.frame_seq(seq)

    def info(self, msg: Info) -> None:
        """The device's INFO (another boot_id: an MCU reset, the next frame a new origin)."""
        self.frontend.info(msg)

    def feed(self, t: Telemetry, seq: int | None = None) -> None:
        """One telemetry frame (and its SEQ, for the link's frame loss)."""
        if seq is not None:
            self.frontend.frame_seq(seq)
        m = self.frontend.measure(t)
        self.health.link(m.t_s, m.lost)
        self.health.update(m.health_input((0.0, 0.0), True))  # nothing is commanded
        if self.health.remeasure_bias:
            self.frontend.remeasure_bias()

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


POLL_S = 0.1  # [s] the longest wait for a frame: how soon a stop request is seen
LINE_PERIOD_S = 1.0  # [s] between plain lines (output that is not a terminal)


def device_line(i: Info) -> str:
    """The device's identity, one line."""
    fw = ".".join(str(v) for v in i.firmware_version)
    return (
        f"device: firmware {fw}, protocol v{i.protocol_version}, schema {i.schema_hash:#010x}, "
        f"{i.telemetry_rate_hz} Hz, failsafe {i.failsafe_ms} ms"
    )


def plain_line(s: MonitorState, transport: SerialTransport, elapsed_s: float) -> str:
    """The live view as one line, for output that is not a terminal."""
    c = transport.decoder.counters
    parts = [
        f"{elapsed_s:6.1f} s",
        f"link {s.link}, {s.frames} telemetry frames, {s.rate_hz():.1f} Hz",
        f"CRC errors {c.crc_errors}, SEQ gaps {c.seq_gaps} ({c.seq_lost} lost)",
    ]
    if s.last is not None:
        t = s.last
        accel, gyro, temp = imu_si(t)
        parts += [
            f"enc {t.enc_left} {t.enc_right}",
            "accel " + " ".join(f"{v:+.3f}" for v in accel),
            "gyro " + " ".join(f"{v:+.4f}" for v in gyro) + f" {temp:.1f} C",
            f"flags {flag_names(t.flags)}",
            f"sensors {s.sensors.line()}",
        ]
    if s.status is not None:
        st = s.status
        parts.append(
            f"device rx {st.rx_frames_ok} CRC {st.rx_crc_errors} bad {st.rx_bad_commands} "
            f"dropped {st.tx_dropped} I2C {st.i2c_errors}"
        )
    return "; ".join(parts)


@contextmanager
def stop_on_signals() -> Iterator[threading.Event]:
    """An event set by SIGINT or SIGTERM while inside (the previous handlers are restored on
    the way out); outside the main thread, one nobody sets."""
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


class _PlainView:
    """What stands in for rich's Live when the output is not a terminal: a line a second."""

    def __init__(self, out: TextIO, transport: SerialTransport, started_s: float) -> None:
        self.out = out
        self.transport = transport
        self.started_s = started_s
        self._next_s = started_s + LINE_PERIOD_S
        self._told_device: Info | None = None
        self._told_logs = 0

    def update(self, s: MonitorState, now_s: float) -> None:
        if s.info is not None and s.info is not self._told_device:
            self._told_device = s.info
            self.out.write(device_line(s.info) + "\n")
            self.out.flush()
        if len(s.logs) > self._told_logs:
            self.out.writelines(f"log: {text}\n" for text in s.logs[self._told_logs :])
            self._told_logs = len(s.logs)
            self.out.flush()
        if now_s >= self._next_s:
            self._next_s = max(self._next_s + LINE_PERIOD_S, now_s)
            self.line(s, now_s)

    def line(self, s: MonitorState, now_s: float) -> None:
        """One line now (also the last one, on the way out)."""
        self.out.write(plain_line(s, self.transport, now_s - self.started_s) + "\n")
        self.out.flush()


def run_monitor(
    port: str,
    baudrate: int = 921600,
    duration_s: float | None = None,
    *,
    plain: bool | None = None,
    out: TextIO | None = None,
) -> MonitorState:
    """Show the live view until SIGINT or SIGTERM (or ``duration_s``); returns the final state.

    Parameters
    ----------
    port : str
        The MCU's serial port.
    baudrate : int
        Its baud rate (a UART bridge's; the native USB port ignores it).
    duration_s : float or None
        Stop after this many seconds (None: until a signal).
    plain : bool or None
        One plain line a second instead of the live table (None: when ``out`` is not a
        terminal).
    out : TextIO or None
        Where the view goes (default: stdout).

    Returns
    -------
    MonitorState
        What it saw.
    """
    stream = out if out is not None else sys.stdout
    if plain is None:
        plain = not stream.isatty()
    transport = SerialTransport(port, baudrate)
    transport.open(reader_thread=False)
    s = MonitorState()
    started = time.monotonic()
    end = None if duration_s is None else started + duration_s
    try:
        with stop_on_signals() as stop:
            if plain:
                view = _PlainView(stream, transport, started)
                _watch(s, transport, started, end, stop, lambda: view.update(s, time.monotonic()))
                view.line(s, time.monotonic())
            else:
                with Live(
                    render(s, transport),
                    console=Console(file=stream),
                    refresh_per_second=4,
                    transient=False,
                ) as live:
                    _watch(
                        s, transport, started, end, stop, lambda: live.update(render(s, transport))
                    )
    finally:
        transport.send(Heartbeat(ack_seq=0, host_state=HostState.SHUTDOWN))
        transport.close()
    return s


def _watch(
    s: MonitorState,
    transport: SerialTransport,
    started: float,
    end: float | None,
    stop: threading.Event,
    show: Callable[[], None],
) -> None:
    """The monitor's loop: frames in, heartbeats out, ``show`` after each (and each wait)."""
    while not stop.is_set() and (end is None or time.monotonic() < end):
        _check_version(s, transport, started)
        item = transport.get(POLL_S)
        if item is None:
            show()
            continue
        if isinstance(item, LinkEvent):
            s.link = "up" if item.kind == "up" else f"down ({item.detail}), retrying"
            if item.kind == "up":
                s.sensors.frontend.link_up()
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
            show()
            continue
        s.sensors.frame(frame.seq)
        if isinstance(msg, Info):
            check_peer(msg)
            s.info = msg
            s.sensors.info(msg)
        elif isinstance(msg, Status):
            s.status = msg
        elif isinstance(msg, Log):
            s.logs.append(msg.text)
        show()
