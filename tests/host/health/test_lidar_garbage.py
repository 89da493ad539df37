"""LiDAR garbage: malformed bytes and revolutions that are not a turn; and a port that fails."""

from __future__ import annotations

import numpy as np

from jackson.host.health import Health

from .synthetic import BEAMS, DT, monitor, room_scan, scans


def test_garbage_on_the_lidar_line_is_suspect_within_half_a_second_then_excluded() -> None:
    mon, rng = monitor(), np.random.default_rng(35)
    t, _ = scans(mon, rng, 0.0, 5.0)
    for k in range(40):  # clean bytes: 5 per node, 1080 nodes every 0.135 s, read per frame
        mon.lidar.bytes_read(t + k * DT, 2000, 0)
    t += 40 * DT
    assert mon.state("lidar") is Health.OK
    onset = t
    for k in range(30):  # half of every frame's bytes malformed
        mon.lidar.bytes_read(t + k * DT, 2000, 1000)
    t += 30 * DT
    first = [x for x in mon.transitions if x.sensor == "lidar"]
    assert first[0].new is Health.SUSPECT and first[0].t_s - onset <= 0.5
    assert "malformed" in first[0].reason
    assert mon.state("lidar") is Health.EXCLUDED  # it lasted
    assert not mon.lidar.scan(t, room_scan(rng, 0.01))  # a scan decoded meanwhile is not used


def test_garbage_while_navigating_holds_the_robot() -> None:
    mon, rng = monitor(), np.random.default_rng(35)
    mon.lidar.needed = True
    t, _ = scans(mon, rng, 0.0, 2.0)
    mon.lidar.bytes_read(t, 2000, 1000)
    assert mon.lidar_blind


def test_a_revolution_that_is_not_a_turn_is_not_used() -> None:
    mon, rng = monitor(), np.random.default_rng(36)
    t, _ = scans(mon, rng, 0.0, 2.0)
    angles = np.linspace(0.0, 0.5, 40)  # a few random nodes decoded as a "revolution"
    assert not mon.lidar.scan(t + DT, np.full(40, 1.0), angles)
    assert mon.state("lidar") is Health.SUSPECT and "not a turn" in mon.reason("lidar")
    whole = np.linspace(0.0, 2.0 * np.pi, BEAMS, endpoint=False)
    assert mon.lidar.scan(t + 3 * DT, room_scan(rng, 0.01), whole)
    assert mon.lidar_counts["unused"] == 1


def test_a_lidar_port_that_fails_is_excluded_at_once() -> None:
    mon = monitor()
    mon.lidar.needed = True
    mon.lidar.gone(4.2, "LiDAR port /dev/pts/9 went away (Input/output error)")
    assert mon.state("lidar") is Health.EXCLUDED
    assert mon.transitions[-1].t_s == 4.2 and mon.counts["excluded"] == 1


def _random_bytes_instead_of_revolutions(answer_type: int) -> tuple[object, float]:
    """A navigating robot whose LiDAR's line carries only random bytes from 5 s on, read per
    frame and judged as the core does (revolutions taken, else the bytes unpaired); the
    monitor and the onset."""
    from jackson.host.lidar.intake import ScanIntake

    from .synthetic import Robot

    mon, rng = monitor(), np.random.default_rng(43)
    mon.lidar.needed = True
    t, _ = scans(mon, rng, 0.0, 5.0)
    intake = ScanIntake(mon.lidar)
    intake.assembler.expect(answer_type)
    intake.take(t, True)  # the frame of the last clean revolution
    robot = Robot(43)
    robot.t = t
    onset = t
    for _ in range(round(2.0 / DT)):
        f = robot.frame(0.28, 0.0)
        intake.feed(rng.integers(0, 256, 400, dtype=np.uint8).tobytes())  # 8 kB/s, as an A1M8
        if not intake.pending:
            intake.unpaired(f.t_s)
        mon.update(f)
        for rev in intake.take(f.t_s, True) if intake.pending else []:
            intake.scan(f.t_s, rev)
    return mon, onset


def test_random_bytes_instead_of_revolutions_are_garbage_not_silence() -> None:
    """Bytes that decode to no revolution are judged before the silence they would look like:
    suspect within 0.3 s, excluded as garbage within 0.8 s, never blamed on a silence."""
    from jackson.protocol.rplidar import CAPSULE_FORMATS, DataType

    for answer_type in (DataType.MEASUREMENT, *CAPSULE_FORMATS):
        mon, onset = _random_bytes_instead_of_revolutions(int(answer_type))
        lidar = [x for x in mon.transitions if x.sensor == "lidar"]
        assert lidar and "garbage" in lidar[0].reason, (answer_type, lidar[:1])
        assert lidar[0].t_s - onset <= 0.3, answer_type
        out = [x for x in lidar if x.new is Health.EXCLUDED]
        assert out and "garbage" in out[0].reason and out[0].t_s - onset <= 0.8, answer_type
