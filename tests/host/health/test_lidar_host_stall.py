"""A silence the daemon's own stall makes is not the LiDAR's: the robot is held, the LiDAR not
blamed, and only a silence that outlasts the stall by ``lidar_silence_s`` excludes it."""

from __future__ import annotations

import numpy as np

from jackson.host.health import Health

from .synthetic import DT, Robot, monitor, room_scan, scans


def _stalled(stall_s: float, silent_after_s: float) -> tuple[object, Robot, float, list[float]]:
    """A navigating robot whose daemon stalls ``stall_s`` after its scans; the frames that waited
    then come without a scan, and scans come again ``silent_after_s`` after the stall began
    (never, for ``inf``). (monitor, robot, the stall's frame time, frames at which it was held)"""
    mon, rng = monitor(), np.random.default_rng(41)
    mon.lidar.needed = True
    t, _ = scans(mon, rng, 0.0, 5.0)
    robot = Robot(41)
    robot.t = t
    mon.update(robot.frame(0.28, 0.0))
    stalled_at = robot.t
    mon.lidar.host_stalled(stalled_at, stall_s)
    held = []
    for _ in range(round(3.5 / DT)):
        f = robot.frame(0.28, 0.0)
        if f.t_s - stalled_at >= silent_after_s and mon.lidar.scan(f.t_s, room_scan(rng, 0.01)):
            pass
        mon.update(f)
        if mon.lidar_blind:
            held.append(f.t_s)
    return mon, robot, stalled_at, held


def test_a_silence_the_daemon_stall_made_holds_the_robot_without_blaming_the_lidar() -> None:
    mon, _, stalled_at, held = _stalled(1.3, 1.3)
    assert held and held[0] - stalled_at < 0.3  # braked while its scans catch up
    assert mon.state("lidar") is Health.OK and not [
        x for x in mon.transitions if x.sensor == "lidar"
    ]
    assert not mon.lidar_blind and "blind" not in mon.counts  # a scan came: going on


def test_a_lidar_still_silent_after_the_stall_is_excluded_a_silence_later() -> None:
    mon, _, stalled_at, held = _stalled(1.0, float("inf"))
    lidar = [x for x in mon.transitions if x.sensor == "lidar"]
    assert mon.state("lidar") is Health.EXCLUDED and "no scan for" in lidar[0].reason
    assert lidar[0].new is Health.EXCLUDED  # never blamed for the stall's part (no suspect)
    assert 2.0 - DT <= lidar[0].t_s - stalled_at <= 2.0 + 2 * DT  # the stall, then 1 s
    assert held[-1] > lidar[0].t_s  # held all along


def test_a_silence_that_began_before_the_stall_is_the_lidars() -> None:
    mon, rng = monitor(), np.random.default_rng(42)
    mon.lidar.needed = True
    t, _ = scans(mon, rng, 0.0, 5.0)
    robot = Robot(42)
    robot.t = t
    for _ in range(10):  # 0.5 s without a scan before the daemon stalls
        mon.update(robot.frame(0.28, 0.0))
    assert mon.lidar_blind and mon.state("lidar") is Health.SUSPECT
    mon.lidar.host_stalled(robot.t, 1.0)
    for _ in range(12):
        mon.update(robot.frame(0.28, 0.0))
    assert mon.state("lidar") is Health.EXCLUDED  # 1 s after its last scan, as without a stall


def test_the_daemon_tells_its_own_stall_once_and_the_replay_reads_it_back() -> None:
    """A frame loop that did not turn for HOST_STALL_S or more, once frames came, while the
    device went on (frames waiting): one line (a link record in the run's log), the core told
    the stall rounded to 10 ms, which the line gives back exactly. A device that waited for the
    daemon meanwhile (one frame waiting: a twin in lockstep) saw no stall: nothing told."""
    from types import SimpleNamespace

    from jackson.host.daemon_link import HOST_STALL_BACKLOG, HOST_STALL_S, LinkWatch, host_stall_s

    stalls: list[float] = []
    core = SimpleNamespace(t_s=None, host_stalled=stalls.append)
    told: list[str] = []
    backlog = [HOST_STALL_BACKLOG - 1]
    link = SimpleNamespace(backlog_frames=lambda: backlog[0])
    watch = LinkWatch(link, None, core, None, told.append)  # type: ignore[arg-type]
    watch.started(10.0)
    watch.turn(10.0)
    watch.turn(12.0)  # before the first frame: the start-up is not a stall
    core.t_s = 4.2
    watch.turn(12.1)
    watch.turn(14.0)  # 1.9 s, and the device waited: no stall
    assert told == [] and stalls == []
    backlog[0] = 37
    for now in (14.1, 14.2, 14.2 + HOST_STALL_S - 0.01, 15.5317, 15.6):
        watch.turn(now)
    assert told == [
        "daemon stalled 0.84 s: its frame loop did not run (stopped, starved of CPU, or busy); "
        "the LiDAR's silence meanwhile is not the LiDAR's"
    ]
    assert stalls == [0.84] and host_stall_s(told[0]) == 0.84
    assert host_stall_s("lockstep stalled: ...") is None
