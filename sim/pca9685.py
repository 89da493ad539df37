"""Register-level model of the NXP PCA9685 16-channel, 12-bit PWM controller (datasheet Rev. 4).

The twin's virtual I²C bus hands every transaction addressed to the chip to :meth:`Pca9685.write`
or :meth:`Pca9685.read`, so the host's driver talks to this model exactly as it talks to the chip
on the robot. The outputs the TB6612FNG sees are read back with :meth:`Pca9685.channel_duty`.
The register map, its bits and power-on values and Eq. 1 are the chip's facts the host's driver
uses too: :mod:`jackson.protocol.pca9685`.

What is modelled (section and table numbers of the datasheet):

- Register map, power-on values and read-only bits (§7.3, Table 4).
- MODE1 (§7.3.1, Table 5): SLEEP stops the outputs; AI auto-increments the register pointer;
  EXTCLK is sticky and can only be set while SLEEP is already 1; RESTART as in §7.3.1.1.
- LEDn_ON/LEDn_OFF (§7.3.3, Table 7): 12-bit ON and OFF counts, full-on (bit 4 of ON_H) and
  full-off (bit 4 of OFF_H), full-off taking precedence; bits 7:5 of the _H registers read 0.
- ALL_LED_ON/ALL_LED_OFF (§7.3.4): a write goes to the same register of all 16 channels; reads
  return 0.
- PRE_SCALE (§7.3.5): accepted only while SLEEP = 1, forced to at least 3; update rate
  ``f = osc_clock / (4096 * (PRE_SCALE + 1))`` (Eq. 1) with the 25 MHz internal oscillator.
- The active-low OE input (§7.4; :attr:`Pca9685.output_enable`, True while OE is low) and MODE2
  (§7.3.2, Table 6): with OE low the outputs follow the LED registers, inverted when INVRT = 1;
  with OE high they follow OUTNE: 00 drives every output low, 01 drives them high when OUTDRV = 1
  (totem pole) and leaves them high-impedance when OUTDRV = 0, 1x leaves them high-impedance.
  The robot's MCU holds OE (its motor interlock, docs/firmware.md); a high-impedance output
  reads low at a TB6612FNG input (its internal pull-down).

Simplifications, stated so nobody mistakes them for the chip:

- With AI = 1 the register pointer advances by one after every byte and wraps from 0xFF to 0x00
  (the chip's own roll-over rules, including the AI1/AI0 subsets, are not reproduced). With
  AI = 0 every byte of a block goes to the same register.
- No time: the 500 µs oscillator start-up after clearing SLEEP is not enforced, output changes
  take effect at once (MODE2 OCH is stored but changes nothing), and the phase of a channel
  within the PWM period is ignored: only its duty matters.
- With OE low the outputs are modelled as totem-pole outputs whatever OUTDRV says (open-drain
  needs external pull-ups, which motor HATs do not fit); OCH and the sub-addresses are stored
  and read back only, and the chip answers only at the address the bus gives it.
- Reserved registers 0x46..0xF9 and TestMode 0xFF ignore writes and read 0.
"""

from __future__ import annotations

from jackson.protocol.pca9685 import (
    ADDRESS_WRITABLE,
    ALL_LED_OFF_H,
    ALL_LED_ON_L,
    ALLCALLADR,
    ALLCALLADR_POWER_ON,
    CHANNELS,
    LED0_ON_L,
    LED15_OFF_H,
    LED_COUNT_H_MASK,
    LED_FULL,
    LED_H_WRITABLE,
    MODE1,
    MODE1_AI,
    MODE1_EXTCLK,
    MODE1_POWER_ON,
    MODE1_RESTART,
    MODE1_SLEEP,
    MODE2,
    MODE2_INVRT,
    MODE2_OUTDRV,
    MODE2_OUTNE,
    MODE2_POWER_ON,
    MODE2_WRITABLE,
    OSC_CLOCK_HZ,
    OUTNE_HIGH,
    OUTNE_LOW,
    PRE_SCALE,
    PRE_SCALE_MIN,
    PRE_SCALE_POWER_ON,
    PWM_STEPS,
    REGISTERS_PER_CHANNEL,
    SUBADR1,
    SUBADR1_POWER_ON,
    SUBADR2_POWER_ON,
    SUBADR3_POWER_ON,
    led_on_l,
    update_rate_hz,
)

_MODE1_STORED = 0x7F  # every bit but RESTART, whose read value is the model's restart state


class Pca9685:
    """One PCA9685 at the register level: what an I²C master can write, read and observe.

    Parameters
    ----------
    extclk_hz : float
        Frequency of a clock on the EXTCLK pin [Hz], used once MODE1 EXTCLK is set.
    """

    _mode1: int
    _mode2: int
    _addresses: list[int]  # SUBADR1, SUBADR2, SUBADR3, ALLCALLADR
    _leds: bytearray  # LED0_ON_L .. LED15_OFF_H
    _prescale: int
    _restart_pending: bool

    def __init__(self, extclk_hz: float = OSC_CLOCK_HZ) -> None:
        self.extclk_hz = extclk_hz
        self.reset()

    generation: int = 0
    """Counts register writes, resets and OE changes: outputs can only have changed when it
    has."""

    _output_enable: bool = True

    @property
    def output_enable(self) -> bool:
        """The active-low OE pin is low: outputs follow the LED registers (§7.4).

        True by default, as on boards that tie OE to ground; on the robot the MCU's interlock
        line drives it (docs/firmware.md, "Motor interlock"). A reset leaves it alone: it is a
        pin, not a register.
        """
        return self._output_enable

    @output_enable.setter
    def output_enable(self, enabled: bool) -> None:
        if enabled != self._output_enable:
            self._output_enable = enabled
            self.generation += 1

    def reset(self) -> None:
        """Return every register to its power-on value (power cycle or SWRST, §7.6)."""
        self.generation += 1
        self._mode1 = MODE1_POWER_ON
        self._mode2 = MODE2_POWER_ON
        self._addresses = [
            SUBADR1_POWER_ON,
            SUBADR2_POWER_ON,
            SUBADR3_POWER_ON,
            ALLCALLADR_POWER_ON,
        ]
        self._leds = bytearray(CHANNELS * REGISTERS_PER_CHANNEL)
        for channel in range(CHANNELS):
            self._leds[REGISTERS_PER_CHANNEL * channel + 3] = LED_FULL  # OFF_H: full-off
        self._prescale = PRE_SCALE_POWER_ON
        self._restart_pending = False

    # ---- bus interface ------------------------------------------------------------------------
    def write(self, reg: int, data: bytes) -> None:
        """One I²C write transaction: ``data`` written starting at register ``reg``.

        With MODE1 AI = 1 the pointer advances after each byte (wrapping 0xFF -> 0x00), with
        AI = 0 every byte goes to ``reg``. A transaction that writes any LED or ALL_LED register
        ends a pending restart (§7.3.1.1, "other actions that clear the RESTART bit").

        Parameters
        ----------
        reg : int
            First register address (0x00..0xFF).
        data : bytes
            The bytes the master sent after the register address.
        """
        pointer = _check_register(reg)
        self.generation += 1
        end = pointer + len(data) - 1
        if self._mode1 & MODE1_AI and LED0_ON_L <= pointer and end <= LED15_OFF_H and data:
            # the common case, a run of LEDn registers: one slice, H registers masked
            start = pointer - LED0_ON_L
            block = bytearray(data)
            first_h = (start + 1) % 2  # the first odd offset (an _H register) in the block
            block[first_h::2] = bytes(v & LED_H_WRITABLE for v in block[first_h::2])
            self._leds[start : start + len(block)] = block
            self._restart_pending = False
            return
        touched_pwm = False
        for value in data:
            touched_pwm |= _is_pwm_register(pointer)
            self._write_register(pointer, value)
            if self._mode1 & MODE1_AI:
                pointer = (pointer + 1) & 0xFF
        if touched_pwm:
            self._restart_pending = False

    def read(self, reg: int, n: int) -> bytes:
        """One I²C read of ``n`` bytes starting at register ``reg`` (pointer rules as in write).

        Parameters
        ----------
        reg : int
            First register address (0x00..0xFF).
        n : int
            Number of bytes the master clocks out.

        Returns
        -------
        bytes
            The ``n`` register values.
        """
        pointer = _check_register(reg)
        if n < 0:
            raise ValueError(f"cannot read {n} bytes")
        out = bytearray()
        for _ in range(n):
            out.append(self._read_register(pointer))
            if self._mode1 & MODE1_AI:
                pointer = (pointer + 1) & 0xFF
        return bytes(out)

    # ---- outputs ------------------------------------------------------------------------------
    @property
    def asleep(self) -> bool:
        """MODE1 SLEEP: the oscillator is off and no output runs."""
        return bool(self._mode1 & MODE1_SLEEP)

    @property
    def restart_pending(self) -> bool:
        """MODE1 RESTART reads 1: outputs held off until RESTART is written 1 (§7.3.1.1)."""
        return self._restart_pending

    @property
    def frequency_hz(self) -> float:
        """PWM update rate [Hz], §7.3.5 Eq. 1: ``clock / (4096 * (PRE_SCALE + 1))``."""
        clock_hz = self.extclk_hz if self._mode1 & MODE1_EXTCLK else OSC_CLOCK_HZ
        return update_rate_hz(self._prescale, clock_hz)

    @property
    def mode2(self) -> int:
        """The MODE2 register (INVRT, OCH, OUTDRV, OUTNE; Table 6)."""
        return self._mode2

    def output(self, channel: int) -> float | None:
        """Fraction of each PWM period output ``channel`` drives high, or None when the output
        is high-impedance (OE high with OUTNE = 1x, or 01 with OUTDRV = 0; §7.3.2 Table 6).

        With OE high: OUTNE = 00 gives 0 and OUTNE = 01 with OUTDRV = 1 gives 1, whatever the
        LED registers hold. With OE low: 0 while asleep or while a restart is pending; otherwise
        full-off gives 0 (it wins over full-on), full-on gives 1, and else
        ``((OFF - ON) mod 4096) / 4096`` (§7.3.3); INVRT = 1 inverts the result.
        """
        if not self._output_enable:
            _ = led_on_l(channel)  # the same channel check as with OE low
            outne = self._mode2 & MODE2_OUTNE
            if outne == OUTNE_LOW:
                return 0.0
            if outne == OUTNE_HIGH and self._mode2 & MODE2_OUTDRV:
                return 1.0
            return None
        duty = self._programmed_duty(channel)
        if self.asleep or self._restart_pending:
            duty = 0.0
        return 1.0 - duty if self._mode2 & MODE2_INVRT else duty

    def channel_duty(self, channel: int) -> float:
        """Fraction of each PWM period output ``channel`` reads high at a TB6612FNG input, in
        [0, 1]: :meth:`output`, with a high-impedance output read low (the TB6612FNG's inputs
        have internal pull-down resistors).
        """
        level = self.output(channel)
        return 0.0 if level is None else level

    # ---- registers ----------------------------------------------------------------------------
    def _programmed_duty(self, channel: int) -> float:
        base = led_on_l(channel) - LED0_ON_L
        on_l, on_h, off_l, off_h = self._leds[base : base + REGISTERS_PER_CHANNEL]
        if off_h & LED_FULL:
            return 0.0
        if on_h & LED_FULL:
            return 1.0
        on = ((on_h & LED_COUNT_H_MASK) << 8) | on_l
        off = ((off_h & LED_COUNT_H_MASK) << 8) | off_l
        return ((off - on) % PWM_STEPS) / PWM_STEPS

    def _any_channel_active(self) -> bool:
        return any(self._programmed_duty(ch) > 0.0 for ch in range(CHANNELS))

    def _write_register(self, reg: int, value: int) -> None:
        if reg == MODE1:
            self._write_mode1(value)
        elif reg == MODE2:
            self._mode2 = value & MODE2_WRITABLE
        elif SUBADR1 <= reg <= ALLCALLADR:
            self._addresses[reg - SUBADR1] = value & ADDRESS_WRITABLE
        elif LED0_ON_L <= reg <= LED15_OFF_H:
            self._leds[reg - LED0_ON_L] = _led_value(reg - LED0_ON_L, value)
        elif ALL_LED_ON_L <= reg <= ALL_LED_OFF_H:
            offset = reg - ALL_LED_ON_L
            for channel in range(CHANNELS):
                index = REGISTERS_PER_CHANNEL * channel + offset
                self._leds[index] = _led_value(offset, value)
        elif reg == PRE_SCALE and self.asleep:  # §7.3.5: only while the oscillator is off
            self._prescale = max(PRE_SCALE_MIN, value)
        # PRE_SCALE while awake, reserved registers and TestMode: ignored

    def _write_mode1(self, value: int) -> None:
        """MODE1 write (Table 5, §7.3.1.1).

        RESTART written 1 restarts held outputs only if the oscillator was already running
        before this write; a write that clears SLEEP and sets RESTART at once leaves them held.
        """
        was_asleep = self.asleep
        stored = value & _MODE1_STORED
        # EXTCLK is sticky and is only taken while SLEEP was already set (Table 5).
        extclk = self._mode1 & MODE1_EXTCLK
        if was_asleep and stored & MODE1_SLEEP:
            extclk |= stored & MODE1_EXTCLK
        stored = (stored & ~MODE1_EXTCLK) | extclk
        if not was_asleep and stored & MODE1_SLEEP and self._any_channel_active():
            self._restart_pending = True  # §7.3.1.1: entering sleep with outputs running
        if value & MODE1_RESTART and not was_asleep:
            self._restart_pending = False  # writing 1 restarts; needs the oscillator running
        self._mode1 = stored

    def _read_register(self, reg: int) -> int:
        if reg == MODE1:
            return self._mode1 | (MODE1_RESTART if self._restart_pending else 0)
        if reg == MODE2:
            return self._mode2
        if SUBADR1 <= reg <= ALLCALLADR:
            return self._addresses[reg - SUBADR1]
        if LED0_ON_L <= reg <= LED15_OFF_H:
            return self._leds[reg - LED0_ON_L]
        if reg == PRE_SCALE:
            return self._prescale
        return 0  # ALL_LED registers read 0; reserved and TestMode too


def _check_register(reg: int) -> int:
    if not 0 <= reg <= 0xFF:
        raise ValueError(f"PCA9685 register {reg:#x} outside 0x00..0xFF")
    return reg


def _is_pwm_register(reg: int) -> bool:
    return LED0_ON_L <= reg <= LED15_OFF_H or ALL_LED_ON_L <= reg <= ALL_LED_OFF_H


def _led_value(offset: int, value: int) -> int:
    """Value stored in the LED register at ``offset`` within a channel (Table 7)."""
    return value & LED_H_WRITABLE if offset % 2 else value & 0xFF
