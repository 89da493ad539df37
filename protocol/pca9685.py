"""The NXP PCA9685 16-channel, 12-bit PWM controller as its datasheet defines it (Rev. 4), no I/O.

The host's driver (:mod:`jackson.host.actuation.pca9685`) writes these registers on the robot's
I²C bus, and the twin's register model (:mod:`jackson.sim.pca9685`) answers the same writes on
the virtual bus; both take the chip's facts from here, as both ends of the RPLIDAR's serial
link share :mod:`jackson.protocol.rplidar`. Names are the datasheet's; section and table numbers
below are those of the datasheet.

Register map (§7.3, Table 4)::

    0x00       MODE1                       0x06..0x45  LEDn_ON_L, LEDn_ON_H, LEDn_OFF_L,
    0x01       MODE2                                   LEDn_OFF_H for n = 0..15, four a channel
    0x02..0x04 SUBADR1..SUBADR3            0x46..0xF9  reserved
    0x05       ALLCALLADR                  0xFA..0xFD  ALL_LED_ON_L .. ALL_LED_OFF_H
                                           0xFE        PRE_SCALE
                                           0xFF        TestMode

The PWM update rate follows PRE_SCALE (§7.3.5, Eq. 1)::

    prescale = round(osc_clock / (4096 * update_rate)) - 1
    update_rate = osc_clock / (4096 * (prescale + 1))

with the 25 MHz internal oscillator (:func:`prescale_for`, :func:`update_rate_hz`).
"""

from __future__ import annotations

# ---- register map (§7.3, Table 4) -------------------------------------------------------------
MODE1 = 0x00
MODE2 = 0x01
SUBADR1 = 0x02
SUBADR2 = 0x03
SUBADR3 = 0x04
ALLCALLADR = 0x05
LED0_ON_L = 0x06
LED0_ON_H = 0x07
LED0_OFF_L = 0x08
LED0_OFF_H = 0x09
LED15_OFF_H = 0x45
ALL_LED_ON_L = 0xFA
ALL_LED_ON_H = 0xFB
ALL_LED_OFF_L = 0xFC
ALL_LED_OFF_H = 0xFD
PRE_SCALE = 0xFE
TESTMODE = 0xFF

CHANNELS = 16
REGISTERS_PER_CHANNEL = 4  # ON_L, ON_H, OFF_L, OFF_H

# ---- MODE1 bits (§7.3.1, Table 5) -------------------------------------------------------------
MODE1_RESTART = 0x80
MODE1_EXTCLK = 0x40
MODE1_AI = 0x20  # register auto-increment
MODE1_SLEEP = 0x10  # low-power mode, oscillator off
MODE1_SUB1 = 0x08
MODE1_SUB2 = 0x04
MODE1_SUB3 = 0x02
MODE1_ALLCALL = 0x01

# ---- MODE2 bits (§7.3.2, Table 6) -------------------------------------------------------------
MODE2_INVRT = 0x10
MODE2_OCH = 0x08
MODE2_OUTDRV = 0x04  # totem-pole outputs (0: open-drain)
MODE2_OUTNE = 0x03  # two-bit field: output state while OE is high
OUTNE_LOW = 0x00  # LEDn = 0 while OE = 1
OUTNE_HIGH = 0x01  # LEDn = 1 while OE = 1 with OUTDRV = 1 (high-impedance with OUTDRV = 0)
MODE2_WRITABLE = 0x1F  # bits 7:5 are reserved and read 0

# ---- LEDn_ON_H / LEDn_OFF_H (§7.3.3, Table 7) -------------------------------------------------
LED_FULL = 0x10  # bit 4: full-on in ON_H, full-off in OFF_H
LED_COUNT_H_MASK = 0x0F  # bits 11:8 of the 12-bit count
LED_H_WRITABLE = 0x1F  # bits 7:5 are reserved and read 0

# ---- power-on values (Table 4) ----------------------------------------------------------------
MODE1_POWER_ON = MODE1_SLEEP | MODE1_ALLCALL  # 0x11
MODE2_POWER_ON = MODE2_OUTDRV  # 0x04
SUBADR1_POWER_ON = 0xE2
SUBADR2_POWER_ON = 0xE4
SUBADR3_POWER_ON = 0xE8
ALLCALLADR_POWER_ON = 0xE0
PRE_SCALE_POWER_ON = 0x1E  # 200 Hz nominal
PRE_SCALE_MIN = 3  # forced by the hardware (§7.3.5)
PRE_SCALE_MAX = 0xFF
ADDRESS_WRITABLE = 0xFE  # bit 0 of SUBADR1..3 and ALLCALLADR is read-only 0

# ---- the part ---------------------------------------------------------------------------------
DEFAULT_ADDRESS = 0x40  # all address pins low (§7.1)
OSC_CLOCK_HZ = 25e6  # internal oscillator [Hz] (§7.3.5)
PWM_STEPS = 4096  # 12-bit counter
RESTART_WAIT_S = 500e-6  # oscillator start-up after clearing SLEEP, before RESTART (§7.3.1.1)


def led_on_l(channel: int) -> int:
    """Address of LEDn_ON_L for channel n; ON_H, OFF_L and OFF_H follow it (§7.3, Table 4).

    Parameters
    ----------
    channel : int
        The output, 0..15.

    Returns
    -------
    int
        ``LED0_ON_L + 4 n``.

    Raises
    ------
    ValueError
        The channel is outside 0..15.
    """
    if not 0 <= channel < CHANNELS:
        raise ValueError(f"PCA9685 channel {channel} outside 0..{CHANNELS - 1}")
    return LED0_ON_L + REGISTERS_PER_CHANNEL * channel


def prescale_for(freq_hz: float) -> int:
    """PRE_SCALE value for an update rate, §7.3.5 Eq. 1.

    ``prescale = round(osc_clock / (4096 * update_rate)) - 1`` with the 25 MHz internal
    oscillator; e.g. 200 Hz gives 30 (0x1E) and 1 kHz gives 5.

    Parameters
    ----------
    freq_hz : float
        Wanted PWM update rate [Hz].

    Returns
    -------
    int
        The PRE_SCALE register value.

    Raises
    ------
    ValueError
        The rate is not positive, or needs a value outside 3..255 (about 24 Hz to 1526 Hz).
    """
    if not freq_hz > 0:
        raise ValueError(f"PWM frequency must be positive, got {freq_hz} Hz")
    prescale = round(OSC_CLOCK_HZ / (PWM_STEPS * freq_hz)) - 1
    if not PRE_SCALE_MIN <= prescale <= PRE_SCALE_MAX:
        raise ValueError(
            f"PWM frequency {freq_hz} Hz needs PRE_SCALE {prescale}, outside "
            f"{PRE_SCALE_MIN}..{PRE_SCALE_MAX}"
        )
    return prescale


def update_rate_hz(prescale: int, clock_hz: float = OSC_CLOCK_HZ) -> float:
    """PWM update rate of a PRE_SCALE value, §7.3.5 Eq. 1 solved for the rate.

    Parameters
    ----------
    prescale : int
        The PRE_SCALE register value.
    clock_hz : float
        The oscillator: the internal 25 MHz, or a clock on the EXTCLK pin [Hz].

    Returns
    -------
    float
        ``clock_hz / (4096 * (prescale + 1))`` [Hz].
    """
    return clock_hz / (PWM_STEPS * (prescale + 1))
