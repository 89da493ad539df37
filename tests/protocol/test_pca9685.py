"""The PCA9685's register map and Eq. 1 against the NXP datasheet (Rev. 4)."""

from __future__ import annotations

import pytest

from jackson.protocol.pca9685 import (
    ALL_LED_OFF_H,
    ALL_LED_ON_L,
    CHANNELS,
    LED0_ON_L,
    LED15_OFF_H,
    MODE1,
    MODE1_POWER_ON,
    MODE2,
    MODE2_POWER_ON,
    OSC_CLOCK_HZ,
    PRE_SCALE,
    PRE_SCALE_POWER_ON,
    SUBADR1,
    TESTMODE,
    led_on_l,
    prescale_for,
    update_rate_hz,
)


def test_register_map_matches_table_4() -> None:
    assert (MODE1, MODE2, SUBADR1, LED0_ON_L, LED15_OFF_H) == (0x00, 0x01, 0x02, 0x06, 0x45)
    assert (ALL_LED_ON_L, ALL_LED_OFF_H, PRE_SCALE, TESTMODE) == (0xFA, 0xFD, 0xFE, 0xFF)
    assert led_on_l(15) + 3 == LED15_OFF_H


def test_power_on_values_match_table_4() -> None:
    assert (MODE1_POWER_ON, MODE2_POWER_ON, PRE_SCALE_POWER_ON) == (0x11, 0x04, 0x1E)


@pytest.mark.parametrize("channel", [-1, CHANNELS])
def test_led_on_l_refuses_a_channel_the_chip_does_not_have(channel: int) -> None:
    with pytest.raises(ValueError, match="channel"):
        led_on_l(channel)


@pytest.mark.parametrize(
    ("freq_hz", "prescale"), [(200.0, 0x1E), (1000.0, 5), (1526.0, 3), (24.0, 253)]
)
def test_prescale_for_follows_equation_1(freq_hz: float, prescale: int) -> None:
    # 200 Hz: the datasheet's example; 1 kHz: round(25e6 / (4096 * 1000)) - 1 = round(6.10) - 1
    assert prescale_for(freq_hz) == round(25e6 / (4096 * freq_hz)) - 1 == prescale


@pytest.mark.parametrize("freq_hz", [0.0, -50.0, 2000.0, 20.0])
def test_prescale_for_rejects_rates_the_chip_cannot_make(freq_hz: float) -> None:
    with pytest.raises(ValueError, match="PWM frequency"):
        prescale_for(freq_hz)


def test_update_rate_inverts_equation_1() -> None:
    assert update_rate_hz(0x1E) == 25e6 / (4096 * 31)  # about 196.9 Hz, the power-on rate
    assert update_rate_hz(prescale_for(1000.0)) == pytest.approx(1017.25, abs=0.01)
    assert update_rate_hz(3, clock_hz=2 * OSC_CLOCK_HZ) == 2 * update_rate_hz(3)
