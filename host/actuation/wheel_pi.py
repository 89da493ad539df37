"""Optional wheel-speed PI on encoder feedback, one instance per wheel.

The deadband stage gives an open-loop feed-forward duty u_ff for the wheel-speed command;
this controller returns a correction u_c that the daemon adds to it:

    e = omega_ref - omega_meas                       [rad/s]
    I_k = clamp(I_{k-1} + K_i e dt, -I_max, I_max)   [duty]
    u_c = clamp(K_p e + I_k, -u_max - u_ff, u_max - u_ff)
    duty = u_ff + u_c                                in [-u_max, u_max]

Anti-windup is conditional integration plus the integral clamp: a step's integration is
dropped when it would leave the total u_ff + K_p e + I_k beyond +-u_max in the direction
of the error, so the integrator never grows while the output is saturated and the output
leaves saturation as soon as the error changes sign. |omega_ref| at or below the zero
threshold is a brake: the integrator resets and the correction is 0, so the PI never
fights the brake.

Time comes in as an argument (MCU seconds, the encoder sample's time): no clock is read.

Where it runs (:class:`WheelPiConfig`): on external velocity commands (``/cmd_vel``, a teleop,
what a user expects to be driven at) by default, and on the missions only with ``enabled``.
Open loop, the deadband stage's feed-forward assumes the motors' no-load speed (100 RPM at full
duty) and the loaded wheels of the default twin run 10-11 % slower (0.134 m/s for 0.15 m/s,
0.450 rad/s for 0.5 rad/s); closed, they track within 0.1 % in steady state, within 3 % after
0.5-0.8 s (tests/sil/test_wheel_speed.py). The paper's Stage 1-2 robot ran open loop, with its
deadband compensation and a static right-side PWM scale (Sec. 2.2.3), and the twin's missions
reproduce its figures that way (their durations follow its 7 % slower wheels): the missions keep
it off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class WheelPiConfig:
    """Gains and limits of the wheel-speed PI: the ``wheel_pi:`` section of the host
    configuration (:class:`jackson.host.config.HostConfig`).

    Attributes
    ----------
    enabled : bool
        Whether the daemon runs the PI on each wheel for every command, the missions' included
        (off: the missions drive on the open-loop deadband feed-forward, as the paper's robot).
    external : bool
        Whether it runs the PI on external velocity commands (``/cmd_vel``) even when
        ``enabled`` is off: a command of 0.15 m/s then drives at 0.15 m/s.
    kp : float
        K_p, proportional gain [duty per rad/s].
    ki : float
        K_i, integral gain [duty per rad] (per rad/s of error per second).
    integral_limit : float
        I_max, clamp on the integral term [duty], >= 0.
    output_limit : float
        u_max, largest |u_ff + u_c| [duty], > 0.
    """

    enabled: bool = False
    external: bool = True
    kp: float = 0.05
    ki: float = 0.5
    integral_limit: float = 0.5
    output_limit: float = 1.0

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "integral_limit"):
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"WheelPiConfig.{name} must be finite and >= 0, got {value}")
        if not 0.0 < self.output_limit < math.inf:
            raise ValueError(
                f"WheelPiConfig.output_limit must be finite and > 0, got {self.output_limit}"
            )


def _clamp(x: float, low: float, high: float) -> float:
    return max(low, min(high, x))


class WheelSpeedPi:
    """PI speed loop for one wheel, updated once per encoder sample.

    The first update after construction or :meth:`reset` is a step of 0 s (no integration,
    proportional term only); so is an update whose t_s is not after the previous one.

    Parameters
    ----------
    config : WheelPiConfig, optional
        Gains and limits (``enabled`` is the daemon's business, not this loop's).
    zero_threshold_rad_s : float
        |omega_ref| at or below this is a stop [rad/s]; the daemon passes
        :attr:`DeadbandConfig.zero_threshold_rad_s` so both stages agree on braking.

    Attributes
    ----------
    integral : float
        I, the integral term [duty], for diagnostics.
    error : float
        e of the last update [rad/s], for diagnostics.
    """

    def __init__(
        self, config: WheelPiConfig | None = None, *, zero_threshold_rad_s: float = 0.05
    ) -> None:
        if not 0.0 <= zero_threshold_rad_s < math.inf:
            raise ValueError(
                f"zero_threshold_rad_s must be finite and >= 0, got {zero_threshold_rad_s}"
            )
        self.config = config if config is not None else WheelPiConfig()
        self.zero_threshold_rad_s = zero_threshold_rad_s
        self.integral = 0.0
        self.error = 0.0
        self._t_prev_s: float | None = None

    def update(
        self,
        omega_ref: float,
        omega_meas: float,
        t_s: float,
        *,
        feedforward_duty: float = 0.0,
    ) -> float:
        """One PI step.

        Parameters
        ----------
        omega_ref : float
            Wheel speed reference [rad/s], positive forward.
        omega_meas : float
            Measured wheel speed from the encoder [rad/s], positive forward.
        t_s : float
            MCU time of the measurement [s].
        feedforward_duty : float
            u_ff, the duty the correction is added to (the deadband stage's output), so
            saturation is judged on the total. 0 judges u_c alone.

        Returns
        -------
        float
            u_c, the duty correction to add to ``feedforward_duty``; 0 when braking.

        Raises
        ------
        ValueError
            If an argument is NaN or infinite.
        """
        if not all(math.isfinite(x) for x in (omega_ref, omega_meas, t_s, feedforward_duty)):
            raise ValueError(
                f"non-finite PI input: ref={omega_ref}, meas={omega_meas}, t={t_s}, "
                f"ff={feedforward_duty}"
            )
        c = self.config
        dt_s = 0.0 if self._t_prev_s is None else max(0.0, t_s - self._t_prev_s)
        self._t_prev_s = t_s
        e = omega_ref - omega_meas
        self.error = e
        if abs(omega_ref) <= self.zero_threshold_rad_s:
            self.integral = 0.0
            return 0.0
        p = c.kp * e
        candidate = _clamp(self.integral + c.ki * e * dt_s, -c.integral_limit, c.integral_limit)
        total = feedforward_duty + p + candidate
        winds_up = (total > c.output_limit and e > 0.0) or (total < -c.output_limit and e < 0.0)
        if not winds_up:
            self.integral = candidate
        return _clamp(
            p + self.integral, -c.output_limit - feedforward_duty, c.output_limit - feedforward_duty
        )

    def reset(self) -> None:
        """Zero the integrator and forget the previous time."""
        self.integral = 0.0
        self.error = 0.0
        self._t_prev_s = None
