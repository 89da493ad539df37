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
