"""Differential-drive dynamics of the twin: DC motors, gearbox stiction, traction and slip.

pymunk integrates the chassis pose and resolves collisions; this module supplies what pymunk
does not know about: wheels that spin on their own, motors, and tyre friction.

Per physics step of ``dt`` (semi-implicit, stable at any friction):

1. **Motor torque** at each wheel shaft from the TB6612 output (signed supply fraction ``drive``
   and the fraction of time the windings are connected ``conn``): the linear torque-speed line
   ``tau* = tau_stall * gain * drive * V_batt / V_nom - k_e * omega * conn`` with
   ``k_e = tau_stall / omega_no_load``, reached through a first-order lag ``time_constant_s``
   (integrated exactly for a constant input).
2. **Gearbox stiction**: a wheel at rest stays locked while ``|tau| <= tau_c``, the torque of the
   breakaway duty (``deadband_duty``); a turning wheel loses ``tau_c`` to Coulomb friction.
3. **Longitudinal traction**: the ground forces ``F_L, F_R`` that make both contact slips
   ``omega_i r_i - (v_x -+ omega_z B/2)`` vanish at the end of the step solve a 2x2 system
   coupling wheel inertia, mass and yaw inertia; each is limited to ``mu_s N_i`` (sticking) or
   set to ``mu_d N_i`` against the slip (sliding). A rolling-resistance force acts at the caster.
4. **Lateral grip**: the lateral force that cancels sideways velocity at the axle, limited by the
   friction left in each wheel's cone ``sqrt((mu N)^2 - F_long^2)``.

The centre of mass is at the axle centre (``base_footprint``), the caster carries
``caster_load_fraction`` of the weight. Collisions with walls and obstacles are pymunk's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from jackson.sim.config import RobotSpec

GRAVITY_M_S2 = 9.81
_STICK_RAD_S = 1e-3  # a wheel slower than this may stick in its gearbox


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
    at the wheel [N m].
    """

    def __init__(
        self, spec: RobotSpec, space: pymunk.Space, mu_static: float, mu_dynamic: float
    ) -> None:
        self.spec = spec
        m = spec.motor
        self.mass = spec.mass_kg
        self.inertia = spec.inertia_kg_m2
        self.half_track = spec.track_width_m / 2.0
        self.r_l = spec.wheel_radius_m.left
        self.r_r = spec.wheel_radius_m.right
        self.j_w = m.wheel_inertia_kg_m2
        self.k_e = m.stall_torque_nm / m.no_load_rad_s  # [N m s/rad]
        v_ratio = m.battery_v / m.nominal_v
        self.tau_drive_l = m.stall_torque_nm * m.gain.left * v_ratio  # torque at drive = 1
        self.tau_drive_r = m.stall_torque_nm * m.gain.right * v_ratio
        self.tau_c_l = m.deadband_duty.left * self.tau_drive_l  # breakaway at the deadband duty
        self.tau_c_r = m.deadband_duty.right * self.tau_drive_r
        self.time_constant = m.time_constant_s
        n_wheel = self.mass * GRAVITY_M_S2 * (1.0 - spec.caster_load_fraction) / 2.0
        self.n_wheel = n_wheel
        self.f_caster = (
            spec.caster_rolling_coeff * self.mass * GRAVITY_M_S2 * spec.caster_load_fraction
        )
        self.mu_s = mu_static
        self.mu_d = mu_dynamic

        self.body = pymunk.Body(self.mass, self.inertia)
        (x0, x1), (y0, y1) = spec.envelope_x_m, spec.envelope_y_m
        self.shape = pymunk.Poly(self.body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
        self.shape.friction = 0.5
        self.shape.elasticity = 0.0
        space.add(self.body, self.shape)

        self.omega_l = self.omega_r = 0.0
        self.angle_l = self.angle_r = 0.0
        self.tau_l = self.tau_r = 0.0
        self.slipping = False
        # body-frame specific force and yaw rate, for the IMU
        self.accel_x = self.accel_y = 0.0

    def place(self, x: float, y: float, yaw: float) -> None:
        self.body.position = (x, y)
        self.body.angle = yaw
        self.body.velocity = (0.0, 0.0)
        self.body.angular_velocity = 0.0

    def _motor(
        self, tau: float, wd: WheelDrive, tau_drive: float, omega: float, alpha: float
    ) -> float:
        target = tau_drive * wd.drive - self.k_e * omega * wd.connected
        return tau + (target - tau) * alpha

    def step_forces(self, dt: float, left: WheelDrive, right: WheelDrive) -> None:
        """Update wheel speeds and the chassis velocity for one step; pymunk then moves it."""
        body = self.body
        yaw = body.angle
        c, s = math.cos(yaw), math.sin(yaw)
        vwx, vwy = body.velocity
        vx = c * vwx + s * vwy
        vy = -s * vwx + c * vwy
        wz = body.angular_velocity
        h = self.half_track
        m, inertia, jw = self.mass, self.inertia, self.j_w

        alpha = 1.0 - math.exp(-dt / self.time_constant) if self.time_constant > 0 else 1.0
        tau_l = self.tau_l = self._motor(self.tau_l, left, self.tau_drive_l, self.omega_l, alpha)
        tau_r = self.tau_r = self._motor(self.tau_r, right, self.tau_drive_r, self.omega_r, alpha)

        # gearbox: locked while the motor cannot break it free
        free_l = abs(self.omega_l) > _STICK_RAD_S or abs(tau_l) > self.tau_c_l
        free_r = abs(self.omega_r) > _STICK_RAD_S or abs(tau_r) > self.tau_c_r

        # caster rolling resistance, smooth through zero
        f_c = -self.f_caster * math.tanh(vx / 0.005)
        for _ in range(2):
            net_l = tau_l - math.copysign(self.tau_c_l, self.omega_l if self.omega_l else tau_l)
            net_r = tau_r - math.copysign(self.tau_c_r, self.omega_r if self.omega_r else tau_r)
            w_l = self.omega_l + dt * net_l / jw if free_l else 0.0
            w_r = self.omega_r + dt * net_r / jw if free_r else 0.0
            v_pred = vx + dt * f_c / m
            s_l = w_l * self.r_l - (v_pred - h * wz)  # slip without ground forces
            s_r = w_r * self.r_r - (v_pred + h * wz)
            a_l = self.r_l * self.r_l / jw if free_l else 0.0
            a_r = self.r_r * self.r_r / jw if free_r else 0.0
            d = 1.0 / m + h * h / inertia
            o = 1.0 / m - h * h / inertia
            a11, a12, a22 = a_l + d, o, a_r + d
            b1, b2 = s_l / dt, s_r / dt
            det = a11 * a22 - a12 * a12
            f_l = (b1 * a22 - a12 * b2) / det
            f_r = (a11 * b2 - a12 * b1) / det
            lim_s, lim_d = self.mu_s * self.n_wheel, self.mu_d * self.n_wheel
            slip_l = abs(f_l) > lim_s
            slip_r = abs(f_r) > lim_s
            if slip_l and slip_r:
                f_l = math.copysign(lim_d, f_l)
                f_r = math.copysign(lim_d, f_r)
            elif slip_l:
                f_l = math.copysign(lim_d, f_l)
                f_r = max(-lim_s, min(lim_s, (b2 - a12 * f_l) / a22))
            elif slip_r:
                f_r = math.copysign(lim_d, f_r)
                f_l = max(-lim_s, min(lim_s, (b1 - a12 * f_r) / a11))
            # a locked wheel breaks free when the ground back-drives it past stiction
            unlock_l = not free_l and abs(tau_l - f_l * self.r_l) > self.tau_c_l
            unlock_r = not free_r and abs(tau_r - f_r * self.r_r) > self.tau_c_r
            if not (unlock_l or unlock_r):
                break
            free_l = free_l or unlock_l
            free_r = free_r or unlock_r

        self.slipping = slip_l or slip_r
        # wheels
        if free_l:
            net_l = tau_l - f_l * self.r_l
            fric = math.copysign(self.tau_c_l, self.omega_l if self.omega_l else net_l)
            new_l = self.omega_l + dt * (net_l - fric) / jw
            if self.omega_l and new_l * self.omega_l < 0 and abs(net_l) <= self.tau_c_l:
                new_l = 0.0  # Coulomb friction stops the wheel; it does not reverse it
            self.omega_l = new_l
        else:
            self.omega_l = 0.0
        if free_r:
            net_r = tau_r - f_r * self.r_r
            fric = math.copysign(self.tau_c_r, self.omega_r if self.omega_r else net_r)
            new_r = self.omega_r + dt * (net_r - fric) / jw
            if self.omega_r and new_r * self.omega_r < 0 and abs(net_r) <= self.tau_c_r:
                new_r = 0.0
            self.omega_r = new_r
        else:
            self.omega_r = 0.0
        self.angle_l += self.omega_l * dt
        self.angle_r += self.omega_r * dt

        # chassis: longitudinal and yaw from the wheel forces, lateral grip at the axle
        vx_new = vx + dt * (f_l + f_r + f_c) / m
        wz_new = wz + dt * (f_r - f_l) * h / inertia
        f_lat = -m * vy / dt
        mu_lat = self.mu_s
        cap = _cone(mu_lat * self.n_wheel, f_l) + _cone(mu_lat * self.n_wheel, f_r)
        if abs(f_lat) > cap:
            cap = _cone(self.mu_d * self.n_wheel, f_l) + _cone(self.mu_d * self.n_wheel, f_r)
            f_lat = math.copysign(cap, f_lat)
            self.slipping = True
        vy_new = vy + dt * f_lat / m
        self.accel_x = (vx_new - vx) / dt - wz * vy
        self.accel_y = (vy_new - vy) / dt + wz * vx
        body.velocity = (c * vx_new - s * vy_new, s * vx_new + c * vy_new)
        body.angular_velocity = wz_new


def _cone(limit: float, f_long: float) -> float:
    """Lateral friction left in a wheel's friction circle."""
    rest = limit * limit - f_long * f_long
    return math.sqrt(rest) if rest > 0.0 else 0.0
