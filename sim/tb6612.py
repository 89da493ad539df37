"""Toshiba TB6612FNG dual H-bridge: what each motor sees for given input levels.

The truth table is the datasheet's "H-SW control function" table:

====  ====  =====  ====  ===========  ===========  ===========
IN1   IN2   PWM    STBY  OUT1         OUT2         mode
====  ====  =====  ====  ===========  ===========  ===========
H     H     H/L    H     L            L            SHORT_BRAKE
L     H     H      H     L            H            CCW
L     H     L      H     L            L            SHORT_BRAKE
H     L     H      H     H            L            CW
H     L     L      H     L            L            SHORT_BRAKE
L     L     H      H     OFF (Hi-Z)   OFF (Hi-Z)   STOP
H/L   H/L   H/L    L     OFF (Hi-Z)   OFF (Hi-Z)   STANDBY
====  ====  =====  ====  ===========  ===========  ===========

On the robot IN1, IN2 and STBY come from PCA9685 channels driven fully on or off, and PWM from a
PCA9685 channel at some duty. The MCU's motor interlock (docs/firmware.md, "Motor interlock")
reaches the bridges either through the PCA9685's OE pin, which :meth:`Pca9685.channel_duty`
honours (OE high with the host's MODE2 OUTNE = 01: every input high, SHORT_BRAKE; with the
power-on OUTNE = 00: every input low, STOP), or through STBY wired to the MCU (``stby`` of
:func:`bridge_outputs`; low: STANDBY). Averaged over a PWM period, a bridge in CW or CCW applies the
supply during the high part and shorts the winding (short brake) during the low part; that is
what :class:`BridgeOutput` reports. Dead time and switching losses are ignored.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from jackson.protocol.pca9685 import CHANNELS
from jackson.sim.pca9685 import Pca9685

LOGIC_HIGH_DUTY = 0.5  # a PCA9685 channel used as a logic input is high at duty >= 0.5


class BridgeMode(enum.Enum):
    """Operating mode of one H-bridge (datasheet H-SW control function)."""

    CW = "cw"  # OUT1 high, OUT2 low: forward
    CCW = "ccw"  # OUT1 low, OUT2 high: reverse
    SHORT_BRAKE = "short_brake"  # both outputs low: the winding is shorted
    STOP = "stop"  # both outputs off (high impedance): the motor coasts
    STANDBY = "standby"  # STBY low: both outputs off (high impedance)


@dataclass(frozen=True)
class BridgeOutput:
    """What one motor sees from its H-bridge, averaged over a PWM period.

    Attributes
    ----------
    mode : BridgeMode
        The mode while PWM is high (SHORT_BRAKE when PWM never is, in CW or CCW).
    drive : float
        Signed average fraction of the supply voltage across the motor, OUT1 - OUT2:
        +duty in CW, -duty in CCW, 0 otherwise.
    brake_fraction : float
        Fraction of the period the winding is shorted: 1 in SHORT_BRAKE,
        1 - duty in CW and CCW, 0 in STOP and STANDBY (outputs open, the motor coasts).
    """

    mode: BridgeMode
    drive: float
    brake_fraction: float


@dataclass(frozen=True)
class MotorWiring:
    """PCA9685 channels wired to one bridge's PWM, IN1 and IN2 inputs.

    :data:`LEFT_WIRING` and :data:`RIGHT_WIRING` are the wiring of the common
    PCA9685 + TB6612FNG motor HATs (e.g. Waveshare's Motor Driver HAT): PWMA 0, AIN1 1, AIN2 2,
    BIN1 3, BIN2 4, PWMB 5.
    """

    pwm: int
    in1: int
    in2: int

    def __post_init__(self) -> None:
        for name, channel in (("pwm", self.pwm), ("in1", self.in1), ("in2", self.in2)):
            if not 0 <= channel < CHANNELS:
                raise ValueError(f"{name} channel {channel} outside 0..{CHANNELS - 1}")
        if len({self.pwm, self.in1, self.in2}) != 3:
            raise ValueError(f"pwm, in1 and in2 need three different channels, got {self}")


LEFT_WIRING = MotorWiring(pwm=0, in1=1, in2=2)  # bridge A
RIGHT_WIRING = MotorWiring(pwm=5, in1=3, in2=4)  # bridge B


def logic_level(duty: float) -> bool:
    """Level a logic input reads from a PCA9685 channel of this duty: high at >= 0.5."""
    return duty >= LOGIC_HIGH_DUTY


def bridge_output(in1: bool, in2: bool, pwm_duty: float, stby: bool) -> BridgeOutput:
    """One row of the H-SW control function table, averaged over a PWM period.

    Parameters
    ----------
    in1 : bool
        IN1 logic level (True = H).
    in2 : bool
        IN2 logic level (True = H).
    pwm_duty : float
        Fraction of the period the PWM input is high, in [0, 1].
    stby : bool
        STBY logic level; low puts the bridge in standby whatever the other inputs.

    Returns
    -------
    BridgeOutput
        The bridge's mode, signed drive and brake fraction.

    Raises
    ------
    ValueError
        ``pwm_duty`` is outside [0, 1].
    """
    if not 0.0 <= pwm_duty <= 1.0:
        raise ValueError(f"PWM duty {pwm_duty} outside [0, 1]")
    if not stby:
        return BridgeOutput(BridgeMode.STANDBY, 0.0, 0.0)
    if in1 and in2:
        return BridgeOutput(BridgeMode.SHORT_BRAKE, 0.0, 1.0)
    if not in1 and not in2:
        return BridgeOutput(BridgeMode.STOP, 0.0, 0.0)
    if pwm_duty == 0.0:
        return BridgeOutput(BridgeMode.SHORT_BRAKE, 0.0, 1.0)
    if in1:
        return BridgeOutput(BridgeMode.CW, pwm_duty, 1.0 - pwm_duty)
    return BridgeOutput(BridgeMode.CCW, -pwm_duty, 1.0 - pwm_duty)


def bridge_outputs(
    pca: Pca9685,
    left: MotorWiring = LEFT_WIRING,
    right: MotorWiring = RIGHT_WIRING,
    stby_channel: int | None = None,
    stby: bool | None = None,
) -> tuple[BridgeOutput, BridgeOutput]:
    """Outputs of both bridges of one TB6612FNG driven by a PCA9685.

    The PCA9685's OE pin (:attr:`Pca9685.output_enable`) acts through its channel outputs.

    Parameters
    ----------
    pca : Pca9685
        The PWM chip whose channels drive the bridge inputs.
    left : MotorWiring
        Channels of the left motor's bridge.
    right : MotorWiring
        Channels of the right motor's bridge.
    stby_channel : int or None
        Channel driving STBY (shared by both bridges), or None when STBY is tied
        high or driven by the MCU.
    stby : bool or None
        STBY level driven by the MCU's interlock line (the pull-down wiring: False while
        the line is released), or None when STBY is not wired to the MCU.

    Returns
    -------
    tuple of BridgeOutput
        ``(left, right)`` bridge outputs.

    Raises
    ------
    ValueError
        Both ``stby_channel`` and ``stby`` are given (one pin, two drivers).
    """
    if stby_channel is not None and stby is not None:
        raise ValueError("STBY is driven either by a PCA9685 channel or by the MCU, not both")
    if stby is None:
        stby = True if stby_channel is None else logic_level(pca.channel_duty(stby_channel))
    return (_one_bridge(pca, left, stby), _one_bridge(pca, right, stby))


def _one_bridge(pca: Pca9685, wiring: MotorWiring, stby: bool) -> BridgeOutput:
    return bridge_output(
        in1=logic_level(pca.channel_duty(wiring.in1)),
        in2=logic_level(pca.channel_duty(wiring.in2)),
        pwm_duty=pca.channel_duty(wiring.pwm),
        stby=stby,
    )
