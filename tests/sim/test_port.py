"""The MCU port's contract (sim/port.py): the firmware core in this process and the POSIX
firmware process, driven by the same host through the same calls, give the same answers."""

from __future__ import annotations

import os
import select
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from jackson.protocol import (
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    FrameDecoder,
    Heartbeat,
    Hello,
    HostState,
    Message,
    SetConfig,
    Telemetry,
    decode_message,
    encode_frame,
)
from jackson.sim.config import load_robot, load_world
from jackson.sim.core_port import CorePort, TelemetryLine
from jackson.sim.fil import DEFAULT_BINARY, FirmwarePort
from jackson.sim.mcu import SensorSample
from jackson.sim.port import DEFAULT_PERIOD_US, McuPort, Tick
from jackson.sim.twin import Twin

AT_REST = SensorSample(0, 0, True, (0, 0, 16384), 0, (0, 0, 0))
ANSWERED = 8  # frames the host acknowledges before it falls silent
FRAMES = 24
FAILSAFE_US = 600_000  # the firmware's default failsafe_ms

needs_firmware = pytest.mark.skipif(
    not Path(os.environ.get("JACKSON_FIRMWARE_POSIX", DEFAULT_BINARY)).exists(),
    reason="the POSIX firmware is not built (make native)",
)


class Host:
    """The host's end of the MCU's pty: frames out, telemetry in."""

    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        self.decoder = FrameDecoder()
        self.seq = 0
        self.telemetry: list[tuple[int, Telemetry]] = []  # (SEQ, frame)

    def send(self, msg: Message) -> None:
        os.write(self.fd, encode_frame(msg, self.seq))
        self.seq = (self.seq + 1) & 0xFF

    def next_telemetry(self, timeout_s: float = 5.0) -> tuple[int, Telemetry]:
        deadline = time.monotonic() + timeout_s
        while not self.telemetry:
            assert time.monotonic() < deadline, "no telemetry frame"
            if select.select([self.fd], [], [], 0.05)[0]:
                for frame in self.decoder.feed(os.read(self.fd, 4096)):
                    msg = decode_message(frame)
                    if isinstance(msg, Telemetry):
                        self.telemetry.append((frame.seq, msg))
        return self.telemetry.pop(0)

    def close(self) -> None:
        os.close(self.fd)


def serving(port: McuPort, clock: list[int]) -> Callable[[float], bool]:
    """The runner's part of a wait: the pty this process serves for the MCU, if any."""

    def serve(timeout_s: float) -> bool:
        link = port.host_link
        if link is not None and select.select([link], [], [], timeout_s)[0]:
            port.receive(clock[0])
        return False

    return serve


def await_ack(port: McuPort, seq: int | None, serve: Callable[[float], bool]) -> None:
    deadline = time.monotonic() + 5.0
    while not (port.session if seq is None else port.acknowledged(seq)):
        assert time.monotonic() < deadline, f"no HEARTBEAT for {seq}"
        port.await_heartbeat(seq, 0.02, serve)


def session(port: McuPort) -> list[tuple[object, ...]]:
    """HELLO at 0, then FRAMES telemetry instants; the host acknowledges the first ANSWERED
    (sets other IMU ranges with the third) and then falls silent. What the port said at each
    instant."""
    clock = [0]
    serve = serving(port, clock)
    host = Host(port.serial_path)
    said: list[tuple[object, ...]] = []
    try:
        host.send(Hello(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH))
        await_ack(port, None, serve)  # the clock stands still until the HELLO
        assert port.tick(0) == Tick(False)  # nothing is due at the HELLO's instant
        for k in range(FRAMES):
            nxt = port.next_deadline(clock[0])
            assert nxt is not None
            clock[0] = nxt
            tick = port.tick(nxt)
            seq = port.last_telemetry_seq
            if tick.frame:
                wire_seq, _ = host.next_telemetry()
                assert wire_seq == seq
            if k < ANSWERED:
                mark = port.heartbeat_mark()
                if k == 2:
                    host.send(SetConfig(accel_fs=1, gyro_fs=2, failsafe_ms=600))
                host.send(Heartbeat(ack_seq=seq, host_state=HostState.ACTIVE))
                await_ack(port, seq, serve)
                assert port.heartbeat_mark() != mark  # a new HEARTBEAT changes the mark
            said.append(
                (nxt, tick, seq, port.acknowledged(seq), port.motor_enable, port.imu_ranges())
            )
    finally:
        host.close()
        port.close()
    return said


@pytest.fixture
def twin() -> Iterator[Twin]:
    yield Twin(load_world("square_room"), load_robot("jackson"), lidar=False, seed=0)


def core_port(twin: Twin) -> CorePort:
    return CorePort(twin, lambda: AT_REST, TelemetryLine(None), boot_id=0x5EED)


def test_the_core_in_process_keeps_the_ports_contract(twin: Twin) -> None:
    said = session(core_port(twin))
    instants = [s[0] for s in said]
    assert instants == [DEFAULT_PERIOD_US * (k + 1) for k in range(FRAMES)]
    assert all(s[1] == Tick(True) for s in said)
    assert len({s[2] for s in said}) == FRAMES  # each frame its own SEQ
    assert [s[3] for s in said] == [k < ANSWERED for k in range(FRAMES)]
    # the interlock line: asserted with the heartbeats, dropped failsafe_ms after the last
    last_heartbeat_us = instants[ANSWERED - 1]
    assert [s[4] for s in said] == [t < last_heartbeat_us + FAILSAFE_US for t in instants]
    assert said[0][5] == (0, 0) and said[-1][5] == (1, 2)  # SET_CONFIG's ranges


@needs_firmware
def test_the_core_in_process_and_the_firmware_process_answer_alike(twin: Twin) -> None:
    in_process = session(core_port(twin))
    process = session(FirmwarePort(lambda: AT_REST, imu_present=True, boot_id=0x5EED))
    assert process == in_process
