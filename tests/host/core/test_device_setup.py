"""The MCU's failsafe and the host's command watchdog are two settings: ``failsafe_ms`` goes to
the device in its set-up (SET_CONFIG), ``cmd_vel_timeout_s`` stays in the host's arbiter."""

from __future__ import annotations

import dataclasses

from jackson.host.actuation.output import NullOutput
from jackson.host.config import HostConfig
from jackson.host.core import HostCore, device_setup
from jackson.host.core.settings import LiveSettings
from jackson.protocol import PROTOCOL_VERSION, SCHEMA_HASH, Info, SetConfig
from jackson.protocol.messages import FAILSAFE_MS_DEFAULT


def info(failsafe_ms: int) -> Info:
    """A device's INFO at the host's default rate, ranges and direction flags."""
    return Info(
        protocol_version=PROTOCOL_VERSION,
        schema_hash=SCHEMA_HASH,
        telemetry_rate_hz=20,
        failsafe_ms=failsafe_ms,
        imu_rotation=(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        accel_scale=1.0,
        boot_id=7,
    )


def test_the_default_failsafe_is_the_devices_power_up_value_and_short() -> None:
    cfg = HostConfig()
    assert cfg.failsafe_ms == FAILSAFE_MS_DEFAULT == 200
    assert cfg.cmd_vel_timeout_s == 0.6  # the paper's /cmd_vel watchdog, unchanged
    assert device_setup(cfg, info(FAILSAFE_MS_DEFAULT)) == []  # nothing to send


def test_a_device_at_another_failsafe_gets_the_configured_one() -> None:
    (msg,) = device_setup(HostConfig(), info(600))
    assert msg == SetConfig(failsafe_ms=200, persist=0)


def test_the_command_timeout_is_not_sent_to_the_device() -> None:
    cfg = dataclasses.replace(HostConfig(), cmd_vel_timeout_s=1.5, failsafe_ms=300)
    (msg,) = device_setup(cfg, info(FAILSAFE_MS_DEFAULT))
    assert isinstance(msg, SetConfig) and msg.failsafe_ms == 300


def test_the_arbiter_keeps_the_command_timeout_not_the_failsafe() -> None:
    cfg = dataclasses.replace(HostConfig(), failsafe_ms=150)
    core = HostCore(cfg, NullOutput(), lambda m: None)
    assert core.watchdog.timeout_s == 0.6
    assert LiveSettings.of(cfg).cmd_vel_timeout_s == 0.6
