"""Throughput of the LiDAR model: full 1080-beam scans per second of wall-clock time.

The twin takes 7.43 scans per simulated second and must run at least 200 times faster than
real time with the LiDAR on, so :meth:`~jackson.sim.lidar.Lidar.scan` needs well over
``200 / 0.13465 = 1485`` scans/s on one core.
"""

from __future__ import annotations

import time

import numpy as np

from jackson.common.bench import BenchResult
from jackson.sim.lidar import A1M8_SCAN_PERIOD_S, Lidar, LidarSpec, Obstacles

REAL_TIME_FACTOR = 200
SCANS_PER_S_TARGET = REAL_TIME_FACTOR / A1M8_SCAN_PERIOD_S  # [scans/s] 1485.3
ROOM_SIDE_M = 6.0
CYLINDER_RADIUS_M = 0.125  # the Stage 3 obstacle


def square_room(n_segments: int, n_circles: int, seed: int = 7) -> Obstacles:
    """A 6 m square room centred on the origin, with cylinders of radius 0.125 m inside.

    The four walls are split into ``n_segments`` collinear pieces in all; the ``n_circles``
    cylinders stand at seeded random places at least 0.5 m from the walls.
    """
    if n_segments < 4:
        raise ValueError(f"a square room needs at least 4 segments, got {n_segments}")
    h = ROOM_SIDE_M / 2
    corners = np.array(((-h, -h), (h, -h), (h, h), (-h, h), (-h, -h)))
    obstacles = Obstacles()
    for wall in range(4):
        pieces = n_segments // 4 + (wall < n_segments % 4)
        points = np.linspace(corners[wall], corners[wall + 1], pieces + 1)
        obstacles.add_polygon(points.tolist(), closed=False)
    rng = np.random.default_rng(seed)
    for cx, cy in rng.uniform(-h + 0.5, h - 0.5, size=(n_circles, 2)):
        obstacles.add_circle(float(cx), float(cy), CYLINDER_RADIUS_M)
    return obstacles


def scans_per_second(n_segments: int = 40, n_circles: int = 4, seconds: float = 1.0) -> float:
    """Full scans per second :meth:`Lidar.scan` achieves in :func:`square_room`.

    The pose changes every scan (64 seeded poses inside the room), noise is on, as in the twin.
    """
    obstacles = square_room(n_segments, n_circles)
    lidar = Lidar(LidarSpec(), np.random.default_rng(1))
    h = ROOM_SIDE_M / 2 - 0.3
    poses = np.random.default_rng(2).uniform((-h, -h, -np.pi), (h, h, np.pi), size=(64, 3))
    pose_list = [(float(x), float(y), float(yaw)) for x, y, yaw in poses]
    for pose in pose_list[:8]:
        lidar.scan(*pose, obstacles)
    count = 0
    t0 = time.perf_counter()
    deadline = t0 + seconds
    while True:
        lidar.scan(*pose_list[count % len(pose_list)], obstacles)
        count += 1
        now = time.perf_counter()
        if now >= deadline:
            return count / (now - t0)


def run(quick: bool = False) -> list[BenchResult]:
    """The LiDAR figure for ``jackson bench``."""
    rate = scans_per_second(seconds=0.3 if quick else 1.0)
    return [BenchResult("sim.lidar_scans_per_s", rate, "scans/s", SCANS_PER_S_TARGET, "higher")]


if __name__ == "__main__":
    print(f"{scans_per_second():.0f} scans/s (target {SCANS_PER_S_TARGET:.0f})")
