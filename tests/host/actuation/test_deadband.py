"""PWM deadband compensation: every nonzero wheel command starts at its breakaway duty."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from jackson.host.actuation.deadband import (
    NOMINAL_MAX_WHEEL_RAD_S,
    DeadbandConfig,
    wheel_duties,
    wheel_duty,
)

CFG = DeadbandConfig(
    forward_left=0.10,
    reverse_left=0.12,
    forward_right=0.14,
    reverse_right=0.16,
    max_wheel_rad_s=NOMINAL_MAX_WHEEL_RAD_S,
)


def test_nominal_full_duty_speed_is_100_rpm() -> None:
    assert NOMINAL_MAX_WHEEL_RAD_S == pytest.approx(10.47, abs=0.01)


def test_small_command_maps_to_breakaway_duty() -> None:
    assert wheel_duty(0.051, "left", CFG) == pytest.approx(0.10, abs=0.005)
    assert wheel_duty(0.051, "left", CFG) > 0.10


@pytest.mark.parametrize("omega", [0.0, 0.05, -0.05, 0.03])
def test_commands_within_the_zero_threshold_brake(omega: float) -> None:
    assert wheel_duty(omega, "left", CFG) == 0.0
    assert wheel_duty(omega, "right", CFG) == 0.0


def test_each_wheel_and_direction_uses_its_own_breakaway() -> None:
    tiny = 0.06  # [rad/s] just above the zero threshold: adds < 0.006 to the breakaway
    assert wheel_duty(tiny, "left", CFG) == pytest.approx(0.10, abs=0.006)
    assert wheel_duty(-tiny, "left", CFG) == pytest.approx(-0.12, abs=0.006)
    assert wheel_duty(tiny, "right", CFG) == pytest.approx(0.14, abs=0.006)
    assert wheel_duty(-tiny, "right", CFG) == pytest.approx(-0.16, abs=0.006)


def test_duty_follows_the_formula_between_breakaway_and_full() -> None:
    half = NOMINAL_MAX_WHEEL_RAD_S / 2
    assert wheel_duty(half, "left", CFG) == pytest.approx(0.10 + 0.90 * 0.5)
    assert wheel_duty(-half, "right", CFG) == pytest.approx(-(0.16 + 0.84 * 0.5))


def test_full_speed_command_is_full_duty_and_beyond_is_clamped() -> None:
    assert wheel_duty(NOMINAL_MAX_WHEEL_RAD_S, "left", CFG) == pytest.approx(1.0)
    assert wheel_duty(3 * NOMINAL_MAX_WHEEL_RAD_S, "right", CFG) == 1.0
    assert wheel_duty(-3 * NOMINAL_MAX_WHEEL_RAD_S, "left", CFG) == -1.0


def test_gain_trims_one_side_above_breakaway_only() -> None:
    trimmed = DeadbandConfig(0.10, 0.10, 0.10, 0.10, 10.0, gain_right=0.9)
    assert wheel_duty(5.0, "left", trimmed) == pytest.approx(0.10 + 0.90 * 0.5)
    assert wheel_duty(5.0, "right", trimmed) == pytest.approx(0.10 + 0.90 * 0.5 * 0.9)
    assert wheel_duty(0.051, "right", trimmed) == pytest.approx(0.10, abs=0.005)


def test_wheel_duties_gives_left_then_right() -> None:
    assert wheel_duties(1.944, 2.904, CFG) == (
        wheel_duty(1.944, "left", CFG),
        wheel_duty(2.904, "right", CFG),
    )


@given(a=st.floats(-20.0, 20.0), b=st.floats(-20.0, 20.0))
def test_duty_is_monotonic_and_bounded(a: float, b: float) -> None:
    lo, hi = sorted((a, b))
    d_lo, d_hi = wheel_duty(lo, "right", CFG), wheel_duty(hi, "right", CFG)
    assert -1.0 <= d_lo <= d_hi <= 1.0


def test_unknown_side_is_rejected() -> None:
    with pytest.raises(ValueError, match="side"):
        wheel_duty(1.0, "middle", CFG)  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_command_is_rejected(bad: float) -> None:
    with pytest.raises(ValueError, match="non-finite"):
        wheel_duty(bad, "left", CFG)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"forward_left": 1.0}, "forward_left"),
        ({"reverse_right": -0.1}, "reverse_right"),
        ({"max_wheel_rad_s": 0.0}, "max_wheel_rad_s"),
        ({"gain_left": math.nan}, "gain_left"),
        ({"zero_threshold_rad_s": -0.01}, "zero_threshold_rad_s"),
    ],
)
def test_impossible_calibration_is_rejected(kwargs: dict[str, float], name: str) -> None:
    base = {
        "forward_left": 0.1,
        "reverse_left": 0.1,
        "forward_right": 0.1,
        "reverse_right": 0.1,
        "max_wheel_rad_s": 10.0,
    }
    with pytest.raises(ValueError, match=name):
        DeadbandConfig(**(base | kwargs))
