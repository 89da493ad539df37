"""Isolation: a lasting disagreement of the wheels and the gyro is charged by the
accelerometer's witnesses: its lateral force, or the forward speed."""

from __future__ import annotations

import pytest

from jackson.host.health import Health

from .synthetic import Robot, drive, monitor


@pytest.mark.parametrize("side", [0, 1])
def test_a_slipping_wheel_is_found_against_the_gyro_and_the_other_wheel(side: int) -> None:
    mon, robot = monitor(), Robot(6)
    drive(mon, robot, 3.0, 0.15, 0.0)
    slip = (1.3, 1.0) if side == 0 else (1.0, 1.3)
    verdicts = drive(mon, robot, 2.0, 0.15, 0.0, slip=slip)
    names = ("encoder_left", "encoder_right")
    assert mon.state(names[side]) is Health.EXCLUDED, mon.transitions
    assert "sides with the gyro" in mon.reason(names[side])
    assert verdicts[-1].use_gyro  # held only while the witness made up its mind
    assert mon.state(names[1 - side]) is Health.OK and mon.state("imu").usable
    drive(mon, robot, 4.0, 0.15, 0.0)  # off the patch
    assert mon.state(names[side]) is Health.RECOVERED and mon.state("imu") is Health.OK


@pytest.mark.parametrize("side", [0, 1])
def test_a_slow_slip_is_told_from_a_gyro_fault_by_the_forward_speed(side: int) -> None:
    """At 0.05 m/s the lateral force hardly tells a slipping wheel from a gyro that jumped;
    the wheels' forward speed running away from the accelerometer's does."""
    mon, robot = monitor(), Robot(16 + side)
    drive(mon, robot, 3.0, 0.05, 0.0)
    slip = (2.5, 1.0) if side == 0 else (1.0, 2.5)
    drive(mon, robot, 1.0, 0.05, 0.0, slip=slip)
    names = ("encoder_left", "encoder_right")
    assert mon.state(names[side]) is Health.EXCLUDED, mon.transitions
    assert "sides with the gyro" in mon.reason(names[side])
    assert mon.state("imu").usable
    # the speed witness alone: the gap is the slip's (its sign names the wheel), not zero
    gap = mon.isolation.speed_gap(3.1)
    assert gap is not None
    g, x, sigma = gap
    assert abs(x) > 3.0 * sigma and (x > 0) == (side == 1)  # + : the right wheel
    slip_gap = x if side == 1 else -x
    assert abs(g - slip_gap) < 0.5 * abs(x) < abs(g)


def test_a_slow_gyro_jump_is_not_blamed_on_a_wheel() -> None:
    """The same disagreement from the gyro's side: the wheels' speed agrees with the
    accelerometer's, so no wheel is excluded but the gyro is."""
    mon, robot = monitor(), Robot(18)
    drive(mon, robot, 3.0, 0.05, 0.0)
    drive(mon, robot, 1.5, 0.05, 0.0, gyro_extra=-0.4)
    assert mon.state("encoder_left").usable and mon.state("encoder_right").usable
    assert mon.state("imu") is Health.EXCLUDED, mon.transitions
    assert "sides with the wheels" in mon.reason("imu")
    gap = mon.isolation.speed_gap(3.1)
    assert gap is not None
    g, x, sigma = gap
    assert abs(x) > 3.0 * sigma and abs(g) < min(abs(g - x), abs(g + x))


def test_without_enough_frames_the_speed_witness_says_nothing() -> None:
    mon, robot = monitor(), Robot(19)
    drive(mon, robot, 0.5, 0.05, 0.0)
    assert mon.isolation.speed_gap(0.4) is None
    assert not mon.isolation.ambiguous
