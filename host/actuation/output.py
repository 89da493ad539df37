"""Where wheel duties go: a PCA9685 driving the TB6612, or MOTOR_PWM messages to the MCU."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from jackson.host.actuation.i2c import I2cBus
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.actuation.tb6612 import BridgeChannels, bridge_duties
from jackson.protocol import Message, MotorPwm


@dataclass(frozen=True)
class I2cHealth:
    """The motor path's bus faults, for the daemon's diagnostics (all zero without a bus)."""

    i2c_errors: int
    reinits: int
    foreign_writes: int  # register read-backs that found the chip reset or rewritten
    bus_down: bool
    last_error: str


NO_BUS_FAULTS = I2cHealth(0, 0, 0, False, "")
"""The health of an output that has no bus of its own to fail (MOTOR_PWM, a bare PCA9685)."""


class MotorOutput(Protocol):
    """The last stage of the actuation chain."""

    last: tuple[float, float] | None  # the duties last set, (left, right)

    def set(self, duty_left: float, duty_right: float) -> None:
        """Signed duties in [-1, 1]; 0 short-brakes that wheel."""

    def brake(self) -> None:
        """Short-brake both wheels now."""

    def health(self) -> I2cHealth:
        """The path's bus faults now (:data:`NO_BUS_FAULTS` for a path without its own bus)."""


class Pca9685Output:
    """TB6612FNG inputs on PCA9685 channels: one block write per command (the channels of the
    common motor HATs, 0-5, are contiguous)."""

    def __init__(
        self,
        pca: Pca9685,
        left: BridgeChannels,
        right: BridgeChannels,
        stby_channel: int | None = None,
    ) -> None:
        self.pca = pca
        self.left = left
        self.right = right
        self.stby = stby_channel
        self.last: tuple[float, float] | None = None

    def set(self, duty_left: float, duty_right: float) -> None:
        duties = {**bridge_duties(self.left, duty_left), **bridge_duties(self.right, duty_right)}
        if self.stby is not None:
            duties[self.stby] = 1.0
        self.pca.set_duties(duties)
        self.last = (duty_left, duty_right)

    def brake(self) -> None:
        self.set(0.0, 0.0)

    def health(self) -> I2cHealth:
        return NO_BUS_FAULTS


class McuOutput:
    """MOTOR_PWM to firmware that drives the motors itself (duty in 1e-4, clamped there too);
    the MCU's own failsafe brakes if these stop."""

    def __init__(self, send: Callable[[Message], object]) -> None:
        self.send = send
        self.last: tuple[float, float] | None = None

    def set(self, duty_left: float, duty_right: float) -> None:
        self.send(
            MotorPwm(left=round(duty_left * 10_000), right=round(duty_right * 10_000), timeout_ms=0)
        )
        self.last = (duty_left, duty_right)

    def brake(self) -> None:
        self.set(0.0, 0.0)

    def health(self) -> I2cHealth:
        return NO_BUS_FAULTS


class NullOutput:
    """Discards commands (offline replay)."""

    def __init__(self) -> None:
        self.last: tuple[float, float] | None = None

    def set(self, duty_left: float, duty_right: float) -> None:
        self.last = (duty_left, duty_right)

    def brake(self) -> None:
        self.last = (0.0, 0.0)

    def health(self) -> I2cHealth:
        return NO_BUS_FAULTS


READBACK_PERIOD_S = 1.0  # [s] MODE1/MODE2/PRE_SCALE read back this often
FIRST_RETRY_S = 0.01  # [s] back-off after an I2C failure, doubling ...
MAX_RETRY_S = 1.0  # [s] ... up to this
BUS_DOWN_AFTER_S = 0.5  # [s] failing this long: the bus counts as down


class ResilientPca9685Output:
    """:class:`Pca9685Output` that never raises: an I2C failure is counted, the bus reopened
    (``open_bus`` again) and the chip re-initialised with back-off (10 ms doubling to 1 s, on the
    caller's calls); every second MODE1, MODE2 and PRE_SCALE are read back and a chip found
    reset or rewritten is initialised again. Failing for 0.5 s the bus counts as down: the daemon
    then lets the MCU's interlock brake (its heartbeats say SHUTDOWN) and tells the operator.
    """

    def __init__(
        self,
        open_bus: Callable[[], I2cBus],
        address: int,
        frequency_hz: float,
        left: BridgeChannels,
        right: BridgeChannels,
        stby_channel: int | None = None,
        clock: Callable[[], float] = time.monotonic,
        pca: Pca9685 | None = None,
    ) -> None:
        self._open = open_bus
        self.address = address
        self.frequency_hz = frequency_hz
        self.channels = (left, right, stby_channel)
        self.clock = clock
        self._out: Pca9685Output | None = None
        self.last: tuple[float, float] | None = None
        self.i2c_errors = self.reinits = self.foreign_writes = 0
        self.last_error = ""
        self._fail_since: float | None = None
        self._retry_at = 0.0
        self._backoff = FIRST_RETRY_S
        self._next_check = 0.0
        if pca is not None:  # already open and initialised
            self._out = Pca9685Output(pca, left, right, stby_channel)
            self._next_check = clock() + READBACK_PERIOD_S

    def set(self, duty_left: float, duty_right: float) -> None:
        self.last = (duty_left, duty_right)
        self._apply()

    def brake(self) -> None:
        self.set(0.0, 0.0)

    def health(self) -> I2cHealth:
        down = self._fail_since is not None and self.clock() - self._fail_since >= BUS_DOWN_AFTER_S
        return I2cHealth(self.i2c_errors, self.reinits, self.foreign_writes, down, self.last_error)

    def _apply(self) -> None:
        now = self.clock()
        if self._out is None and now < self._retry_at:
            return
        try:
            if self._out is None:
                self._connect()
            assert self._out is not None
            if now >= self._next_check:
                self._next_check = now + READBACK_PERIOD_S
                if not self._out.pca.registers_ok(self.frequency_hz):
                    self.foreign_writes += 1
                    self.last_error = "PCA9685 registers changed (chip reset or a foreign write)"
                    self._out.pca.init(self.frequency_hz)
                    self.reinits += 1
            if self.last is not None:
                self._out.set(*self.last)
        except (OSError, ValueError) as exc:
            self._failed(now, exc)
            return
        self._fail_since = None
        self._backoff = FIRST_RETRY_S

    def _connect(self) -> None:
        left, right, stby = self.channels
        pca = Pca9685(self._open(), self.address)
        pca.init(self.frequency_hz)
        self._out = Pca9685Output(pca, left, right, stby)
        self._next_check = self.clock() + READBACK_PERIOD_S
        if self.i2c_errors:
            self.reinits += 1

    def _failed(self, now: float, exc: BaseException) -> None:
        self.i2c_errors += 1
        self.last_error = str(exc)
        if self._fail_since is None:
            self._fail_since = now
        if self._out is not None:
            with contextlib.suppress(Exception):
                self._out.pca.bus.close()
            self._out = None
        self._retry_at = now + self._backoff
        self._backoff = min(MAX_RETRY_S, self._backoff * 2)
