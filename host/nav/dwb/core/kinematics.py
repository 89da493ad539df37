"""DWB's own kinematic limits (Nav2's KinematicParameters, kept by its KinematicsHandler).

The dynamic window (:mod:`.window`) and the roll-outs (:mod:`.rollouts`) ramp each axis as the
daemon's velocity limiter will (:func:`jackson.common.ramp.ramp`), so DWB needs the same
speed and acceleration bounds. It keeps its own copy under Nav2's names, built from the
navigation limits whatever type holds them (:class:`SpeedLimits`: the limiter's configuration
is one), so the planner depends on no actuation code; the navigator hands it new limits when
they change at run time (:meth:`jackson.host.nav.dwb.planner.DwbPlanner.set_limits`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Protocol


class SpeedLimits(Protocol):
    """Speed and acceleration bounds of the body velocity, as the navigation sets them (the
    velocity limiter's ``LimiterConfig`` has these)."""

    @property
    def max_v_m_s(self) -> float:
        """Largest |v| [m/s]."""
        ...

    @property
    def max_w_rad_s(self) -> float:
        """Largest |w| [rad/s]."""
        ...

    @property
    def max_accel_m_s2(self) -> float:
        """Largest growth of |v| [m/s^2]."""
        ...

    @property
    def max_decel_m_s2(self) -> float:
        """Largest fall of |v| [m/s^2]."""
        ...

    @property
    def max_alpha_rad_s2(self) -> float:
        """Largest growth of |w| [rad/s^2]."""
        ...

    @property
    def max_alpha_decel_rad_s2(self) -> float:
        """Largest fall of |w| [rad/s^2]."""
        ...


@dataclass(frozen=True)
class Kinematics:
    """The bounds DWB samples and rolls out within (Nav2's ``max_vel_x``, ``max_vel_theta``,
    ``acc_lim_x``, ``decel_lim_x``, ``acc_lim_theta``, ``decel_lim_theta``; decelerations as
    positive magnitudes). Every bound must be > 0 (``math.inf``: none).

    Attributes
    ----------
    max_vel_x_m_s : float
        Largest |v| [m/s].
    max_vel_theta_rad_s : float
        Largest |w| [rad/s].
    acc_lim_x_m_s2, decel_lim_x_m_s2 : float
        Largest growth and fall of |v| [m/s^2].
    acc_lim_theta_rad_s2, decel_lim_theta_rad_s2 : float
        Largest growth and fall of |w| [rad/s^2].
    """

    max_vel_x_m_s: float = 0.30
    max_vel_theta_rad_s: float = 2.0
    acc_lim_x_m_s2: float = 0.5
    decel_lim_x_m_s2: float = 1.0
    acc_lim_theta_rad_s2: float = 3.0
    decel_lim_theta_rad_s2: float = 6.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not value > 0.0:  # also rejects NaN
                raise ValueError(f"Kinematics.{f.name} must be > 0, got {value}")

    @classmethod
    def of(cls, limits: SpeedLimits | Kinematics) -> Kinematics:
        """DWB's bounds from the navigation's limits (a :class:`Kinematics` as it is).

        Parameters
        ----------
        limits : SpeedLimits or Kinematics
            The bounds.

        Returns
        -------
        Kinematics
        """
        if isinstance(limits, Kinematics):
            return limits
        return cls(
            limits.max_v_m_s,
            limits.max_w_rad_s,
            limits.max_accel_m_s2,
            limits.max_decel_m_s2,
            limits.max_alpha_rad_s2,
            limits.max_alpha_decel_rad_s2,
        )
