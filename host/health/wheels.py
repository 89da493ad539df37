"""What the wheels say, as the checks read it: their yaw rate and forward speed, the speed one
wheel should have by the other and the gyro, and the encoders' quantisation.

Pure functions of the configured geometry (and the learned wheel yaw model), shared by the
encoder, yaw and isolation checks so that each reads the same numbers.
"""

from __future__ import annotations

import math

from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.health.types import HealthInput
from jackson.host.health.wheel_yaw import WheelYawModel

SILENT_TICKS = 3.0  # a wheel expected to make this many counts in a frame and making none


def wheel_yaw_rate(r: RobotGeometry, om_l: float, om_r: float) -> float:
    """w_e = (r_R omega_R - r_L omega_L) / B [rad/s]."""
    return (r.wheel_radius_right_m * om_r - r.wheel_radius_left_m * om_l) / r.wheel_separation_m


def forward_speed(r: RobotGeometry, om_l: float, om_r: float) -> float:
    """v = (r_L omega_L + r_R omega_R) / 2 [m/s]."""
    return 0.5 * (r.wheel_radius_left_m * om_l + r.wheel_radius_right_m * om_r)


def quantisation_variance(r: RobotGeometry, dt_s: float) -> float:
    """sigma_q^2: one count of each wheel over a frame of ``dt_s``, a triangular error of 1/6
    count^2 per wheel, as a yaw rate [(rad/s)^2] (0 for the first frame)."""
    if dt_s <= 0.0:
        return 0.0
    per_count = [
        r.wheel_radius_left_m * 2.0 * math.pi / r.ticks_per_rev_left,
        r.wheel_radius_right_m * 2.0 * math.pi / r.ticks_per_rev_right,
    ]
    return sum((c / (r.wheel_separation_m * dt_s)) ** 2 / 6.0 for c in per_count)


def expected_wheel(
    r: RobotGeometry, model: WheelYawModel, i: int, h: HealthInput, wz: float | None
) -> float:
    """Wheel i's speed implied by the other wheel and the gyro (``wz``), or, without a gyro,
    by the command [rad/s]."""
    if wz is None:
        return h.wheel_cmd_rad_s[i]
    # the other wheel's speed stands for v (this wheel's own reading may be the fault)
    other = (
        r.wheel_radius_right_m * h.wheel_rad_s[1],
        r.wheel_radius_left_m * h.wheel_rad_s[0],
    )
    yaw = model.predict(wz, other[i]) * r.wheel_separation_m
    if i == 0:  # r_L om_L = r_R om_R - (s wz + c v) B
        return (r.wheel_radius_right_m * h.wheel_rad_s[1] - yaw) / r.wheel_radius_left_m
    return (r.wheel_radius_left_m * h.wheel_rad_s[0] + yaw) / r.wheel_radius_right_m


def expected_ticks(
    r: RobotGeometry, model: WheelYawModel, i: int, h: HealthInput, wz: float | None
) -> float:
    """Counts wheel i should have made over the frame, by :func:`expected_wheel`."""
    tpr = (r.ticks_per_rev_left, r.ticks_per_rev_right)[i]
    return abs(expected_wheel(r, model, i, h, wz)) * h.dt_s * tpr / (2.0 * math.pi)
