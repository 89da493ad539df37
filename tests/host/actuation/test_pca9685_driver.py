"""The host's PCA9685 driver against the datasheet (NXP PCA9685 Rev. 4) and the register model."""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from jackson.host.actuation.pca9685 import Pca9685, led_registers
from jackson.protocol.pca9685 import (
    ALL_LED_ON_L,
    LED0_ON_L,
    LED_FULL,
    MODE1,
    MODE1_AI,
    MODE1_RESTART,
    MODE1_SLEEP,
    PRE_SCALE,
)
from jackson.sim.pca9685 import Pca9685 as Pca9685Model


class ModelBus:
    """The twin's register model behind the I2C-bus interface, recording every transaction."""

    def __init__(self) -> None:
        self.chip = Pca9685Model()
        self.log: list[tuple[str, int, list[int]]] = []

    def write_byte_data(self, i2c_addr: int, register: int, value: int) -> None:
        self.log.append(("byte", register, [value]))
        self.chip.write(register, bytes([value]))

    def read_byte_data(self, i2c_addr: int, register: int) -> int:
        return self.chip.read(register, 1)[0]

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: Sequence[int]) -> None:
        self.log.append(("block", register, list(data)))
        self.chip.write(register, bytes(data))

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int) -> list[int]:
        return list(self.chip.read(register, length))

    def close(self) -> None:
        pass


def test_init_sleeps_sets_prescale_wakes_and_restarts_with_auto_increment() -> None:
    bus = ModelBus()
    Pca9685(bus).init(1000)
    mode1_writes = [v[0] for kind, reg, v in bus.log if reg == MODE1]
    assert mode1_writes[0] & MODE1_SLEEP  # PRE_SCALE is only writable asleep
    assert ("byte", PRE_SCALE, [5]) in bus.log
    assert bus.log.index(("byte", PRE_SCALE, [5])) > 0
    assert not mode1_writes[1] & MODE1_SLEEP  # awake
    assert mode1_writes[2] & MODE1_RESTART and mode1_writes[2] & MODE1_AI
    assert bus.chip.frequency_hz == pytest.approx(25e6 / (4096 * 6))
    assert not bus.chip.asleep and not bus.chip.restart_pending
    assert all(bus.chip.channel_duty(ch) == 0.0 for ch in range(16))  # starts fully off


def test_full_on_and_full_off_bits() -> None:
    assert led_registers(0.0) == [0, 0, 0, LED_FULL]  # OFF_H bit 4: full off
    assert led_registers(1.0) == [0, LED_FULL, 0, 0]  # ON_H bit 4: full on
    assert led_registers(0.5) == [0, 0, 0x00, 0x08]  # OFF = 2048 of 4096


def test_contiguous_channels_go_in_one_auto_increment_block() -> None:
    bus = ModelBus()
    pca = Pca9685(bus)
    pca.init(1000)
    bus.log.clear()
    pca.set_duties({0: 0.6, 1: 1.0, 2: 0.0, 3: 0.0, 4: 1.0, 5: 0.3})
    expected = [b for d in (0.6, 1.0, 0.0, 0.0, 1.0, 0.3) for b in led_registers(d)]
    assert bus.log == [("block", LED0_ON_L, expected)]
    assert bus.chip.channel_duty(0) == pytest.approx(0.6, abs=1 / 4096)
    assert bus.chip.channel_duty(1) == 1.0 and bus.chip.channel_duty(2) == 0.0
    assert bus.chip.channel_duty(5) == pytest.approx(0.3, abs=1 / 4096)


def test_all_off_uses_all_led_full_off() -> None:
    bus = ModelBus()
    pca = Pca9685(bus)
    pca.init(1000)
    pca.set_duties({0: 0.5, 7: 1.0})
    pca.all_off()
    assert bus.log[-1] == ("byte", ALL_LED_ON_L + 3, [LED_FULL])
    assert all(bus.chip.channel_duty(ch) == 0.0 for ch in range(16))
