"""Differential-drive kinematics between body velocity (v, w) and wheel angular velocities.

Eq. 2-3 with a radius per wheel (r_L, r_R) and wheel separation B:

    v = (r_R omega_R + r_L omega_L) / 2
    w = (r_R omega_R - r_L omega_L) / B

and, inverted,

    omega_L = (v - w B / 2) / r_L
    omega_R = (v + w B / 2) / r_R

w is CCW positive (REP-103), so a left turn spins the right wheel faster. With r_L = r_R = r
these are the paper's Eq. 2-3 exactly.
"""

from __future__ import annotations


def _check_geometry(
    wheel_radius_left_m: float, wheel_radius_right_m: float, wheel_separation_m: float
) -> None:
    for name, value in (
        ("wheel_radius_left_m", wheel_radius_left_m),
        ("wheel_radius_right_m", wheel_radius_right_m),
        ("wheel_separation_m", wheel_separation_m),
    ):
        if not 0.0 < value < float("inf"):
            raise ValueError(f"{name} must be finite and > 0, got {value}")


def inverse(
    v_m_s: float,
    w_rad_s: float,
    wheel_radius_left_m: float,
    wheel_radius_right_m: float,
    wheel_separation_m: float,
) -> tuple[float, float]:
    """Wheel angular velocities for a body velocity (Eq. 2-3 inverted).

    omega_L = (v - w B / 2) / r_L,  omega_R = (v + w B / 2) / r_R.

    Parameters
    ----------
    v_m_s : float
        Linear velocity of the wheel-axle midpoint [m/s].
    w_rad_s : float
        Yaw rate [rad/s], CCW positive.
    wheel_radius_left_m : float
        r_L [m].
    wheel_radius_right_m : float
        r_R [m].
    wheel_separation_m : float
        B, the distance between the wheel contact points [m].

    Returns
    -------
    tuple of float
        (omega_L, omega_R) [rad/s], positive when the wheel drives the robot forward.

    Raises
    ------
    ValueError
        If a radius or the separation is not finite and > 0.
    """
    _check_geometry(wheel_radius_left_m, wheel_radius_right_m, wheel_separation_m)
    half_b_m = 0.5 * wheel_separation_m
    omega_l_rad_s = (v_m_s - w_rad_s * half_b_m) / wheel_radius_left_m
    omega_r_rad_s = (v_m_s + w_rad_s * half_b_m) / wheel_radius_right_m
    return omega_l_rad_s, omega_r_rad_s


def forward(
    omega_left_rad_s: float,
    omega_right_rad_s: float,
    wheel_radius_left_m: float,
    wheel_radius_right_m: float,
    wheel_separation_m: float,
) -> tuple[float, float]:
    """Body velocity for wheel angular velocities (Eq. 2-3).

    v = (r_R omega_R + r_L omega_L) / 2,  w = (r_R omega_R - r_L omega_L) / B.

    Parameters
    ----------
    omega_left_rad_s : float
        omega_L [rad/s], positive forward.
    omega_right_rad_s : float
        omega_R [rad/s], positive forward.
    wheel_radius_left_m : float
        r_L [m].
    wheel_radius_right_m : float
        r_R [m].
    wheel_separation_m : float
        B [m].

    Returns
    -------
    tuple of float
        (v [m/s], w [rad/s]), w CCW positive.

    Raises
    ------
    ValueError
        If a radius or the separation is not finite and > 0.
    """
    _check_geometry(wheel_radius_left_m, wheel_radius_right_m, wheel_separation_m)
    s_l_m_s = wheel_radius_left_m * omega_left_rad_s
    s_r_m_s = wheel_radius_right_m * omega_right_rad_s
    return 0.5 * (s_r_m_s + s_l_m_s), (s_r_m_s - s_l_m_s) / wheel_separation_m
