"""Synthetic frames and revolutions for the health checks: a robot with exact (quantised)
encoders, a noisy gyro and accelerometer, and faults on demand; a LiDAR in a room."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace

import numpy as np

from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.health import HealthConfig, HealthInput, HealthMonitor, Verdict

DT = 0.05
ROBOT = RobotGeometry()
GYRO_SIGMA = 0.005  # [rad/s] a quieter gyro than the EKF's R assumes, as the MPU-6050 is
ACCEL_SIGMA = 0.018  # [m/s^2] the twin's MPU-6050
LIDAR_PERIOD = 1.0 / 7.43  # [s] the twin's A1M8
BEAMS = 1080


class Robot:
    """A robot driving (v, w) with exact encoders (quantised) and a noisy gyro."""

    def __init__(self, seed: int = 0) -> None:
        self.rng = np.random.default_rng(seed)
        self.t = 0.0
        self.phi = [0.0, 0.0]  # wheel angles [rad]
        self.counts = [0, 0]
        self.raw_noise = 0
        self.v = 0.0  # the true forward speed at the last frame [m/s]

    def frame(
        self,
        v: float,
        w: float,
        *,
        gyro_extra: float = 0.0,
        imu_ok: bool = True,
        frozen: bool = False,
        stuck: tuple[bool, bool] = (False, False),
        slip: tuple[float, float] = (1.0, 1.0),
    ) -> HealthInput:
        """One frame; ``slip`` scales each wheel's turn over the floor's (1.3: spins 30 % more)."""
        self.t += DT
        b = ROBOT.wheel_separation_m
        om = [
            (v - w * b / 2) / ROBOT.wheel_radius_left_m,
            (v + w * b / 2) / ROBOT.wheel_radius_right_m,
        ]
        ticks = []
        speeds = []
        for i, tpr in enumerate((ROBOT.ticks_per_rev_left, ROBOT.ticks_per_rev_right)):
            self.phi[i] += om[i] * slip[i] * DT
            new = math.floor(self.phi[i] / (2 * math.pi) * tpr)
            if stuck[i]:
                new = self.counts[i]
            ticks.append(new - self.counts[i])
            self.counts[i] = new
            speeds.append(ticks[-1] * 2 * math.pi / tpr / DT)
        wz = w + self.rng.normal(0.0, GYRO_SIGMA) + gyro_extra
        a_x = (v - self.v) / DT + self.rng.normal(0.0, ACCEL_SIGMA)  # the true speed's change
        self.v = v
        if not frozen:
            self.raw_noise = int(self.rng.integers(-1000, 1000))
        return HealthInput(
            t_s=self.t,
            imu_ok=imu_ok,
            imu_raw=(self.raw_noise, 0, 16384, 0, 0, 0, 0),
            wz_rad_s=wz if imu_ok else None,
            wheel_rad_s=(speeds[0], speeds[1]),
            ticks=(ticks[0], ticks[1]),
            dt_s=DT,
            wheel_cmd_rad_s=(om[0], om[1]),
            commanded_still=v == 0.0 and w == 0.0,
            accel_y_m_s2=v * w + self.rng.normal(0.0, ACCEL_SIGMA) if imu_ok else None,
            accel_x_m_s2=a_x if imu_ok else None,
        )


def drive(
    mon: HealthMonitor, robot: Robot, seconds: float, v: float, w: float, **fault: object
) -> list[Verdict]:
    """``seconds`` of frames driving (v, w) with ``fault``; each frame's verdict."""
    return [mon.update(robot.frame(v, w, **fault)) for _ in range(round(seconds / DT))]  # type: ignore[arg-type]


def monitor(**cfg: object) -> HealthMonitor:
    """A monitor of the default configuration with ``cfg`` changed."""
    return HealthMonitor(replace(HealthConfig(), **cfg), ROBOT)  # type: ignore[arg-type]


def course(seconds: float) -> Iterator[tuple[float, float]]:
    """Straights, arcs both ways, pivots and stops, 20 s per lap."""
    laps = [
        (0.15, 0.0, 5.0),
        (0.08, 0.15, 4.0),
        (0.0, 0.6, 2.0),
        (0.08, -0.15, 4.0),
        (0.0, 0.0, 1.0),
        (0.0, -0.6, 2.0),
        (0.2, 0.0, 2.0),
    ]
    t = 0.0
    while t < seconds:
        for v, w, span in laps:
            for _ in range(round(span / DT)):
                yield v, w
            t += span


def room_scan(rng: np.random.Generator, sigma: float, x: float = 0.7, y: float = 0.4) -> np.ndarray:
    """Ranges from (x, y) in a 4 m x 3 m room centred on the origin, with N(0, sigma^2) noise,
    in the order a revolution measures them."""
    a = np.linspace(0.0, 2.0 * np.pi, BEAMS, endpoint=False)
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (2.0 - x) / c, np.where(c < 0, (-2.0 - x) / c, np.inf))
        ty = np.where(s > 0, (1.5 - y) / s, np.where(s < 0, (-1.5 - y) / s, np.inf))
    r = np.minimum(tx, ty) + rng.normal(0.0, sigma, BEAMS)
    r[rng.random(BEAMS) < 0.05] = np.inf  # no return now and then
    return r


def scans(
    mon: HealthMonitor,
    rng: np.random.Generator,
    t0: float,
    seconds: float,
    sigma: float = 0.01,
    lost: float = 0.0,
) -> tuple[float, list[bool]]:
    """Revolutions every LIDAR_PERIOD for ``seconds``, stamped on 20 Hz frames as the core
    does, a fraction ``lost`` of them missing; (the time reached, each scan's use)."""
    used = []
    t = t0
    for _ in range(round(seconds / LIDAR_PERIOD)):
        t += LIDAR_PERIOD
        if rng.random() < lost:
            continue
        used.append(mon.lidar.scan(math.ceil(t / DT) * DT, room_scan(rng, sigma)))
    return t, used
