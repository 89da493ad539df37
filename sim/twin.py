"""The twin: world, robot, sensors and ground truth, advanced in fixed physics steps.

The physics rate is 200 Hz (``PHYSICS_HZ``): each step applies motor, stiction and traction
forces (:mod:`jackson.sim.physics`) and, near obstacles, lets pymunk integrate and resolve
collisions; in free space the model integrates itself, running the steps up to the next event
(a command taking effect, a wheel-slip window opening or closing, a scan, a trigger's check)
in one call, which the compiled model (:mod:`jackson.sim.compiled`) makes fast. Sensor
values for the MCU are read at telemetry instants; the IMU sample is the mean specific force
and yaw rate over the steps since the previous read, as the firmware's averaging of its 100 Hz
samples gives. Motor commands take effect after the robot's actuation latency.

A trial is one ``Twin``: at its start it draws the robot file's per-trial variation
(``variation:``, :func:`draw_trial`) from its seed, on random streams of their own, so the
sensor noise of a seed stays the same whether or not variation is on, each varied quantity
keeps its draw when another is switched on, and one seed reproduces a trial bit for bit.

Faults (:mod:`jackson.sim.faults`: the robot file's ``faults:`` and any given to the ``Twin``)
act in the sensor values :meth:`Twin.sensors` returns, in the wheels' floor friction at the
physics steps of a ``wheel_slip`` window, and in the scans; each on a stream of its own, so a
twin without faults draws exactly what it drew before.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pymunk

from jackson.sim.config import ConfigError, RobotSpec, Sides, WorldSpec
from jackson.sim.faults import FaultInjector, FaultSpec
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles
from jackson.sim.mcu import SensorSample
from jackson.sim.physics import TruthRow
from jackson.sim.robot import DiffDriveRobot, WheelDrive
from jackson.sim.sensors import ImuModel, encoder_counts
from jackson.sim.twin_scans import Scan, TwinScans
from jackson.sim.world import FrictionField, World

PHYSICS_HZ = 200
CONTACT_MARGIN_M = 0.05  # pymunk takes over within this distance of an obstacle
VARIATION_STREAM = 0x7472_6961  # keys the per-trial streams apart from the seed's noise stream
TRUNCATE_SIGMA = 3.0  # per-trial draws are normal, truncated at this many sigma


@dataclass(frozen=True)
class TrialConditions:
    """What the robot and the floor are in one trial (the robot file's values when its
    ``variation`` sigmas are 0).

    Attributes
    ----------
    battery_v : float
        Motor supply voltage [V].
    wheel_radius_m : Sides
        Effective rolling radius of each wheel [m].
    encoder_scale : Sides
        Factor on each encoder's ticks per revolution [1].
    gyro_bias_rad_s : tuple of float
        Gyro bias at the start, xyz [rad/s].
    floor : FrictionField or None
        Friction patches (None: a uniform floor).
    caster_rolling_coeff : float
        The caster's rolling resistance coefficient [1].
    """

    battery_v: float
    wheel_radius_m: Sides
    encoder_scale: Sides
    gyro_bias_rad_s: tuple[float, float, float]
    floor: FrictionField | None
    caster_rolling_coeff: float


def trial_stream(seed: int, index: int) -> np.random.Generator:
    """The random stream of one per-trial quantity: independent of the seed's noise stream
    (``default_rng(seed)``) and of the other quantities' streams.

    Parameters
    ----------
    seed : int
        The twin's seed (>= 0).
    index : int
        Which quantity: 0 supply, 1 wheel radii, 2 encoders, 3 gyro bias, 4 floor, 5 bias walk,
        6 the MCU's boot_id (:func:`trial_boot_id`), 7 the caster's drag.

    Returns
    -------
    numpy.random.Generator
        Its generator.
    """
    return np.random.default_rng([seed, VARIATION_STREAM, index])


def trial_boot_id(seed: int) -> int:
    """The MCU's boot_id for a trial of ``seed``: odd (never 0), drawn from the seed, so a trial
    run twice writes the same INFO and the still LiDAR's noise (seeded by it) is the same; a
    twin started by hand (``jackson sim``) draws one at random, as each boot of the robot."""
    return int(trial_stream(seed, 6).integers(0, 2**32)) | 1


def _normal(seed: int, index: int, n: int) -> list[float]:
    z = np.clip(trial_stream(seed, index).standard_normal(n), -TRUNCATE_SIGMA, TRUNCATE_SIGMA)
    return [float(v) for v in z]


def draw_trial(
    robot: RobotSpec, seed: int, origin: tuple[float, float] = (0.0, 0.0)
) -> TrialConditions:
    """Draw one trial's conditions from the robot file's ``variation`` and a seed.

    Parameters
    ----------
    robot : RobotSpec
        The robot file.
    seed : int
        The trial's seed (>= 0).
    origin : tuple of float
        Where the friction field's cell (0, 0) starts (the start position) [m].

    Returns
    -------
    TrialConditions
        The draws; a quantity whose sigma is 0 keeps the robot file's value, drawn from nothing.
    """
    v = robot.variation
    battery_v = robot.motor.battery_v
    if v.battery_v_sigma > 0.0:
        battery_v += v.battery_v_sigma * _normal(seed, 0, 1)[0]
    radius = robot.wheel_radius_m
    if v.wheel_radius_sigma > 0.0:
        zl, zr = _normal(seed, 1, 2)
        radius = Sides(
            radius.left * (1.0 + v.wheel_radius_sigma * zl),
            radius.right * (1.0 + v.wheel_radius_sigma * zr),
        )
    scale = Sides(1.0, 1.0)
    if v.encoder_scale_sigma > 0.0:
        zl, zr = _normal(seed, 2, 2)
        scale = Sides(1.0 + v.encoder_scale_sigma * zl, 1.0 + v.encoder_scale_sigma * zr)
    bias = robot.imu.gyro_bias_rad_s
    if v.gyro_bias_sigma_rad_s > 0.0:
        z = _normal(seed, 3, 3)
        bias = (
            bias[0] + v.gyro_bias_sigma_rad_s * z[0],
            bias[1] + v.gyro_bias_sigma_rad_s * z[1],
            bias[2] + v.gyro_bias_sigma_rad_s * z[2],
        )
    floor = None
    if v.floor_mu_sigma > 0.0:
        floor = FrictionField.random(
            trial_stream(seed, 4), v.floor_mu_sigma, v.floor_patch_size_m, origin
        )
    caster = robot.caster_rolling_coeff
    if v.caster_drag_sigma > 0.0:
        caster *= 1.0 + v.caster_drag_sigma * _normal(seed, 7, 1)[0]
    return TrialConditions(battery_v, radius, scale, bias, floor, caster)


class Truth(NamedTuple):
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


class TruthLog:
    """Ground truth at every physics step: the rows the physics model appends (pose and
    world-frame velocity), turned into :class:`Truth` (body-frame twist) when first read.

    Parameters
    ----------
    dt : float
        The physics step [s].
    keep : bool
        Keep the rows (False: :attr:`rows` is None and nothing is recorded).
    """

    def __init__(self, dt: float, keep: bool) -> None:
        self.dt = dt
        self.rows: list[TruthRow] | None = [] if keep else None
        self._truth: list[Truth] = []

    def read(self) -> list[Truth]:
        """Every row so far as :class:`Truth`."""
        raw = self.rows
        done = len(self._truth)
        if raw is not None and done < len(raw):
            dt = self.dt
            for steps, x, y, yaw, vwx, vwy, wz, om_l, om_r in raw[done:]:
                c, s = math.cos(yaw), math.sin(yaw)
                self._truth.append(
                    Truth(
                        steps * dt, x, y, yaw, c * vwx + s * vwy, -s * vwx + c * vwy, wz, om_l, om_r
                    )
                )
        return self._truth


class Twin:
    """Everything physical about one simulated robot in one world.

    Parameters
    ----------
    world : WorldSpec
        The world file.
    robot : RobotSpec
        The robot file (its ``faults`` are injected).
    seed : int
        Seeds the sensor noise, the trial's draws and the faults' streams.
    physics_hz : int
        Physics steps per second.
    lidar : bool or None
        Simulate the LiDAR (None: as the robot file says).
    record_truth : bool
        Keep the ground truth of every physics step (:attr:`truth_log`).
    scan_history : int or None
        Scans kept (None: all).
    faults : sequence of FaultSpec
        Faults injected besides the robot file's.

    Attributes
    ----------
    faults : FaultInjector or None
        The faults at run time (None: no faults); ``faults.record()`` tells what they did.
    lidar_scans : TwinScans
        The LiDAR model and the scans it took (:attr:`scans`, :attr:`scans_taken`,
        :attr:`lost_scans`, :attr:`scans_lost`).
    """

    def _check_start(self) -> None:
        """Refuse a start pose where the robot's footprint overlaps a wall or a cylinder."""
        shape = self.robot.shape
        shape.cache_bb()
        static = self.world.space.static_body
        hits = [
            q for q in self.world.space.shape_query(shape) if q.shape and q.shape.body is static
        ]
        if hits:
            x, y, yaw = self.world_spec.start_pose
            raise ConfigError(
                f"world {self.world_spec.name}: start_pose [{x:g}, {y:g}, {yaw:g}]: robot "
                f"{self.robot_spec.name} overlaps {len(hits)} wall(s) or cylinder(s) there; "
                "move the start pose into free space"
            )

    def __init__(
        self,
        world: WorldSpec,
        robot: RobotSpec,
        *,
        seed: int = 0,
        physics_hz: int = PHYSICS_HZ,
        lidar: bool | None = None,
        record_truth: bool = True,
        scan_history: int | None = None,
        faults: Sequence[FaultSpec] = (),
    ) -> None:
        self.world_spec = world
        self.robot_spec = robot
        self.dt = 1.0 / physics_hz
        self.steps = 0
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.world = World(world)
        x0, y0, yaw0 = world.start_pose
        self.trial = trial = draw_trial(robot, seed, (x0, y0))
        self.robot = DiffDriveRobot(
            robot,
            self.world.space,
            world.mu_static,
            world.mu_dynamic,
            battery_v=trial.battery_v,
            wheel_radius_m=trial.wheel_radius_m,
            floor=trial.floor,
            caster_rolling_coeff=trial.caster_rolling_coeff,
        )
        self.robot.shape.collision_type = 1
        self.robot.place(x0, y0, yaw0)
        self._check_start()
        (ex0, ex1), (ey0, ey1) = robot.envelope_x_m, robot.envelope_y_m
        self._radius = max(math.hypot(ex, ey) for ex in (ex0, ex1) for ey in (ey0, ey1))
        self._free_budget = -1.0  # metres the robot may move before clearance is checked again
        self._recheck = 0
        self.start_xy = (x0, y0)
        imu = robot.imu
        if trial.gyro_bias_rad_s != imu.gyro_bias_rad_s:
            imu = dataclasses.replace(imu, gyro_bias_rad_s=trial.gyro_bias_rad_s)
        drift = trial_stream(seed, 5) if imu.gyro_bias_drift_rad_s_per_sqrt_s > 0.0 else None
        self.imu = ImuModel(imu, self.rng, drift)
        tpr, k = robot.ticks_per_rev, trial.encoder_scale
        self._ticks = tpr if k == Sides(1.0, 1.0) else Sides(tpr.left * k.left, tpr.right * k.right)
        self._drive = (WheelDrive(), WheelDrive())  # coasting until commanded
        self._pending: deque[tuple[float, WheelDrive, WheelDrive]] = deque()
        self._acc_sum = [0.0, 0.0, 0.0]
        self._acc_from_step = 0
        self._truth_log = TruthLog(self.dt, record_truth)
        specs = (*robot.faults, *faults)
        self.faults = FaultInjector(specs, seed) if specs else None
        self._slip_steps: deque[int] = deque()
        self._next_slip_step = sys.maxsize  # the next physics step a slip window opens or closes
        if self.faults is not None:
            edges = self.faults.slip_boundaries_s()
            self._slip_steps.extend(sorted({math.ceil(t / self.dt - 1e-6) for t in edges}))
            self._next_slip_step = self._slip_steps[0] if self._slip_steps else sys.maxsize
        use_lidar = robot.lidar.enabled if lidar is None else lidar
        lidar_model = self._make_lidar() if use_lidar else None
        self.lidar_scans = TwinScans(lidar_model, self.world.obstacles, scan_history)
        if self._truth_log.rows is not None:
            r = self.robot
            self._truth_log.rows.append((0, r.x, r.y, r.yaw, 0.0, 0.0, 0.0, 0.0, 0.0))

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
        return Lidar(spec, np.random.default_rng(self.rng.integers(1 << 62)))

    @property
    def t_s(self) -> float:
        return self.steps * self.dt

    @property
    def t_us(self) -> int:
        return round(self.steps * 1_000_000 / round(1.0 / self.dt))

    @property
    def _lidar(self) -> Lidar | None:
        """The LiDAR model (None: the twin has none)."""
        return self.lidar_scans.lidar

    @property
    def _obstacles(self) -> Obstacles:
        """The world's obstacles as the LiDAR sees them."""
        return self.lidar_scans.obstacles

    @property
    def scan_period_s(self) -> float:
        """Time between scans [s] (inf without a LiDAR)."""
        return self.lidar_scans.period_s

    @property
    def scans(self) -> deque[Scan]:
        """The newest scans (all of them with ``scan_history`` None)."""
        return self.lidar_scans.kept

    @property
    def scans_taken(self) -> int:
        """Every scan delivered, kept or not (a lost one is neither)."""
        return self.lidar_scans.taken

    @property
    def lost_scans(self) -> deque[float]:
        """When each scan a ``lidar_dropout`` lost was due [s]."""
        return self.lidar_scans.lost

    @property
    def scans_lost(self) -> int:
        """Revolutions a ``lidar_dropout`` lost (not in :attr:`scans`)."""
        return self.lidar_scans.lost_count

    def command(self, left: WheelDrive, right: WheelDrive) -> None:
        """Set the H-bridge outputs; they reach the motors after the actuation latency."""
        latency = self.robot_spec.actuation_latency_s
        if latency <= 0.0:
            self._set_drive(left, right)
        else:
            self._pending.append((self.t_s + latency - 1e-9, left, right))

    def _set_drive(self, left: WheelDrive, right: WheelDrive) -> None:
        self._drive = (left, right)
        self.robot.drive(left, right)

    def advance(self, duration_s: float) -> None:
        """Run physics for ``duration_s`` (rounded to whole steps).

        In free space the model runs the steps up to the next event in one call
        (:meth:`~jackson.sim.physics.DiffDriveDynamics.run_free`); near obstacles each step is
        the model's forces and pymunk's integration. Events (commands taking effect, wheel-slip
        windows, triggers, scans) are handled here between those calls, at the same steps as
        if every step were taken one by one.
        """
        dt = self.dt
        end = self.steps + round(duration_s / dt)
        model, space, radius = self.robot.model, self.world.space, self._radius
        pending, world = self._pending, self.world
        raw = self._truth_log.rows
        scans = self.lidar_scans
        lidar = scans.lidar is not None
        steps = self.steps
        model.sum_accel_x = model.sum_accel_y = model.sum_wz = 0.0
        while steps < end:
            if steps >= self._next_slip_step:
                self._slip_change(steps)
            if pending and pending[0][0] <= steps * dt:
                while pending and pending[0][0] <= steps * dt:
                    _, left, right = pending.popleft()
                self._set_drive(left, right)
            if self._free_budget > 0.0:  # free space: the update pymunk would make (physics.py)
                steps = model.run_free(
                    dt,
                    steps,
                    min(end, world.next_check_step(steps, dt)),  # when a trigger may act
                    self._next_slip_step,
                    pending[0][0] if pending else math.inf,
                    scans.next_s if lidar else math.inf,
                    radius,
                    self._free_budget,
                    raw,
                )
                self._free_budget = model.free_budget_m
            else:
                model.step_forces(dt)
                self.steps = steps
                self._step_near_obstacles(space, dt)
                steps += 1
                model.record(steps, raw)
            if world.pending or (lidar and steps * dt + 1e-9 >= scans.next_s):
                self.steps = steps
                if world.pending:
                    self._check_triggers()
                if lidar and steps * dt + 1e-9 >= scans.next_s:
                    r = self.robot
                    scans.take(self.t_s, r.x, r.y, r.yaw, self.faults)
        self.steps = steps
        acc = self._acc_sum
        acc[0] += model.sum_accel_x
        acc[1] += model.sum_accel_y
        acc[2] += model.sum_wz
        r = self.robot
        if not math.isfinite(r.x + r.y + r.yaw):
            raise ConfigError(
                f"robot {self.robot_spec.name}: the physics diverged by {self.t_s:.3f} s (the "
                "pose is not finite): its mass, inertia and motor values together are more "
                f"than a {PHYSICS_HZ} Hz step integrates; bring them nearer the shipped robots'"
            )

    def _slip_change(self, steps: int) -> int:
        """A wheel-slip window opens or closes at physics step ``steps``: set the wheels' floor
        friction factors for the steps from it; return the next such step."""
        slip = self._slip_steps
        while slip and slip[0] <= steps:
            slip.popleft()
        assert self.faults is not None
        self.robot.mu_scale = self.faults.mu_scale(steps * self.dt)
        self._next_slip_step = slip[0] if slip else sys.maxsize
        return self._next_slip_step

    def _check_triggers(self) -> None:
        r = self.robot
        fired = self.world.check_triggers(
            math.hypot(r.x - self.start_xy[0], r.y - self.start_xy[1]),
            self.t_s,
            robot_xy=(r.x, r.y),
            robot_radius_m=self._radius,
        )
        if fired:
            self._free_budget = -1.0
        self.lidar_scans.obstacles = self.world.obstacles  # a removal replaces it

    @property
    def truth_log(self) -> list[Truth]:
        """Ground truth at every physics step since the start (when recorded)."""
        return self._truth_log.read()

    @property
    def record_truth(self) -> bool:
        """The ground truth of every physics step is kept (:attr:`truth_log`)."""
        return self._truth_log.rows is not None

    def _step_near_obstacles(self, space: pymunk.Space, dt: float) -> None:
        robot = self.robot
        if self._recheck <= 0:
            self._free_budget = (
                self.world.clearance(robot.x, robot.y) - self._radius - CONTACT_MARGIN_M
            )
            self._recheck = 20
            if self._free_budget > 0.0:
                robot.step_free(dt)
                return
        self._recheck -= 1
        self.world.t_s = self.steps * self.dt  # a contact in this step is dated by it
        robot.step_space(space, dt)

    def truth(self) -> Truth:
        r = self.robot
        yaw = r.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        return Truth(
            self.steps * self.dt,
            r.x,
            r.y,
            yaw,
            c * r.vwx + s * r.vwy,
            -s * r.vwx + c * r.vwy,
            r.wz,
            r.omega_l,
            r.omega_r,
        )

    def sensors(self) -> SensorSample:
        """Encoder counts now, and the IMU sample averaged since the previous call."""
        r = self.robot
        enc_l, enc_r = encoder_counts(r.angle_l, r.angle_r, self._ticks)
        count = self.steps - self._acc_from_step
        n = count or 1
        accel = (self._acc_sum[0] / n, self._acc_sum[1] / n)
        yaw_rate = self._acc_sum[2] / n if count else r.wz
        self._acc_sum[:] = [0.0, 0.0, 0.0]
        self._acc_from_step = self.steps
        self.imu.drift(count * self.dt)
        faults = self.faults
        if faults is None:
            a, temp, g = self.imu.sample(accel, yaw_rate)
            return SensorSample(enc_l, enc_r, self.robot_spec.imu.present, a, temp, g)
        t = self.t_s
        a, temp, g = self.imu.sample(accel, yaw_rate, faults.gyro_z_offset_rad_s(t))
        return faults.sensors(
            t, SensorSample(enc_l, enc_r, self.robot_spec.imu.present, a, temp, g)
        )

    @property
    def collisions(self) -> int:
        return self.world.collisions
