"""TB6612FNG inputs for a signed wheel duty (Toshiba datasheet, H-SW control function).

Forward is IN1 = H, IN2 = L with PWM = |duty|; reverse is IN1 = L, IN2 = H; a zero command
short-brakes (IN1 = IN2 = H); ``coast`` opens the bridge (IN1 = IN2 = L). The PCA9685 drives
IN1 and IN2 as logic levels (full on / full off) and PWM as a duty.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BridgeChannels:
    """PCA9685 channels wired to one bridge's PWM, IN1 and IN2 inputs."""

    pwm: int
    in1: int
    in2: int


def bridge_duties(
    channels: BridgeChannels, duty: float, *, coast: bool = False
) -> dict[int, float]:
    """PCA9685 channel duties for a signed wheel duty in [-1, 1]."""
    d = max(-1.0, min(1.0, duty))
    if coast:
        return {channels.pwm: 0.0, channels.in1: 0.0, channels.in2: 0.0}
    if d == 0.0:
        return {channels.pwm: 0.0, channels.in1: 1.0, channels.in2: 1.0}
    if d > 0.0:
        return {channels.pwm: d, channels.in1: 1.0, channels.in2: 0.0}
    return {channels.pwm: -d, channels.in1: 0.0, channels.in2: 1.0}
