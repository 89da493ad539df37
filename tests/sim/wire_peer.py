"""A wire-level test peer of the twin: the handshake, then wheel duties and a heartbeat per frame.

The host is :class:`jackson.host.daemon.Daemon`; the twin's tests use this smaller peer where
they need to misbehave on the wire on purpose (arbitrary messages, raw corrupt bytes, a port
closed and reopened, heartbeats that stop) while behaving like the host otherwise (HELLO and
INFO check, telemetry in, PCA9685 register writes through the I2C bus, HEARTBEAT
acknowledging each frame).
"""

from __future__ import annotations

import os
import select
import time
from collections.abc import Callable

import serial

from jackson.common.spin import spin_poll
from jackson.host.actuation.i2c import SocketI2cBus, open_bus
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.actuation.tb6612 import BridgeChannels, bridge_duties
from jackson.protocol import (
    Ack,
    FrameDecoder,
    Heartbeat,
    HostState,
    Info,
    Message,
    Telemetry,
    check_peer,
    decode_message,
    encode_frame,
    hello,
)

LEFT = BridgeChannels(pwm=0, in1=1, in2=2)
RIGHT = BridgeChannels(pwm=5, in1=3, in2=4)
DutyFn = Callable[[Telemetry], tuple[float, float]]


class HostTimeoutError(TimeoutError):
    """The robot did not answer in time."""


class WirePeer:
    """Connects to a robot (or the twin) by its serial port and I2C bus."""

    def __init__(self, serial_path: str, i2c_spec: str, address: int = 0x40) -> None:
        self.port = serial.Serial(serial_path, baudrate=921600, timeout=0.05)
        self.bus = open_bus(i2c_spec)
        # poll the port briefly before blocking, as the twin's socket bus does (and not when
        # the twin runs in this process: jackson.common.spin)
        self.spin_s = self.bus.spin_s if isinstance(self.bus, SocketI2cBus) else 0.0
        self.pca = Pca9685(self.bus, address)
        self.decoder = FrameDecoder()
        self.seq = 0
        self.inbox: list[tuple[int, Message]] = []  # (SEQ, message) not yet taken
        self.info: Info | None = None
        self.last_telemetry_seq = 0
        self.connected = False
        self.others: list[Message] = []  # ACK, NACK, STATUS, LOG after the handshake
        self.received = bytearray()  # every byte from the robot, for recordings and tests

    def send(self, msg: Message) -> None:
        # os.write on the port's descriptor, as _pump reads: pyserial's write adds a select
        frame = memoryview(encode_frame(msg, self.seq))
        fd = self.port.fileno()
        while frame:
            try:
                frame = frame[os.write(fd, frame) :]
            except BlockingIOError:
                select.select([], [fd], [], 0.05)
        self.seq = (self.seq + 1) & 0xFF

    def _pump(self, timeout_s: float = 0.05) -> None:
        # select + os.read on the port's descriptor: pyserial's read adds an ioctl and a
        # second select per call, which shows in lockstep round trips
        fd = self.port.fileno()
        ready = spin_poll(lambda: select.select([fd], [], [], 0)[0], min(self.spin_s, timeout_s))
        if not ready and not select.select([fd], [], [], timeout_s)[0]:
            return
        try:
            data = os.read(fd, 4096)
        except BlockingIOError:
            return
        if not data:
            raise serial.SerialException("the serial port was closed by the robot")
        self.received += data
        for frame in self.decoder.feed(data):
            msg = decode_message(frame)
            if isinstance(msg, Telemetry) or not self.connected:
                self.inbox.append((frame.seq, msg))
            else:
                self.others.append(msg)

    def connect(self, timeout_s: float = 5.0) -> Info:
        """HELLO, then wait for INFO and its ACK; refuses another protocol or schema."""
        self.pca.init()
        self.send(hello())
        deadline = time.monotonic() + timeout_s
        acked = False
        while self.info is None or not acked:
            if time.monotonic() > deadline:
                raise HostTimeoutError("no INFO/ACK after HELLO")
            self._pump()
            rest: list[tuple[int, Message]] = []
            for seq, m in self.inbox:
                if isinstance(m, Info):
                    check_peer(m)
                    self.info = m
                elif isinstance(m, Ack):
                    acked = True
                else:  # telemetry may already follow: keep it
                    rest.append((seq, m))
            self.inbox = rest
        self.connected = True
        return self.info

    def next_telemetry(self, timeout_s: float = 5.0) -> Telemetry:
        """The next telemetry frame (other messages stay in :attr:`inbox`)."""
        deadline = time.monotonic() + timeout_s
        while True:
            for i, (seq, m) in enumerate(self.inbox):
                if isinstance(m, Telemetry):
                    del self.inbox[i]
                    self.last_telemetry_seq = seq
                    return m
            if time.monotonic() > deadline:
                raise HostTimeoutError("no telemetry")
            self._pump()

    def set_wheels(self, left: float, right: float) -> None:
        """Signed duties in [-1, 1]; 0 short-brakes."""
        self.pca.set_duties({**bridge_duties(LEFT, left), **bridge_duties(RIGHT, right)})

    def run(self, frames: int, duties: DutyFn) -> list[Telemetry]:
        """For each telemetry frame: set the duties it asks for, then acknowledge it."""
        out = []
        for _ in range(frames):
            t = self.next_telemetry()
            self.set_wheels(*duties(t))
            self.heartbeat()
            out.append(t)
        return out

    def heartbeat(self, state: HostState = HostState.ACTIVE) -> None:
        """Acknowledge the newest telemetry frame taken."""
        self.send(Heartbeat(ack_seq=self.last_telemetry_seq, host_state=state))

    def close(self) -> None:
        try:
            self.heartbeat(HostState.SHUTDOWN)
        finally:
            self.port.close()
            self.bus.close()
