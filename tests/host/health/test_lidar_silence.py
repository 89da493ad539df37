"""LiDAR silence: lost revolutions make the LiDAR suspect, a silence excludes it, and a
navigating robot without a usable scan is held."""

from __future__ import annotations

import numpy as np
import pytest

from jackson.host.health import Health

from .synthetic import DT, Robot, drive, monitor, room_scan, scans


def test_lost_revolutions_make_the_lidar_suspect_and_silence_excludes_it() -> None:
    mon, rng = monitor(), np.random.default_rng(32)
    t, _ = scans(mon, rng, 0.0, 10.0)
    t, _ = scans(mon, rng, t, 6.0, lost=0.3)
    assert mon.state("lidar") is Health.SUSPECT and "lost" in mon.reason("lidar")
    assert 0.15 < mon.lidar_missing < 0.45
    t, _ = scans(mon, rng, t, 12.0)
    assert mon.state("lidar") is Health.OK
    robot = Robot(32)
    robot.t = t
    drive(mon, robot, 1.2, 0.1, 0.0)  # frames but no scan
    assert mon.state("lidar") is Health.EXCLUDED and "no scan" in mon.reason("lidar")
    t, used = scans(mon, rng, robot.t, 3.0)
    assert mon.state("lidar") is Health.RECOVERED and used[-1]


def test_a_navigating_robot_is_held_sooner_the_faster_it_drives_when_the_lidar_falls_silent() -> (
    None
):
    """At 0.28 m/s the robot covers lidar_blind_m (6 cm) on its last scan in 0.21 s: it is held
    (lidar_blind, braked) then, and a scan that comes lets it go on; never sooner than 1.5
    revolution periods, the stream's own spacing. A silence of lidar_silence_s (1 s) excludes
    the LiDAR whatever the speed."""
    for v, limit in ((0.28, 0.06 / 0.28), (0.0, 1.0), (2.0, 1.5 * 0.13465)):
        mon, rng = monitor(), np.random.default_rng(33)
        mon.lidar.needed = True
        t, _ = scans(mon, rng, 0.0, 5.0)
        robot = Robot(33)
        robot.t = t
        drive(mon, robot, 0.1, v, 0.0)  # no scan from t on
        assert mon.lidar.silence_limit_s() == pytest.approx(limit, rel=0.05, abs=0.01)
        held_at = None
        for _ in range(round(1.5 / DT)):
            mon.update(robot.frame(v, 0.0))
            if mon.lidar_blind and held_at is None:
                held_at = robot.t
        if v > 0.0:  # standing, the 1 s silence excludes it first (and that brakes too)
            assert held_at is not None and held_at - t <= limit + 2 * DT, (v, held_at, t)
        assert mon.state("lidar") is Health.EXCLUDED and "no scan for 1.0" in mon.reason("lidar")
    mon, rng = monitor(), np.random.default_rng(37)
    mon.lidar.needed = True
    t, _ = scans(mon, rng, 0.0, 5.0)
    robot = Robot(37)
    robot.t = t
    drive(mon, robot, 0.4, 0.28, 0.0)
    assert mon.lidar_blind and mon.state("lidar") is Health.SUSPECT
    assert mon.counts["blind"] == 1
    assert mon.lidar.scan(robot.t, room_scan(rng, 0.01))  # a scan again: the hold ends
    assert not mon.lidar_blind


def test_a_lidar_that_never_scanned_is_not_silent() -> None:
    mon = monitor()
    mon.lidar.needed = True
    drive(mon, Robot(38), 3.0, 0.2, 0.0)
    assert mon.state("lidar") is Health.OK and not mon.lidar_blind and "blind" not in mon.counts
