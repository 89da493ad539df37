"""The twin: world, robot, sensors and ground truth, advanced in fixed physics steps.

The physics rate is 200 Hz (``PHYSICS_HZ``): each step applies motor, stiction and traction
forces (:mod:`jackson.sim.robot`) and lets pymunk integrate and resolve collisions. Sensor
values for the MCU are read at telemetry instants; the IMU sample is the mean specific force
and yaw rate over the steps since the previous read, as the firmware's averaging of its 100 Hz
samples gives. Motor commands take effect after the robot's actuation latency.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from jackson.sim.config import RobotSpec, WorldSpec
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles
from jackson.sim.mcu import SensorSample
from jackson.sim.robot import DiffDriveRobot, WheelDrive
from jackson.sim.sensors import ImuModel, encoder_counts
from jackson.sim.world import World

PHYSICS_HZ = 200


@dataclass(frozen=True)
class Truth:
    """Ground truth at one instant: pose in the world, twist in the body frame."""

    t_s: float
    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    wz: float
    omega_left: float
    omega_right: float


@dataclass(frozen=True)
class Scan:
    """One LiDAR scan taken at ``t_s`` (ranges in metres, inf for no return)."""

    t_s: float
    ranges: NDArray[np.float32]


class Twin:
    """Everything physical about one simulated robot in one world."""

    def __init__(
        self,
        world: WorldSpec,
        robot: RobotSpec,
        *,
        seed: int = 0,
        physics_hz: int = PHYSICS_HZ,
        lidar: bool | None = None,
        record_truth: bool = True,
    ) -> None:
        self.world_spec = world
        self.robot_spec = robot
        self.dt = 1.0 / physics_hz
        self.steps = 0
        self.rng = np.random.default_rng(seed)
        self.world = World(world)
        self.robot = DiffDriveRobot(robot, self.world.space, world.mu_static, world.mu_dynamic)
        self.robot.shape.collision_type = 1
        x0, y0, yaw0 = world.start_pose
        self.robot.place(x0, y0, yaw0)
        self.start_xy = (x0, y0)
        self.imu = ImuModel(robot.imu, self.rng)
        self._drive = (WheelDrive(), WheelDrive())  # coasting until commanded
        self._pending: deque[tuple[float, WheelDrive, WheelDrive]] = deque()
        self._acc_sum = [0.0, 0.0, 0.0]
        self._acc_n = 0
        self.truth_log: list[Truth] = []
        self.record_truth = record_truth
        self.scans: list[Scan] = []
        use_lidar = robot.lidar.enabled if lidar is None else lidar
        self._lidar = self._make_lidar() if use_lidar else None
        self._next_scan_s = 0.0
        if record_truth:
            self.truth_log.append(self.truth())

    def _make_lidar(self) -> Lidar:
        m = self.robot_spec.lidar
        spec = LidarSpec(
            noise_sigma_m=m.noise_sigma_m,
            extra_noise_sigma_m=m.extra_noise_sigma_m,
            dropout_probability=m.dropout_probability,
            mount_x_m=m.mount_x_m,
            mount_y_m=m.mount_y_m,
            mount_yaw_rad=m.mount_yaw_rad,
        )
        self._obstacles = Obstacles(self.world.segments, self.world.circles)
        self.scan_period_s = spec.scan_period_s
        return Lidar(spec, np.random.default_rng(self.rng.integers(1 << 62)))

    @property
    def t_s(self) -> float:
        return self.steps * self.dt

    @property
    def t_us(self) -> int:
        return round(self.steps * 1_000_000 / round(1.0 / self.dt))

    def command(self, left: WheelDrive, right: WheelDrive) -> None:
        """Set the H-bridge outputs; they reach the motors after the actuation latency."""
        latency = self.robot_spec.actuation_latency_s
        if latency <= 0.0:
            self._drive = (left, right)
        else:
            self._pending.append((self.t_s + latency - 1e-9, left, right))

    def advance(self, duration_s: float) -> None:
        """Run physics for ``duration_s`` (rounded to whole steps)."""
        end = self.steps + round(duration_s / self.dt)
        robot, space, dt = self.robot, self.world.space, self.dt
        while self.steps < end:
            pending = self._pending
            while pending and pending[0][0] <= self.t_s:
                _, left, right = pending.popleft()
                self._drive = (left, right)
            robot.step_forces(dt, self._drive[0], self._drive[1])
            space.step(dt)
            self.steps += 1
            self._acc_sum[0] += robot.accel_x
            self._acc_sum[1] += robot.accel_y
            self._acc_sum[2] += robot.body.angular_velocity
            self._acc_n += 1
            if self.world._pending:
                x, y = robot.body.position
                fired = self.world.check_triggers(
                    math.hypot(x - self.start_xy[0], y - self.start_xy[1]), self.t_s
                )
                if fired and self._lidar is not None:
                    for c in fired:
                        self._obstacles.add_circle(c.x, c.y, c.radius)
            if self.record_truth:
                self.truth_log.append(self.truth())
            if self._lidar is not None and self.t_s + 1e-9 >= self._next_scan_s:
                self._take_scan()

    def _take_scan(self) -> None:
        x, y = self.robot.body.position
        assert self._lidar is not None
        ranges = self._lidar.scan(x, y, self.robot.body.angle, self._obstacles)
        self.scans.append(Scan(self.t_s, ranges))
        self._next_scan_s += self.scan_period_s

    def truth(self) -> Truth:
        b = self.robot.body
        yaw = b.angle
        c, s = math.cos(yaw), math.sin(yaw)
        vwx, vwy = b.velocity
        x, y = b.position
        return Truth(
            self.t_s,
            x,
            y,
            yaw,
            c * vwx + s * vwy,
            -s * vwx + c * vwy,
            b.angular_velocity,
            self.robot.omega_l,
            self.robot.omega_r,
        )

    def sensors(self) -> SensorSample:
        """Encoder counts now, and the IMU sample averaged since the previous call."""
        r = self.robot
        enc_l, enc_r = encoder_counts(r.angle_l, r.angle_r, self.robot_spec.ticks_per_rev)
        n = self._acc_n or 1
        accel = (self._acc_sum[0] / n, self._acc_sum[1] / n)
        yaw_rate = self._acc_sum[2] / n if self._acc_n else r.body.angular_velocity
        self._acc_sum = [0.0, 0.0, 0.0]
        self._acc_n = 0
        a, temp, g = self.imu.sample(accel, yaw_rate)
        return SensorSample(enc_l, enc_r, self.robot_spec.imu.present, a, temp, g)

    @property
    def collisions(self) -> int:
        return self.world.collisions
