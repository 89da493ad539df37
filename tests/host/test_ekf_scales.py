"""The EKF's optional scale states: a gyro or wheel scale error carried in the covariance."""

from __future__ import annotations

import math

import pytest

from jackson.host.ekf import YAW, Ekf, EkfConfig, ProcessNoise

DT = 0.05


def turn(ekf: Ekf, angle_rad: float, rate: float = 0.5) -> None:
    t = 0.0
    for _ in range(round(angle_rad / rate / DT)):
        t += DT
        ekf.update_wheel(t, 0.0)
        ekf.update_gyro(t, rate)


def quiet(**kw: float) -> EkfConfig:
    noise = ProcessNoise(x=1e-9, y=1e-9, yaw=1e-9)
    return EkfConfig(process_noise=noise, r_vx=1e-6, r_wz=1e-6, **kw)


def test_without_scale_states_the_filter_is_the_seven_state_one() -> None:
    ekf = Ekf()
    assert ekf.n == 7 and len(ekf.state().x) == 7


def test_a_gyro_scale_state_makes_the_heading_variance_grow_with_the_angle_turned() -> None:
    sigma = 0.01
    spins = {}
    for turns in (1, 2):
        ekf = Ekf(quiet(gyro_scale_sigma=sigma))
        assert ekf.n == 8
        turn(ekf, 2 * math.pi * turns)
        spins[turns] = ekf.P[YAW, YAW]
    # (sigma * angle)^2: four times the variance for twice the angle, not twice
    assert spins[1] == pytest.approx((sigma * 2 * math.pi) ** 2, rel=0.1)
    assert spins[2] / spins[1] == pytest.approx(4.0, rel=0.1)
    plain = Ekf(quiet())
    turn(plain, 2 * math.pi)
    assert plain.P[YAW, YAW] < 0.01 * spins[1]


def test_the_wheel_scale_state_grows_the_position_variance_with_the_distance() -> None:
    ekf = Ekf(quiet(wheel_scale_sigma=0.02))
    t = 0.0
    for _ in range(round(10.0 / DT)):  # 10 s at 0.2 m/s: 2 m
        t += DT
        ekf.update_wheel(t, 0.2)
        ekf.update_gyro(t, 0.0)
    assert math.sqrt(ekf.P[0, 0]) == pytest.approx(0.02 * 2.0, rel=0.15)
    assert ekf.x_m == pytest.approx(2.0, rel=0.02)
