"""How fast the mapper maps (``jackson bench``'s ``mapping`` suite): robot-seconds of a drive
mapped per CPU-second, loop closure, optimisation and rewrites in their thread included.

The drive is the twin's ray caster in an 8 m x 5 m ring of 1.5 m corridors around a closed
block, once round (20 m) and 3 m on past the start at 0.3 m/s, one A1M8 revolution per scan
period, with odometry that over-reads distance by 2 % and turns by 1 % so that coming back
closes the loop. Only the mapper's CPU counts (the scans are cast before the clock starts); the
target asks for a quarter of a core at most on the machine that runs the bench, so that on a
Jetson, several times slower per core, mapping still keeps up with the LiDAR.
"""

from __future__ import annotations

import math
import time

import numpy as np

from jackson.common.bench import BenchResult, reference_loop_us
from jackson.host.nav.slam.mapper import Mapper, MappingConfig
from jackson.host.nav.types import Pose2D, Scan
from jackson.protocol.rplidar import A1M8_SCAN_PERIOD_S
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles

MAPPING_RATE_TARGET = 4.0  # robot-seconds per CPU-second: a quarter of a core at most
MOUNT = Pose2D(0.04, 0.0, 0.0)
# an 8 m x 5 m ring of 1.5 m corridors around a 5 m x 2 m block, with posts on the outer walls
RING = Obstacles(
    [
        [0.0, 0.0, 8.0, 0.0],
        [8.0, 0.0, 8.0, 5.0],
        [8.0, 5.0, 0.0, 5.0],
        [0.0, 5.0, 0.0, 0.0],
        [1.5, 1.5, 6.5, 1.5],
        [6.5, 1.5, 6.5, 3.5],
        [6.5, 3.5, 1.5, 3.5],
        [1.5, 3.5, 1.5, 1.5],
        [2.5, 0.0, 2.5, 0.3],
        [5.2, 5.0, 5.2, 4.7],
        [8.0, 2.2, 7.7, 2.2],
        [0.0, 3.1, 0.3, 3.1],
    ],
    [(4.0, 0.45, 0.1)],
)


def ring_route(v_m_s: float = 0.3) -> list[Pose2D]:
    """True poses in :data:`RING`, one per scan period: round the corridors' middle (a 20 m
    loop, corners turned on the spot) and 3 m on past the start."""
    corners = [(0.75, 0.75), (7.25, 0.75), (7.25, 4.25), (0.75, 4.25)]
    step = v_m_s * A1M8_SCAN_PERIOD_S
    poses: list[Pose2D] = []
    for lap in range(2):
        for k in range(4):
            (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % 4]
            yaw = math.atan2(y1 - y0, x1 - x0)
            n = round(math.hypot(x1 - x0, y1 - y0) / step)
            for i in range(n if lap == 0 else round(3.0 / step)):
                poses.append(Pose2D(x0 + i / n * (x1 - x0), y0 + i / n * (y1 - y0), yaw))
            if lap == 1:
                return poses
            for turn in np.linspace(yaw, yaw + math.pi / 2, 6)[1:-1]:
                poses.append(Pose2D(x1, y1, float(turn)))
    return poses


def _drive() -> tuple[list[Scan], list[Pose2D]]:
    """The scans and the drifting odometry of the drive (cast before any timing)."""
    sensor = Lidar(LidarSpec(mount_x_m=MOUNT.x, mount_y_m=MOUNT.y), np.random.default_rng(3))
    truth = ring_route()
    scans, odoms = [], []
    odom = truth[0]
    for i, pose in enumerate(truth):
        if i:
            step = truth[i - 1].inverse().compose(pose)
            odom = odom.compose(Pose2D(step.x * 1.02, step.y, step.yaw * 1.01))
        ranges = sensor.scan(pose.x, pose.y, pose.yaw, RING).astype(np.float64)
        scans.append(Scan(i * A1M8_SCAN_PERIOD_S, sensor.angles(), ranges, 0.15, 8.0))
        odoms.append(odom)
    return scans, odoms


def run(quick: bool = False) -> list[BenchResult]:
    """The mapping rate, best of 3 drives (quick: 1).

    Parameters
    ----------
    quick : bool
        One drive.

    Returns
    -------
    list[BenchResult]
        Robot-seconds mapped per CPU-second.
    """
    scans, odoms = _drive()
    robot_s = len(scans) * A1M8_SCAN_PERIOD_S
    best_cpu = math.inf
    loops = 0
    for _ in range(1 if quick else 3):
        mapper = Mapper(MappingConfig())
        t0 = time.process_time()
        for scan, odom in zip(scans, odoms, strict=True):
            mapper.update(scan, odom, MOUNT)
        mapper.finish()
        best_cpu = min(best_cpu, time.process_time() - t0)
        loops = mapper.loops_closed
    return [
        BenchResult(
            "mapping.robot_seconds_per_cpu_second",
            robot_s / best_cpu,
            "robot-s mapped per CPU-s",
            MAPPING_RATE_TARGET,
            "higher",
            f"the drive's robot time: {robot_s:.0f} s round a 20 m ring and 3 m on, "
            f"{len(scans)} scans, {loops} loop closures (the mapper's CPU, its loop-closure "
            "thread included)",
            best_cpu,
            "CPU s",
            None,
            reference_loop_us(),
        )
    ]
