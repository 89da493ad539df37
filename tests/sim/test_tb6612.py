"""The TB6612FNG model: every row of the datasheet's H-SW control function table."""

from __future__ import annotations

import pytest

from jackson.protocol.pca9685 import (
    LED_FULL,
    MODE1,
    MODE1_AI,
    MODE1_ALLCALL,
    MODE2,
    MODE2_OUTDRV,
    MODE2_POWER_ON,
    OUTNE_HIGH,
    led_on_l,
)
from jackson.sim.pca9685 import Pca9685
from jackson.sim.tb6612 import (
    LEFT_WIRING,
    RIGHT_WIRING,
    BridgeMode,
    BridgeOutput,
    MotorWiring,
    bridge_output,
    bridge_outputs,
    logic_level,
)

H, L = True, False

# IN1, IN2, PWM duty, STBY -> mode, drive, brake fraction
TRUTH_TABLE = [
    pytest.param(H, H, 1.0, H, BridgeMode.SHORT_BRAKE, 0.0, 1.0, id="H-H-H-H-short-brake"),
    pytest.param(H, H, 0.0, H, BridgeMode.SHORT_BRAKE, 0.0, 1.0, id="H-H-L-H-short-brake"),
    pytest.param(L, H, 1.0, H, BridgeMode.CCW, -1.0, 0.0, id="L-H-H-H-ccw"),
    pytest.param(L, H, 0.0, H, BridgeMode.SHORT_BRAKE, 0.0, 1.0, id="L-H-L-H-short-brake"),
    pytest.param(H, L, 1.0, H, BridgeMode.CW, 1.0, 0.0, id="H-L-H-H-cw"),
    pytest.param(H, L, 0.0, H, BridgeMode.SHORT_BRAKE, 0.0, 1.0, id="H-L-L-H-short-brake"),
    pytest.param(L, L, 1.0, H, BridgeMode.STOP, 0.0, 0.0, id="L-L-H-H-stop"),
    pytest.param(L, L, 0.0, H, BridgeMode.STOP, 0.0, 0.0, id="L-L-L-H-stop"),
    pytest.param(H, L, 1.0, L, BridgeMode.STANDBY, 0.0, 0.0, id="H-L-H-L-standby"),
    pytest.param(L, H, 1.0, L, BridgeMode.STANDBY, 0.0, 0.0, id="L-H-H-L-standby"),
    pytest.param(H, H, 0.0, L, BridgeMode.STANDBY, 0.0, 0.0, id="H-H-L-L-standby"),
    pytest.param(L, L, 0.0, L, BridgeMode.STANDBY, 0.0, 0.0, id="L-L-L-L-standby"),
]


@pytest.mark.parametrize(
    ("in1", "in2", "pwm", "stby", "mode", "drive", "brake"),
    TRUTH_TABLE,
)
def test_truth_table_row(
    in1: bool, in2: bool, pwm: float, stby: bool, mode: BridgeMode, drive: float, brake: float
) -> None:
    assert bridge_output(in1, in2, pwm, stby) == BridgeOutput(mode, drive, brake)


def test_cw_at_partial_duty_drives_then_short_brakes() -> None:
    out = bridge_output(in1=H, in2=L, pwm_duty=0.6, stby=H)
    assert out == BridgeOutput(BridgeMode.CW, 0.6, pytest.approx(0.4))


def test_ccw_at_partial_duty_drives_negative_then_short_brakes() -> None:
    out = bridge_output(in1=L, in2=H, pwm_duty=0.3, stby=H)
    assert out == BridgeOutput(BridgeMode.CCW, -0.3, pytest.approx(0.7))


@pytest.mark.parametrize("duty", [-0.01, 1.01])
def test_duty_outside_0_1_is_refused(duty: float) -> None:
    with pytest.raises(ValueError, match="duty"):
        bridge_output(H, L, duty, H)


def test_logic_input_is_high_from_half_duty() -> None:
    assert (logic_level(0.0), logic_level(0.49), logic_level(0.5), logic_level(1.0)) == (
        L,
        L,
        H,
        H,
    )


def test_default_wiring_is_the_motor_hat_wiring() -> None:
    assert LEFT_WIRING == MotorWiring(pwm=0, in1=1, in2=2)
    assert RIGHT_WIRING == MotorWiring(pwm=5, in1=3, in2=4)


@pytest.mark.parametrize(("pwm", "in1", "in2"), [(16, 1, 2), (0, -1, 2), (0, 1, 1)])
def test_wiring_needs_three_distinct_valid_channels(pwm: int, in1: int, in2: int) -> None:
    with pytest.raises(ValueError, match="channel"):
        MotorWiring(pwm=pwm, in1=in1, in2=in2)


def set_channel(pca: Pca9685, channel: int, duty: float) -> None:
    """Program a channel as a driver does: full-on, full-off, or OFF = duty * 4096."""
    if duty >= 1.0:
        regs = bytes((0, LED_FULL, 0, 0))
    elif duty <= 0.0:
        regs = bytes((0, 0, 0, LED_FULL))
    else:
        off = round(duty * 4096)
        regs = bytes((0, 0, off & 0xFF, off >> 8))
    pca.write(led_on_l(channel), regs)


def awake_pca() -> Pca9685:
    pca = Pca9685()
    pca.write(MODE1, bytes((MODE1_AI | MODE1_ALLCALL,)))
    return pca


def test_bridge_outputs_read_the_pca9685_channels() -> None:
    pca = awake_pca()
    set_channel(pca, LEFT_WIRING.pwm, 0.5)
    set_channel(pca, LEFT_WIRING.in1, 1.0)
    set_channel(pca, RIGHT_WIRING.pwm, 0.25)
    set_channel(pca, RIGHT_WIRING.in2, 1.0)
    left, right = bridge_outputs(pca, LEFT_WIRING, RIGHT_WIRING, stby_channel=None)
    assert left == BridgeOutput(BridgeMode.CW, 0.5, 0.5)
    assert right == BridgeOutput(BridgeMode.CCW, -0.25, 0.75)


def test_stby_channel_low_puts_both_bridges_in_standby() -> None:
    pca = awake_pca()
    set_channel(pca, LEFT_WIRING.pwm, 1.0)
    set_channel(pca, LEFT_WIRING.in1, 1.0)
    set_channel(pca, 15, 0.0)
    left, right = bridge_outputs(pca, LEFT_WIRING, RIGHT_WIRING, stby_channel=15)
    assert left.mode is right.mode is BridgeMode.STANDBY
    set_channel(pca, 15, 1.0)
    left, _ = bridge_outputs(pca, LEFT_WIRING, RIGHT_WIRING, stby_channel=15)
    assert left == BridgeOutput(BridgeMode.CW, 1.0, 0.0)


def test_power_on_pca9685_leaves_both_motors_coasting() -> None:
    left, right = bridge_outputs(Pca9685())  # asleep, every channel full-off
    assert left.mode is right.mode is BridgeMode.STOP


# ---- the MCU's interlock line (docs/firmware.md, "Motor interlock") ---------------------------


def driving_forward(mode2: int) -> Pca9685:
    """Both bridges commanded forward at 62.5 % by a host that wrote MODE2 = ``mode2``."""
    pca = awake_pca()
    pca.write(MODE2, bytes((mode2,)))
    for w in (LEFT_WIRING, RIGHT_WIRING):
        set_channel(pca, w.pwm, 0.625)  # 2560 / 4096: exact
        set_channel(pca, w.in1, 1.0)
        set_channel(pca, w.in2, 0.0)
    return pca


def test_oe_released_with_the_hosts_mode2_short_brakes_both_bridges() -> None:
    pca = driving_forward(MODE2_OUTDRV | OUTNE_HIGH)  # what the host's driver writes
    assert bridge_outputs(pca)[0] == BridgeOutput(BridgeMode.CW, 0.625, 0.375)
    pca.output_enable = False  # the MCU released OE: the pull-up disables the outputs
    left, right = bridge_outputs(pca)
    assert left == right == BridgeOutput(BridgeMode.SHORT_BRAKE, 0.0, 1.0)
    pca.output_enable = True
    assert bridge_outputs(pca)[1] == BridgeOutput(BridgeMode.CW, 0.625, 0.375)


def test_oe_released_after_a_pca9685_reset_leaves_both_motors_coasting() -> None:
    pca = driving_forward(MODE2_POWER_ON)  # OUTNE = 00: a chip that lost the host's MODE2
    pca.output_enable = False
    left, right = bridge_outputs(pca)
    assert left == right == BridgeOutput(BridgeMode.STOP, 0.0, 0.0)


def test_oe_released_with_high_impedance_outputs_reads_low_and_coasts() -> None:
    pca = driving_forward(MODE2_OUTDRV | 0x02)  # OUTNE = 1x: outputs float
    pca.output_enable = False
    assert all(b.mode is BridgeMode.STOP and b.drive == 0.0 for b in bridge_outputs(pca))


def test_stby_wired_to_the_mcu_puts_both_bridges_in_standby_when_released() -> None:
    pca = driving_forward(MODE2_OUTDRV | OUTNE_HIGH)
    left, right = bridge_outputs(pca, stby=False)  # the pull-down holds STBY low
    assert left.mode is right.mode is BridgeMode.STANDBY
    assert left.drive == right.drive == 0.0
    assert bridge_outputs(pca, stby=True)[0].mode is BridgeMode.CW


def test_stby_cannot_have_two_drivers() -> None:
    with pytest.raises(ValueError, match="STBY"):
        bridge_outputs(awake_pca(), stby_channel=15, stby=True)
