"""Encoder stuck: a wheel that must turn and does not count is excluded; a drive that does not
move is not two cut encoders."""

from __future__ import annotations

from dataclasses import replace

import pytest

from jackson.host.health import Health

from .synthetic import DT, Robot, drive, monitor


@pytest.mark.parametrize("side", [0, 1])
def test_a_cut_encoder_wire_excludes_that_encoder_only(side: int) -> None:
    mon, robot = monitor(), Robot(5)
    drive(mon, robot, 3.0, 0.15, 0.0)
    stuck = (side == 0, side == 1)
    verdicts = drive(mon, robot, 1.0, 0.15, 0.0, stuck=stuck)
    names = ("encoder_left", "encoder_right")
    assert mon.state(names[side]) is Health.EXCLUDED, mon.transitions
    assert mon.state(names[1 - side]) is Health.OK and mon.state("imu") is Health.OK
    assert verdicts[-1].lost is None and verdicts[-1].use_gyro
    assert not (verdicts[-1].use_left, verdicts[-1].use_right)[side]
    # with the IMU gone too, nothing is left to steer by: the policy brakes
    drive(mon, robot, 0.3, 0.15, 0.0, stuck=stuck, imu_ok=False)
    assert mon.update(robot.frame(0.15, 0.0, stuck=stuck, imu_ok=False)).lost is not None


def test_a_cut_encoder_is_back_once_it_counts_and_agrees_again() -> None:
    mon, robot = monitor(), Robot(5)
    drive(mon, robot, 3.0, 0.15, 0.0)
    drive(mon, robot, 1.0, 0.15, 0.0, stuck=(True, False))
    assert mon.state("encoder_left") is Health.EXCLUDED
    drive(mon, robot, 2.5, 0.15, 0.0)
    assert mon.state("encoder_left") is Health.RECOVERED
    # suspect at its first silent sample, excluded once silent for encoder_stuck_s
    assert [t.new for t in mon.transitions][-2:] == [Health.EXCLUDED, Health.RECOVERED]
    assert {t.sensor for t in mon.transitions} == {"encoder_left"}


def test_two_silent_wheels_judged_by_the_command_alone_are_not_two_cut_encoders() -> None:
    """Before the gyro's bias is known the command is the only witness: a robot whose motors do
    not move yet (the interlock, a stall) must not lose both encoders and brake for good."""
    mon, robot = monitor(), Robot(11)
    for _ in range(round(2.0 / DT)):
        h = robot.frame(0.0, 0.0)
        h = replace(h, wz_rad_s=None, wheel_cmd_rad_s=(4.5, 4.5), commanded_still=False)
        assert mon.update(h).lost is None
    assert mon.state("encoder_left") is Health.OK and mon.state("encoder_right") is Health.OK
