"""The monitor as a whole: an hour of healthy driving raises no alarm, and ``jackson monitor``
shows each sensor's health from the frames alone."""

from __future__ import annotations

import numpy as np

from jackson.host.health import SENSORS, Health

from .synthetic import Robot, course, drive, monitor


def test_a_healthy_robot_raises_no_alarm_in_an_hour_of_driving() -> None:
    mon, robot = monitor(), Robot(1)
    for v, w in course(3600.0):
        verdict = mon.update(robot.frame(v, w))
        assert verdict.lost is None
    assert mon.transitions == [], mon.transitions[:3]
    assert mon.counts["gated"] <= 2  # 1e-4 per sample of 72 000


def test_every_sensor_starts_ok_and_a_frame_judges_them_in_order() -> None:
    mon, robot = monitor(), Robot(12)
    assert mon.sensors == dict.fromkeys(SENSORS, Health.OK)
    drive(mon, robot, 3.0, 0.15, 0.0)
    verdicts = drive(mon, robot, 0.8, 0.15, 0.0, imu_ok=False, stuck=(True, False))
    # the dead IMU (0.25 s) first, then the silent wheel judged by the command alone (0.5 s)
    assert [(t.sensor, t.new) for t in mon.transitions] == [
        ("imu", Health.EXCLUDED),
        ("encoder_left", Health.EXCLUDED),
    ]
    lost = verdicts[-1].lost
    assert lost is not None and "the IMU and an encoder" in lost


def test_the_monitor_shows_each_sensors_health_from_the_frames_alone() -> None:
    from jackson.host.monitor import SensorWatch
    from jackson.protocol import Telemetry, TelemetryFlags

    watch = SensorWatch()
    rng = np.random.default_rng(9)
    for k in range(100):  # 5 s standing still, a live IMU, then 1 s without IMU_OK
        flags = TelemetryFlags.IMU_OK if k < 80 else 0
        noise = tuple(int(v) for v in rng.integers(-3, 4, size=3))
        watch.feed(Telemetry(t_us=50_000 * k, flags=flags, accel=(0, 0, 16384), gyro=noise))
        if k == 79:
            assert "imu ok" in watch.line() and "encoder_left ok" in watch.line()
    assert "imu excluded" in watch.line() and "dead" in watch.line()
