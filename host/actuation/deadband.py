"""PWM deadband compensation and left/right gain trim: wheel speed command to signed duty.

A DC gear motor does not turn until its duty passes a breakaway value, different per wheel
and per direction. This stage maps a wheel-speed command onto the duty range above that
value, so every nonzero command moves the wheel (this is the opposite of a zero-out
deadband, which drops small commands):

    duty = 0                                                 if |omega| <= omega_0
    duty = sign(omega) min(1, d_b + (1 - d_b) g |omega| / omega_max)   otherwise

with omega_0 the zero threshold, d_b the breakaway duty of that wheel in that direction,
g the gain trim of that wheel in that direction and omega_max the wheel speed at duty 1. A
duty of 0 brakes (the TB6612FNG's short brake, see :mod:`jackson.host.actuation.tb6612`). The
gain trim scales only the part above breakaway, so it corrects a wheel that is faster or
slower at speed without moving its start-up point.

With a first-order motor model whose steady state is omega = K (d - d_b) (K the wheel's
speed per unit duty above breakaway in that direction), the map gives omega = K (1 - d_b) g
omega_cmd / omega_max, so every wheel and direction reaches the commanded speed when
g = omega_max / (K (1 - d_b)): a faster wheel gets a smaller gain. The step-response
identification (:mod:`jackson.calibration.procedures.step`) computes these gains, taking the
slowest wheel and direction as the reference (gain 1, omega_max its speed at duty 1).

A wheel's gain holds for both directions unless a reverse gain is given
(``gain_reverse_left`` / ``gain_reverse_right`` None: as forward), so a configuration of one
gain per wheel behaves as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

NOMINAL_MAX_WHEEL_RAD_S = 100.0 * 2.0 * math.pi / 60.0  # [rad/s] the 100 RPM gear motor

Side = Literal["left", "right"]
Direction = Literal["forward", "reverse"]


@dataclass(frozen=True)
class DeadbandConfig:
    """Breakaway duties, full-duty wheel speed, zero threshold and gain trims.

    Attributes
    ----------
    forward_left : float
        Breakaway duty of the left wheel driving forward, in [0, 1).
    reverse_left : float
        Breakaway duty of the left wheel driving backward, in [0, 1).
    forward_right : float
        Breakaway duty of the right wheel driving forward, in [0, 1).
    reverse_right : float
        Breakaway duty of the right wheel driving backward, in [0, 1).
    max_wheel_rad_s : float
        omega_max, the wheel speed at duty 1 [rad/s] (100 RPM = 10.47).
    zero_threshold_rad_s : float
        omega_0: commands with |omega| at or below it brake [rad/s].
    gain_left : float
        Left gain trim g driving forward, and backward unless ``gain_reverse_left``
        is given (dimensionless, > 0).
    gain_right : float
        Right gain trim g driving forward, and backward unless ``gain_reverse_right``
        is given (dimensionless, > 0).
    gain_reverse_left : float or None
        Left gain trim g driving backward (> 0); None: ``gain_left``.
    gain_reverse_right : float or None
        Right gain trim g driving backward (> 0); None: ``gain_right``.
    """

    forward_left: float = 0.10
    reverse_left: float = 0.10
    forward_right: float = 0.10
    reverse_right: float = 0.10
    max_wheel_rad_s: float = 10.47  # 100 RPM
    zero_threshold_rad_s: float = 0.05
    gain_left: float = 1.0
    gain_right: float = 1.0
    gain_reverse_left: float | None = None
    gain_reverse_right: float | None = None

    def __post_init__(self) -> None:
        for name in ("forward_left", "reverse_left", "forward_right", "reverse_right"):
            value = getattr(self, name)
            if not 0.0 <= value < 1.0:
                raise ValueError(f"DeadbandConfig.{name} must be in [0, 1), got {value}")
        for name in ("max_wheel_rad_s", "gain_left", "gain_right"):
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"DeadbandConfig.{name} must be finite and > 0, got {value}")
        for name in ("gain_reverse_left", "gain_reverse_right"):
            value = getattr(self, name)
            if value is not None and not 0.0 < value < math.inf:
                raise ValueError(
                    f"DeadbandConfig.{name} must be finite and > 0 or None, got {value}"
                )
        if not 0.0 <= self.zero_threshold_rad_s < math.inf:
            raise ValueError(
                f"DeadbandConfig.zero_threshold_rad_s must be finite and >= 0, "
                f"got {self.zero_threshold_rad_s}"
            )

    def gain(self, side: Side, direction: Direction) -> float:
        """The gain trim g of one wheel in one direction.

        Parameters
        ----------
        side : Side
            ``"left"`` or ``"right"``.
        direction : Direction
            ``"forward"`` or ``"reverse"``.

        Returns
        -------
        float
            g (dimensionless, > 0).

        Raises
        ------
        ValueError
            If ``side`` or ``direction`` is unknown.
        """
        if side == "left":
            forward, reverse = self.gain_left, self.gain_reverse_left
        elif side == "right":
            forward, reverse = self.gain_right, self.gain_reverse_right
        else:
            raise ValueError(f"side must be 'left' or 'right', got {side!r}")
        if direction == "forward":
            return forward
        if direction == "reverse":
            return forward if reverse is None else reverse
        raise ValueError(f"direction must be 'forward' or 'reverse', got {direction!r}")

    def breakaway(self, side: Side, direction: Direction) -> float:
        """The breakaway duty d_b of one wheel in one direction.

        Parameters
        ----------
        side : Side
            ``"left"`` or ``"right"``.
        direction : Direction
            ``"forward"`` or ``"reverse"``.

        Returns
        -------
        float
            d_b in [0, 1).

        Raises
        ------
        ValueError
            If ``side`` or ``direction`` is unknown.
        """
        if side not in ("left", "right"):
            raise ValueError(f"side must be 'left' or 'right', got {side!r}")
        if direction not in ("forward", "reverse"):
            raise ValueError(f"direction must be 'forward' or 'reverse', got {direction!r}")
        value: float = getattr(self, f"{direction}_{side}")
        return value


def wheel_duty(omega_cmd_rad_s: float, side: Side, cfg: DeadbandConfig) -> float:
    """Signed duty for one wheel's speed command.

    duty = 0 for |omega| <= omega_0, else
    sign(omega) min(1, d_b + (1 - d_b) g |omega| / omega_max).

    Parameters
    ----------
    omega_cmd_rad_s : float
        Wheel speed command [rad/s], positive forward.
    side : Side
        ``"left"`` or ``"right"``: which breakaway duties and gains apply (those of the
        command's direction).
    cfg : DeadbandConfig
        The wheel's calibration.

    Returns
    -------
    float
        Signed duty in [-1, 1]; 0 means brake.

    Raises
    ------
    ValueError
        If ``side`` is neither wheel or the command is NaN or infinite.
    """
    if side == "left":
        forward, reverse = cfg.forward_left, cfg.reverse_left
        gain_forward, gain_reverse = cfg.gain_left, cfg.gain_reverse_left
    elif side == "right":
        forward, reverse = cfg.forward_right, cfg.reverse_right
        gain_forward, gain_reverse = cfg.gain_right, cfg.gain_reverse_right
    else:
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    if not math.isfinite(omega_cmd_rad_s):
        raise ValueError(f"non-finite wheel speed command: {omega_cmd_rad_s}")
    magnitude = abs(omega_cmd_rad_s)
    if magnitude <= cfg.zero_threshold_rad_s:
        return 0.0
    if omega_cmd_rad_s > 0.0:
        breakaway, gain = forward, gain_forward
    else:
        breakaway = reverse
        gain = gain_forward if gain_reverse is None else gain_reverse
    duty = min(1.0, breakaway + (1.0 - breakaway) * gain * magnitude / cfg.max_wheel_rad_s)
    return math.copysign(duty, omega_cmd_rad_s)


def wheel_duties(
    omega_l_rad_s: float, omega_r_rad_s: float, cfg: DeadbandConfig
) -> tuple[float, float]:
    """Signed (left, right) duties for both wheels' speed commands, by :func:`wheel_duty`.

    Parameters
    ----------
    omega_l_rad_s : float
        Left wheel speed command [rad/s], positive forward.
    omega_r_rad_s : float
        Right wheel speed command [rad/s], positive forward.
    cfg : DeadbandConfig
        Both wheels' calibration.

    Returns
    -------
    tuple of float
        (left duty, right duty), each in [-1, 1].

    Raises
    ------
    ValueError
        If a command is NaN or infinite.
    """
    return wheel_duty(omega_l_rad_s, "left", cfg), wheel_duty(omega_r_rad_s, "right", cfg)
