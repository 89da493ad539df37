"""Speed and acceleration limits on the body velocity command (v, w), the chain's first stage.

Each axis is clamped to its speed limit and then rate-limited towards that target, with a
separate, larger bound when the magnitude falls. For one axis with previous output u, clamped
target r, acceleration bound a, deceleration bound d and step dt = t_k - t_{k-1} [s]:

* same side of zero, speeding up (|r| >= |u|):  u' = u + clamp(r - u, -a dt, a dt)
* same side of zero, slowing down (|r| < |u|):  u' = u + clamp(r - u, -d dt, d dt)
* through zero (r = 0 or sign(r) != sign(u)): decelerate to 0 at d, which takes
  t_0 = |u| / d; if dt <= t_0 then u' = u - sign(u) d dt, else the rest of the step
  accelerates the other way at a: u' = sign(r) min(|r|, a (dt - t_0)).

So a reversal is a braking ramp followed by an acceleration ramp, never a jump, and a stop
(r = 0) always uses the deceleration bound. The speed limiter of ros2_controllers'
diff_drive_controller does the same job with one bound for both directions.

The ramp of one axis is :func:`jackson.common.ramp.ramp`, which DWB's dynamic window uses too
(:mod:`jackson.host.nav.dwb.core.kinematics`). Time comes in as an argument (MCU seconds): the
limiter never reads a clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from jackson.common.ramp import clamp
from jackson.common.ramp import ramp as ramp  # the ramp of one axis (re-exported)


@dataclass(frozen=True)
class LimiterConfig:
    """Speed, acceleration and deceleration bounds of the body velocity.

    Every bound must be > 0; ``math.inf`` switches that bound off.

    Attributes
    ----------
    max_v_m_s : float
        Largest |v| [m/s].
    max_w_rad_s : float
        Largest |w| [rad/s].
    max_accel_m_s2 : float
        Largest rate at which |v| may grow [m/s^2].
    max_decel_m_s2 : float
        Largest rate at which |v| may fall [m/s^2].
    max_alpha_rad_s2 : float
        Largest rate at which |w| may grow [rad/s^2].
    max_alpha_decel_rad_s2 : float
        Largest rate at which |w| may fall [rad/s^2].
    """

    max_v_m_s: float = 0.30
    max_w_rad_s: float = 2.0
    max_accel_m_s2: float = 0.5
    max_decel_m_s2: float = 1.0
    max_alpha_rad_s2: float = 3.0
    max_alpha_decel_rad_s2: float = 6.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not value > 0.0:  # also rejects NaN
                raise ValueError(f"LimiterConfig.{f.name} must be > 0, got {value}")


class VelocityLimiter:
    """Clamps and rate-limits (v, w) commands, one call per control tick.

    The first call after construction or :meth:`reset` has no previous time, so it is a
    step of 0 s: the output stays at rest, (0, 0), and the ramp starts on the next tick.
    A step with t_s at or before the previous call (a clock that stepped back) is also a
    0 s step: the output holds and the next step is measured from the new t_s.

    Call :meth:`limit` on every tick, with (0, 0) while the watchdog brakes, or call
    :meth:`reset` when the motors are braked, so that the limiter's state matches the robot.
    """

    def __init__(self, config: LimiterConfig | None = None) -> None:
        self.config = config if config is not None else LimiterConfig()
        self._v_m_s = 0.0
        self._w_rad_s = 0.0
        self._t_prev_s: float | None = None

    @property
    def v_m_s(self) -> float:
        """The last limited linear velocity [m/s]."""
        return self._v_m_s

    @property
    def w_rad_s(self) -> float:
        """The last limited angular velocity [rad/s]."""
        return self._w_rad_s

    def limit(self, v_cmd: float, w_cmd: float, t_s: float) -> tuple[float, float]:
        """Limit one command.

        Parameters
        ----------
        v_cmd : float
            Commanded linear velocity [m/s].
        w_cmd : float
            Commanded angular velocity [rad/s], CCW positive (REP-103).
        t_s : float
            MCU time of this tick [s].

        Returns
        -------
        tuple of float
            The limited (v [m/s], w [rad/s]).

        Raises
        ------
        ValueError
            If a command or the time is NaN or infinite.
        """
        if not (math.isfinite(v_cmd) and math.isfinite(w_cmd) and math.isfinite(t_s)):
            raise ValueError(f"non-finite command or time: v={v_cmd}, w={w_cmd}, t={t_s}")
        c = self.config
        dt_s = 0.0 if self._t_prev_s is None else max(0.0, t_s - self._t_prev_s)
        self._t_prev_s = t_s
        v_target = clamp(v_cmd, -c.max_v_m_s, c.max_v_m_s)
        w_target = clamp(w_cmd, -c.max_w_rad_s, c.max_w_rad_s)
        self._v_m_s = ramp(self._v_m_s, v_target, dt_s, c.max_accel_m_s2, c.max_decel_m_s2)
        self._w_rad_s = ramp(
            self._w_rad_s, w_target, dt_s, c.max_alpha_rad_s2, c.max_alpha_decel_rad_s2
        )
        return self._v_m_s, self._w_rad_s

    def reset(self) -> None:
        """Back to rest, (0, 0), with no previous time."""
        self._v_m_s = 0.0
        self._w_rad_s = 0.0
        self._t_prev_s = None
