"""Differential-drive kinematics: Eq. 2-3 and their inverse, with a radius per wheel."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from jackson.host.actuation.kinematics import forward, inverse

R_M = 0.033  # [m] physical wheel radius (Table 3)
B_M = 0.198  # [m] physical wheel separation (Table 3)


def test_figure_eight_wheel_speeds() -> None:
    omega_l, omega_r = inverse(0.08, 0.16, R_M, R_M, B_M)  # Stage 2: R = 0.50 m, CCW loop
    assert omega_l == pytest.approx(1.944, abs=1e-3)  # (0.08 - 0.16 * 0.099) / 0.033
    assert omega_r == pytest.approx(2.904, abs=1e-3)  # (0.08 + 0.16 * 0.099) / 0.033
    assert inverse(0.08, -0.16, R_M, R_M, B_M) == pytest.approx((omega_r, omega_l))  # CW loop


def test_straight_line_turns_both_wheels_equally() -> None:
    assert inverse(0.2, 0.0, R_M, R_M, B_M) == pytest.approx((0.2 / R_M, 0.2 / R_M))


def test_ccw_rotation_turns_the_right_wheel_forward() -> None:
    omega_l, omega_r = inverse(0.0, 1.0, R_M, R_M, B_M)
    assert omega_r == pytest.approx(B_M / 2 / R_M)
    assert omega_l == pytest.approx(-omega_r)


def test_360_degree_rotation_check_recovers_the_separation() -> None:
    # Eq. A12-A15: B = r (dphi_R - dphi_L) / dtheta; the paper measured 37.70 rad for 2 pi.
    omega_l, omega_r = inverse(0.0, 2 * math.pi, R_M, R_M, B_M)  # one turn in 1 s
    assert omega_r - omega_l == pytest.approx(37.70, abs=0.01)


def test_forward_is_eq_2_3_for_equal_wheels() -> None:
    v, w = forward(2.0, 3.0, R_M, R_M, B_M)
    assert v == pytest.approx(R_M / 2 * (3.0 + 2.0))
    assert w == pytest.approx(R_M / B_M * (3.0 - 2.0))


def test_a_larger_wheel_turns_slower_for_the_same_speed() -> None:
    omega_l, omega_r = inverse(0.1, 0.0, 0.033, 0.034, B_M)
    assert omega_l * 0.033 == pytest.approx(omega_r * 0.034)
    assert omega_r < omega_l


@given(
    v=st.floats(-1.0, 1.0),
    w=st.floats(-5.0, 5.0),
    r_l=st.floats(0.01, 0.1),
    r_r=st.floats(0.01, 0.1),
    b=st.floats(0.05, 1.0),
)
def test_inverse_then_forward_round_trips(
    v: float, w: float, r_l: float, r_r: float, b: float
) -> None:
    omega_l, omega_r = inverse(v, w, r_l, r_r, b)
    assert forward(omega_l, omega_r, r_l, r_r, b) == pytest.approx((v, w), abs=1e-12)


@pytest.mark.parametrize(
    ("r_l", "r_r", "b", "name"),
    [
        (0.0, R_M, B_M, "wheel_radius_left_m"),
        (R_M, -0.03, B_M, "wheel_radius_right_m"),
        (R_M, R_M, math.nan, "wheel_separation_m"),
        (R_M, R_M, math.inf, "wheel_separation_m"),
    ],
)
def test_impossible_geometry_is_rejected(r_l: float, r_r: float, b: float, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        inverse(0.1, 0.0, r_l, r_r, b)
    with pytest.raises(ValueError, match=name):
        forward(1.0, 1.0, r_l, r_r, b)
