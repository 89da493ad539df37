"""The twin's robot: its file turned into the model's parameters, and its body in pymunk.

The per-step model (motors, gearbox stiction, traction, lateral grip, scrub) is
:mod:`jackson.sim.physics`, run compiled when its build is current (:mod:`jackson.sim.compiled`);
a :class:`DiffDriveRobot` derives its parameters from the robot file and this trial's draws,
keeps its state (:attr:`DiffDriveRobot.model`, also read and written through the robot's own
attributes ``x, y, yaw, vwx, ...``), and owns the chassis' pymunk body, which pymunk integrates
near obstacles (:meth:`DiffDriveRobot.step_space`); in free space the model makes the same update
itself (a test checks that both give the same trajectory).
"""

from __future__ import annotations

import operator
from dataclasses import dataclass
from typing import Any

import pymunk

from jackson.protocol.messages import GRAVITY_M_S2  # the twin's g is the nominal one
from jackson.sim import compiled
from jackson.sim.config import RobotSpec, Sides
from jackson.sim.physics import DiffDriveDynamics
from jackson.sim.world import FrictionField


@dataclass(frozen=True)
class WheelDrive:
    """What the H-bridge applies to one motor."""

    drive: float = 0.0  # signed average fraction of the supply, -1..1
    connected: float = 0.0  # fraction of time the windings are connected (drive or brake)

    @staticmethod
    def brake() -> WheelDrive:
        return WheelDrive(0.0, 1.0)


def _model_state(name: str) -> Any:
    """A robot attribute kept by its model: a property that reads and writes ``model.<name>``
    (its getter a C callable, so a read costs little more than the model's own)."""

    def write(robot: DiffDriveRobot, value: object) -> None:
        setattr(robot.model, name, value)

    return property(operator.attrgetter(f"model.{name}"), write, doc=f"``model.{name}``")


class DiffDriveRobot:
    """The robot's chassis (a pymunk body) plus its model's parameters and state.

    ``tau_drive_*`` is the motor torque at drive 1, ``tau_c_*`` the breakaway and
    ``tau_run_*`` the running friction [N m] (the model's parameters, as named in
    :mod:`jackson.sim.physics`). The state is the model's (:attr:`model`) and reads and writes
    through these attributes: ``x, y, yaw, vwx, vwy, wz`` (pose and world-frame velocity),
    ``omega_l/omega_r`` wheel speeds [rad/s], ``angle_l/angle_r`` integrated wheel angles
    [rad], ``tau_l/tau_r`` motor torques at the wheel [N m], ``slipping``, ``accel_x/accel_y``
    (body-frame specific force for the IMU), ``in_space`` and ``mu_scale``: None, or a factor
    per wheel (left, right) on the floor's friction under it (a slippery patch, set by the
    twin's ``wheel_slip`` faults).

    Parameters
    ----------
    spec : RobotSpec
        The robot file.
    space : pymunk.Space
        The world's space, which receives the chassis.
    mu_static, mu_dynamic : float
        The floor's friction coefficients.
    battery_v : float or None
        This trial's supply voltage [V] (None: ``spec.motor.battery_v``).
    wheel_radius_m : Sides or None
        This trial's effective wheel radii [m] (None: ``spec.wheel_radius_m``).
    floor : FrictionField or None
        This trial's friction patches (None: a uniform floor).
    caster_rolling_coeff : float or None
        This trial's caster rolling resistance (None: ``spec.caster_rolling_coeff``).

    Attributes
    ----------
    model : DiffDriveDynamics
        The per-step model and its state (the compiled class when it is in use).
    """

    x: float = _model_state("x")
    y: float = _model_state("y")
    yaw: float = _model_state("yaw")
    vwx: float = _model_state("vwx")
    vwy: float = _model_state("vwy")
    wz: float = _model_state("wz")
    in_space: bool = _model_state("in_space")
    omega_l: float = _model_state("omega_l")
    omega_r: float = _model_state("omega_r")
    angle_l: float = _model_state("angle_l")
    angle_r: float = _model_state("angle_r")
    tau_l: float = _model_state("tau_l")
    tau_r: float = _model_state("tau_r")
    slipping: bool = _model_state("slipping")
    accel_x: float = _model_state("accel_x")
    accel_y: float = _model_state("accel_y")
    mu_scale: tuple[float, float] | None = _model_state("mu_scale")

    def __init__(
        self,
        spec: RobotSpec,
        space: pymunk.Space,
        mu_static: float,
        mu_dynamic: float,
        *,
        battery_v: float | None = None,
        wheel_radius_m: Sides | None = None,
        floor: FrictionField | None = None,
        caster_rolling_coeff: float | None = None,
    ) -> None:
        self.spec = spec
        m = spec.motor
        self.mass = spec.mass_kg
        self.inertia = spec.inertia_kg_m2
        self.half_track = spec.wheel_separation_m / 2.0
        radius = spec.wheel_radius_m if wheel_radius_m is None else wheel_radius_m
        self.r_l = radius.left
        self.r_r = radius.right
        self.j_w = m.wheel_inertia_kg_m2
        self.k_e = m.stall_torque_nm / m.no_load_rad_s  # [N m s/rad]
        v_ratio = m.battery_v / m.nominal_v
        self.tau_drive_l = m.stall_torque_nm * m.gain.left * v_ratio  # torque at drive = 1
        self.tau_drive_r = m.stall_torque_nm * m.gain.right * v_ratio
        f_run = m.running_friction_fraction
        if m.ratings_net_of_friction:  # the ratings are measured past the running friction
            self.tau_drive_l /= 1.0 - f_run * m.deadband_duty.left
            self.tau_drive_r /= 1.0 - f_run * m.deadband_duty.right
        self.tau_c_l = m.deadband_duty.left * self.tau_drive_l  # breakaway at the deadband duty
        self.tau_c_r = m.deadband_duty.right * self.tau_drive_r
        self.tau_run_l = f_run * self.tau_c_l
        self.tau_run_r = f_run * self.tau_c_r
        if battery_v is not None and battery_v != m.battery_v:  # friction stays mechanical
            self.tau_drive_l *= battery_v / m.battery_v
            self.tau_drive_r *= battery_v / m.battery_v
        self.time_constant = m.time_constant_s
        self.n_wheel = self.mass * GRAVITY_M_S2 * (1.0 - spec.caster_load_fraction) / 2.0
        caster = spec.caster_rolling_coeff if caster_rolling_coeff is None else caster_rolling_coeff
        self.f_caster = caster * self.mass * GRAVITY_M_S2 * spec.caster_load_fraction
        self.mu_s = mu_static
        self.mu_d = mu_dynamic
        self.floor = floor
        t = spec.tyre
        self.model: DiffDriveDynamics = compiled.Dynamics(
            mass=float(self.mass),
            inertia=float(self.inertia),
            half_track=float(self.half_track),
            r_l=float(self.r_l),
            r_r=float(self.r_r),
            j_w=float(self.j_w),
            k_e=float(self.k_e),
            tau_drive_l=float(self.tau_drive_l),
            tau_drive_r=float(self.tau_drive_r),
            tau_c_l=float(self.tau_c_l),
            tau_c_r=float(self.tau_c_r),
            tau_run_l=float(self.tau_run_l),
            tau_run_r=float(self.tau_run_r),
            time_constant=float(self.time_constant),
            n_wheel=float(self.n_wheel),
            f_caster=float(self.f_caster),
            mu_s=float(mu_static),
            mu_d=float(mu_dynamic),
            creep=float(t.longitudinal_compliance),
            corner=float(t.cornering_compliance_rad),
            scrub_arm=float(t.scrub_arm_m),
            scrub_phi=float(t.scrub_saturation_curvature_1_m),
            cells=None if floor is None else floor.cells,
            cells_per_m=1.0 if floor is None else floor.cells_per_m,
            cells_x0=0.0 if floor is None else floor.origin_x_m,
            cells_y0=0.0 if floor is None else floor.origin_y_m,
        )

        self.body = pymunk.Body(self.mass, self.inertia)
        (x0, x1), (y0, y1) = spec.envelope_x_m, spec.envelope_y_m
        self.shape = pymunk.Poly(self.body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
        self.shape.friction = 0.5
        self.shape.elasticity = 0.0
        space.add(self.body, self.shape)

    def place(self, x: float, y: float, yaw: float) -> None:
        """Put the robot at rest at a pose.

        Parameters
        ----------
        x, y : float
            Position [m].
        yaw : float
            Heading [rad].
        """
        model = self.model
        model.x, model.y, model.yaw = x, y, yaw
        model.vwx = model.vwy = model.wz = 0.0
        self.sync_body()

    def drive(self, left: WheelDrive, right: WheelDrive) -> None:
        """Apply H-bridge outputs to the motors from the next step on.

        Parameters
        ----------
        left, right : WheelDrive
            Each motor's drive.
        """
        model = self.model
        model.left.drive, model.left.connected = left.drive, left.connected
        model.right.drive, model.right.connected = right.drive, right.connected

    def sync_body(self) -> None:
        """Copy the float state into the pymunk body (before pymunk takes over)."""
        b, model = self.body, self.model
        b.position = (model.x, model.y)
        b.angle = model.yaw
        b.velocity = (model.vwx, model.vwy)
        b.angular_velocity = model.wz

    def step_space(self, space: pymunk.Space, dt: float) -> None:
        """Let pymunk integrate this step and resolve contacts, then read the result back.

        Parameters
        ----------
        space : pymunk.Space
            The world's space.
        dt : float
            The physics step [s].
        """
        b, model = self.body, self.model
        if not model.in_space:
            model.in_space = True
            b.position = (model.x, model.y)
            b.angle = model.yaw
        b.velocity = (model.vwx, model.vwy)
        b.angular_velocity = model.wz
        space.step(dt)
        model.x, model.y = b.position
        model.yaw = b.angle
        model.vwx, model.vwy = b.velocity
        model.wz = b.angular_velocity

    def step_free(self, dt: float) -> None:
        """The step pymunk would take in free space: p += v dt, yaw += omega dt.

        Parameters
        ----------
        dt : float
            The physics step [s].
        """
        self.model.step_free(dt)
