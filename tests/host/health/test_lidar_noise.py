"""LiDAR noise: a revolution's range noise is measured; a rough LiDAR is suspect, a useless one
excluded (and stops a navigation mission)."""

from __future__ import annotations

import numpy as np
import pytest

from jackson.host.health import Health, HealthConfig
from jackson.host.health.lidar_noise import LidarNoise
from jackson.host.health.types import ScanInput

from .synthetic import Robot, monitor, room_scan, scans


def test_a_healthy_lidar_raises_no_alarm_and_its_noise_is_measured() -> None:
    mon, rng = monitor(), np.random.default_rng(30)
    _, used = scans(mon, rng, 0.0, 120.0)
    assert all(used) and mon.transitions == []
    assert mon.lidar_roughness_m == pytest.approx(0.01, rel=0.15)
    assert mon.lidar_missing < 0.05


def test_a_noisy_lidar_is_suspect_and_a_useless_one_excluded_and_stops_navigation() -> None:
    mon, rng = monitor(), np.random.default_rng(31)
    t, _ = scans(mon, rng, 0.0, 5.0)
    t, used = scans(mon, rng, t, 1.0, sigma=0.05)
    assert mon.state("lidar") is Health.SUSPECT and all(used)  # rough but usable
    assert mon.lidar_roughness_m == pytest.approx(0.05, rel=0.15)
    t, used = scans(mon, rng, t, 1.0, sigma=0.2)
    assert not any(used) and mon.state("lidar") is Health.EXCLUDED, mon.transitions
    robot = Robot(31)
    assert mon.update(robot.frame(0.1, 0.0)).lost is None  # nothing navigates by it
    mon.lidar.needed = True
    lost = mon.update(robot.frame(0.1, 0.0)).lost
    assert lost is not None and "LiDAR" in lost
    t, used = scans(mon, rng, t, 3.0)  # the noise goes: back in after recover_s
    assert mon.state("lidar") is Health.RECOVERED and used[-1] and not used[0]


def test_too_few_returns_are_not_judged() -> None:
    check = LidarNoise(HealthConfig())
    ranges = np.full(1080, np.inf)
    ranges[:20] = np.random.default_rng(1).normal(1.0, 0.5, 20)  # 18 triplets of very rough
    assert check.observe(ScanInput(1.0, ranges)) == []
    assert check.smooth and check.usable and check.roughness_m == 0.0
    rough = check.observe(ScanInput(1.1, room_scan(np.random.default_rng(2), 0.2)))
    assert not check.usable and rough[0].reason.startswith("range noise")
