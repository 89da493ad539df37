"""Wheel odometry from cumulative encoder counts (Eq. 2, 3 and 9).

Per telemetry frame k the MCU sends its unwrapped clock t_k [s] and the cumulative signed
32-bit counts of both encoders. Over one frame, with N_i the tick difference of wheel i
(:func:`tick_delta`), r_i its radius and C_i its ticks per revolution:

    d_phi_i = 2 pi N_i / C_i              wheel rotation [rad]
    d_s_i   = r_i d_phi_i                 wheel travel [m]  (Eq. 9: 2 pi r N / C_e)
    d_s     = (d_s_R + d_s_L) / 2         travel of the axle midpoint [m]   (Eq. 2 times dt)
    d_theta = (d_s_R - d_s_L) / B         heading change [rad], CCW positive (Eq. 3 times dt)

and the pose is integrated along the arc those two numbers describe (exact-arc integration,
as ros2_controllers' diff_drive_controller does):

    |d_theta| <  ARC_THRESHOLD_RAD  (second-order Runge-Kutta, the midpoint heading):
        x += d_s cos(theta + d_theta / 2),  y += d_s sin(theta + d_theta / 2)
    otherwise (the exact circular arc of radius d_s / d_theta):
        x += d_s / d_theta (sin(theta + d_theta) - sin(theta))
        y -= d_s / d_theta (cos(theta + d_theta) - cos(theta))
    theta += d_theta

The exact arc is evaluated in its product form, identical by the sum-to-product identities,

    x += d_s c cos(theta + d_theta / 2),  y += d_s c sin(theta + d_theta / 2),
    c = sin(d_theta / 2) / (d_theta / 2),

because the difference of sines loses about eps d_s / d_theta to cancellation (1e-12 m for
a 1 cm step at d_theta = 1e-6 rad) and the product form loses nothing. It also shows the
midpoint form as the same formula with c = 1: below the threshold c differs from 1 by
d_theta^2 / 24 < 5e-14, far below the encoder's resolution.

The pose depends on the counts only, never on dt: a lost frame loses no distance, because the
next frame's count difference covers both intervals, and a constant-curvature path gives the
same end pose however it is cut into frames. Velocities divide by dt = t_k - t_ref taken from
the MCU clock (never the host's wall clock); a frame with dt <= 0 keeps the previous
velocities, and its counts are carried into the next frame's velocity.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

from jackson.common.robot import TICKS_PER_REV, WHEEL_RADIUS_M, WHEEL_SEPARATION_M

COUNTER_MODULUS = 1 << 32  # cumulative encoder counts are signed 32-bit (schema: i32)
COUNTER_HALF = 1 << 31
ARC_THRESHOLD_RAD = 1e-6  # [rad] below this |d_theta| the midpoint form is used


@dataclass(frozen=True)
class RobotGeometry:
    """Wheel geometry and encoder resolution the odometry believes (Table 3, physical runtime).

    It is the ``robot:`` section of the host configuration (:class:`jackson.host.config.HostConfig`)
    and the configuration of :class:`WheelOdometry`.

    Attributes
    ----------
    wheel_radius_left_m, wheel_radius_right_m : float
        r_L, r_R [m], the runtime radius r_run (measured 66 mm wheels).
    wheel_separation_m : float
        B [m], the distance between the wheel contact points (360 deg rotation check).
    ticks_per_rev_left, ticks_per_rev_right : float
        C_e,run [ticks/rev] per wheel, 4x quadrature (floor calibration 652 x 0.9525 = 621;
        the history had 617 left / 621 right).
    """

    wheel_radius_left_m: float = WHEEL_RADIUS_M
    wheel_radius_right_m: float = WHEEL_RADIUS_M
    wheel_separation_m: float = WHEEL_SEPARATION_M
    ticks_per_rev_left: float = TICKS_PER_REV
    ticks_per_rev_right: float = TICKS_PER_REV

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"RobotGeometry.{f.name} must be finite and > 0, got {value}")

    @property
    def meters_per_tick_left(self) -> float:
        """2 pi r_L / C_L [m/tick] (Eq. 9, Eq. A18)."""
        return 2.0 * math.pi * self.wheel_radius_left_m / self.ticks_per_rev_left

    @property
    def meters_per_tick_right(self) -> float:
        """2 pi r_R / C_R [m/tick] (Eq. 9, Eq. A18)."""
        return 2.0 * math.pi * self.wheel_radius_right_m / self.ticks_per_rev_right


@dataclass(frozen=True)
class OdometryCovariance:
    """Diagonal covariances published with the wheel odometry (/wheel/odom).

    It is the ``odometry:`` section of the host configuration.

    Attributes
    ----------
    twist_vx, twist_vy, twist_wz : float
        Twist covariance for v_x [(m/s)^2], v_y [(m/s)^2] and w_z [(rad/s)^2].
        robot_localization takes its R from these, so v_x and v_y equal Table 2's R_vx and
        R_vy (:attr:`jackson.host.estimation.ekf.EkfConfig.r_vx`, ``r_vy``); w_z from the wheels is
        published but not fused (the IMU's is).
    pose_xy, pose_yaw : float
        Pose covariance for x and y [m^2] and yaw [rad^2]; the dead-reckoned pose is not
        fused, so these only inform consumers.
    """

    twist_vx: float = 0.01
    twist_vy: float = 0.001
    twist_wz: float = 0.02
    pose_xy: float = 0.01
    pose_yaw: float = 0.05

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not 0.0 <= value < math.inf:
                raise ValueError(
                    f"OdometryCovariance.{f.name} must be finite and >= 0, got {value}"
                )


def tick_delta(previous: int, current: int) -> int:
    """Signed tick difference of two cumulative 32-bit counter readings, wrap-safe.

    delta = ((current - previous + 2^31) mod 2^32) - 2^31, i.e. the difference modulo 2^32
    read as a signed 32-bit number. A counter that wrapped from 2^31 - 10 to -2^31 + 20 has
    moved +30 ticks. Inputs may be signed or unsigned 32-bit readings.

    Parameters
    ----------
    previous, current : int
        Cumulative counts of the same encoder at two frames [ticks].

    Returns
    -------
    int
        current - previous in [-2^31, 2^31) [ticks].
    """
    return (current - previous + COUNTER_HALF) % COUNTER_MODULUS - COUNTER_HALF


@dataclass(frozen=True)
class OdometryState:
    """The odometry after one telemetry frame.

    Attributes
    ----------
    t_s : float
        MCU time of the frame [s].
    x_m, y_m : float
        Position of the axle midpoint in the odometry frame [m] (start = origin).
    yaw_rad : float
        Heading [rad], CCW positive, continuous (not wrapped: one full CCW turn reads 2 pi).
    v_m_s, w_rad_s : float
        Body velocity v [m/s] and yaw rate w [rad/s] over the last frame with dt > 0 (Eq. 2-3).
    wheel_angle_left_rad, wheel_angle_right_rad : float
        Wheel rotation since the reference frame, 2 pi N / C [rad] (for /joint_states).
    wheel_velocity_left_rad_s, wheel_velocity_right_rad_s : float
        Wheel angular velocity over the last frame with dt > 0 [rad/s].
    distance_left_m, distance_right_m : float
        Cumulative signed travel of each wheel since the reference frame [m] (Eq. 9 summed).
    """

    t_s: float = 0.0
    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0
    v_m_s: float = 0.0
    w_rad_s: float = 0.0
    wheel_angle_left_rad: float = 0.0
    wheel_angle_right_rad: float = 0.0
    wheel_velocity_left_rad_s: float = 0.0
    wheel_velocity_right_rad_s: float = 0.0
    distance_left_m: float = 0.0
    distance_right_m: float = 0.0


def integrate_arc(
    x_m: float, y_m: float, yaw_rad: float, d_s_m: float, d_theta_rad: float
) -> tuple[float, float, float]:
    """Move a pose along a circular arc of length d_s and heading change d_theta.

    For |d_theta| < ARC_THRESHOLD_RAD the second-order Runge-Kutta (midpoint) form

        x' = x + d_s cos(theta + d_theta / 2),  y' = y + d_s sin(theta + d_theta / 2)

    else the exact arc

        x' = x + d_s / d_theta (sin(theta + d_theta) - sin(theta))
        y' = y - d_s / d_theta (cos(theta + d_theta) - cos(theta))

    evaluated as x' = x + d_s c cos(theta + d_theta / 2), y' = y + d_s c sin(theta + d_theta / 2)
    with c = sin(d_theta / 2) / (d_theta / 2) (no cancellation); theta' = theta + d_theta.

    Parameters
    ----------
    x_m, y_m, yaw_rad : float
        Pose before the step [m, m, rad].
    d_s_m : float
        Signed travel of the axle midpoint [m].
    d_theta_rad : float
        Heading change [rad], CCW positive.

    Returns
    -------
    tuple of float
        (x', y', theta') [m, m, rad].
    """
    half_rad = 0.5 * d_theta_rad
    mid_rad = yaw_rad + half_rad
    chord_m = (
        d_s_m if abs(d_theta_rad) < ARC_THRESHOLD_RAD else d_s_m * math.sin(half_rad) / half_rad
    )
    return (
        x_m + chord_m * math.cos(mid_rad),
        y_m + chord_m * math.sin(mid_rad),
        yaw_rad + d_theta_rad,
    )


class WheelOdometry:
    """Dead reckoning from the MCU's cumulative encoder counts (Eq. 2, 3, 9).

    The first :meth:`update` only takes the counts as the reference and returns the zero
    state; every later one integrates the tick differences since the previous frame.

    Parameters
    ----------
    config : RobotGeometry
        Wheel radii, separation and ticks per revolution (the defaults: the paper's robot).
    """

    def __init__(self, config: RobotGeometry | None = None) -> None:
        self.config = config if config is not None else RobotGeometry()
        self.reset()

    def reset(self) -> None:
        """Forget the reference counts and the pose: the next update starts at the origin.

        Call it too when the MCU's counters are zeroed (ZERO_COUNTERS) or the MCU rebooted.
        """
        self._enc_left: int | None = None
        self._enc_right: int | None = None
        self._t_ref_s = 0.0  # time of the last velocity estimate
        self._ticks_left = 0  # unwrapped counts since the reference frame
        self._ticks_right = 0
        self._pending_left_rad = 0.0  # rotation since _t_ref_s not yet turned into a velocity
        self._pending_right_rad = 0.0
        self._state = OdometryState()
        self._reanchored = False

    def reanchor(self) -> None:
        """Keep the pose, forget the reference counts: the next update is a new reference with
        no motion. For counters that restarted under the host (an MCU reset, protocol/spec.md
        §8.6), whose first counts would otherwise be integrated as a jump."""
        if self._enc_left is None:
            return
        self._enc_left = self._enc_right = None
        self._reanchored = True

    @property
    def state(self) -> OdometryState:
        """The state after the last update (the zero state before the first)."""
        return self._state

    def update(self, t_s: float, enc_left: int, enc_right: int) -> OdometryState:
        """Integrate one telemetry frame.

        Parameters
        ----------
        t_s : float
            The MCU's unwrapped timestamp of the frame [s].
        enc_left, enc_right : int
            Cumulative signed 32-bit encoder counts [ticks].

        Returns
        -------
        OdometryState
            The pose and velocities after this frame.
        """
        cfg = self.config
        if self._enc_left is None or self._enc_right is None:
            self._enc_left, self._enc_right = enc_left, enc_right
            self._t_ref_s = t_s
            if self._reanchored:  # same pose and wheel angles, standing still
                self._reanchored = False
                self._pending_left_rad = self._pending_right_rad = 0.0
                self._state = dataclasses.replace(
                    self._state,
                    t_s=t_s,
                    v_m_s=0.0,
                    w_rad_s=0.0,
                    wheel_velocity_left_rad_s=0.0,
                    wheel_velocity_right_rad_s=0.0,
                )
            else:
                self._state = OdometryState(t_s=t_s)
            return self._state

        n_left = tick_delta(self._enc_left, enc_left)
        n_right = tick_delta(self._enc_right, enc_right)
        self._enc_left, self._enc_right = enc_left, enc_right
        self._ticks_left += n_left
        self._ticks_right += n_right

        d_phi_left_rad = 2.0 * math.pi * n_left / cfg.ticks_per_rev_left
        d_phi_right_rad = 2.0 * math.pi * n_right / cfg.ticks_per_rev_right
        d_s_left_m = cfg.wheel_radius_left_m * d_phi_left_rad
        d_s_right_m = cfg.wheel_radius_right_m * d_phi_right_rad
        d_s_m = 0.5 * (d_s_right_m + d_s_left_m)
        d_theta_rad = (d_s_right_m - d_s_left_m) / cfg.wheel_separation_m

        prev = self._state
        x_m, y_m, yaw_rad = integrate_arc(prev.x_m, prev.y_m, prev.yaw_rad, d_s_m, d_theta_rad)

        self._pending_left_rad += d_phi_left_rad
        self._pending_right_rad += d_phi_right_rad
        dt_s = t_s - self._t_ref_s
        if dt_s > 0.0:
            omega_left_rad_s = self._pending_left_rad / dt_s
            omega_right_rad_s = self._pending_right_rad / dt_s
            r_l, r_r = cfg.wheel_radius_left_m, cfg.wheel_radius_right_m
            v_m_s = 0.5 * (r_r * omega_right_rad_s + r_l * omega_left_rad_s)
            w_rad_s = (r_r * omega_right_rad_s - r_l * omega_left_rad_s) / cfg.wheel_separation_m
            self._pending_left_rad = self._pending_right_rad = 0.0
            self._t_ref_s = t_s
        else:
            omega_left_rad_s = prev.wheel_velocity_left_rad_s
            omega_right_rad_s = prev.wheel_velocity_right_rad_s
            v_m_s, w_rad_s = prev.v_m_s, prev.w_rad_s

        angle_left_rad = 2.0 * math.pi * self._ticks_left / cfg.ticks_per_rev_left
        angle_right_rad = 2.0 * math.pi * self._ticks_right / cfg.ticks_per_rev_right
        self._state = OdometryState(
            t_s=t_s,
            x_m=x_m,
            y_m=y_m,
            yaw_rad=yaw_rad,
            v_m_s=v_m_s,
            w_rad_s=w_rad_s,
            wheel_angle_left_rad=angle_left_rad,
            wheel_angle_right_rad=angle_right_rad,
            wheel_velocity_left_rad_s=omega_left_rad_s,
            wheel_velocity_right_rad_s=omega_right_rad_s,
            distance_left_m=cfg.wheel_radius_left_m * angle_left_rad,
            distance_right_m=cfg.wheel_radius_right_m * angle_right_rad,
        )
        return self._state
