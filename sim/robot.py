"""Differential-drive dynamics of the twin: DC motors, gearbox stiction, traction and slip.

pymunk integrates the chassis pose and resolves collisions; this module supplies what pymunk
does not know about: wheels that spin on their own, motors, and tyre friction.

Per physics step of ``dt`` (semi-implicit, stable at any friction):

1. **Motor torque** at each wheel shaft from the TB6612 output (signed supply fraction ``drive``
   and the fraction of time the windings are connected ``conn``): the linear torque-speed line
   ``tau* = tau_d * drive - k_e * omega * conn`` with ``tau_d = tau_stall * gain * V_batt /
   V_nom`` and ``k_e = tau_stall / omega_no_load``, reached through a first-order lag
   ``time_constant_s`` (integrated exactly for a constant input). With
   ``ratings_net_of_friction`` the ratings are those measured at the wheel, net of the gearbox's
   running friction ``tau_r``: ``tau_d = tau_stall * gain * V_batt / V_nom / (1 - f d_b)``, so
   a wheel at full duty and no load turns at ``omega_no_load * gain * V_batt / V_nom`` (a
   datasheet's no-load speed is measured with the gearbox in it). A trial's supply voltage
   (``variation.battery_v_sigma``) scales ``tau_d``, not the friction.
2. **Gearbox stiction**: a wheel at rest stays locked while ``|tau| <= tau_c``, the breakaway
   torque of the breakaway duty ``d_b`` (``deadband_duty``), ``tau_c = d_b tau_d``; a turning
   wheel loses ``tau_r = f tau_c`` to Coulomb friction (``f = running_friction_fraction``, 1:
   running friction equal to breakaway).
3. **Longitudinal traction**: the ground forces ``F_L, F_R`` that make both contact slips
   ``omega_i r_i - (v_x -+ omega_z B/2)`` vanish at the end of the step solve a 2x2 system
   coupling wheel inertia, mass and yaw inertia; each is limited to ``mu_s N_i`` (sticking) or
   set to ``mu_d N_i`` against the slip (sliding). A rolling-resistance force acts at the caster.
   With tyre creep (``tyre.longitudinal_compliance`` c) the slip at the end of the step is not
   zero but the brush model's linear creep ``kappa v_ref = c F_i v_ref / N_i`` (``v_ref``
   the larger of the wheel's rim and ground speeds, at least ``V_CREEP_MIN_M_S``): the same
   system with ``c v_ref / (N_i dt)`` added to its diagonal.
4. **Lateral grip**: the lateral force that cancels sideways velocity at the axle, limited by the
   friction left in each wheel's cone ``sqrt((mu N)^2 - F_long^2)``. With
   ``tyre.cornering_compliance_rad`` c the axle keeps the slip angle ``alpha = c F_y / N``
   (``F_y = -v_y / (dt / m + c max(|v_x|, V_CREEP_MIN_M_S) / N)``, implicit in ``v_y``).
5. **Scrub**: ``tyre.scrub_arm_m`` a adds a yaw moment against the yaw rate, at most
   ``a mu_d (N_L + N_R)`` (never more than stops the yaw in one step): the contact patches'
   spin friction and the caster's drag. Saturated (Coulomb) at any turn, or with
   ``tyre.scrub_saturation_curvature_1_m`` phi_s > 0 each wheel's share grows as
   ``tanh(phi_i / phi_s)`` of its path curvature ``phi_i = |omega_z| / |v_i|`` (a rolling
   tyre scrubs less than one pivoting on the spot: phi_i = 2/B there). With creep the wheels
   give way to it, so a turning robot turns slower than its wheels say (a wider effective
   track); with rigid tyres it only loads the motors.

Friction patches (a :class:`~jackson.sim.world.FrictionField`) multiply mu_s and mu_d under
each wheel, and so its traction limits and its share of the scrub; a ``wheel_slip`` fault
(:mod:`jackson.sim.faults`) multiplies them further by its ``mu_scale`` under one wheel
(:attr:`DiffDriveRobot.mu_scale`) while it lasts.

The centre of mass is at the axle centre (``base_footprint``), the caster carries
``caster_load_fraction`` of the weight. Collisions with walls and obstacles are pymunk's.

The chassis state is kept as plain floats (``x, y, yaw`` and the world-frame velocity). Within
reach of an obstacle every step goes through ``pymunk.Space.step``; in free space, where pymunk
would only integrate ``p += v dt, yaw += omega dt`` (no gravity, no damping, no contact), the
same update is done directly, and the pymunk body is brought up to date before the next step
that needs it. Both paths give the same trajectory (a test checks this).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from jackson.protocol.messages import GRAVITY_M_S2  # the twin's g is the nominal one
from jackson.sim.config import RobotSpec, Sides
from jackson.sim.world import FrictionField

_STICK_RAD_S = 1e-3  # a wheel slower than this may stick in its gearbox
V_CREEP_MIN_M_S = 0.01  # [m/s] reference speed of the creep and slip-angle models near rest


@dataclass(frozen=True)
class WheelDrive:
    """What the H-bridge applies to one motor."""

    drive: float = 0.0  # signed average fraction of the supply, -1..1
    connected: float = 0.0  # fraction of time the windings are connected (drive or brake)

    @staticmethod
    def brake() -> WheelDrive:
        return WheelDrive(0.0, 1.0)


class DiffDriveRobot:
    """The robot's chassis (a pymunk body) plus wheel and motor state.

    Attributes are named as in the module docstring; ``omega_l/omega_r`` are wheel speeds
    [rad/s], ``angle_l/angle_r`` integrated wheel angles [rad], ``tau_l/tau_r`` motor torques
    at the wheel [N m], ``tau_c_*`` breakaway and ``tau_run_*`` running friction [N m];
    ``mu_scale`` is None, or a factor per wheel (left, right) on the floor's friction under
    it (a slippery patch, set by the twin's ``wheel_slip`` faults).

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
    """

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
        n_wheel = self.mass * GRAVITY_M_S2 * (1.0 - spec.caster_load_fraction) / 2.0
        self.n_wheel = n_wheel
        self.f_caster = (
            spec.caster_rolling_coeff * self.mass * GRAVITY_M_S2 * spec.caster_load_fraction
        )
        self.mu_s = mu_static
        self.mu_d = mu_dynamic
        self.floor = floor
        if floor is not None:  # read inline by step_forces, as FrictionField.factor does
            self._cells = floor.cells
            self._cells_n = len(floor.cells)
            self._cells_per_m = floor.cells_per_m
            self._cells_x0, self._cells_y0 = floor.origin_x_m, floor.origin_y_m
        t = spec.tyre
        self.creep = t.longitudinal_compliance
        self.corner = t.cornering_compliance_rad
        self.scrub_arm = t.scrub_arm_m
        self.scrub_phi = t.scrub_saturation_curvature_1_m

        self.body = pymunk.Body(self.mass, self.inertia)
        (x0, x1), (y0, y1) = spec.envelope_x_m, spec.envelope_y_m
        self.shape = pymunk.Poly(self.body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
        self.shape.friction = 0.5
        self.shape.elasticity = 0.0
        space.add(self.body, self.shape)

        self.x = self.y = self.yaw = 0.0
        self.vwx = self.vwy = self.wz = 0.0  # world-frame velocity, yaw rate
        self.in_space = False  # True while pymunk integrates (near obstacles)
        self.omega_l = self.omega_r = 0.0
        self.angle_l = self.angle_r = 0.0
        self.tau_l = self.tau_r = 0.0
        self.slipping = False
        self.mu_scale: tuple[float, float] | None = None
        # body-frame specific force and yaw rate, for the IMU
        self.accel_x = self.accel_y = 0.0

    def place(self, x: float, y: float, yaw: float) -> None:
        self.x, self.y, self.yaw = x, y, yaw
        self.vwx = self.vwy = self.wz = 0.0
        self.sync_body()

    def sync_body(self) -> None:
        """Copy the float state into the pymunk body (before pymunk takes over)."""
        b = self.body
        b.position = (self.x, self.y)
        b.angle = self.yaw
        b.velocity = (self.vwx, self.vwy)
        b.angular_velocity = self.wz

    def step_space(self, space: pymunk.Space, dt: float) -> None:
        """Let pymunk integrate this step and resolve contacts, then read the result back."""
        b = self.body
        if not self.in_space:
            self.in_space = True
            b.position = (self.x, self.y)
            b.angle = self.yaw
        b.velocity = (self.vwx, self.vwy)
        b.angular_velocity = self.wz
        space.step(dt)
        self.x, self.y = b.position
        self.yaw = b.angle
        self.vwx, self.vwy = b.velocity
        self.wz = b.angular_velocity

    def step_free(self, dt: float) -> None:
        """The step pymunk would take in free space: p += v dt, yaw += omega dt."""
        self.in_space = False
        self.x += self.vwx * dt
        self.y += self.vwy * dt
        self.yaw += self.wz * dt

    def _constants(self, dt: float) -> tuple[float, ...]:
        """Per-step constants (dt is fixed for a run; recomputed only when it changes)."""
        if self._const_dt != dt:
            tc = self.time_constant
            h2i = self.half_track * self.half_track / self.inertia
            self._const = (
                1.0 - math.exp(-dt / tc) if tc > 0 else 1.0,  # motor lag per step
                1.0 / self.mass + h2i,  # coupling of a wheel force to its own contact
                1.0 / self.mass - h2i,  # ... and to the other wheel's contact
                self.r_l * self.r_l / self.j_w,
                self.r_r * self.r_r / self.j_w,
                self.mu_s * self.n_wheel,
                self.mu_d * self.n_wheel,
            )
            self._creep_k = self.creep / (self.n_wheel * dt)  # slip per dt per N, per m/s
            self._corner_k = self.corner / (2.0 * self.n_wheel)
            self._i_dt = self.inertia / dt
            self._const_dt = dt
        return self._const

    _const_dt = -1.0
    _const: tuple[float, ...] = ()

    def step_forces(self, dt: float, left: WheelDrive, right: WheelDrive) -> None:
        """Update wheel speeds and the chassis velocity for one step (then step_space/free)."""
        alpha, d, o, a_free_l, a_free_r, lim_s, lim_d = self._constants(dt)
        yaw = self.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        vwx, vwy, wz = self.vwx, self.vwy, self.wz
        vx = c * vwx + s * vwy
        vy = -s * vwx + c * vwy
        h, m, jw = self.half_track, self.mass, self.j_w
        r_l, r_r = self.r_l, self.r_r
        om_l, om_r = self.omega_l, self.omega_r
        tc_l, tc_r = self.tau_c_l, self.tau_c_r
        tr_l, tr_r = self.tau_run_l, self.tau_run_r
        k_e = self.k_e

        # motor torque: first-order lag towards the torque-speed line
        tau_l = self.tau_l
        tau_l += (self.tau_drive_l * left.drive - k_e * om_l * left.connected - tau_l) * alpha
        tau_r = self.tau_r
        tau_r += (self.tau_drive_r * right.drive - k_e * om_r * right.connected - tau_r) * alpha
        self.tau_l, self.tau_r = tau_l, tau_r

        # gearbox: locked while the motor cannot break it free
        free_l = abs(om_l) > _STICK_RAD_S or abs(tau_l) > tc_l
        free_r = abs(om_r) > _STICK_RAD_S or abs(tau_r) > tc_r

        # friction under each wheel
        lim_s_l = lim_s_r = lim_s
        lim_d_l = lim_d_r = lim_d
        if self.floor is not None:  # FrictionField.factor under each wheel, inline
            cells, n, per_m = self._cells, self._cells_n, self._cells_per_m
            x0, y0, sh, ch = self._cells_x0, self._cells_y0, s * h, c * h
            k_l = cells[math.floor((self.x - sh - x0) * per_m) % n][
                math.floor((self.y + ch - y0) * per_m) % n
            ]
            k_r = cells[math.floor((self.x + sh - x0) * per_m) % n][
                math.floor((self.y - ch - y0) * per_m) % n
            ]
            lim_s_l, lim_d_l = lim_s * k_l, lim_d * k_l
            lim_s_r, lim_d_r = lim_s * k_r, lim_d * k_r
        if self.mu_scale is not None:  # a slippery patch under a wheel (a wheel_slip fault)
            k_l, k_r = self.mu_scale
            lim_s_l, lim_d_l = lim_s_l * k_l, lim_d_l * k_l
            lim_s_r, lim_d_r = lim_s_r * k_r, lim_d_r * k_r

        # caster rolling resistance, smooth through zero; tyre scrub against the yaw rate
        f_c = -self.f_caster * math.tanh(vx / 0.005)
        v_pred = vx + dt * f_c / m
        wz_pred = wz
        if self.scrub_arm > 0.0 and wz:
            phi = self.scrub_phi
            if phi > 0.0:  # the unsaturated share: each wheel's path curvature / phi_sat
                w = abs(wz)
                m_l = lim_d_l * math.tanh(w / (max(abs(vx - h * wz), V_CREEP_MIN_M_S) * phi))
                m_r = lim_d_r * math.tanh(w / (max(abs(vx + h * wz), V_CREEP_MIN_M_S) * phi))
                m_z = self.scrub_arm * (m_l + m_r)
            else:
                m_z = self.scrub_arm * (lim_d_l + lim_d_r)
            stop = self._i_dt * abs(wz)
            wz_pred = 0.0 if m_z >= stop else wz - math.copysign(m_z, wz) / self._i_dt
        net_l = tau_l - math.copysign(tr_l, om_l if om_l else tau_l)
        net_r = tau_r - math.copysign(tr_r, om_r if om_r else tau_r)
        cl_l = cl_r = 0.0  # creep: slip per unit force, per dt
        if self.creep > 0.0:  # reference speed: the larger of rim and ground speed
            ref_l, g = abs(om_l * r_l), abs(v_pred - h * wz_pred)
            ref_l = g if g > ref_l else ref_l
            ref_r, g = abs(om_r * r_r), abs(v_pred + h * wz_pred)
            ref_r = g if g > ref_r else ref_r
            k = self._creep_k
            cl_l = k * (ref_l if ref_l > V_CREEP_MIN_M_S else V_CREEP_MIN_M_S)
            cl_r = k * (ref_r if ref_r > V_CREEP_MIN_M_S else V_CREEP_MIN_M_S)
        while True:
            w_l = om_l + dt * net_l / jw if free_l else 0.0
            w_r = om_r + dt * net_r / jw if free_r else 0.0
            b1 = (w_l * r_l - (v_pred - h * wz_pred)) / dt  # slip without ground forces, per dt
            b2 = (w_r * r_r - (v_pred + h * wz_pred)) / dt
            a11 = (a_free_l if free_l else 0.0) + d + cl_l
            a22 = (a_free_r if free_r else 0.0) + d + cl_r
            det = a11 * a22 - o * o
            f_l = (b1 * a22 - o * b2) / det
            f_r = (a11 * b2 - o * b1) / det
            slip_l = abs(f_l) > lim_s_l
            slip_r = abs(f_r) > lim_s_r
            if slip_l and slip_r:
                f_l = math.copysign(lim_d_l, f_l)
                f_r = math.copysign(lim_d_r, f_r)
            elif slip_l:
                f_l = math.copysign(lim_d_l, f_l)
                f_r = max(-lim_s_r, min(lim_s_r, (b2 - o * f_l) / a22))
            elif slip_r:
                f_r = math.copysign(lim_d_r, f_r)
                f_l = max(-lim_s_l, min(lim_s_l, (b1 - o * f_r) / a11))
            # a locked wheel breaks free when the ground back-drives it past stiction
            unlock_l = not free_l and abs(tau_l - f_l * r_l) > tc_l
            unlock_r = not free_r and abs(tau_r - f_r * r_r) > tc_r
            if not (unlock_l or unlock_r):
                break
            free_l = free_l or unlock_l
            free_r = free_r or unlock_r

        slipping = slip_l or slip_r
        # wheels: running friction while turning; stopped unless the torque breaks stiction
        if free_l:
            net = tau_l - f_l * r_l
            new = om_l + dt * (net - math.copysign(tr_l, om_l if om_l else net)) / jw
            if om_l and new * om_l < 0 and abs(net) <= tc_l:
                new = 0.0  # Coulomb friction stops the wheel; it does not reverse it
            om_l = new
        else:
            om_l = 0.0
        if free_r:
            net = tau_r - f_r * r_r
            new = om_r + dt * (net - math.copysign(tr_r, om_r if om_r else net)) / jw
            if om_r and new * om_r < 0 and abs(net) <= tc_r:
                new = 0.0
            om_r = new
        else:
            om_r = 0.0
        self.omega_l, self.omega_r = om_l, om_r
        self.angle_l += om_l * dt
        self.angle_r += om_r * dt

        # chassis: longitudinal and yaw from the wheel forces, lateral grip at the axle
        vx_new = vx + dt * (f_l + f_r + f_c) / m
        wz_new = wz_pred + dt * (f_r - f_l) * h / self.inertia
        if self.corner > 0.0:  # the slip angle the lateral force needs, implicit in v_y
            ref = abs(vx)
            ref = ref if ref > V_CREEP_MIN_M_S else V_CREEP_MIN_M_S
            f_lat = -vy / (dt / m + self._corner_k * ref)
        else:
            f_lat = -m * vy / dt
        cap = _cone(lim_s_l, f_l) + _cone(lim_s_r, f_r)
        if abs(f_lat) > cap:
            f_lat = math.copysign(_cone(lim_d_l, f_l) + _cone(lim_d_r, f_r), f_lat)
            slipping = True
        self.slipping = slipping
        vy_new = vy + dt * f_lat / m
        self.accel_x = (vx_new - vx) / dt - wz * vy
        self.accel_y = (vy_new - vy) / dt + wz * vx
        self.vwx = c * vx_new - s * vy_new
        self.vwy = s * vx_new + c * vy_new
        self.wz = wz_new


def _cone(limit: float, f_long: float) -> float:
    """Lateral friction left in a wheel's friction circle."""
    rest = limit * limit - f_long * f_long
    return math.sqrt(rest) if rest > 0.0 else 0.0
