"""Per-step dynamics of the twin's robot: DC motors, gearbox stiction, traction and slip.

pymunk integrates the chassis pose and resolves collisions near obstacles; this module supplies
what pymunk does not know about: wheels that spin on their own, motors, and tyre friction; and
in free space it also makes pymunk's position update itself. It is plain Python on floats and
imports nothing but :mod:`math` and :mod:`dataclasses`, so that ``make setup`` can compile it
with mypyc into a native module of the same arithmetic (:mod:`jackson.sim.compiled`,
docs/compiled.md); interpreted or compiled, a run is the same bit for bit.

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

Friction patches (a :class:`~jackson.sim.world.FrictionField`'s cells) multiply mu_s and mu_d
under each wheel, and so its traction limits and its share of the scrub; a ``wheel_slip`` fault
(:mod:`jackson.sim.faults`) multiplies them further by its ``mu_scale`` under one wheel
(:attr:`DiffDriveDynamics.mu_scale`) while it lasts.

The centre of mass is at the axle centre (``base_footprint``), the caster carries
``caster_load_fraction`` of the weight (in ``n_wheel`` and ``f_caster``).

The chassis state is plain floats (``x, y, yaw`` and the world-frame velocity). In free space,
where pymunk would only integrate ``p += v dt, yaw += omega dt`` (no gravity, no damping, no
contact), :meth:`DiffDriveDynamics.run_free` makes that update itself, many steps per call;
within reach of an obstacle the twin lets pymunk integrate the step instead
(:meth:`jackson.sim.robot.DiffDriveRobot.step_space`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

STICK_RAD_S: Final = 1e-3  # [rad/s] a wheel slower than this may stick in its gearbox
V_CREEP_MIN_M_S: Final = 0.01  # [m/s] reference speed of the creep and slip-angle models near rest
tanh: Final = math.tanh  # no mypyc primitive: bound once, a compiled call skips the lookup

TruthRow = tuple[int, float, float, float, float, float, float, float, float]
"""One physics step's raw ground truth: (step, x, y, yaw, vwx, vwy, wz, omega_l, omega_r)."""

Limits = tuple[float, float, float, float]
"""The friction limits under the wheels, ``(mu_s N_L, mu_d N_L, mu_s N_R, mu_d N_R)`` [N]."""


class FrictionCells:
    """The floor's friction patches as the model reads them: the factors of a
    :class:`~jackson.sim.world.FrictionField`, a periodic tile of ``cells_per_m`` cells a metre
    from ``(x0, y0)`` [m], nearest cell (fixed for a trial).
    """

    def __init__(
        self, cells: tuple[tuple[float, ...], ...], cells_per_m: float, x0: float, y0: float
    ) -> None:
        self.cells = cells
        self.n = len(cells)
        self.per_m = cells_per_m
        self.x0 = x0
        self.y0 = y0

    def factor(self, x: float, y: float) -> float:
        """The factor on mu_s and mu_d at a point of the floor [1] (``FrictionField.factor``)."""
        n, per_m = self.n, self.per_m
        return self.cells[math.floor((x - self.x0) * per_m) % n][
            math.floor((y - self.y0) * per_m) % n
        ]


@dataclass(frozen=True)
class DynamicsParams:
    """The model's parameters, fixed for a trial, named as in the module docstring.

    ``mass`` [kg], ``inertia`` [kg m^2], ``half_track`` B/2 [m], ``r_l, r_r`` wheel radii [m],
    ``j_w`` wheel inertia [kg m^2], ``k_e`` [N m s/rad], ``tau_drive_*`` torque at drive 1
    [N m], ``tau_c_*`` breakaway and ``tau_run_*`` running friction [N m], ``time_constant``
    [s], ``n_wheel`` load per wheel [N], ``f_caster`` caster rolling resistance [N], ``mu_s,
    mu_d`` the floor's friction, ``creep`` [1], ``corner`` [rad], ``scrub_arm`` [m],
    ``scrub_phi`` [1/m], ``floor`` the friction patches (None: a uniform floor).
    """

    mass: float
    inertia: float
    half_track: float
    r_l: float
    r_r: float
    j_w: float
    k_e: float
    tau_drive_l: float
    tau_drive_r: float
    tau_c_l: float
    tau_c_r: float
    tau_run_l: float
    tau_run_r: float
    time_constant: float
    n_wheel: float
    f_caster: float
    mu_s: float
    mu_d: float
    creep: float
    corner: float
    scrub_arm: float
    scrub_phi: float
    floor: FrictionCells | None = None


class StepConstants:
    """What a step of ``dt`` [s] needs that follows from the parameters and ``dt`` alone (dt
    is fixed for a run: made once)."""

    def __init__(self, p: DynamicsParams, dt: float) -> None:
        tc = p.time_constant
        h2i = p.half_track * p.half_track / p.inertia
        self.dt = dt
        self.alpha = 1.0 - math.exp(-dt / tc) if tc > 0 else 1.0  # motor lag per step
        self.d = 1.0 / p.mass + h2i  # coupling of a wheel force to its own contact
        self.o = 1.0 / p.mass - h2i  # ... and to the other wheel's contact
        self.a_free_l = p.r_l * p.r_l / p.j_w
        self.a_free_r = p.r_r * p.r_r / p.j_w
        self.lim_s = p.mu_s * p.n_wheel
        self.lim_d = p.mu_d * p.n_wheel
        self.creep_k = p.creep / (p.n_wheel * dt)  # slip per dt per N, per m/s
        self.corner_k = p.corner / (2.0 * p.n_wheel)
        self.i_dt = p.inertia / dt


class WheelState:
    """One wheel's motor and shaft: the H-bridge's output it gets (``drive``, signed supply
    fraction; ``connected``, fraction of time the windings are connected), the motor torque
    at the wheel ``tau`` [N m], the speed ``omega`` [rad/s] and the integrated angle
    ``angle`` [rad]."""

    def __init__(self) -> None:
        self.drive = 0.0
        self.connected = 0.0
        self.tau = 0.0
        self.omega = 0.0
        self.angle = 0.0


class DiffDriveDynamics:
    """The robot's wheel, motor and chassis state and its update per physics step.

    Parameters are keyword arguments named as in :class:`DynamicsParams` (kept in
    :attr:`params`), with the friction patches' factors ``cells`` (or None), ``cells_per_m``
    [1/m] and their origin ``cells_x0, cells_y0`` [m].

    State: pose ``x, y`` [m], ``yaw`` [rad]; world-frame velocity ``vwx, vwy`` [m/s] and yaw
    rate ``wz`` [rad/s]; each wheel's :class:`WheelState` in :attr:`left` and :attr:`right`,
    also as ``omega_l, omega_r`` [rad/s], ``angle_l, angle_r`` [rad], the motor torques at the
    wheel ``tau_l, tau_r`` [N m]; ``slipping`` (a tyre slid in the last step); the body-frame
    specific force ``accel_x, accel_y`` [m/s^2] of the last step, for the IMU; ``in_space``
    (pymunk integrated the last step); ``mu_scale``, None or a factor per wheel (left, right)
    on the floor's friction under it.

    Inputs: the H-bridge output per wheel, ``left.drive, right.drive`` (signed supply
    fraction) and ``left.connected, right.connected`` (fraction of time the windings are
    connected).

    Sums for the IMU: ``sum_accel_x, sum_accel_y, sum_wz`` add up the specific force and the
    yaw rate after each step (:meth:`record`); ``free_budget_m`` is what is left of the free
    space :meth:`run_free` was given [m].
    """

    def __init__(
        self,
        *,
        mass: float,
        inertia: float,
        half_track: float,
        r_l: float,
        r_r: float,
        j_w: float,
        k_e: float,
        tau_drive_l: float,
        tau_drive_r: float,
        tau_c_l: float,
        tau_c_r: float,
        tau_run_l: float,
        tau_run_r: float,
        time_constant: float,
        n_wheel: float,
        f_caster: float,
        mu_s: float,
        mu_d: float,
        creep: float,
        corner: float,
        scrub_arm: float,
        scrub_phi: float,
        cells: tuple[tuple[float, ...], ...] | None = None,
        cells_per_m: float = 1.0,
        cells_x0: float = 0.0,
        cells_y0: float = 0.0,
    ) -> None:
        self.params = DynamicsParams(
            mass=mass,
            inertia=inertia,
            half_track=half_track,
            r_l=r_l,
            r_r=r_r,
            j_w=j_w,
            k_e=k_e,
            tau_drive_l=tau_drive_l,
            tau_drive_r=tau_drive_r,
            tau_c_l=tau_c_l,
            tau_c_r=tau_c_r,
            tau_run_l=tau_run_l,
            tau_run_r=tau_run_r,
            time_constant=time_constant,
            n_wheel=n_wheel,
            f_caster=f_caster,
            mu_s=mu_s,
            mu_d=mu_d,
            creep=creep,
            corner=corner,
            scrub_arm=scrub_arm,
            scrub_phi=scrub_phi,
            floor=None if cells is None else FrictionCells(cells, cells_per_m, cells_x0, cells_y0),
        )
        self.left = WheelState()
        self.right = WheelState()
        self.x = 0.0
        self.y = 0.0
        self.yaw = 0.0
        self.vwx = 0.0
        self.vwy = 0.0
        self.wz = 0.0
        self.in_space = False
        self.slipping = False
        self.mu_scale: tuple[float, float] | None = None
        self.accel_x = 0.0
        self.accel_y = 0.0
        self.sum_accel_x = 0.0
        self.sum_accel_y = 0.0
        self.sum_wz = 0.0
        self.free_budget_m = 0.0
        self._k: StepConstants | None = None  # for the step dt they were made for

    def step_forces(self, dt: float) -> None:
        """Update wheel speeds and the chassis velocity for one step of ``dt`` [s] under the
        present drive (then integrate the pose: :meth:`step_free` or pymunk).

        Parameters
        ----------
        dt : float
            The physics step [s].
        """
        k = self._k
        if k is None or k.dt != dt:
            k = self._k = StepConstants(self.params, dt)
        p, left, right = self.params, self.left, self.right
        yaw = self.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        vwx, vwy, wz = self.vwx, self.vwy, self.wz
        vx = c * vwx + s * vwy
        vy = -s * vwx + c * vwy
        h, m = p.half_track, p.mass
        om_l, om_r = left.omega, right.omega

        k_e, alpha = p.k_e, k.alpha
        tau_l = left.tau
        tau_l += (p.tau_drive_l * left.drive - k_e * om_l * left.connected - tau_l) * alpha
        tau_r = right.tau
        tau_r += (p.tau_drive_r * right.drive - k_e * om_r * right.connected - tau_r) * alpha
        left.tau = tau_l
        right.tau = tau_r
        # gearbox: locked while the motor cannot break it free
        free_l = abs(om_l) > STICK_RAD_S or abs(tau_l) > p.tau_c_l
        free_r = abs(om_r) > STICK_RAD_S or abs(tau_r) > p.tau_c_r

        limits = self._friction_limits(k, c, s)
        # caster rolling resistance, smooth through zero; tyre scrub against the yaw rate
        f_c = -p.f_caster * tanh(vx / 0.005)
        v_pred = vx + dt * f_c / m
        wz_pred = self._scrubbed_yaw_rate(k, vx, wz, limits)
        f_l, f_r, slipping, free_l, free_r = self._traction(
            k, dt, v_pred, wz_pred, free_l, free_r, limits
        )
        jw = p.j_w
        if free_l:
            net = tau_l - f_l * p.r_l
            new = om_l + dt * (net - math.copysign(p.tau_run_l, om_l if om_l else net)) / jw
            if om_l and new * om_l < 0 and abs(net) <= p.tau_c_l:
                new = 0.0  # Coulomb friction stops the wheel; it does not reverse it
            om_l = new
        else:
            om_l = 0.0
        if free_r:
            net = tau_r - f_r * p.r_r
            new = om_r + dt * (net - math.copysign(p.tau_run_r, om_r if om_r else net)) / jw
            if om_r and new * om_r < 0 and abs(net) <= p.tau_c_r:
                new = 0.0
            om_r = new
        else:
            om_r = 0.0
        left.omega = om_l
        right.omega = om_r
        left.angle += om_l * dt
        right.angle += om_r * dt

        # chassis: longitudinal and yaw from the wheel forces, lateral grip at the axle
        vx_new = vx + dt * (f_l + f_r + f_c) / m
        wz_new = wz_pred + dt * (f_r - f_l) * h / p.inertia
        if p.corner > 0.0:  # the slip angle the lateral force needs, implicit in v_y
            ref = abs(vx)
            ref = ref if ref > V_CREEP_MIN_M_S else V_CREEP_MIN_M_S
            f_lat = -vy / (dt / m + k.corner_k * ref)
        else:
            f_lat = -m * vy / dt
        lim_s_l, lim_d_l, lim_s_r, lim_d_r = limits
        cap = cone(lim_s_l, f_l) + cone(lim_s_r, f_r)
        if abs(f_lat) > cap:
            f_lat = math.copysign(cone(lim_d_l, f_l) + cone(lim_d_r, f_r), f_lat)
            slipping = True
        self.slipping = slipping
        vy_new = vy + dt * f_lat / m
        self.accel_x = (vx_new - vx) / dt - wz * vy
        self.accel_y = (vy_new - vy) / dt + wz * vx
        self.vwx = c * vx_new - s * vy_new
        self.vwy = s * vx_new + c * vy_new
        self.wz = wz_new

    def _friction_limits(self, k: StepConstants, c: float, s: float) -> Limits:
        """The friction limits under each wheel: the floor's, times its patch under the wheel
        (at heading cos ``c``, sin ``s``) and a ``wheel_slip`` fault's factor."""
        lim_s, lim_d = k.lim_s, k.lim_d
        lim_s_l = lim_s
        lim_s_r = lim_s
        lim_d_l = lim_d
        lim_d_r = lim_d
        floor = self.params.floor
        if floor is not None:
            h = self.params.half_track
            sh, ch = s * h, c * h
            k_l = floor.factor(self.x - sh, self.y + ch)
            k_r = floor.factor(self.x + sh, self.y - ch)
            lim_s_l, lim_d_l = lim_s * k_l, lim_d * k_l
            lim_s_r, lim_d_r = lim_s * k_r, lim_d * k_r
        mu_scale = self.mu_scale
        if mu_scale is not None:  # a slippery patch under a wheel (a wheel_slip fault)
            k_l, k_r = mu_scale
            lim_s_l, lim_d_l = lim_s_l * k_l, lim_d_l * k_l
            lim_s_r, lim_d_r = lim_s_r * k_r, lim_d_r * k_r
        return lim_s_l, lim_d_l, lim_s_r, lim_d_r

    def _scrubbed_yaw_rate(self, k: StepConstants, vx: float, wz: float, limits: Limits) -> float:
        """Step 5: the yaw rate ``wz`` less what the scrub moment takes in a step (at most all
        of it), at forward speed ``vx``."""
        p = self.params
        if not (p.scrub_arm > 0.0 and wz):
            return wz
        lim_d_l, lim_d_r = limits[1], limits[3]
        phi = p.scrub_phi
        if phi > 0.0:  # the unsaturated share: each wheel's path curvature / phi_sat
            h = p.half_track
            w = abs(wz)
            v_l, v_r = abs(vx - h * wz), abs(vx + h * wz)
            v_l = V_CREEP_MIN_M_S if V_CREEP_MIN_M_S > v_l else v_l  # max(v_l, V_CREEP_MIN)
            v_r = V_CREEP_MIN_M_S if V_CREEP_MIN_M_S > v_r else v_r
            m_l = lim_d_l * tanh(w / (v_l * phi))
            m_r = lim_d_r * tanh(w / (v_r * phi))
            m_z = p.scrub_arm * (m_l + m_r)
        else:
            m_z = p.scrub_arm * (lim_d_l + lim_d_r)
        stop = k.i_dt * abs(wz)
        return 0.0 if m_z >= stop else wz - math.copysign(m_z, wz) / k.i_dt

    def _traction(
        self,
        k: StepConstants,
        dt: float,
        v_pred: float,
        wz_pred: float,
        free_l: bool,
        free_r: bool,
        limits: Limits,
    ) -> tuple[float, float, bool, bool, bool]:
        """Step 3: the ground forces ``F_L, F_R`` [N] that leave each wheel's contact the
        slip its creep allows, given the chassis' speed ``v_pred`` and yaw rate ``wz_pred``
        after the caster and scrub; whether a tyre slides, and which gearboxes turn (a locked
        wheel breaks free when the ground back-drives it past stiction)."""
        p, left, right = self.params, self.left, self.right
        h, jw, r_l, r_r = p.half_track, p.j_w, p.r_l, p.r_r
        om_l, om_r, tau_l, tau_r = left.omega, right.omega, left.tau, right.tau
        tc_l, tc_r = p.tau_c_l, p.tau_c_r
        d, o, a_free_l, a_free_r = k.d, k.o, k.a_free_l, k.a_free_r
        lim_s_l, lim_d_l, lim_s_r, lim_d_r = limits
        net_l = tau_l - math.copysign(p.tau_run_l, om_l if om_l else tau_l)
        net_r = tau_r - math.copysign(p.tau_run_r, om_r if om_r else tau_r)
        cl_l = 0.0  # creep: slip per unit force, per dt
        cl_r = 0.0
        if p.creep > 0.0:  # reference speed: the larger of rim and ground speed
            ref_l, g = abs(om_l * r_l), abs(v_pred - h * wz_pred)
            ref_l = g if g > ref_l else ref_l
            ref_r, g = abs(om_r * r_r), abs(v_pred + h * wz_pred)
            ref_r = g if g > ref_r else ref_r
            creep_k = k.creep_k
            cl_l = creep_k * (ref_l if ref_l > V_CREEP_MIN_M_S else V_CREEP_MIN_M_S)
            cl_r = creep_k * (ref_r if ref_r > V_CREEP_MIN_M_S else V_CREEP_MIN_M_S)
        f_l = f_r = 0.0
        slip_l = slip_r = False
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
                f_r = clamp((b2 - o * f_l) / a22, lim_s_r)
            elif slip_r:
                f_r = math.copysign(lim_d_r, f_r)
                f_l = clamp((b1 - o * f_r) / a11, lim_s_l)
            # a locked wheel breaks free when the ground back-drives it past stiction
            unlock_l = not free_l and abs(tau_l - f_l * r_l) > tc_l
            unlock_r = not free_r and abs(tau_r - f_r * r_r) > tc_r
            if not (unlock_l or unlock_r):
                break
            free_l = free_l or unlock_l
            free_r = free_r or unlock_r
        return f_l, f_r, slip_l or slip_r, free_l, free_r

    @property
    def omega_l(self) -> float:
        """The left wheel's speed [rad/s] (``left.omega``)."""
        return self.left.omega

    @omega_l.setter
    def omega_l(self, value: float) -> None:
        self.left.omega = value

    @property
    def angle_l(self) -> float:
        """The left wheel's integrated angle [rad] (``left.angle``)."""
        return self.left.angle

    @angle_l.setter
    def angle_l(self, value: float) -> None:
        self.left.angle = value

    @property
    def tau_l(self) -> float:
        """The left wheel's motor torque at the wheel [N m] (``left.tau``)."""
        return self.left.tau

    @tau_l.setter
    def tau_l(self, value: float) -> None:
        self.left.tau = value

    @property
    def omega_r(self) -> float:
        """The right wheel's speed [rad/s] (``right.omega``)."""
        return self.right.omega

    @omega_r.setter
    def omega_r(self, value: float) -> None:
        self.right.omega = value

    @property
    def angle_r(self) -> float:
        """The right wheel's integrated angle [rad] (``right.angle``)."""
        return self.right.angle

    @angle_r.setter
    def angle_r(self, value: float) -> None:
        self.right.angle = value

    @property
    def tau_r(self) -> float:
        """The right wheel's motor torque at the wheel [N m] (``right.tau``)."""
        return self.right.tau

    @tau_r.setter
    def tau_r(self, value: float) -> None:
        self.right.tau = value

    def step_free(self, dt: float) -> None:
        """The step pymunk would take in free space: p += v dt, yaw += omega dt.

        Parameters
        ----------
        dt : float
            The physics step [s].
        """
        self.in_space = False
        self.x += self.vwx * dt
        self.y += self.vwy * dt
        self.yaw += self.wz * dt

    def record(self, step: int, truth: list[TruthRow] | None) -> None:
        """After a step: add its specific force and yaw rate to the IMU's sums and append its
        ground truth to ``truth`` (None: none kept).

        Parameters
        ----------
        step : int
            The number of the physics step just completed.
        truth : list of TruthRow or None
            The raw ground truth.
        """
        self.sum_accel_x += self.accel_x
        self.sum_accel_y += self.accel_y
        self.sum_wz += self.wz
        if truth is not None:
            truth.append(
                (
                    step,
                    self.x,
                    self.y,
                    self.yaw,
                    self.vwx,
                    self.vwy,
                    self.wz,
                    self.left.omega,
                    self.right.omega,
                )
            )

    def run_free(
        self,
        dt: float,
        step: int,
        end: int,
        stop_before: int,
        command_s: float,
        scan_s: float,
        radius_m: float,
        budget_m: float,
        truth: list[TruthRow] | None,
    ) -> int:
        """Physics steps in free space, from step ``step`` until an event is due.

        Each step is :meth:`step_forces`, :meth:`step_free` and :meth:`record`; the free space
        ``budget_m`` shrinks by the distance any point of the robot may have moved. Runs while
        the budget is left, before step ``end`` and ``stop_before`` (the next wheel-slip change)
        and while the next command's instant ``command_s`` has not come; stops after the step
        that brings the next scan's instant ``scan_s`` (within 1 ns). What is left of the
        budget is in :attr:`free_budget_m`.

        Parameters
        ----------
        dt : float
            The physics step [s].
        step : int
            The first step's number (steps done so far).
        end, stop_before : int
            Steps not to reach: the end of the advance and the next wheel-slip change.
        command_s, scan_s : float
            When the next pending command takes effect and the next scan is due [s] (inf:
            none).
        radius_m : float
            The robot's outer radius about its axle centre [m].
        budget_m : float
            Free space around the robot [m].
        truth : list of TruthRow or None
            The raw ground truth (None: none kept).

        Returns
        -------
        int
            The number of steps done so far after the last step taken.
        """
        limit = end if end < stop_before else stop_before
        while step < limit and budget_m > 0.0 and not (command_s <= step * dt):
            self.step_forces(dt)
            # step_free and record, inline (the interpreted loop is slower through calls)
            self.in_space = False
            vwx, vwy, wz = self.vwx, self.vwy, self.wz
            x = self.x = self.x + vwx * dt
            y = self.y = self.y + vwy * dt
            yaw = self.yaw = self.yaw + wz * dt
            budget_m -= (abs(vwx) + abs(vwy) + abs(wz) * radius_m) * dt
            step += 1
            self.sum_accel_x += self.accel_x
            self.sum_accel_y += self.accel_y
            self.sum_wz += wz
            if truth is not None:
                truth.append((step, x, y, yaw, vwx, vwy, wz, self.left.omega, self.right.omega))
            if step * dt + 1e-9 >= scan_s:
                break
        self.free_budget_m = budget_m
        return step


def cone(limit: float, f_long: float) -> float:
    """Lateral friction left in a wheel's friction circle.

    Parameters
    ----------
    limit : float
        The wheel's friction limit mu N [N].
    f_long : float
        Its longitudinal force [N].

    Returns
    -------
    float
        ``sqrt(limit^2 - f_long^2)``, 0 when the longitudinal force takes it all [N].
    """
    rest = limit * limit - f_long * f_long
    return math.sqrt(rest) if rest > 0.0 else 0.0


def clamp(value: float, limit: float) -> float:
    """``max(-limit, min(limit, value))``, spelt out so that it is the same operation
    interpreted and compiled (the builtins' choice between equal values, such as 0.0 and -0.0,
    included).

    Parameters
    ----------
    value : float
        The value.
    limit : float
        The bound on its magnitude (>= 0).

    Returns
    -------
    float
        The value within [-limit, limit].
    """
    low = value if value < limit else limit  # min(limit, value)
    return low if low > -limit else -limit  # max(-limit, low)
