"""The twin against bare pymunk stepping the same bodies (run by ``jackson bench``).

The twin drives a figure-eight in the 4 m room for two minutes of simulated time at its 200 Hz
physics rate, reading the sensors at 20 Hz as the MCU does and recording ground truth at every
physics step; with LiDAR it also takes 7.43 scans per simulated second. Beside it, interleaved
and best of N, bare pymunk steps the same space (the room's walls and the robot's body, in a
fresh twin) at the same rate for the same time, the body given at each 20 Hz period the
velocities the twin's robot had then: the physics library's own cost for this motion, with
none of the twin's models. The two run period by period (the twin's 20 Hz period, then bare
pymunk's), each period's best time over the rounds summed. With LiDAR the bare run also takes
the same scans with the LiDAR model alone. Figure: the twin's wall time over the bare run's
(target: within 2x); the twin's real-time factor stays beside it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from jackson.common.bench import BenchResult, interleaved_slices
from jackson.sim.compiled import SELECTION
from jackson.sim.config import load_robot, load_world
from jackson.sim.robot import WheelDrive
from jackson.sim.twin import PHYSICS_HZ, Twin

SENSOR_HZ = 20
TWIN_OVER_PYMUNK_TARGET = 2.0


def _twin(lidar: bool) -> Twin:
    return Twin(load_world("square_room"), load_robot("jackson"), lidar=lidar, seed=1)


def _duties(k: int, periods: int) -> tuple[float, float]:
    """A left loop, then a right loop: a figure-eight."""
    return (0.35, 0.5) if k < periods // 2 else (0.5, 0.35)


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
    t0 = time.perf_counter()
    for k in range(periods):
        velocities.append(_twin_period(twin, *_duties(k, periods)))
    return time.perf_counter() - t0, velocities


def _twin_period(twin: Twin, left: float, right: float) -> tuple[float, float, float]:
    """One 20 Hz period of the twin; the robot's velocities at its start."""
    robot = twin.robot
    start = (robot.vwx, robot.vwy, robot.wz)
    twin.command(WheelDrive(left, 1.0), WheelDrive(right, 1.0))
    twin.advance(1.0 / SENSOR_HZ)
    twin.sensors()
    return start


class BarePymunk:
    """pymunk alone stepping a fresh twin's space (the room's walls and the robot's body).

    Parameters
    ----------
    lidar : bool
        Also take the twin's scans (at its scan period, each beam from the body's pose at its
        instant of the turn, as the twin casts them) with the LiDAR model alone.
    """

    def __init__(self, lidar: bool) -> None:
        twin = _twin(lidar)
        self.space, self.body = twin.world.space, twin.robot.body
        self.body.position = (twin.robot.x, twin.robot.y)
        self.body.angle = twin.robot.yaw
        self.dt = twin.dt
        self.steps_per_period = round(PHYSICS_HZ / SENSOR_HZ)
        self.scanner = twin._lidar
        self.obstacles = twin._obstacles if self.scanner is not None else None
        self.scan_period_s = twin.scan_period_s if self.scanner is not None else math.inf
        self.step = 0
        self.next_scan_s = 0.0
        self.last_scan_pose: tuple[float, float, float] | None = None

    def period(self, vx: float, vy: float, wz: float) -> None:
        """One 20 Hz period: the body given these velocities, then 10 physics steps.

        Parameters
        ----------
        vx, vy : float
            Velocity in the world [m/s].
        wz : float
            Yaw rate [rad/s].
        """
        body, space, dt = self.body, self.space, self.dt
        body.velocity = (vx, vy)
        body.angular_velocity = wz
        for _ in range(self.steps_per_period):
            space.step(dt)
            self.step += 1
            if self.obstacles is not None and self.step * dt + 1e-9 >= self.next_scan_s:
                assert self.scanner is not None
                x, y = body.position
                pose = (x, y, body.angle)
                self.scanner.scan_moving(self.last_scan_pose or pose, pose, self.obstacles)
                self.last_scan_pose = pose
                self.next_scan_s += self.scan_period_s


def bare_pymunk(velocities: list[tuple[float, float, float]], lidar: bool) -> float:
    """Wall time of :class:`BarePymunk` through the same motion.

    Parameters
    ----------
    velocities : list[tuple[float, float, float]]
        Per 20 Hz period, the body's velocity and yaw rate (from :func:`drive_figure_eight`).
    lidar : bool
        Also take the twin's scans with the LiDAR model alone.

    Returns
    -------
    float
        Wall time [s].
    """
    bare = BarePymunk(lidar)
    t0 = time.perf_counter()
    for v in velocities:
        bare.period(*v)
    return time.perf_counter() - t0


def twin_vs_pymunk(lidar: bool, sim_seconds: float, repeats: int) -> BenchResult:
    """The twin's wall time over bare pymunk's, period by period, best of ``repeats``.

    In each round a fresh twin and a fresh :class:`BarePymunk` run side by side: the twin's
    20 Hz period k, then bare pymunk's period k with the velocities the twin's robot had at its
    start (:func:`jackson.common.bench.interleaved_slices`).

    Parameters
    ----------
    lidar : bool
        With the LiDAR on (and its scans in the bare run).
    sim_seconds : float
        Simulated time per run [s].
    repeats : int
        Rounds.

    Returns
    -------
    BenchResult
        The ratio, the twin's real-time factor and bare pymunk's.
    """
    periods = round(sim_seconds * SENSOR_HZ)

    def make_round() -> dict[str, list[Callable[[], object]]]:
        twin, bare = _twin(lidar), BarePymunk(lidar)
        starts: list[tuple[float, float, float]] = []

        def twin_slice(k: int) -> Callable[[], object]:
            return lambda: starts.append(_twin_period(twin, *_duties(k, periods)))

        def bare_slice(k: int) -> Callable[[], object]:
            return lambda: bare.period(*starts[k])

        return {
            "twin": [twin_slice(k) for k in range(periods)],
            "pymunk": [bare_slice(k) for k in range(periods)],
        }

    best, loop_us = interleaved_slices(make_round, repeats)
    which = "lidar" if lidar else "no_lidar"
    physics = "compiled" if SELECTION.compiled else "interpreted"
    return BenchResult(
        f"sim.twin_over_pymunk_{which}_{PHYSICS_HZ}Hz_physics",
        best["twin"] / best["pymunk"],
        "x bare pymunk's time",
        TWIN_OVER_PYMUNK_TARGET,
        "lower",
        "pymunk stepping the same space through the same motion"
        + (", plus the same scans by the LiDAR model" if lidar else "")
        + f" (the twin's physics {physics}: docs/compiled.md)",
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
