"""Every check has the one interface: it observes its input and returns findings, and it never
moves a sensor's state itself."""

from __future__ import annotations

import numpy as np

from jackson.host.health import Finding, FrameFacts, Health
from jackson.host.health.check import Check
from jackson.host.health.types import ByteCount, LidarFrame, LinkInput, ScanInput

from .synthetic import Robot, monitor


def test_each_check_observes_its_input_and_returns_findings_without_moving_a_state() -> None:
    mon = monitor()
    h = Robot(1).frame(0.1, 0.0, imu_ok=False)
    f = FrameFacts(h, False, False, None, 0.0, 0.1, 4e-4)
    inputs = [
        (mon.imu_silence, h),
        (mon.imu_stuck, h),
        (mon.encoders, f),
        (mon.still_bias, f),
        (mon.yaw, f),
        (mon.link_check, LinkInput(0.05, 40)),
        (mon.lidar.garbage, ByteCount(0.05, 2000, 2000)),
        (mon.lidar.noise, ScanInput(0.05, np.linspace(1.0, 9.0, 720) % 2.0)),
        (mon.lidar.silence, LidarFrame(0.05, 0.1, True)),
    ]
    said: dict[str, list[Finding]] = {}
    for check, x in inputs:
        assert isinstance(check, Check), check
        found = check.observe(x)
        assert isinstance(found, list) and all(isinstance(y, Finding) for y in found)
        said[type(check).__name__] = found
    # the link lost 40 frames, the LiDAR sent garbage: failures found, no state moved
    assert [y.sensor for y in said["LinkCheck"] + said["LidarGarbage"]] == ["link", "lidar"]
    assert not any(y.passed for y in said["LinkCheck"] + said["LidarGarbage"])
    assert mon.sensors == dict.fromkeys(mon.sensors, Health.OK) and mon.transitions == []
