"""The paper's Stage 3 course as test fixtures: the corridor, its map, scans in it, an ideal
differential drive, and seeded perfect mazes (shared by the planner, DWB and navigator tests)."""

from __future__ import annotations

import math

import numpy as np

from jackson.experiments.bench_stage3 import perfect_maze
from jackson.experiments.metrics import Cylinder
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D
from jackson.sim.lidar import A1M8_ANGLE_INCREMENT_RAD, A1M8_BEAMS, Obstacles, cast

RES = 0.05
DT_S = 0.05  # [s] the 20 Hz control period
SCAN_PERIOD_S = 0.13465  # [s] RPLIDAR A1M8
START = Pose2D(-0.6909, -0.0364, 0.0)  # REFERENCE Stage 3
GOAL = Pose2D(1.2091, -0.0364, 0.0)
CYLINDER = Cylinder(0.6091, -0.0364, 0.125)
INSERT_AFTER_M = 0.1217
WALLS = (
    (-1.2, -0.9, 1.8, -0.9),
    (1.8, -0.9, 1.8, 0.8),
    (1.8, 0.8, -1.2, 0.8),
    (-1.2, 0.8, -1.2, -0.9),
)
"""The corridor of the twin's stage3_corridor world: 3.0 m x 1.7 m around the course."""


def corridor_map() -> OccupancyGrid:
    """The course's static map: the corridor free, its walls occupied, outside unknown."""
    g = OccupancyGrid.empty(3.4, 2.1, RES, origin_x_m=-1.4, origin_y_m=-1.1, fill=-1)
    rows, cols = np.mgrid[0 : g.height, 0 : g.width]
    x, y = g.cell_to_world(rows, cols)
    g.data[(x > -1.2) & (x < 1.8) & (y > -0.9) & (y < 0.8)] = 0
    s = np.linspace(0.0, 1.0, 400)
    for x1, y1, x2, y2 in WALLS:
        r, c = g.world_to_cell(x1 + s * (x2 - x1), y1 + s * (y2 - y1))
        g.data[r, c] = 100
    return g


def scan_points(pose: Pose2D, obstacles: Obstacles, rng: np.random.Generator, sigma_m: float):
    """One A1M8 scan from ``pose`` as map-frame points (exact ray casting plus noise)."""
    angles = -math.pi + A1M8_ANGLE_INCREMENT_RAD * np.arange(A1M8_BEAMS) + pose.yaw
    r = cast((pose.x, pose.y), angles, obstacles, 8.0)
    if sigma_m > 0.0:
        r = r + rng.normal(0.0, sigma_m, r.shape)
    ok = np.isfinite(r) & (r >= 0.15) & (r <= 8.0)
    return np.column_stack(
        (pose.x + r[ok] * np.cos(angles[ok]), pose.y + r[ok] * np.sin(angles[ok]))
    )


def unicycle(pose: Pose2D, v: float, w: float, dt: float) -> Pose2D:
    """Ideal differential drive: the exact arc (Eq. 1) over one step."""
    if abs(w) < 1e-9:
        return Pose2D(
            pose.x + v * dt * math.cos(pose.yaw), pose.y + v * dt * math.sin(pose.yaw), pose.yaw
        )
    yaw = pose.yaw + w * dt
    x = pose.x + v / w * (math.sin(yaw) - math.sin(pose.yaw))
    y = pose.y - v / w * (math.cos(yaw) - math.cos(pose.yaw))
    return Pose2D(x, y, math.atan2(math.sin(yaw), math.cos(yaw)))


def maze_map(size_m: float, cell_m: float, seed: int) -> OccupancyGrid:
    """A perfect maze (depth-first carved, seeded) of ``cell_m`` cells with 0.1 m walls."""
    n, k = round(size_m / RES), round(cell_m / RES)
    return OccupancyGrid(perfect_maze(n, k, 2, np.random.default_rng(seed)), RES)
