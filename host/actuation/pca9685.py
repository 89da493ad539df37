"""PCA9685 16-channel PWM driver over the host's I2C bus (NXP PCA9685 datasheet, Rev. 4).

The chip's register map, its bits and Eq. 1 are :mod:`jackson.protocol.pca9685`'s, which the
twin's register model reads too. Channels are set with one block write of their four
LEDn_ON/OFF registers (auto-increment); contiguous channels go in a single transfer, so one
motor command is one I2C transaction.
"""

from __future__ import annotations

import time
from collections.abc import Mapping

from jackson.host.actuation.i2c import I2cBus
from jackson.protocol.pca9685 import (
    ALL_LED_OFF_H,
    ALL_LED_ON_L,
    DEFAULT_ADDRESS,
    LED_FULL,
    MODE1,
    MODE1_AI,
    MODE1_ALLCALL,
    MODE1_RESTART,
    MODE1_SLEEP,
    MODE2,
    MODE2_OUTDRV,
    OUTNE_HIGH,
    PRE_SCALE,
    PWM_STEPS,
    REGISTERS_PER_CHANNEL,
    RESTART_WAIT_S,
    led_on_l,
    prescale_for,
)

MODE2_INTERLOCK = MODE2_OUTDRV | OUTNE_HIGH
"""MODE2 as the host sets it: totem-pole outputs, all high while OE is high (§7.3.2, Table 6),
so the MCU's interlock on OE short-brakes both TB6612 bridges (docs/firmware.md)."""
MAX_BLOCK_BYTES = 32  # an SMBus block transfer's limit


def led_registers(duty: float) -> list[int]:
    """LEDn_ON_L, ON_H, OFF_L, OFF_H for a duty in [0, 1]: full-off at 0, full-on at 1."""
    if duty <= 0.0:
        return [0, 0, 0, LED_FULL]
    if duty >= 1.0:
        return [0, LED_FULL, 0, 0]
    off = min(PWM_STEPS - 1, max(1, round(duty * PWM_STEPS)))
    return [0, 0, off & 0xFF, off >> 8]


def block_runs(channels: tuple[int, ...]) -> tuple[tuple[int, ...], ...]:
    """Sorted channels grouped into block writes: contiguous, at most 32 bytes (8 channels)."""
    runs: list[tuple[int, ...]] = []
    run: list[int] = []
    for ch in channels:
        if run and (ch != run[-1] + 1 or REGISTERS_PER_CHANNEL * (len(run) + 1) > MAX_BLOCK_BYTES):
            runs.append(tuple(run))
            run = []
        run.append(ch)
    if run:
        runs.append(tuple(run))
    return tuple(runs)


class Pca9685:
    """One PCA9685 on an :class:`~jackson.host.actuation.i2c.I2cBus` (smbus2 or the twin's
    socket)."""

    def __init__(self, bus: I2cBus, address: int = DEFAULT_ADDRESS) -> None:
        self.bus = bus
        self.address = address
        self.writes = 0  # I2C transactions issued, for diagnostics
        self._runs: dict[tuple[int, ...], tuple[tuple[int, ...], ...]] = {}

    def init(self, frequency_hz: float = 1000.0) -> None:
        """Sleep, set the prescaler and MODE2, wake, wait for the oscillator, restart with
        auto-increment. Outputs start fully off; MODE2 = OUTDRV | OUTNE=01 makes every output
        high while the MCU holds OE high, a short brake (docs/firmware.md, "Motor interlock").
        """
        prescale = prescale_for(frequency_hz)
        self._write(MODE1, MODE1_SLEEP | MODE1_AI | MODE1_ALLCALL)  # PRE_SCALE: only asleep
        self._write(PRE_SCALE, prescale)
        # OE released by the MCU's interlock: all outputs high, both TB6612 bridges short-brake
        self._write(MODE2, MODE2_INTERLOCK)
        self.bus.write_i2c_block_data(self.address, ALL_LED_ON_L, [0, 0, 0, LED_FULL])
        self.writes += 1
        self._write(MODE1, MODE1_AI | MODE1_ALLCALL)
        time.sleep(RESTART_WAIT_S)
        self._write(MODE1, MODE1_RESTART | MODE1_AI | MODE1_ALLCALL)

    def registers_ok(self, frequency_hz: float) -> bool:
        """Read MODE1, MODE2 and PRE_SCALE back: False when the chip was reset or someone else
        wrote them (a sleeping chip drives nothing)."""
        mode1 = self.bus.read_byte_data(self.address, MODE1)
        mode2 = self.bus.read_byte_data(self.address, MODE2)
        prescale = self.bus.read_byte_data(self.address, PRE_SCALE)
        awake = (mode1 & (MODE1_SLEEP | MODE1_AI)) == MODE1_AI
        return awake and mode2 == MODE2_INTERLOCK and prescale == prescale_for(frequency_hz)

    def _write(self, reg: int, value: int) -> None:
        self.bus.write_byte_data(self.address, reg, value)
        self.writes += 1

    def set_duties(self, duties: Mapping[int, float]) -> None:
        """Set channels to duties in [0, 1], contiguous channels in one block write each (the
        blocks of a set of channels are worked out once: a motor output sets the same six)."""
        channels = tuple(sorted(duties))
        runs = self._runs.get(channels)
        if runs is None:
            runs = self._runs[channels] = block_runs(channels)
        for run in runs:
            self._write_run(run, duties)

    def _write_run(self, run: tuple[int, ...], duties: Mapping[int, float]) -> None:
        data: list[int] = []
        for ch in run:
            data += led_registers(duties[ch])
        self.bus.write_i2c_block_data(self.address, led_on_l(run[0]), data)
        self.writes += 1

    def all_off(self) -> None:
        """Every channel fully off in one write (ALL_LED_OFF_H full-off bit)."""
        self._write(ALL_LED_OFF_H, LED_FULL)
