"""Real-time factor of the twin alone (run by ``jackson bench``).

The twin drives a figure-eight in the 4 m room for two minutes of simulated time
at its 200 Hz physics rate, reading the sensors at 20 Hz as the MCU does and recording ground
truth at every physics step; with LiDAR it also takes 7.43 scans per simulated second. Targets:
1000x real time without LiDAR, 200x with it.
"""

from __future__ import annotations

import time

from jackson.common.bench import BenchResult
from jackson.sim.config import load_robot, load_world
from jackson.sim.robot import WheelDrive
from jackson.sim.twin import PHYSICS_HZ, Twin


def real_time_factor(lidar: bool, sim_seconds: float) -> float:
    twin = Twin(load_world("square_room"), load_robot("jackson"), lidar=lidar, seed=1)
    periods = round(sim_seconds * 20)
    t0 = time.perf_counter()
    for k in range(periods):
        first_half = k < periods // 2  # a left loop, then a right loop: a figure-eight
        left, right = (0.35, 0.5) if first_half else (0.5, 0.35)
        twin.command(WheelDrive(left, 1.0), WheelDrive(right, 1.0))
        twin.advance(0.05)
        twin.sensors()
    return sim_seconds / (time.perf_counter() - t0)


def run(quick: bool = False) -> list[BenchResult]:
    seconds = 30.0 if quick else 120.0
    return [
        BenchResult(
            f"sim.twin_rtf_no_lidar_{PHYSICS_HZ}Hz_physics",
            real_time_factor(False, seconds),
            "x real time",
            1000,
            "higher",
        ),
        BenchResult(
            f"sim.twin_rtf_lidar_{PHYSICS_HZ}Hz_physics",
            real_time_factor(True, seconds),
            "x real time",
            200,
            "higher",
        ),
    ]
