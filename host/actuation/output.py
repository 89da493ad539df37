"""Where wheel duties go: a PCA9685 driving the TB6612, or MOTOR_PWM messages to the MCU."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.actuation.tb6612 import BridgeChannels, bridge_duties
from jackson.protocol import Message, MotorPwm


class MotorOutput(Protocol):
    """The last stage of the actuation chain."""

    def set(self, duty_left: float, duty_right: float) -> None:
        """Signed duties in [-1, 1]; 0 short-brakes that wheel."""

    def brake(self) -> None:
        """Short-brake both wheels now."""


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


class NullOutput:
    """Discards commands (offline replay)."""

    def __init__(self) -> None:
        self.last: tuple[float, float] | None = None

    def set(self, duty_left: float, duty_right: float) -> None:
        self.last = (duty_left, duty_right)

    def brake(self) -> None:
        self.last = (0.0, 0.0)
