"""IMU stuck: registers frozen for ``stuck_s`` exclude the IMU; its sample is not live."""

from __future__ import annotations

from jackson.host.health import Health, HealthConfig
from jackson.host.health.imu_stuck import ImuStuck

from .synthetic import Robot, drive, monitor


def test_frozen_registers_exclude_the_imu() -> None:
    mon, robot = monitor(), Robot(4)
    drive(mon, robot, 3.0, 0.0, 0.3)
    drive(mon, robot, 0.6, 0.0, 0.3, frozen=True)
    assert mon.state("imu") is Health.EXCLUDED and "stuck" in mon.reason("imu")


def test_a_frozen_sample_is_not_live_and_a_changing_one_is() -> None:
    check, robot = ImuStuck(HealthConfig()), Robot(2)
    check.observe(robot.frame(0.0, 0.0))
    found = [check.observe(robot.frame(0.0, 0.0, frozen=True)) for _ in range(10)]
    assert check.frozen and found[-1][0].exclude and "frozen" in found[-1][0].reason
    assert not any(found[:9])  # 0.5 s of the same registers at 20 Hz
    assert check.observe(robot.frame(0.0, 0.0)) == [] and not check.frozen
