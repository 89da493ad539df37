"""The LiDAR model against pymunk's own ray queries (run by ``jackson bench``).

A full 1080-beam scan of :meth:`~jackson.sim.lidar.Lidar.scan` (noise on) in a 6 m room with
four cylinders, from seeded poses, against the physics library casting the same 1080 rays at the
same geometry (``Space.segment_query_first`` per beam, the closest hit) and against the
textbook vectorised cast (:func:`numpy_rays`: all rays against all segments and circles in one
numpy broadcast, the fair peer for a vectorised model), interleaved pose by pose, each pose's
best time over N rounds. Figures: each peer's time over ours (target: above 1); scans per
second stay beside them. The twin takes
7.43 scans per simulated second.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable

import numpy as np
import pymunk
from numpy.typing import ArrayLike, NDArray

from jackson.common.bench import BenchResult, interleaved_slices
from jackson.protocol.rplidar import A1M8_SCAN_PERIOD_S
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles

REAL_TIME_FACTOR = 200
SCANS_PER_S_TARGET = REAL_TIME_FACTOR / A1M8_SCAN_PERIOD_S  # [scans/s] 1485.3
VS_PYMUNK_TARGET = 1.0
VS_NUMPY_TARGET = 1.0  # the model (with its noise) at least as fast as the plain broadcast
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


def pymunk_room(obstacles: Obstacles) -> pymunk.Space:
    """A pymunk space holding ``obstacles`` as static segments and circles.

    Parameters
    ----------
    obstacles : Obstacles
        The geometry.

    Returns
    -------
    pymunk.Space
        The space, ready for segment queries.
    """
    space = pymunk.Space()
    static = space.static_body
    for x1, y1, x2, y2 in obstacles.segments.tolist():
        space.add(pymunk.Segment(static, (x1, y1), (x2, y2), 0.0))
    for cx, cy, r in obstacles.circles.tolist():
        space.add(pymunk.Circle(static, r, (cx, cy)))
    return space


def numpy_rays(
    obstacles: Obstacles, x: float, y: float, angles_rad: ArrayLike, reach_m: float
) -> NDArray[np.float64]:
    """The nearest hit along each ray by the textbook vectorised cast: every ray against every
    segment and circle at once in (rays x obstacles) arrays, the minimum per ray.

    A ray ``o + t d`` meets segment ``a + u e`` where ``t = (w x e) / (d x e)`` and
    ``u = (w x d) / (d x e)`` (``w = a - o``), 0 <= u <= 1, t >= 0; it meets circle ``(c, r)``
    at ``t = b -+ sqrt(b^2 - |f|^2 + r^2)`` with ``f = c - o``, ``b = d . f`` (the far root
    from inside). Rays hitting nothing within ``reach_m`` get ``inf``. This is the peer the
    model's own cast is judged against: the same geometry with nothing but numpy broadcasting.
    """
    angles = np.asarray(angles_rad, np.float64)
    d = np.stack((np.cos(angles), np.sin(angles)), axis=1)[:, None, :]
    best = np.full(len(angles), np.inf)
    seg = obstacles.segments
    if len(seg):
        a, e = seg[None, :, 0:2], seg[None, :, 2:4] - seg[None, :, 0:2]
        w = a - np.array((x, y))
        den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / den
            u = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / den
        t = np.where((den != 0.0) & (t >= 0.0) & (u >= 0.0) & (u <= 1.0), t, np.inf)
        best = np.minimum(best, t.min(axis=1))
    circ = obstacles.circles
    if len(circ):
        f = circ[None, :, 0:2] - np.array((x, y))
        b = d[..., 0] * f[..., 0] + d[..., 1] * f[..., 1]
        disc = b * b - (f[..., 0] ** 2 + f[..., 1] ** 2) + circ[None, :, 2] ** 2
        root = np.sqrt(np.maximum(disc, 0.0))
        near, far = b - root, b + root
        t = np.where(near >= 0.0, near, far)
        t = np.where((disc >= 0.0) & (t >= 0.0), t, np.inf)
        best = np.minimum(best, t.min(axis=1))
    return np.where(best <= reach_m, best, np.inf)


def _poses(count: int) -> list[tuple[float, float, float]]:
    h = ROOM_SIDE_M / 2 - 0.3
    poses = np.random.default_rng(2).uniform((-h, -h, -np.pi), (h, h, np.pi), size=(count, 3))
    return [(float(x), float(y), float(yaw)) for x, y, yaw in poses]


def vs_pymunk(repeats: int, n_poses: int = 16) -> tuple[float, float, float, float]:
    """Time per scan of the model, of pymunk's ray queries and of the vectorised numpy cast
    (:func:`numpy_rays`), interleaved pose by pose.

    Parameters
    ----------
    repeats : int
        Rounds.
    n_poses : int
        Poses (seeded); each round scans from each, the model then pymunk.

    Returns
    -------
    model_s : float
        Mean over the poses of each pose's best scan time by :meth:`Lidar.scan` [s].
    pymunk_s : float
        The same for pymunk casting the same rays [s].
    numpy_s : float
        The same for :func:`numpy_rays` [s].
    machine_loop_us : float
        The reference loop's best time in the same run [us].
    """
    obstacles = square_room(40, 4)
    spec = LidarSpec()
    lidar = Lidar(spec, np.random.default_rng(1))
    space = pymunk_room(obstacles)
    poses = _poses(n_poses)
    angles = -np.pi + np.arange(spec.beams) * spec.angle_increment_rad
    every = pymunk.ShapeFilter()
    reach = spec.range_max_m

    def rays(x: float, y: float, yaw: float) -> None:
        for a in (angles + yaw).tolist():
            end = (x + reach * math.cos(a), y + reach * math.sin(a))
            space.segment_query_first((x, y), end, 0.0, every)

    def vectorised(x: float, y: float, yaw: float) -> None:
        numpy_rays(obstacles, x, y, angles + yaw, reach)

    def make_round() -> dict[str, list[Callable[[], object]]]:
        return {
            "model": [functools.partial(lidar.scan, *pose, obstacles) for pose in poses],
            "pymunk": [functools.partial(rays, *pose) for pose in poses],
            "numpy": [functools.partial(vectorised, *pose) for pose in poses],
        }

    for pose in poses[:4]:
        lidar.scan(*pose, obstacles)
    best, loop_us = interleaved_slices(make_round, repeats)
    return (
        best["model"] / n_poses,
        best["pymunk"] / n_poses,
        best["numpy"] / n_poses,
        loop_us,
    )


def run(quick: bool = False) -> list[BenchResult]:
    """The LiDAR figure for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        Fewer rounds.

    Returns
    -------
    list[BenchResult]
        The model's speed as a multiple of pymunk's ray queries.
    """
    model_s, pymunk_s, numpy_s, loop_us = vs_pymunk(3 if quick else 7)
    return [
        BenchResult(
            "sim.lidar_scan_vs_numpy_rays",
            numpy_s / model_s,
            "x the vectorised cast's speed",
            VS_NUMPY_TARGET,
            "higher",
            "the textbook vectorised cast (numpy_rays: every ray against every segment and "
            "circle in one broadcast, geometry only) for the same 1080 beams and geometry",
            1.0 / model_s,
            "scans/s",
            1.0 / numpy_s,
            loop_us,
        ),
        BenchResult(
            "sim.lidar_scan_vs_pymunk_rays",
            pymunk_s / model_s,
            "x pymunk's speed",
            VS_PYMUNK_TARGET,
            "higher",
            "pymunk Space.segment_query_first for the same 1080 beams and geometry",
            1.0 / model_s,
            "scans/s",
            1.0 / pymunk_s,
            loop_us,
        ),
    ]


if __name__ == "__main__":
    print(f"{scans_per_second():.0f} scans/s (target {SCANS_PER_S_TARGET:.0f})")
