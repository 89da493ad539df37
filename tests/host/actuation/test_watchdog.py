"""The /cmd_vel watchdog: stale after 0.6 s of MCU time without a command."""

from __future__ import annotations

import math

import pytest

from jackson.host.actuation.watchdog import COMMAND_TIMEOUT_S, CommandWatchdog

TICK_S = 0.05  # [s] 20 Hz control tick


def test_watchdog_is_expired_before_any_command() -> None:
    wd = CommandWatchdog()
    assert wd.expired(0.0)
    assert wd.age(0.0) == math.inf


def test_watchdog_expires_at_0_6_s() -> None:
    assert COMMAND_TIMEOUT_S == 0.6
    wd = CommandWatchdog()
    wd.feed(10.0)
    assert not wd.expired(10.0)
    assert not wd.expired(10.599)
    assert wd.expired(10.6)  # 10.6 - 10.0 is 0.5999999999999996 in floats
    assert wd.expired(11.0)


def test_feed_restarts_the_timeout() -> None:
    wd = CommandWatchdog()
    wd.feed(1.0)
    wd.feed(1.5)
    assert not wd.expired(2.0)
    assert wd.age(2.0) == pytest.approx(0.5)


def test_watchdog_brakes_within_0_6_s_plus_one_tick() -> None:
    wd = CommandWatchdog()
    last_command_s = 3.0123  # between ticks
    wd.feed(last_command_s)
    ticks = [k * TICK_S for k in range(200)]
    first_brake_s = next(t for t in ticks if t > last_command_s and wd.expired(t))
    assert 0.6 <= first_brake_s - last_command_s <= 0.6 + TICK_S


def test_twenty_hz_ticks_expire_on_the_twelfth_tick() -> None:
    wd = CommandWatchdog()
    t = 0.0
    for _ in range(37):  # tick times summed like a loop would sum them
        t += TICK_S
    wd.feed(t)
    for k in range(1, 13):
        t += TICK_S
        assert wd.expired(t) == (k == 12)


def test_command_stamped_just_after_the_tick_is_fresh() -> None:
    wd = CommandWatchdog()
    wd.feed(5.02)
    assert wd.age(5.0) == 0.0
    assert not wd.expired(5.0)


def test_clock_stepping_far_back_counts_as_expired() -> None:
    wd = CommandWatchdog()
    wd.feed(100.0)
    assert wd.expired(0.1)  # MCU restarted, time re-based
    wd.feed(0.2)
    assert not wd.expired(0.3)


def test_reset_expires_until_the_next_feed() -> None:
    wd = CommandWatchdog(timeout_s=1.0)
    wd.feed(1.0)
    wd.reset()
    assert wd.expired(1.0)


@pytest.mark.parametrize("bad", [0.0, -0.6, math.nan, math.inf])
def test_impossible_timeout_is_rejected(bad: float) -> None:
    with pytest.raises(ValueError, match="timeout_s"):
        CommandWatchdog(bad)


def test_non_finite_feed_is_rejected() -> None:
    with pytest.raises(ValueError, match="non-finite"):
        CommandWatchdog().feed(math.nan)
