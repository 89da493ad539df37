"""The yaw cross-check: spikes, the windowed test, the tyres' creep, and a bias step."""

from __future__ import annotations

import pytest

from jackson.host.health import Health, HealthMonitor

from .synthetic import DT, Robot, drive, monitor


def test_a_spike_is_not_fused_and_three_in_a_window_exclude_the_imu_until_it_recovers() -> None:
    mon, robot = monitor(), Robot(2)
    drive(mon, robot, 5.0, 0.1, 0.2)
    (one,) = drive(mon, robot, DT, 0.1, 0.2, gyro_extra=2.0)
    assert not one.use_gyro  # not fused; a spike once the next sample passes
    drive(mon, robot, DT, 0.1, 0.2)
    assert mon.state("imu") is Health.SUSPECT
    drive(mon, robot, 0.2, 0.1, 0.2)
    drive(mon, robot, DT, 0.1, 0.2, gyro_extra=-2.0)
    drive(mon, robot, 0.1, 0.1, 0.2)
    (third,) = drive(mon, robot, DT, 0.1, 0.2, gyro_extra=2.0)
    (after,) = drive(mon, robot, DT, 0.1, 0.2)
    assert not third.use_gyro and not after.use_gyro and after.lost is None
    assert mon.state("imu") is Health.EXCLUDED
    verdicts = drive(mon, robot, 2.5, 0.1, 0.2)
    assert mon.state("imu") is Health.RECOVERED and verdicts[-1].use_gyro
    drive(mon, robot, 10.0, 0.1, 0.2)
    assert mon.state("imu") is Health.OK
    assert [t.new for t in mon.transitions] == [
        Health.SUSPECT,
        Health.EXCLUDED,
        Health.RECOVERED,
        Health.OK,
    ]
    assert mon.counts["gated"] == 3


def test_a_gyro_bias_step_while_driving_is_held_as_ambiguous_then_charged_to_the_gyro() -> None:
    """Over a short window a bias step and a slipping wheel look alike and the accelerometer
    cannot tell them apart at 0.1 m/s: the wheels' yaw stands in, and a disagreement that
    outlasts ``ambiguity_s`` is the gyro's; it stays out while the disagreement lasts."""
    mon, robot = monitor(), Robot(10)
    drive(mon, robot, 5.0, 0.1, 0.15)
    verdicts = drive(mon, robot, 6.0, 0.1, 0.15, gyro_extra=0.05)
    first = next(i for i, v in enumerate(verdicts) if not v.use_gyro)
    assert first * DT < 1.5  # the windowed test: about a window
    assert verdicts[first].hold_yaw  # ambiguous first: the wheels' yaw rate stands in
    assert mon.state("imu") is Health.EXCLUDED and "longer than a slipping wheel" in mon.reason(
        "imu"
    )
    assert mon.state("encoder_left").usable and mon.state("encoder_right").usable
    assert not any(v.use_gyro for v in verdicts[first:])
    assert all(v.lost is None for v in verdicts)


def test_a_gyro_bias_step_is_still_found_once_the_model_is_learned() -> None:
    """The model learned over straights, arcs and pivots at navigation speeds; a +0.05 rad/s
    bias step on a straight at 0.25 m/s is the gyro's."""
    mon, robot = monitor(), Robot(43)
    for _ in range(3):
        for v, w, span in ((0.25, 0.0, 5.0), (0.15, 0.4, 3.0), (0.0, 0.8, 2.0)):
            drive(mon, robot, span, v, w)
    assert mon.model.identified == [True, True] and mon.transitions == []
    verdicts = drive(mon, robot, 6.0, 0.25, 0.0, gyro_extra=0.05)
    first = next(i for i, v in enumerate(verdicts) if not v.use_gyro)
    assert first * DT < 1.5
    assert mon.state("imu") is Health.EXCLUDED
    assert mon.state("encoder_left").usable and mon.state("encoder_right").usable
    assert abs(mon.model.per_metre) < 0.02  # the step was not learned as geometry


def test_with_the_gyro_excluded_the_wheels_yaw_rate_stands_in_through_the_model() -> None:
    mon, robot = monitor(), Robot(10)
    drive(mon, robot, 5.0, 0.1, 0.15)
    verdicts = drive(mon, robot, 6.0, 0.1, 0.15, gyro_extra=0.05)
    v = verdicts[-1]
    assert not v.use_gyro and v.use_left and v.use_right
    assert v.wheel_yaw_rate_rad_s == pytest.approx(0.15, abs=0.05)  # the true rate, not 0.20
    assert v.wheel_yaw_variance > 0.02**2  # at least the gyro's own


def _turn_in(mon: HealthMonitor, robot: Robot, creep: float) -> None:
    """Healthy driving, then turning in from 0.08 m/s to 0.24 m/s and 0.72 rad/s in 0.4 s
    (1.8 rad/s^2) with the outer wheel over-reading its floor speed by ``creep``."""
    drive(mon, robot, 1.0, 0.0, 0.0)
    for _ in range(3):
        for v, w, span in ((0.25, 0.0, 4.0), (0.15, 0.4, 3.0), (0.0, 0.8, 2.0)):
            drive(mon, robot, span, v, w)
    drive(mon, robot, 4.0, 0.08, 0.0)
    assert mon.transitions == []
    for k in range(1, 9):
        drive(mon, robot, DT, 0.08 + 0.02 * k, 0.09 * k, slip=(1.0, 1.0 + creep))
    drive(mon, robot, 3.0, 0.24, 0.72)


@pytest.mark.parametrize("seed", [50, 51, 52])
def test_the_tyres_creep_while_turning_in_at_speed_is_no_fault(seed: int) -> None:
    """Turning in at speed, the outer tyre creeps under the traction that turns the robot: its
    wheel reads 20 % more than the floor moved for 0.4 s (0.2 rad/s of yaw the robot does
    not make, as the twin's tyres do). The creep term (kappa_a v alpha) covers it."""
    mon, robot = monitor(), Robot(seed)
    _turn_in(mon, robot, 0.2)
    assert mon.transitions == [], mon.transitions[:2]


def test_a_wheel_spinning_while_turning_in_is_still_found() -> None:
    """The same turn-in with the outer wheel spinning 50 % faster than the floor: beyond any
    creep, the right wheel is excluded."""
    mon, robot = monitor(), Robot(50)
    _turn_in(mon, robot, 0.5)
    assert mon.transitions[0].sensor == "encoder_right"
    assert mon.transitions[0].new is Health.EXCLUDED
    assert mon.state("imu").usable
