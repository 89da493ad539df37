"""The LiDAR's intake: bytes as read, whole revolutions at the next telemetry frame stamped
with its time, judged by the health monitor's LiDAR checks."""

from __future__ import annotations

import numpy as np

from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.health import Health, HealthConfig, HealthInput, HealthMonitor
from jackson.host.lidar.intake import ScanIntake
from jackson.protocol.rplidar.nodes import encode_nodes

BEAMS = 720
FRAME_S = 0.05


def turn(ranges_m: np.ndarray) -> bytes:
    """One revolution of standard nodes (the first with its start flag), evenly spread."""
    n = len(ranges_m)
    start = np.zeros(n, dtype=bool)
    start[0] = True
    angle_q6 = np.arange(n) * (360 * 64) // n
    distance_q2 = np.round(np.asarray(ranges_m) * 4000.0).astype(np.int64)
    return encode_nodes(start, 47, angle_q6, distance_q2)


def room(rng: np.random.Generator, sigma: float = 0.0) -> np.ndarray:
    """Ranges in a 4 m x 3 m room from (0.7, 0.4), with N(0, sigma^2) noise [m]."""
    a = np.linspace(0.0, 2.0 * np.pi, BEAMS, endpoint=False)
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, 1.3 / c, np.where(c < 0, -2.7 / c, np.inf))
        ty = np.where(s > 0, 1.1 / s, np.where(s < 0, -1.9 / s, np.inf))
    return np.clip(np.minimum(tx, ty) + rng.normal(0.0, sigma, BEAMS), 0.2, 8.0)


def still(t_s: float) -> HealthInput:
    """A frame of a robot standing still, its IMU live."""
    return HealthInput(
        t_s=t_s,
        imu_ok=True,
        imu_raw=(int(t_s * 1000) % 7, 0, 16384, 0, 0, 0, 0),
        wz_rad_s=0.0,
        wheel_rad_s=(0.0, 0.0),
        ticks=(0, 0),
        dt_s=FRAME_S,
        wheel_cmd_rad_s=(0.0, 0.0),
        commanded_still=True,
        accel_y_m_s2=0.0,
        accel_x_m_s2=0.0,
    )


def test_a_revolution_waits_for_the_next_frame_and_is_stamped_with_its_time() -> None:
    intake, rng = ScanIntake(), np.random.default_rng(1)
    ranges = room(rng)
    intake.feed(turn(ranges)[: 5 * 300])  # part of a turn: nothing yet
    assert not intake.pending
    intake.feed(turn(ranges)[5 * 300 :])
    assert not intake.pending  # complete only once the next turn's first node comes
    intake.feed(turn(ranges)[:5])
    assert intake.pending
    (rev,) = intake.take(1.25, needed=False)
    scan, use = intake.scan(1.25, rev)
    assert use and scan.t_s == 1.25 and intake.scans == 1 and intake.last_scan is scan
    assert len(scan.ranges_m) == BEAMS
    np.testing.assert_allclose(np.sort(scan.ranges_m), np.sort(ranges), atol=0.001)
    assert not intake.pending and intake.take(1.3, needed=False) == []


def test_the_intake_judges_each_revolution_with_the_lidar_checks() -> None:
    mon = HealthMonitor(HealthConfig(), RobotGeometry())
    intake, rng = ScanIntake(mon.lidar), np.random.default_rng(2)
    uses = []
    for k, sigma in enumerate((0.0, 0.01, 0.3, 0.3, 0.3, 0.3, 0.0)):
        intake.feed(turn(room(rng, sigma)))  # and the previous revolution is complete
        for rev in intake.take(0.15 * k, needed=True):
            uses.append(intake.scan(0.15 * k, rev)[1])
    # two smooth revolutions, then rough ones: not used, three in a row exclude the LiDAR
    assert uses == [True, True, False, False, False, False]
    assert mon.state("lidar") is Health.EXCLUDED and "range noise" in mon.reason("lidar")
    assert mon.lidar.needed and mon.lidar_counts == {"scans": 6, "unused": 4}


def test_garbage_between_two_frames_is_reported_at_the_next() -> None:
    mon = HealthMonitor(HealthConfig(), RobotGeometry())
    intake, rng = ScanIntake(mon.lidar), np.random.default_rng(3)
    noise = bytes(rng.integers(0, 256, 4000, dtype=np.uint8) & 0xFC)  # check bits all wrong
    intake.feed(turn(room(rng)) + noise + turn(room(rng)))
    intake.take(1.0, needed=False)
    assert mon.state("lidar") is Health.SUSPECT and "malformed" in mon.reason("lidar")


def test_the_intake_hands_on_revolutions_and_a_silent_lidar_is_excluded() -> None:
    """A LiDAR that scanned through the intake and stops: the frames' silence check excludes it
    after ``lidar_silence_s``; a port that fails excludes it at once."""
    mon = HealthMonitor(HealthConfig(), RobotGeometry())
    intake, rng = ScanIntake(mon.lidar), np.random.default_rng(4)
    t, next_turn, taken = 0.0, 0.0, 0
    for _ in range(100):  # 5 s of frames, a revolution every 0.135 s
        t += FRAME_S
        mon.update(still(t))
        while next_turn <= t:
            intake.feed(turn(room(rng, 0.01)))
            next_turn += 0.13465
        if intake.pending:
            for rev in intake.take(t, needed=False):
                taken += intake.scan(t, rev)[1]
    assert taken >= 35 and mon.state("lidar") is Health.OK
    silent_from = t
    while mon.state("lidar") is Health.OK:  # no more bytes
        t += FRAME_S
        mon.update(still(t))
    assert 1.0 - FRAME_S <= t - silent_from <= 1.0 + 2 * FRAME_S
    assert mon.state("lidar") is Health.EXCLUDED and "no scan" in mon.reason("lidar")
    fresh = HealthMonitor(HealthConfig(), RobotGeometry())
    ScanIntake(fresh.lidar).gone(2.5, "LiDAR port went away")
    assert fresh.state("lidar") is Health.EXCLUDED and fresh.transitions[-1].t_s == 2.5


def test_without_the_monitor_every_revolution_is_used() -> None:
    intake, rng = ScanIntake(), np.random.default_rng(5)
    intake.feed(turn(room(rng, 0.5)) + turn(room(rng))[:5])
    (rev,) = intake.take(0.5, needed=True)
    assert intake.scan(0.5, rev)[1]
    intake.gone(0.6, "gone")  # nothing to tell
