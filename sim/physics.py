"""Per-step dynamics of the twin's robot: DC motors, gearbox stiction, traction and slip.

pymunk integrates the chassis pose and resolves collisions near obstacles; this module supplies
what pymunk does not know about: wheels that spin on their own, motors, and tyre friction; and
in free space it also makes pymunk's position update itself. It is plain Python on floats and
imports nothing but :mod:`math`, so that ``make setup`` can compile it with mypyc into a native
module of the same arithmetic (:mod:`jackson.sim.compiled`, docs/compiled.md); interpreted or
compiled, a run is the same bit for bit.

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
from typing import Final

STICK_RAD_S: Final = 1e-3  # [rad/s] a wheel slower than this may stick in its gearbox
V_CREEP_MIN_M_S: Final = 0.01  # [m/s] reference speed of the creep and slip-angle models near rest

TruthRow = tuple[int, float, float, float, float, float, float, float, float]
"""One physics step's raw ground truth: (step, x, y, yaw, vwx, vwy, wz, omega_l, omega_r)."""


class DiffDriveDynamics:
    """The robot's wheel, motor and chassis state and its update per physics step.

    Attributes are named as in the module docstring. Parameters (fixed for a trial): ``mass``
    [kg], ``inertia`` [kg m^2], ``half_track`` B/2 [m], ``r_l, r_r`` wheel radii [m], ``j_w``
    wheel inertia [kg m^2], ``k_e`` [N m s/rad], ``tau_drive_*`` torque at drive 1 [N m],
    ``tau_c_*`` breakaway and ``tau_run_*`` running friction [N m], ``time_constant`` [s],
    ``n_wheel`` load per wheel [N], ``f_caster`` caster rolling resistance [N], ``mu_s, mu_d``
    the floor's friction, ``creep`` [1], ``corner`` [rad], ``scrub_arm`` [m], ``scrub_phi``
    [1/m], ``cells`` the friction patches' factors (or None) with ``cells_per_m`` [1/m] and
    their origin ``cells_x0, cells_y0`` [m].

    State: pose ``x, y`` [m], ``yaw`` [rad]; world-frame velocity ``vwx, vwy`` [m/s] and yaw
    rate ``wz`` [rad/s]; wheel speeds ``omega_l, omega_r`` [rad/s] and integrated angles
    ``angle_l, angle_r`` [rad]; motor torques at the wheel ``tau_l, tau_r`` [N m]; ``slipping``
    (a tyre slid in the last step); the body-frame specific force ``accel_x, accel_y``
    [m/s^2] of the last step, for the IMU; ``in_space`` (pymunk integrated the last step);
    ``mu_scale``, None or a factor per wheel (left, right) on the floor's friction under it.

    Inputs: the H-bridge output per wheel, ``drive_l, drive_r`` (signed supply fraction) and
    ``connected_l, connected_r`` (fraction of time the windings are connected).

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
        self.mass = mass
        self.inertia = inertia
        self.half_track = half_track
        self.r_l = r_l
        self.r_r = r_r
        self.j_w = j_w
        self.k_e = k_e
        self.tau_drive_l = tau_drive_l
        self.tau_drive_r = tau_drive_r
        self.tau_c_l = tau_c_l
        self.tau_c_r = tau_c_r
        self.tau_run_l = tau_run_l
        self.tau_run_r = tau_run_r
        self.time_constant = time_constant
        self.n_wheel = n_wheel
        self.f_caster = f_caster
        self.mu_s = mu_s
        self.mu_d = mu_d
        self.creep = creep
        self.corner = corner
        self.scrub_arm = scrub_arm
        self.scrub_phi = scrub_phi
        self.cells = cells
        self.cells_n = len(cells) if cells is not None else 0
        self.cells_per_m = cells_per_m
        self.cells_x0 = cells_x0
        self.cells_y0 = cells_y0

        self.x = 0.0
        self.y = 0.0
        self.yaw = 0.0
        self.vwx = 0.0
        self.vwy = 0.0
        self.wz = 0.0
        self.in_space = False
        self.omega_l = 0.0
        self.omega_r = 0.0
        self.angle_l = 0.0
        self.angle_r = 0.0
        self.tau_l = 0.0
        self.tau_r = 0.0
        self.slipping = False
        self.mu_scale: tuple[float, float] | None = None
        self.accel_x = 0.0
        self.accel_y = 0.0
        self.drive_l = 0.0
        self.connected_l = 0.0
        self.drive_r = 0.0
        self.connected_r = 0.0
        self.sum_accel_x = 0.0
        self.sum_accel_y = 0.0
        self.sum_wz = 0.0
        self.free_budget_m = 0.0

        # per-step constants, for the step dt they were made for (see _constants)
        self._const_dt = -1.0
        self._alpha = 0.0  # motor lag per step
        self._d = 0.0  # coupling of a wheel force to its own contact
        self._o = 0.0  # ... and to the other wheel's contact
        self._a_free_l = 0.0
        self._a_free_r = 0.0
        self._lim_s = 0.0
        self._lim_d = 0.0
        self._creep_k = 0.0  # slip per dt per N, per m/s
        self._corner_k = 0.0
        self._i_dt = 0.0

    def _constants(self, dt: float) -> None:
        """Per-step constants (dt is fixed for a run; recomputed only when it changes)."""
        tc = self.time_constant
        h2i = self.half_track * self.half_track / self.inertia
        self._alpha = 1.0 - math.exp(-dt / tc) if tc > 0 else 1.0
        self._d = 1.0 / self.mass + h2i
        self._o = 1.0 / self.mass - h2i
        self._a_free_l = self.r_l * self.r_l / self.j_w
        self._a_free_r = self.r_r * self.r_r / self.j_w
        self._lim_s = self.mu_s * self.n_wheel
        self._lim_d = self.mu_d * self.n_wheel
        self._creep_k = self.creep / (self.n_wheel * dt)
        self._corner_k = self.corner / (2.0 * self.n_wheel)
        self._i_dt = self.inertia / dt
        self._const_dt = dt

    def step_forces(self, dt: float) -> None:
        """Update wheel speeds and the chassis velocity for one step of ``dt`` [s] under the
        present drive (then integrate the pose: :meth:`step_free` or pymunk).

        Parameters
        ----------
        dt : float
            The physics step [s].
        """
        if self._const_dt != dt:
            self._constants(dt)
        alpha, d, o = self._alpha, self._d, self._o
        a_free_l, a_free_r, lim_s, lim_d = self._a_free_l, self._a_free_r, self._lim_s, self._lim_d
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
        tau_l += (self.tau_drive_l * self.drive_l - k_e * om_l * self.connected_l - tau_l) * alpha
        tau_r = self.tau_r
        tau_r += (self.tau_drive_r * self.drive_r - k_e * om_r * self.connected_r - tau_r) * alpha
        self.tau_l = tau_l
        self.tau_r = tau_r

        # gearbox: locked while the motor cannot break it free
        free_l = abs(om_l) > STICK_RAD_S or abs(tau_l) > tc_l
        free_r = abs(om_r) > STICK_RAD_S or abs(tau_r) > tc_r

        # friction under each wheel
        lim_s_l = lim_s
        lim_s_r = lim_s
        lim_d_l = lim_d
        lim_d_r = lim_d
        cells = self.cells
        if cells is not None:  # FrictionField.factor under each wheel, inline
            n, per_m = self.cells_n, self.cells_per_m
            x0, y0, sh, ch = self.cells_x0, self.cells_y0, s * h, c * h
            k_l = cells[math.floor((self.x - sh - x0) * per_m) % n][
                math.floor((self.y + ch - y0) * per_m) % n
            ]
            k_r = cells[math.floor((self.x + sh - x0) * per_m) % n][
                math.floor((self.y - ch - y0) * per_m) % n
            ]
            lim_s_l, lim_d_l = lim_s * k_l, lim_d * k_l
            lim_s_r, lim_d_r = lim_s * k_r, lim_d * k_r
        mu_scale = self.mu_scale
        if mu_scale is not None:  # a slippery patch under a wheel (a wheel_slip fault)
            k_l, k_r = mu_scale
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
                v_l, v_r = abs(vx - h * wz), abs(vx + h * wz)
                v_l = V_CREEP_MIN_M_S if V_CREEP_MIN_M_S > v_l else v_l  # max(v_l, V_CREEP_MIN)
                v_r = V_CREEP_MIN_M_S if V_CREEP_MIN_M_S > v_r else v_r
                m_l = lim_d_l * math.tanh(w / (v_l * phi))
                m_r = lim_d_r * math.tanh(w / (v_r * phi))
                m_z = self.scrub_arm * (m_l + m_r)
            else:
                m_z = self.scrub_arm * (lim_d_l + lim_d_r)
            stop = self._i_dt * abs(wz)
            wz_pred = 0.0 if m_z >= stop else wz - math.copysign(m_z, wz) / self._i_dt
        net_l = tau_l - math.copysign(tr_l, om_l if om_l else tau_l)
        net_r = tau_r - math.copysign(tr_r, om_r if om_r else tau_r)
        cl_l = 0.0  # creep: slip per unit force, per dt
        cl_r = 0.0
        if self.creep > 0.0:  # reference speed: the larger of rim and ground speed
            ref_l, g = abs(om_l * r_l), abs(v_pred - h * wz_pred)
            ref_l = g if g > ref_l else ref_l
            ref_r, g = abs(om_r * r_r), abs(v_pred + h * wz_pred)
            ref_r = g if g > ref_r else ref_r
            k = self._creep_k
            cl_l = k * (ref_l if ref_l > V_CREEP_MIN_M_S else V_CREEP_MIN_M_S)
            cl_r = k * (ref_r if ref_r > V_CREEP_MIN_M_S else V_CREEP_MIN_M_S)
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
        self.omega_l = om_l
        self.omega_r = om_r
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
                    self.omega_l,
                    self.omega_r,
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
                truth.append((step, x, y, yaw, vwx, vwy, wz, self.omega_l, self.omega_r))
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
