"""The motor output's settings, apart from the rest of the host configuration.

``jackson brake`` (systemd's ``ExecStopPost``) reads only these: the ``actuator`` and the
``pca9685`` section of the host YAML, so it starts without loading the estimator and its
numerical libraries, and brakes even when another section of the file is broken.
:mod:`jackson.host.config` parses the same sections with the same functions.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from jackson.common.fields import Fields, read_yaml, show
from jackson.host.actuation.i2c import I2cSpecError, check_bus_spec
from jackson.host.actuation.tb6612 import BridgeChannels

DEFAULT_CONFIG = Path(__file__).resolve().parents[1] / "config" / "jackson.yaml"  # the shipped YAML
Actuator = Literal["pca9685", "mcu"]
ACTUATORS: dict[str, Actuator] = {"pca9685": "pca9685", "mcu": "mcu"}
PWM_FREQUENCY_RANGE_HZ = (24.0, 1526.0)  # PCA9685 PRE_SCALE 253..3 (datasheet eq. 1)
LEFT_CHANNELS = BridgeChannels(pwm=0, in1=1, in2=2)  # PWMA, AIN1, AIN2 (the common motor HAT)
RIGHT_CHANNELS = BridgeChannels(pwm=5, in1=3, in2=4)  # PWMB, BIN1, BIN2


@dataclass(frozen=True)
class Pca9685Settings:
    """The PCA9685 and the TB6612FNG inputs wired to its outputs."""

    bus: str = "/dev/i2c-7"  # or "unix:/path/to.sock" for the twin
    address: int = 0x40
    frequency_hz: float = 1000.0
    left: BridgeChannels = LEFT_CHANNELS
    right: BridgeChannels = RIGHT_CHANNELS
    stby_channel: int | None = None  # None: STBY tied high


def load_motor_settings(path: str | Path) -> tuple[Actuator, Pca9685Settings]:
    """The ``actuator`` and the ``pca9685`` section of a host YAML, and nothing else.

    Raises
    ------
    ConfigError
        One line naming the file and the field at fault (in these two only).
    """
    where, data = read_yaml(Path(path), "config")
    top = Fields(where, data)
    return parse_actuator(top), parse_pca9685(top.section("pca9685"))


def parse_actuator(s: Fields) -> Actuator:
    """The top level's ``actuator`` (pca9685 or mcu)."""
    s.used.add("actuator")
    v = s.data.get("actuator", "pca9685")
    if not isinstance(v, str) or v not in ACTUATORS:
        raise s.fail("actuator", f"expected pca9685 or mcu, got {show(v)}")
    return ACTUATORS[v]


def parse_pca9685(s: Fields) -> Pca9685Settings:
    """The ``pca9685`` section, checked (a channel used twice is refused)."""
    d = Pca9685Settings()
    bus = s.text("bus", d.bus)
    try:
        check_bus_spec(bus)
    except I2cSpecError as exc:
        raise s.fail("bus", f"expected /dev/i2c-N or unix:/path/to.sock, got {show(bus)}") from exc
    frequency = s.number("frequency_hz", d.frequency_hz, *PWM_FREQUENCY_RANGE_HZ)
    channels = s.section("channels")
    used: dict[int, str] = {}  # channel -> the field that took it

    def claim(section: Fields, key: str, value: int) -> None:
        if value in used:
            raise section.fail(key, f"channel {value} is already used by {used[value]}")
        used[value] = f"{section.prefix}{key}"

    def bridge(key: str, default: BridgeChannels) -> BridgeChannels:
        b = channels.section(key)
        values = []
        for name in ("pwm", "in1", "in2"):
            value = b.integer(name, getattr(default, name), 0, 15)
            claim(b, name, value)
            values.append(value)
        b.finish()
        return BridgeChannels(*values)

    left = bridge("left", d.left)
    right = bridge("right", d.right)
    channels.finish()
    stby = s.optional_integer("stby_channel", 0, 15)
    if stby is not None:
        claim(s, "stby_channel", stby)
    out = Pca9685Settings(
        bus=bus,
        address=s.integer("address", d.address, 0x03, 0x77, hexadecimal=True),
        frequency_hz=frequency,
        left=left,
        right=right,
        stby_channel=stby,
    )
    s.finish()
    return out
