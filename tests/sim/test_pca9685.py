"""The PCA9685 model against the NXP datasheet (Rev. 4): registers, outputs, sleep and restart."""

from __future__ import annotations

import pytest

from jackson.protocol.pca9685 import (
    ALL_LED_OFF_H,
    ALL_LED_ON_L,
    LED0_OFF_H,
    LED0_ON_H,
    LED0_ON_L,
    LED15_OFF_H,
    LED_FULL,
    MODE1,
    MODE1_AI,
    MODE1_ALLCALL,
    MODE1_EXTCLK,
    MODE1_RESTART,
    MODE1_SLEEP,
    MODE2,
    MODE2_INVRT,
    MODE2_OUTDRV,
    MODE2_POWER_ON,
    OUTNE_HIGH,
    PRE_SCALE,
    SUBADR1,
    TESTMODE,
    led_on_l,
    prescale_for,
)
from jackson.sim.pca9685 import Pca9685


def counts(on: int, off: int, full_on: bool = False, full_off: bool = False) -> bytes:
    """The four LEDn registers (ON_L, ON_H, OFF_L, OFF_H) for 12-bit ON and OFF counts."""
    on_h = (on >> 8) | (LED_FULL if full_on else 0)
    off_h = (off >> 8) | (LED_FULL if full_off else 0)
    return bytes((on & 0xFF, on_h, off & 0xFF, off_h))


def running_pca(freq_hz: float = 1000.0) -> Pca9685:
    """A chip after the init sequence a driver runs: sleep, PRE_SCALE, wake, RESTART | AI."""
    pca = Pca9685()
    pca.write(MODE1, bytes((MODE1_SLEEP | MODE1_ALLCALL,)))
    pca.write(PRE_SCALE, bytes((prescale_for(freq_hz),)))
    pca.write(MODE1, bytes((MODE1_ALLCALL,)))
    pca.write(MODE1, bytes((MODE1_RESTART | MODE1_AI | MODE1_ALLCALL,)))
    return pca


def test_power_on_values() -> None:
    pca = Pca9685()
    assert pca.read(MODE1, 1) == b"\x11"  # SLEEP | ALLCALL
    assert pca.read(MODE2, 1) == b"\x04"  # OUTDRV
    assert pca.read(SUBADR1, 4) == b"\xe2" * 4  # AI is off at power-on: the same register
    assert pca.read(PRE_SCALE, 1) == b"\x1e"
    for channel in range(16):
        assert pca.read(led_on_l(channel) + 3, 1) == b"\x10"  # OFF_H: full-off
    assert pca.asleep


def test_power_on_outputs_are_off_and_asleep() -> None:
    pca = Pca9685()
    assert [pca.channel_duty(ch) for ch in range(16)] == [0.0] * 16


def test_driver_init_sequence_sets_1_khz_and_runs() -> None:
    pca = running_pca(1000.0)
    assert not pca.asleep
    assert not pca.restart_pending
    assert pca.read(MODE1, 1)[0] == MODE1_AI | MODE1_ALLCALL
    assert pca.read(PRE_SCALE, 1) == bytes((5,))
    assert pca.frequency_hz == pytest.approx(25e6 / (4096 * 6))  # 1017.25 Hz


def test_frequency_is_clock_over_4096_times_prescale_plus_one() -> None:
    pca = Pca9685()
    assert pca.frequency_hz == pytest.approx(25e6 / (4096 * 31))  # power-on: ~197 Hz
    pca.write(PRE_SCALE, b"\xff")
    assert pca.frequency_hz == pytest.approx(25e6 / (4096 * 256))  # slowest: ~23.8 Hz


def test_prescale_is_ignored_while_awake() -> None:
    pca = running_pca(1000.0)
    pca.write(PRE_SCALE, bytes((prescale_for(200.0),)))
    assert pca.read(PRE_SCALE, 1) == bytes((5,))


def test_prescale_below_3_reads_as_3() -> None:
    pca = Pca9685()  # asleep at power-on: PRE_SCALE writable
    pca.write(PRE_SCALE, b"\x00")
    assert pca.read(PRE_SCALE, 1) == b"\x03"
    assert pca.frequency_hz == pytest.approx(25e6 / (4096 * 4))


def test_duty_is_off_minus_on_over_4096() -> None:
    pca = running_pca()
    pca.write(led_on_l(0), counts(on=0, off=2048))
    pca.write(led_on_l(1), counts(on=4000, off=400))  # wraps around the period
    pca.write(led_on_l(2), counts(on=100, off=100))
    assert pca.channel_duty(0) == 0.5
    assert pca.channel_duty(1) == (400 - 4000) % 4096 / 4096
    assert pca.channel_duty(2) == 0.0


def test_full_on_bit_gives_duty_1() -> None:
    pca = running_pca()
    pca.write(led_on_l(3), counts(on=0, off=1000, full_on=True))
    assert pca.channel_duty(3) == 1.0


def test_full_off_bit_gives_duty_0() -> None:
    pca = running_pca()
    pca.write(led_on_l(3), counts(on=0, off=1000, full_off=True))
    assert pca.channel_duty(3) == 0.0


def test_full_off_takes_precedence_over_full_on() -> None:
    pca = running_pca()
    pca.write(led_on_l(4), counts(on=0, off=0, full_on=True, full_off=True))
    assert pca.channel_duty(4) == 0.0


def test_reserved_bits_of_the_high_registers_read_0() -> None:
    pca = running_pca()
    pca.write(LED0_ON_H, b"\xff")
    assert pca.read(LED0_ON_H, 1) == b"\x1f"


def test_auto_increment_writes_a_whole_channel_in_one_block() -> None:
    pca = running_pca()
    pca.write(led_on_l(7), bytes((0x10, 0x01, 0x99, 0x0A)))  # ON = 0x110, OFF = 0xA99
    assert pca.read(led_on_l(7), 4) == bytes((0x10, 0x01, 0x99, 0x0A))
    assert pca.channel_duty(7) == (0xA99 - 0x110) / 4096


def test_auto_increment_crosses_channel_boundaries() -> None:
    pca = running_pca()
    pca.write(LED0_ON_L, counts(0, 1024) + counts(0, 3072))
    assert pca.channel_duty(0) == 0.25
    assert pca.channel_duty(1) == 0.75


def test_led_block_writes_equal_byte_by_byte_writes() -> None:
    # Auto-increment blocks inside LED0..LED15 take a sliced fast path; every start, length
    # and value must store what one-byte writes with AI off (the general path) store: H
    # registers keep bits 4:0 only, and a pending restart ends.
    import random

    rng = random.Random(7)
    n = LED15_OFF_H - LED0_ON_L + 1
    for k in range(300):
        start = rng.randrange(LED0_ON_L, LED15_OFF_H + 1)
        data = bytes(rng.randrange(256) for _ in range(rng.randrange(1, LED15_OFF_H - start + 2)))
        block, single = running_pca(), running_pca()
        for pca in (block, single):
            pca.write(LED0_ON_L, counts(0, 2048))
            if k % 2:  # sleep with a channel running, wake: outputs held, restart pending
                pca.write(MODE1, bytes((MODE1_AI | MODE1_ALLCALL | MODE1_SLEEP,)))
                pca.write(MODE1, bytes((MODE1_AI | MODE1_ALLCALL,)))
                assert pca.restart_pending
        single.write(MODE1, bytes((MODE1_ALLCALL,)))  # AI off
        block.write(start, data)
        for i, value in enumerate(data):
            single.write(start + i, bytes((value,)))
        assert block.read(LED0_ON_L, n) == b"".join(
            single.read(LED0_ON_L + i, 1)
            for i in range(n)  # AI off: one register at a time
        )
        assert not block.restart_pending and not single.restart_pending
        assert [block.channel_duty(c) for c in range(16)] == [
            single.channel_duty(c) for c in range(16)
        ]


def test_generation_counts_every_write_and_reset() -> None:
    pca = Pca9685()
    g = pca.generation
    pca.write(LED0_ON_L, counts(0, 1024))
    pca.write(MODE1, bytes((MODE1_ALLCALL,)))
    pca.reset()
    assert pca.generation == g + 3
    pca.read(LED0_ON_L, 4)
    assert pca.generation == g + 3


def test_auto_increment_pointer_wraps_from_0xff_to_0x00() -> None:
    pca = running_pca()
    assert pca.read(TESTMODE, 2) == bytes((0x00, MODE1_AI | MODE1_ALLCALL))


def test_without_auto_increment_every_byte_goes_to_the_same_register() -> None:
    pca = running_pca()
    pca.write(MODE1, bytes((MODE1_ALLCALL,)))  # AI off
    pca.write(LED0_ON_L, bytes((0x11, 0x22, 0x33, 0x44)))
    assert pca.read(LED0_ON_L, 1) == b"\x44"  # the last byte wins
    assert pca.read(LED0_OFF_H, 1) == b"\x10"  # the rest of the channel untouched
    assert pca.read(LED0_ON_L, 3) == b"\x44\x44\x44"  # reads repeat the register too


def test_all_led_write_goes_to_every_channel() -> None:
    pca = running_pca()
    pca.write(ALL_LED_ON_L, counts(on=0, off=1024))
    assert [pca.channel_duty(ch) for ch in range(16)] == [0.25] * 16
    assert pca.read(led_on_l(9), 4) == counts(on=0, off=1024)


def test_all_led_full_off_stops_every_channel() -> None:
    pca = running_pca()
    pca.write(led_on_l(5), counts(on=0, off=0, full_on=True))
    pca.write(ALL_LED_OFF_H, bytes((LED_FULL,)))
    assert [pca.channel_duty(ch) for ch in range(16)] == [0.0] * 16


def test_all_led_registers_read_0() -> None:
    pca = running_pca()
    pca.write(ALL_LED_ON_L, counts(on=0x123, off=0x456))
    assert pca.read(ALL_LED_ON_L, 4) == bytes(4)


def test_outputs_are_off_while_asleep() -> None:
    pca = running_pca()
    pca.write(led_on_l(0), counts(on=0, off=2048))
    pca.write(MODE1, bytes((MODE1_SLEEP | MODE1_AI | MODE1_ALLCALL,)))
    assert pca.asleep
    assert pca.channel_duty(0) == 0.0


def test_sleep_with_active_channels_sets_restart_and_holds_outputs_after_wake() -> None:
    pca = running_pca()
    pca.write(led_on_l(0), counts(on=0, off=2048))
    pca.write(MODE1, bytes((MODE1_SLEEP | MODE1_AI | MODE1_ALLCALL,)))
    assert pca.read(MODE1, 1)[0] & MODE1_RESTART
    pca.write(MODE1, bytes((MODE1_AI | MODE1_ALLCALL,)))  # clear SLEEP, RESTART still 1
    assert not pca.asleep
    assert pca.restart_pending
    assert pca.channel_duty(0) == 0.0
    pca.write(MODE1, bytes((MODE1_RESTART | MODE1_AI | MODE1_ALLCALL,)))  # write 1 to restart
    assert not pca.read(MODE1, 1)[0] & MODE1_RESTART
    assert pca.channel_duty(0) == 0.5


def test_sleep_with_every_channel_off_does_not_set_restart() -> None:
    pca = running_pca()
    pca.write(MODE1, bytes((MODE1_SLEEP | MODE1_AI | MODE1_ALLCALL,)))
    assert not pca.read(MODE1, 1)[0] & MODE1_RESTART
    pca.write(MODE1, bytes((MODE1_AI | MODE1_ALLCALL,)))
    pca.write(led_on_l(0), counts(on=0, off=1024))
    assert pca.channel_duty(0) == 0.25  # clearing SLEEP resumes


def test_restart_written_while_asleep_does_not_restart() -> None:
    pca = running_pca()
    pca.write(led_on_l(0), counts(on=0, off=2048))
    pca.write(MODE1, bytes((MODE1_SLEEP | MODE1_ALLCALL,)))
    pca.write(MODE1, bytes((MODE1_RESTART | MODE1_ALLCALL,)))  # wakes, but oscillator was off
    assert pca.restart_pending
    assert pca.channel_duty(0) == 0.0


def test_writing_a_pwm_register_clears_a_pending_restart() -> None:
    pca = running_pca()
    pca.write(led_on_l(0), counts(on=0, off=2048))
    pca.write(MODE1, bytes((MODE1_SLEEP | MODE1_AI | MODE1_ALLCALL,)))
    pca.write(MODE1, bytes((MODE1_AI | MODE1_ALLCALL,)))
    pca.write(led_on_l(1), counts(on=0, off=1024))
    assert not pca.restart_pending
    assert (pca.channel_duty(0), pca.channel_duty(1)) == (0.5, 0.25)


def test_restart_written_with_nothing_pending_changes_nothing() -> None:
    pca = running_pca()
    pca.write(led_on_l(0), counts(on=0, off=2048))
    pca.write(MODE1, bytes((MODE1_RESTART | MODE1_AI | MODE1_ALLCALL,)))
    assert pca.read(MODE1, 1)[0] == MODE1_AI | MODE1_ALLCALL
    assert pca.channel_duty(0) == 0.5


def test_extclk_is_sticky_and_set_only_while_asleep() -> None:
    pca = Pca9685(extclk_hz=20e6)
    pca.write(MODE1, bytes((MODE1_SLEEP | MODE1_EXTCLK,)))  # SLEEP was already 1
    pca.write(MODE1, bytes((MODE1_SLEEP,)))  # writing 0 does not clear it
    assert pca.read(MODE1, 1)[0] & MODE1_EXTCLK
    assert pca.frequency_hz == pytest.approx(20e6 / (4096 * 31))
    awake = running_pca()
    awake.write(MODE1, bytes((MODE1_EXTCLK | MODE1_SLEEP,)))  # SLEEP was 0: not taken
    assert not awake.read(MODE1, 1)[0] & MODE1_EXTCLK


def test_reserved_registers_ignore_writes_and_read_0() -> None:
    pca = running_pca()
    pca.write(0x46, b"\xff")
    pca.write(TESTMODE, b"\xff")
    assert pca.read(0x46, 1) == b"\x00"
    assert pca.read(TESTMODE, 1) == b"\x00"


def test_reset_returns_to_power_on() -> None:
    pca = running_pca()
    pca.write(ALL_LED_ON_L, counts(on=0, off=1024))
    pca.reset()
    assert pca.read(MODE1, 1) == b"\x11"
    assert pca.read(PRE_SCALE, 1) == b"\x1e"
    assert pca.channel_duty(0) == 0.0


@pytest.mark.parametrize("channel", [-1, 16])
def test_channel_out_of_range_is_refused(channel: int) -> None:
    with pytest.raises(ValueError, match="channel"):
        Pca9685().channel_duty(channel)


# ---- OE pin and MODE2 output states (§7.3.2 Table 6, §7.4) -----------------------------------


def driving_pca() -> Pca9685:
    """Channel 0 at 25 % duty, channel 1 full-on, channel 2 full-off."""
    pca = running_pca()
    pca.write(led_on_l(0), counts(0, 1024))
    pca.write(led_on_l(1), counts(0, 0, full_on=True))
    pca.write(led_on_l(2), counts(0, 0, full_off=True))
    return pca


def test_oe_is_low_by_default_and_outputs_follow_the_registers() -> None:
    pca = driving_pca()
    assert pca.output_enable
    assert [pca.channel_duty(ch) for ch in (0, 1, 2)] == [0.25, 1.0, 0.0]


@pytest.mark.parametrize(
    ("mode2", "level"),
    [
        (MODE2_OUTDRV, 0.0),  # power-on OUTNE = 00: every output low
        (MODE2_OUTDRV | OUTNE_HIGH, 1.0),  # the host's MODE2 0x05: every output high
        (OUTNE_HIGH, None),  # OUTNE = 01 with open-drain outputs: high-impedance
        (MODE2_OUTDRV | 0x02, None),  # OUTNE = 1x: high-impedance
        (MODE2_OUTDRV | 0x03, None),
    ],
)
def test_oe_high_sets_every_output_as_outne_says(mode2: int, level: float | None) -> None:
    pca = driving_pca()
    pca.write(MODE2, bytes((mode2,)))
    pca.output_enable = False
    assert all(pca.output(ch) == level for ch in range(16))
    # a high-impedance output reads low at a TB6612FNG input (internal pull-down)
    assert all(pca.channel_duty(ch) == (level or 0.0) for ch in range(16))


def test_oe_does_not_touch_the_registers_and_low_again_restores_the_outputs() -> None:
    pca = driving_pca()
    pca.write(MODE2, bytes((MODE2_OUTDRV | OUTNE_HIGH,)))
    before = pca.read(led_on_l(0), 12)
    pca.output_enable = False
    assert pca.read(led_on_l(0), 12) == before
    pca.output_enable = True
    assert [pca.channel_duty(ch) for ch in (0, 1, 2)] == [0.25, 1.0, 0.0]


def test_oe_changes_count_as_output_changes() -> None:
    pca = driving_pca()
    g = pca.generation
    pca.output_enable = False
    assert pca.generation == g + 1
    pca.output_enable = False  # no change, no new generation
    assert pca.generation == g + 1


def test_oe_high_wins_over_sleep_and_a_reset_keeps_the_pin() -> None:
    pca = Pca9685()  # asleep, MODE2 power-on
    pca.output_enable = False
    pca.write(MODE2, bytes((MODE2_OUTDRV | OUTNE_HIGH,)))
    assert pca.channel_duty(0) == 1.0  # OE high drives the outputs even with SLEEP = 1
    pca.reset()  # SWRST: MODE2 back to OUTNE = 00, the OE pin is not a register
    assert not pca.output_enable
    assert pca.read(MODE2, 1) == bytes((MODE2_POWER_ON,))
    assert pca.channel_duty(0) == 0.0


def test_invrt_inverts_the_enabled_outputs() -> None:
    pca = driving_pca()
    pca.write(MODE2, bytes((MODE2_INVRT | MODE2_OUTDRV,)))
    assert [pca.channel_duty(ch) for ch in (0, 1, 2)] == [0.75, 0.0, 1.0]
    pca.output_enable = False  # OUTNE = 00 applies as it is, not inverted
    assert pca.channel_duty(1) == 0.0
