"""Still bias: a gyro that does not read zero standing still is excluded and its bias measured
again."""

from __future__ import annotations

from jackson.host.health import Health

from .synthetic import Robot, drive, monitor


def test_a_gyro_reading_non_zero_standing_still_is_a_bias_to_measure_again() -> None:
    mon, robot = monitor(), Robot(7)
    drive(mon, robot, 2.0, 0.1, 0.0)
    verdicts = drive(mon, robot, 2.0, 0.0, 0.0, gyro_extra=0.05)
    assert any(v.stationary for v in verdicts)
    assert mon.state("imu") is Health.EXCLUDED and "bias" in mon.reason("imu")
    assert any("bias" in t.reason for t in mon.transitions)
    asked = [v.remeasure_gyro_bias for v in verdicts]
    assert sum(asked) >= 1 and mon.remeasure_bias == asked[-1]


def test_a_gyro_reading_zero_standing_still_is_left_alone() -> None:
    mon, robot = monitor(), Robot(7)
    drive(mon, robot, 2.0, 0.1, 0.0)
    verdicts = drive(mon, robot, 5.0, 0.0, 0.0)
    assert not any(v.remeasure_gyro_bias for v in verdicts) and mon.transitions == []
