"""The actuation chain as one stage: a velocity command in, wheel duties on the motor output.

Per telemetry frame (docs/host.md, "What happens per telemetry frame", step 4): velocity and
acceleration limits, inverse kinematics, per-wheel and per-direction deadband compensation (the
feed-forward), the wheel-speed PI on the encoders where it runs (external commands by default,
every command with ``wheel_pi.enabled``: :mod:`jackson.host.actuation.wheel_pi`), then the motor
output. A brake resets the limiter and the PIs and short-brakes the motors; the PIs also start
again from 0 whenever the loop closes or opens (a mission after a teleop keeps nothing of its
correction). Calibration's raw duties bypass all of it (:meth:`ActuationChain.raw`).
"""

from __future__ import annotations

from jackson.host.actuation.deadband import wheel_duty
from jackson.host.actuation.kinematics import inverse
from jackson.host.actuation.limiter import VelocityLimiter
from jackson.host.actuation.output import MotorOutput
from jackson.host.actuation.wheel_pi import WheelSpeedPi
from jackson.host.config import HostConfig
from jackson.host.estimation.odometry import OdometryState


class ActuationChain:
    """Limits, kinematics, PI, deadband and the motor output (module docstring).

    Parameters
    ----------
    cfg : HostConfig
        ``limits``, ``robot``, ``deadband`` and ``wheel_pi``.
    output : MotorOutput
        Where the duties go (the PCA9685 or the MCU).
    """

    def __init__(self, cfg: HostConfig, output: MotorOutput) -> None:
        self.output = output
        self.robot = cfg.robot
        self.limiter = VelocityLimiter(cfg.limits)
        self.deadband = cfg.deadband
        zero = cfg.deadband.zero_threshold_rad_s  # the PI brakes where the deadband stage does
        self.wheel_pi = cfg.wheel_pi
        self.pi = (
            (
                WheelSpeedPi(cfg.wheel_pi, zero_threshold_rad_s=zero),
                WheelSpeedPi(cfg.wheel_pi, zero_threshold_rad_s=zero),
            )
            if cfg.wheel_pi.enabled or cfg.wheel_pi.external
            else None
        )
        self.closed_loop = False  # the PIs ran at the last frame
        self.braked = True
        self.wheel_cmd: tuple[float, float] = (0.0, 0.0)  # [rad/s] commanded at the last frame

    @property
    def commanded_still(self) -> bool:
        """Braked, or the wheels commanded to stand still."""
        return self.braked or self.wheel_cmd == (0.0, 0.0)

    def apply(
        self,
        t_s: float,
        v_cmd: float,
        w_cmd: float,
        brake: bool,
        odo: OdometryState,
        *,
        external: bool = False,
    ) -> tuple[float, float, tuple[float, float]]:
        """One frame's command through the chain.

        Parameters
        ----------
        t_s : float
            MCU time [s].
        v_cmd, w_cmd : float
            The command [m/s, rad/s].
        brake : bool
            Brake instead.
        odo : OdometryState
            This frame's wheel speeds (the PI's feedback).
        external : bool
            The command is an external velocity command (``/cmd_vel``), not a mission's: the
            wheel-speed PI runs on it with ``wheel_pi.external``.

        Returns
        -------
        v, w : float
            The command after the limits (0 braked).
        duties : tuple of float
            The duties written (0 braked).
        """
        if brake:
            self.limiter.reset()
            if self.pi is not None:
                for pi in self.pi:
                    pi.reset()
            self.brake()
            self.wheel_cmd = (0.0, 0.0)
            return 0.0, 0.0, (0.0, 0.0)
        v, w = self.limiter.limit(v_cmd, w_cmd, t_s)
        r = self.robot
        om_l, om_r = inverse(
            v, w, r.wheel_radius_left_m, r.wheel_radius_right_m, r.wheel_separation_m
        )
        self.wheel_cmd = (om_l, om_r)
        d_l = wheel_duty(om_l, "left", self.deadband)
        d_r = wheel_duty(om_r, "right", self.deadband)
        closed = self.wheel_pi.enabled or (external and self.wheel_pi.external)
        if self.pi is not None and closed != self.closed_loop:
            for pi in self.pi:
                pi.reset()
        self.closed_loop = closed
        if self.pi is not None and closed:
            fb_l, fb_r = odo.wheel_velocity_left_rad_s, odo.wheel_velocity_right_rad_s
            d_l = max(
                -1.0, min(1.0, d_l + self.pi[0].update(om_l, fb_l, t_s, feedforward_duty=d_l))
            )
            d_r = max(
                -1.0, min(1.0, d_r + self.pi[1].update(om_r, fb_r, t_s, feedforward_duty=d_r))
            )
        self.output.set(d_l, d_r)
        self.braked = False
        return v, w, (d_l, d_r)

    def raw(self, d_l: float, d_r: float) -> tuple[float, float]:
        """Duties written as they are (calibration's staircases and steps); (0, 0) brakes."""
        self.output.set(d_l, d_r)
        self.braked = d_l == 0.0 and d_r == 0.0
        return d_l, d_r

    def brake(self) -> None:
        """Short-brake the motors now."""
        self.output.brake()
        self.braked = True
