"""Unwrapping the u32 microsecond MCU clock."""

from __future__ import annotations

from jackson.protocol import TimestampUnwrapper


def test_monotonic_stamps_pass_through() -> None:
    u = TimestampUnwrapper()
    assert [u.unwrap(t) for t in (100, 50_100, 100_100)] == [100, 50_100, 100_100]


def test_wrap_moves_forward_by_the_true_step() -> None:
    u = TimestampUnwrapper()
    u.unwrap(0xFFFF_FFF0)
    assert u.unwrap(0x10) == 0xFFFF_FFF0 + 0x20


def test_many_wraps_accumulate() -> None:
    u = TimestampUnwrapper()
    t = 0
    step = 50_000_000  # 50 s steps, 2^32 us = 4295 s, so several wraps
    for k in range(1, 400):
        t = u.unwrap((k * step) % 2**32)
    assert t == 399 * step


def test_small_step_back_is_followed_but_a_reset_is_counted() -> None:
    u = TimestampUnwrapper()
    u.unwrap(5_000_000)
    assert u.unwrap(4_999_000) == 4_999_000  # reordering: follow it
    assert u.resets == 0
    assert u.unwrap(1_000) == 4_999_000  # MCU restarted: time holds, reset counted
    assert u.resets == 1
    assert u.unwrap(51_000) == 5_049_000
