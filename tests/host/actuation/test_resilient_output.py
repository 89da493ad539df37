"""ResilientPca9685Output against the twin's real I2C socket server: restarts, a foreign write
and a bus that stays down, on an injected clock (so no test waits on wall time)."""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from jackson.host.actuation.i2c import I2cBus, open_bus
from jackson.host.actuation.output import (
    BUS_DOWN_AFTER_S,
    MAX_RETRY_S,
    READBACK_PERIOD_S,
    ResilientPca9685Output,
)
from jackson.host.config import Pca9685Settings
from jackson.protocol import pca9685 as regs
from jackson.sim import pca9685 as model
from jackson.sim.i2c_server import I2cSocketServer
from jackson.sim.tb6612 import LEFT_WIRING, RIGHT_WIRING, BridgeMode, bridge_outputs


class Bus:
    """The twin's I2C server serving in a thread; ``restart()`` kills it and starts a new one
    (a fresh chip, in its power-on state) at the same path."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.server: I2cSocketServer | None = None
        self.thread: threading.Thread | None = None
        self.stop = threading.Event()
        self.start()

    def start(self) -> None:
        self.server = I2cSocketServer(self.path)
        self.stop = threading.Event()
        server, stop = self.server, self.stop

        def serve() -> None:
            while not stop.is_set():
                server.service(0.02)

        self.thread = threading.Thread(target=serve, daemon=True)
        self.thread.start()

    def kill(self) -> None:
        assert self.server is not None and self.thread is not None
        self.stop.set()
        self.thread.join(timeout=5)
        self.server.close()
        self.server = None

    def restart(self) -> None:
        self.kill()
        self.start()

    def chip(self) -> model.Pca9685:
        assert self.server is not None
        chip = self.server.devices[0x40]
        assert isinstance(chip, model.Pca9685)
        return chip

    def modes(self) -> tuple[BridgeMode, BridgeMode]:
        left, right = bridge_outputs(self.chip(), LEFT_WIRING, RIGHT_WIRING)
        return left.mode, right.mode


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[Bus]:
    b = Bus(tmp_path / "i2c.sock")
    yield b
    if b.server is not None:
        b.kill()


def output(bus: Bus, clock: Clock) -> ResilientPca9685Output:
    p = Pca9685Settings(bus=f"unix:{bus.path}")
    return ResilientPca9685Output(
        lambda: open_bus(p.bus), p.address, p.frequency_hz, p.left, p.right, clock=clock
    )


def drive_until_driving(out: ResilientPca9685Output, bus: Bus, clock: Clock) -> int:
    """Call set() every 10 ms of clock until the bridges drive; the calls it took."""
    for k in range(1, 1000):
        out.set(0.5, -0.5)
        if bus.modes() == (BridgeMode.CW, BridgeMode.CCW):
            return k
        clock.t += 0.01
    raise AssertionError(f"never drove again: {out.health()}")


def test_ten_server_restarts_are_survived_and_counted(bus: Bus) -> None:
    clock = Clock()
    out = output(bus, clock)
    drive_until_driving(out, bus, clock)
    assert out.health().i2c_errors == 0
    calls = []
    for n in range(1, 11):
        bus.restart()  # the new chip is asleep with every output off
        calls.append(drive_until_driving(out, bus, clock))
        h = out.health()
        assert h.i2c_errors == n  # one failed call each: the old connection is gone
        assert h.reinits == n
        assert not h.bus_down
    assert max(calls) <= 3  # first retry after 10 ms of clock


def put_to_sleep(foreign: I2cBus) -> None:
    foreign.write_byte_data(0x40, regs.MODE1, regs.MODE1_SLEEP)


def set_50_hz(foreign: I2cBus) -> None:
    """Sleep (the chip takes PRE_SCALE only then), 50 Hz, wake and restart: still driving."""
    foreign.write_byte_data(0x40, regs.MODE1, regs.MODE1_SLEEP | regs.MODE1_AI)
    foreign.write_byte_data(0x40, regs.PRE_SCALE, regs.prescale_for(50.0))
    foreign.write_byte_data(0x40, regs.MODE1, regs.MODE1_RESTART | regs.MODE1_AI)


@pytest.mark.parametrize("foreign_write", [put_to_sleep, set_50_hz], ids=["MODE1", "PRE_SCALE"])
def test_a_foreign_write_is_detected_and_repaired_at_the_next_readback(
    bus: Bus, foreign_write: Callable[[I2cBus], None]
) -> None:
    clock = Clock()
    out = output(bus, clock)
    drive_until_driving(out, bus, clock)
    frequency_hz = bus.chip().frequency_hz
    foreign = open_bus(f"unix:{bus.path}")  # another program on the same bus
    foreign_write(foreign)
    foreign.close()
    if foreign_write is set_50_hz:  # awake and driving, only slower: MODE1 alone cannot tell
        assert not bus.chip().asleep and bus.chip().frequency_hz < frequency_hz / 10
    else:
        assert bus.chip().asleep
    written = clock.t
    clock.t += READBACK_PERIOD_S / 2
    out.set(0.5, -0.5)
    assert out.health().foreign_writes == 0  # not yet read back
    while out.health().foreign_writes == 0:
        assert clock.t - written <= READBACK_PERIOD_S, "not detected within one readback period"
        clock.t += 0.01
        out.set(0.5, -0.5)
    h = out.health()
    assert h.foreign_writes == 1 and h.reinits == 1 and h.i2c_errors == 0
    assert "changed" in h.last_error
    assert not bus.chip().asleep and bus.chip().frequency_hz == frequency_hz
    assert bus.modes() == (BridgeMode.CW, BridgeMode.CCW)


def test_a_bus_that_stays_down_is_reported_down_and_backs_off(bus: Bus) -> None:
    clock = Clock()
    out = output(bus, clock)
    drive_until_driving(out, bus, clock)
    bus.kill()
    attempts = []
    start = clock.t
    while clock.t - start < 5.0:  # 5 s of calls every 10 ms: 500 calls
        before = out.health().i2c_errors
        out.set(0.5, -0.5)
        if out.health().i2c_errors > before:
            attempts.append(clock.t - start)
        clock.t += 0.01
        if clock.t - start < BUS_DOWN_AFTER_S - 0.02:
            assert not out.health().bus_down
    assert out.health().bus_down
    assert "i2c.sock" in out.health().last_error
    gaps = [b - a for a, b in itertools.pairwise(attempts)]
    assert len(attempts) < 20  # backed off: not 500 attempts
    assert max(gaps) <= MAX_RETRY_S + 0.02
    bus.start()
    clock.t += MAX_RETRY_S
    drive_until_driving(out, bus, clock)
    assert not out.health().bus_down
