"""The twin against bare pymunk stepping the same bodies (run by ``jackson bench``).

The twin drives a figure-eight in the 4 m room for two minutes of simulated time at its 200 Hz
physics rate, reading the sensors at 20 Hz as the MCU does and recording ground truth at every
physics step; with LiDAR it also takes 7.43 scans per simulated second. Beside it, interleaved
and best of N, bare pymunk steps the same space (the room's walls and the robot's body, in a
fresh twin) at the same rate for the same time, the body given at each 20 Hz period the
velocities the twin's robot had then: the physics library's own cost for this motion, with
none of the twin's models. With LiDAR the bare run also takes the same scans with the LiDAR
model alone. Figure: the twin's wall time over the bare run's (target: within 2x); the twin's
real-time factor stays beside it.
"""

from __future__ import annotations

import math
import time

from jackson.common.bench import BenchResult, interleaved_best
from jackson.sim.config import load_robot, load_world
from jackson.sim.robot import WheelDrive
from jackson.sim.twin import PHYSICS_HZ, Twin

SENSOR_HZ = 20
TWIN_OVER_PYMUNK_TARGET = 2.0


def _twin(lidar: bool) -> Twin:
    return Twin(load_world("square_room"), load_robot("jackson"), lidar=lidar, seed=1)


def drive_figure_eight(
    twin: Twin, sim_seconds: float
) -> tuple[float, list[tuple[float, float, float]]]:
    """Drive ``twin`` through a figure-eight; its wall time and the velocities per period.

    Parameters
    ----------
    twin : Twin
        A fresh twin.
    sim_seconds : float
        Simulated time [s].

    Returns
    -------
    wall_s : float
        Wall time of the drive [s].
    velocities : list[tuple[float, float, float]]
        The robot's (vx, vy) [m/s] in the world and yaw rate [rad/s] at the start of each
        20 Hz period.
    """
    periods = round(sim_seconds * SENSOR_HZ)
    velocities: list[tuple[float, float, float]] = []
    robot = twin.robot
    t0 = time.perf_counter()
    for k in range(periods):
        velocities.append((robot.vwx, robot.vwy, robot.wz))
        first_half = k < periods // 2  # a left loop, then a right loop: a figure-eight
        left, right = (0.35, 0.5) if first_half else (0.5, 0.35)
        twin.command(WheelDrive(left, 1.0), WheelDrive(right, 1.0))
        twin.advance(1.0 / SENSOR_HZ)
        twin.sensors()
    return time.perf_counter() - t0, velocities


def bare_pymunk(velocities: list[tuple[float, float, float]], lidar: bool) -> float:
    """Wall time of pymunk alone stepping a fresh twin's space through the same motion.

    Parameters
    ----------
    velocities : list[tuple[float, float, float]]
        Per 20 Hz period, the body's velocity and yaw rate (from :func:`drive_figure_eight`).
    lidar : bool
        Also take the twin's scans (at its scan period, from the body's pose) with the LiDAR
        model alone.

    Returns
    -------
    float
        Wall time [s].
    """
    twin = _twin(lidar)
    space, body = twin.world.space, twin.robot.body
    body.position = (twin.robot.x, twin.robot.y)
    body.angle = twin.robot.yaw
    dt = twin.dt
    steps = round(PHYSICS_HZ / SENSOR_HZ)
    scanner = twin._lidar
    obstacles = twin._obstacles if scanner is not None else None
    scan_period_s = twin.scan_period_s if scanner is not None else math.inf
    step = 0
    next_scan_s = 0.0
    t0 = time.perf_counter()
    for vx, vy, wz in velocities:
        body.velocity = (vx, vy)
        body.angular_velocity = wz
        for _ in range(steps):
            space.step(dt)
            step += 1
            if scanner is not None and obstacles is not None and step * dt + 1e-9 >= next_scan_s:
                x, y = body.position
                scanner.scan(x, y, body.angle, obstacles)
                next_scan_s += scan_period_s
    return time.perf_counter() - t0


def twin_vs_pymunk(lidar: bool, sim_seconds: float, repeats: int) -> BenchResult:
    """The twin's wall time over bare pymunk's, interleaved, best of ``repeats``.

    Parameters
    ----------
    lidar : bool
        With the LiDAR on (and its scans in the bare run).
    sim_seconds : float
        Simulated time per run [s].
    repeats : int
        Rounds (each a fresh twin and a fresh bare space).

    Returns
    -------
    BenchResult
        The ratio, the twin's real-time factor and bare pymunk's.
    """
    _, velocities = drive_figure_eight(_twin(lidar), sim_seconds)
    work = {
        "twin": lambda: drive_figure_eight(_twin(lidar), sim_seconds)[0],
        "pymunk": lambda: bare_pymunk(velocities, lidar),
    }
    best, loop_us = interleaved_best(work, repeats, self_timed=True)
    which = "lidar" if lidar else "no_lidar"
    return BenchResult(
        f"sim.twin_over_pymunk_{which}_{PHYSICS_HZ}Hz_physics",
        best["twin"] / best["pymunk"],
        "x bare pymunk's time",
        TWIN_OVER_PYMUNK_TARGET,
        "lower",
        "pymunk stepping the same space through the same motion"
        + (", plus the same scans by the LiDAR model" if lidar else ""),
        sim_seconds / best["twin"],
        "x real time",
        sim_seconds / best["pymunk"],
        loop_us,
    )


def real_time_factor(lidar: bool, sim_seconds: float) -> float:
    """The twin's real-time factor on the figure-eight (one run).

    Parameters
    ----------
    lidar : bool
        With the LiDAR on.
    sim_seconds : float
        Simulated time [s].

    Returns
    -------
    float
        Simulated seconds per wall second.
    """
    wall, _ = drive_figure_eight(_twin(lidar), sim_seconds)
    return sim_seconds / wall


def run(quick: bool = False) -> list[BenchResult]:
    """The twin's figures for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        30 s of simulated time and 5 rounds instead of 120 s and 7.

    Returns
    -------
    list[BenchResult]
        Without and with LiDAR.
    """
    seconds, repeats = (30.0, 5) if quick else (120.0, 7)
    return [twin_vs_pymunk(lidar, seconds, repeats) for lidar in (False, True)]
