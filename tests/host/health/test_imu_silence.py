"""IMU silence: frames without IMU_OK for ``imu_silence_s`` exclude the IMU, and the policy
decides whether the robot goes on."""

from __future__ import annotations

from jackson.host.health import Health, HealthConfig
from jackson.host.health.imu_silence import ImuSilence

from .synthetic import DT, Robot, drive, monitor


def test_a_dead_imu_is_excluded_and_the_policy_decides() -> None:
    for policy, lost in (("continue", False), ("stop", True)):
        mon, robot = monitor(imu_lost=policy), Robot(3)
        drive(mon, robot, 3.0, 0.1, 0.0)
        verdicts = drive(mon, robot, 0.3, 0.1, 0.0, imu_ok=False)
        first = next(i for i, v in enumerate(verdicts) if mon.transitions)
        assert mon.state("imu") is Health.EXCLUDED
        assert (first + 1) * DT <= 0.25 + DT + 1e-9
        assert (verdicts[-1].lost is not None) == lost
        assert "dead" in mon.reason("imu")


def test_the_check_fails_at_imu_silence_s_and_not_a_frame_before() -> None:
    check, robot = ImuSilence(HealthConfig()), Robot(1)
    assert check.observe(robot.frame(0.0, 0.0)) == []
    found = [check.observe(robot.frame(0.0, 0.0, imu_ok=False)) for _ in range(5)]
    assert [bool(f) for f in found] == [False, False, False, False, True]  # 0.25 s at 20 Hz
    (finding,) = found[-1]
    assert finding.sensor == "imu" and finding.exclude and not finding.passed
    assert check.observe(robot.frame(0.0, 0.0)) == []  # a sample again: silent no more
