"""Wheel odometry (Eq. 2, 3, 9): the cases of diff_drive_controller's odometry tests and more."""

from __future__ import annotations

import math

import pytest

from jackson.host.estimation.odometry import (
    ARC_THRESHOLD_RAD,
    OdometryCovariance,
    OdometryState,
    RobotGeometry,
    WheelOdometry,
    integrate_arc,
    tick_delta,
)

DT_S = 0.05  # [s] telemetry period (20 Hz)
TPR = 621  # [ticks/rev] default ticks per revolution
R_M = 0.033  # [m] default wheel radius
B_M = 0.198  # [m] default wheel separation


def drive(odom: WheelOdometry, counts: list[tuple[int, int]], t0_s: float = 0.0) -> OdometryState:
    """Feed cumulative (left, right) counts at 20 Hz; returns the last state."""
    state = odom.state
    for k, (left, right) in enumerate(counts):
        state = odom.update(t0_s + k * DT_S, left, right)
    return state


def test_first_update_only_sets_the_reference() -> None:
    odom = WheelOdometry()
    state = odom.update(12.5, 1000, -2000)
    assert state == OdometryState(t_s=12.5)
    assert odom.update(12.55, 1000, -2000) == OdometryState(t_s=12.55)


def test_straight_line() -> None:
    odom = WheelOdometry()
    counts = [(10 * k, 10 * k) for k in range(41)]  # 400 ticks each over 2 s
    state = drive(odom, counts)
    distance_m = 2.0 * math.pi * R_M * 400 / TPR
    assert state.x_m == pytest.approx(distance_m, abs=1e-12)
    assert state.y_m == 0.0
    assert state.yaw_rad == 0.0
    assert state.distance_left_m == pytest.approx(distance_m, abs=1e-12)
    assert state.distance_right_m == pytest.approx(distance_m, abs=1e-12)
    assert state.v_m_s == pytest.approx(distance_m / 2.0, rel=1e-9)
    assert state.w_rad_s == 0.0
    wheel_rad_s = 2.0 * math.pi * 10 / TPR / DT_S
    assert state.wheel_velocity_left_rad_s == pytest.approx(wheel_rad_s, rel=1e-9)
    assert state.wheel_angle_right_rad == pytest.approx(2.0 * math.pi * 400 / TPR, rel=1e-12)


def test_straight_line_backwards() -> None:
    state = drive(WheelOdometry(), [(-7 * k, -7 * k) for k in range(21)])
    assert state.x_m == pytest.approx(-2.0 * math.pi * R_M * 140 / TPR, abs=1e-12)
    assert state.y_m == 0.0
    assert state.v_m_s < 0.0


def test_pure_rotation_in_place_recovers_wheel_separation() -> None:
    # A 360 deg CCW turn: each wheel travels pi B, i.e. B / (2 r) turns = 3 turns = 1863 ticks.
    odom = WheelOdometry()
    steps = 81
    counts = [(round(-1863 * k / (steps - 1)), round(1863 * k / (steps - 1))) for k in range(steps)]
    state = drive(odom, counts)
    assert state.yaw_rad == pytest.approx(2.0 * math.pi, abs=1e-12)
    assert math.hypot(state.x_m, state.y_m) < 1e-12
    assert state.distance_left_m == pytest.approx(-math.pi * B_M, abs=1e-12)
    # Eq. A12-A15: B = r (dphi_R - dphi_L) / dtheta; the paper's 0.033 * 37.70 / 2 pi ~ 0.198.
    dphi_rad = state.wheel_angle_right_rad - state.wheel_angle_left_rad
    assert dphi_rad == pytest.approx(37.70, abs=5e-3)
    assert R_M * dphi_rad / state.yaw_rad == pytest.approx(B_M, abs=1e-12)
    assert 0.033 * 37.70 / (2.0 * math.pi) == pytest.approx(B_M, abs=1e-4)


def test_exact_arc_on_a_quarter_circle() -> None:
    # B = 0.2 m and 3:2 right:left ticks put the axle on a circle of radius
    # (B / 2) (3 + 2) / (3 - 2) = 0.5 m; r = 0.1035 m and 900 - 600 ticks make it a quarter
    # turn: dtheta = 2 pi r (900 - 600) / (621 B) = pi / 2. Uneven frames on purpose: the
    # exact arc composes, so the frame sizes must not matter.
    cfg = RobotGeometry(
        wheel_radius_left_m=0.1035, wheel_radius_right_m=0.1035, wheel_separation_m=0.2
    )
    odom = WheelOdometry(cfg)
    counts = [(0, 0)]  # per frame 2n left and 3n right ticks
    for n in (5, 25, 15, 1, 54, 100, 30, 70):  # sums to 300: 600 left, 900 right ticks
        counts.append((counts[-1][0] + 2 * n, counts[-1][1] + 3 * n))
    assert counts[-1] == (600, 900)
    state = drive(odom, counts)
    assert state.yaw_rad == pytest.approx(math.pi / 2, abs=1e-12)
    assert state.x_m == pytest.approx(0.5, abs=1e-9)
    assert state.y_m == pytest.approx(0.5, abs=1e-9)
    # Constant curvature: v / w is the radius in every frame.
    assert state.v_m_s / state.w_rad_s == pytest.approx(0.5, rel=1e-12)


def test_exact_arc_and_midpoint_forms_meet_at_the_threshold() -> None:
    d_s_m = 0.01
    below = integrate_arc(0.3, -0.2, 1.0, d_s_m, (1.0 - 1e-9) * ARC_THRESHOLD_RAD)
    above = integrate_arc(0.3, -0.2, 1.0, d_s_m, (1.0 + 1e-9) * ARC_THRESHOLD_RAD)
    assert below[0] == pytest.approx(above[0], abs=1e-15)
    assert below[1] == pytest.approx(above[1], abs=1e-15)


@pytest.mark.parametrize("d_theta_rad", [1e-3, 0.5, -2.0, math.pi])
def test_exact_arc_is_the_circle_through_both_poses(d_theta_rad: float) -> None:
    x0_m, y0_m, yaw0_rad, d_s_m = 0.3, -0.2, 1.0, 0.25
    x_m, y_m, yaw_rad = integrate_arc(x0_m, y0_m, yaw0_rad, d_s_m, d_theta_rad)
    radius_m = d_s_m / d_theta_rad
    tolerance_m = 1e-15 * (1.0 + abs(radius_m))  # the textbook form cancels ~eps * radius
    assert yaw_rad == yaw0_rad + d_theta_rad
    assert x_m == pytest.approx(
        x0_m + radius_m * (math.sin(yaw_rad) - math.sin(yaw0_rad)), abs=tolerance_m
    )
    assert y_m == pytest.approx(
        y0_m - radius_m * (math.cos(yaw_rad) - math.cos(yaw0_rad)), abs=tolerance_m
    )


def test_tiny_dt() -> None:
    odom = WheelOdometry()
    odom.update(1.0, 0, 0)
    state = odom.update(1.0 + 1e-6, 1, 1)
    meters_per_tick = 2.0 * math.pi * R_M / TPR
    assert state.x_m == pytest.approx(meters_per_tick, abs=1e-15)
    assert state.v_m_s == pytest.approx(meters_per_tick / 1e-6, rel=1e-6)
    assert math.isfinite(state.wheel_velocity_left_rad_s)
    state = odom.update(1.0 + 2e-6, 1, 1)
    assert state.v_m_s == 0.0
    assert state.x_m == pytest.approx(meters_per_tick, abs=1e-15)


def test_non_positive_dt_keeps_velocities_and_loses_no_distance() -> None:
    odom = WheelOdometry()
    odom.update(0.0, 0, 0)
    moving = odom.update(0.05, 10, 10)
    repeated = odom.update(0.05, 20, 20)  # same MCU time: velocities kept, counts integrated
    assert repeated.v_m_s == moving.v_m_s
    assert repeated.wheel_velocity_right_rad_s == moving.wheel_velocity_right_rad_s
    assert repeated.x_m == pytest.approx(2 * moving.x_m, abs=1e-15)
    backwards = odom.update(0.04, 20, 20)
    assert backwards.v_m_s == moving.v_m_s
    # The next frame's velocity spans all the ticks since the last estimate (0.05 s).
    later = odom.update(0.10, 30, 30)
    assert later.v_m_s == pytest.approx(2 * moving.v_m_s, rel=1e-12)
    assert later.x_m == pytest.approx(3 * moving.x_m, abs=1e-15)


def test_per_side_ticks_per_rev() -> None:
    cfg = RobotGeometry(ticks_per_rev_left=617, ticks_per_rev_right=626)
    odom = WheelOdometry(cfg)
    # A wheel turn is 617 left and 626 right ticks: equal turns drive a straight line.
    counts = [(617 * k, 626 * k) for k in range(6)]
    state = drive(odom, counts)
    assert state.wheel_angle_left_rad == pytest.approx(5 * 2.0 * math.pi, abs=1e-12)
    assert state.wheel_angle_right_rad == pytest.approx(5 * 2.0 * math.pi, abs=1e-12)
    assert state.yaw_rad == pytest.approx(0.0, abs=1e-12)
    assert state.x_m == pytest.approx(5 * 2.0 * math.pi * R_M, abs=1e-12)
    assert abs(state.y_m) < 1e-12
    assert state.wheel_velocity_left_rad_s == pytest.approx(2.0 * math.pi / DT_S, rel=1e-12)
    # With one shared TPR the same counts would curve left.
    curved = drive(WheelOdometry(RobotGeometry()), counts)
    assert curved.yaw_rad > 0.0


def test_tick_delta_wraps_across_2_31() -> None:
    assert tick_delta(2**31 - 10, -(2**31) + 20) == 30
    assert tick_delta(-(2**31) + 20, 2**31 - 10) == -30
    assert tick_delta(5, 3) == -2
    assert tick_delta(0xFFFFFFFF, 0) == 1  # unsigned readings work too
    assert tick_delta(-1, 2**31 - 1) == -(2**31)  # half the range reads as negative


def test_counter_wrap_across_2_31_is_30_ticks() -> None:
    odom = WheelOdometry()
    odom.update(0.0, 2**31 - 10, 2**31 - 10)
    state = odom.update(0.05, -(2**31) + 20, -(2**31) + 20)
    assert state.distance_left_m == pytest.approx(2.0 * math.pi * R_M * 30 / TPR, abs=1e-15)
    assert state.x_m == pytest.approx(2.0 * math.pi * R_M * 30 / TPR, abs=1e-15)


def test_lost_frame_loses_no_distance() -> None:
    counts = [(13 * k, 13 * k) for k in range(21)]
    full = drive(WheelOdometry(), counts)
    odom = WheelOdometry()
    for k, (left, right) in enumerate(counts):
        if k in (7, 8, 15):  # frames lost on the link
            continue
        skipped = odom.update(k * DT_S, left, right)
    assert skipped.x_m == pytest.approx(full.x_m, abs=1e-12)
    assert skipped.y_m == full.y_m == 0.0
    assert skipped.v_m_s == pytest.approx(full.v_m_s, rel=1e-12)


def test_lost_frame_on_an_arc_gives_the_same_pose() -> None:
    counts = [(20 * k, 30 * k) for k in range(41)]
    full = drive(WheelOdometry(), counts)
    odom = WheelOdometry()
    for k, (left, right) in enumerate(counts):
        if k % 4 != 1:
            skipped = odom.update(k * DT_S, left, right)
    assert skipped.x_m == pytest.approx(full.x_m, abs=1e-12)
    assert skipped.y_m == pytest.approx(full.y_m, abs=1e-12)
    assert skipped.yaw_rad == pytest.approx(full.yaw_rad, abs=1e-12)


def test_reset_starts_again_at_the_origin() -> None:
    odom = WheelOdometry()
    drive(odom, [(10 * k, 12 * k) for k in range(10)])
    odom.reset()
    assert odom.state == OdometryState()
    assert odom.update(3.0, 5, 5) == OdometryState(t_s=3.0)
    assert odom.update(3.05, 15, 15).x_m == pytest.approx(2.0 * math.pi * R_M * 10 / TPR)


@pytest.mark.parametrize(
    "field",
    ["wheel_radius_left_m", "wheel_separation_m", "ticks_per_rev_right", "pose_xy"],
)
def test_config_rejects_bad_values(field: str) -> None:
    kind = OdometryCovariance if field == "pose_xy" else RobotGeometry
    with pytest.raises(ValueError, match=field):
        kind(**{field: -1})
    OdometryCovariance(twist_vx=0.0)  # a zero covariance is allowed
    with pytest.raises(ValueError, match="wheel_separation_m"):
        RobotGeometry(wheel_separation_m=0.0)
