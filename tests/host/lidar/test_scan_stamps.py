"""/scan stamps in the run's bag (``ScanTimer``): never 0, one revolution apart from the first.

The twin's emulated RPLIDAR (Sensitivity, 127 us a sample: revolution k ends at k x 0.13465 s
of sim time) is advanced as the lockstep twin advances it, one 50 ms telemetry frame at a time;
the host's decoder turns its bytes into revolutions at each frame, and the daemon's ROS output
builds /scan into a real bag (MCU time, as with the twin's /clock), which is read back.
"""

from __future__ import annotations

import os
import select
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from jackson.host.core.results import FrameResult
from jackson.host.estimation.odometry import OdometryState
from jackson.host.lidar.rplidar import RevolutionAssembler
from jackson.host.nav.types import Scan
from jackson.host.ros.bag import BagRecorder, read_bag
from jackson.host.ros.messages import RosOutput
from jackson.protocol import Telemetry
from jackson.protocol.rplidar import Command, DataType, encode_request
from jackson.sim.lidar import LidarSpec
from jackson.sim.rplidar import RplidarEmulator

FRAME_S = 0.05  # [s] the telemetry period at 20 Hz
PERIOD_S = 0.13465  # [s] the A1M8's revolution (REFERENCE: LiDAR)
SENSITIVITY = encode_request(Command.EXPRESS_SCAN, bytes((3, 0, 0, 0, 0)))
WITHIN_S = 0.005  # [s] consecutive stamps: one revolution apart within this (docs/ros2.md)


class _Lidar:
    """The twin's RPLIDAR scanning in Sensitivity, read as the daemon reads its port."""

    def __init__(self, lost: frozenset[int] = frozenset()) -> None:
        self.spec = LidarSpec(noise_sigma_m=0.0)
        self.emulator = RplidarEmulator(self.spec)
        self.fd = os.open(self.emulator.path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        self.assembler = RevolutionAssembler(
            streaming=True, answer_type=DataType.MEASUREMENT_ULTRA_CAPSULED
        )
        self.lost = lost  # revolutions (ending at k x period) the twin loses
        self.ranges = np.full(self.spec.beams, 2.0)
        os.write(self.fd, SENSITIVITY)
        select.select([self.emulator.fileno()], [], [], 5.0)
        assert self.emulator.serve(0.0) == 1 and self.emulator.scanning
        self._read()  # the descriptor (the daemon's driver reads it when it starts the scan)

    def _ranges(self, end_s: float) -> NDArray[np.float64] | None:
        k = round(end_s / self.spec.scan_period_s)
        return None if k in self.lost else self.ranges

    def advance(self, t_s: float) -> None:
        """The twin's clock moves to ``t_s``: the revolutions that ended go on the line."""
        self.emulator.advance(t_s, self._ranges)

    def _read(self) -> bytes:
        data = b""
        while select.select([self.fd], [], [], 0.0)[0]:
            chunk = os.read(self.fd, 65536)
            if not chunk:
                break
            data += chunk
        return data

    def read(self) -> list[Scan]:
        """What the port holds now, as the revolutions it completes (a frame's scans)."""
        return [Scan(0.0, r.angles_rad, r.ranges_m) for r in self.assembler.feed(self._read())]

    def close(self) -> None:
        os.close(self.fd)
        self.emulator.close()


def _result(t_s: float) -> FrameResult:
    t = Telemetry(t_us=round(t_s * 1e6), enc_left=0, enc_right=0, flags=0)
    return FrameResult(
        t_s, t, OdometryState(t_s=t_s), 0.0, 0.0, 0.0, 0.0, (0.0, 0.0), True, 0, None, None
    )


def _record(
    tmp_path: Path, frames: int, before_first_s: float = 0.0, lost: frozenset[int] = frozenset()
) -> list[tuple[float, float]]:
    """Run ``frames`` telemetry frames through the ROS output into a bag; the twin's clock may
    run ``before_first_s`` ahead of the first frame the host reads (a host kept away while a
    lockstep twin ran on in real time). The bag's /scan as (stamp [s], scan_time [s])."""
    lidar = _Lidar(lost)
    bag = BagRecorder(tmp_path / "bag")
    out = RosOutput(bag.builder, [bag], telemetry=False)
    try:
        lidar.advance(before_first_s)
        for k in range(1, frames + 1):
            t_s = k * FRAME_S
            lidar.advance(max(t_s, before_first_s))  # a revolution goes out before the frame
            for scan in lidar.read():  # the daemon reads the LiDAR at the frame, before the core
                out.on_scan(Scan(t_s, scan.angles_rad, scan.ranges_m))
            out.on_result(_result(t_s))
    finally:
        lidar.close()
        bag.close()
    scans = read_bag(tmp_path / "bag")["/scan"]
    return [(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, m.scan_time) for _, m in scans]


def _intervals(scans: list[tuple[float, float]]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each stamp's step from the one before, and how many revolutions it spans."""
    stamps = np.array([s for s, _ in scans])
    steps = np.diff(stamps)
    turns = np.round(steps / np.array([d for _, d in scans[1:]]))
    return steps, turns


def _assert_one_revolution_apart(scans: list[tuple[float, float]]) -> NDArray[np.float64]:
    stamps = np.array([s for s, _ in scans])
    assert stamps.min() > 0.0, stamps[:10]  # never 0 (1970 on the robot's clock)
    steps, turns = _intervals(scans)
    assert np.all(turns >= 1), steps
    durations = np.array([d for _, d in scans[1:]])
    error = np.abs(steps - turns * durations)
    assert error.max() < WITHIN_S, (np.argmax(error), error.max(), steps[:20])
    assert np.allclose(durations, PERIOD_S, rtol=0.003)  # the twin's turn, from its samples
    return turns


def test_lockstep_scans_are_one_revolution_apart_from_the_first_and_on_the_twins_clock(
    tmp_path: Path,
) -> None:
    scans = _record(tmp_path, 300)  # 15 s: 110 revolutions
    turns = _assert_one_revolution_apart(scans)
    assert np.all(turns == 1)  # none lost
    # on the twin's clock: revolution k starts at (k - 1) x period; the first ones come within
    # a frame of it, and the phase settles within a few milliseconds
    stamps = np.array([s for s, _ in scans])
    k = np.round(stamps / PERIOD_S)
    late = stamps - k * PERIOD_S
    assert np.all(np.abs(late) < FRAME_S), late[:10]
    assert np.all(np.abs(late[20:]) < WITHIN_S), late[20:]


def test_revolutions_that_arrive_with_the_first_frame_are_not_stamped_0(tmp_path: Path) -> None:
    # the host was away while the twin ran on for 2 s (its heartbeat timeout: real time): the
    # revolutions waiting in the port all come with the first frame the host reads, at 0.05 s,
    # older than they are; before, they were stamped at 0.05 s less a revolution: 0
    scans = _record(tmp_path, 200, before_first_s=2.0)
    assert len(scans) > 60
    _assert_one_revolution_apart(scans)


@pytest.mark.parametrize("lost", [frozenset({30}), frozenset({40, 41}), frozenset({12, 60, 61})])
def test_lost_revolutions_leave_whole_revolutions_between_stamps(
    tmp_path: Path, lost: frozenset[int]
) -> None:
    # before, a lost revolution made the next ones up to 20 ms off for the rest of the window
    scans = _record(tmp_path, 300, lost=lost)
    turns = _assert_one_revolution_apart(scans)
    assert int(np.sum(turns - 1)) == len(lost)
