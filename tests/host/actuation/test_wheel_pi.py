"""The wheel-speed PI: a duty correction on top of the feed-forward, without windup."""

from __future__ import annotations

import math

import pytest

from jackson.host.actuation.deadband import DeadbandConfig, wheel_duty
from jackson.host.actuation.wheel_pi import WheelPiConfig, WheelSpeedPi

TICK_S = 0.05  # [s] encoder sample period


def test_first_update_is_proportional_only() -> None:
    pi = WheelSpeedPi()
    assert pi.update(3.0, 1.0, 7.0) == pytest.approx(0.05 * 2.0)
    assert pi.integral == 0.0
    assert pi.error == 2.0


def test_pi_integrates_the_error_over_time() -> None:
    pi = WheelSpeedPi()
    pi.update(3.0, 2.0, 0.0)
    u = pi.update(3.0, 2.0, TICK_S)  # I = 0.5 * 1.0 * 0.05
    assert pi.integral == pytest.approx(0.025)
    assert u == pytest.approx(0.05 * 1.0 + 0.025)


def test_integral_is_clamped_to_its_limit() -> None:
    pi = WheelSpeedPi(WheelPiConfig(integral_limit=0.1))
    pi.update(5.0, 4.0, 0.0)
    for k in range(1, 100):
        pi.update(5.0, 4.0, k * TICK_S)
    assert pi.integral == pytest.approx(0.1)


def test_pi_does_not_wind_up_when_saturated() -> None:
    cfg = WheelPiConfig(integral_limit=100.0)  # only conditional integration stops it
    pi = WheelSpeedPi(cfg)
    for k in range(200):  # stalled wheel: 10 s of a 10 rad/s error
        u = pi.update(10.0, 0.0, k * TICK_S)
    assert u == 1.0
    assert pi.integral <= cfg.output_limit - cfg.kp * 10.0
    u = pi.update(10.0, 12.0, 200 * TICK_S)  # the wheel breaks free and overshoots
    assert u < 1.0  # out of saturation at once


def test_feedforward_counts_toward_saturation() -> None:
    pi = WheelSpeedPi()
    for k in range(100):
        u = pi.update(10.0, 8.0, k * TICK_S, feedforward_duty=0.95)
    assert 0.95 + u == pytest.approx(1.0)
    assert pi.integral <= 0.05


def test_a_correction_can_pull_a_saturated_feedforward_back() -> None:
    pi = WheelSpeedPi()
    assert pi.update(10.0, 12.0, 0.0, feedforward_duty=1.0) == pytest.approx(-0.1)


def test_pi_resets_when_the_reference_is_zero() -> None:
    pi = WheelSpeedPi()
    for k in range(10):
        pi.update(5.0, 4.0, k * TICK_S)
    assert pi.integral > 0.0
    assert pi.update(0.0, 3.0, 10 * TICK_S) == 0.0  # braking: no correction fights the brake
    assert pi.integral == 0.0


def test_reset_clears_the_integrator_and_the_time() -> None:
    pi = WheelSpeedPi()
    for k in range(10):
        pi.update(5.0, 4.0, k * TICK_S)
    pi.reset()
    assert pi.integral == 0.0
    assert pi.update(5.0, 4.0, 99.0) == pytest.approx(0.05)  # 0 s step: no integration


def test_time_stepping_back_does_not_integrate() -> None:
    pi = WheelSpeedPi()
    pi.update(5.0, 4.0, 1.0)
    pi.update(5.0, 4.0, 0.5)
    assert pi.integral == 0.0


def test_pi_removes_the_steady_state_error_of_a_miscalibrated_feedforward() -> None:
    # Plant: first-order motor, tau 0.1 s, weaker than the calibration believes.
    db_true, omega_max_true_rad_s, tau_s = 0.15, 9.0, 0.1
    cfg = DeadbandConfig(0.10, 0.10, 0.10, 0.10, max_wheel_rad_s=10.47)
    pi = WheelSpeedPi()
    omega_ref, omega = 5.0, 0.0
    decay = math.exp(-TICK_S / tau_s)
    for k in range(100):
        ff = wheel_duty(omega_ref, "left", cfg)
        duty = max(
            -1.0, min(1.0, ff + pi.update(omega_ref, omega, k * TICK_S, feedforward_duty=ff))
        )
        target = max(0.0, (abs(duty) - db_true) / (1 - db_true)) * omega_max_true_rad_s
        omega = target + (omega - target) * decay
    open_loop = max(0.0, (wheel_duty(omega_ref, "left", cfg) - db_true) / (1 - db_true)) * 9.0
    assert abs(omega_ref - open_loop) > 0.5
    assert omega == pytest.approx(omega_ref, abs=0.01)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"kp": -0.1}, "kp"), ({"ki": math.nan}, "ki"), ({"output_limit": 0.0}, "output_limit")],
)
def test_impossible_gains_are_rejected(kwargs: dict[str, float], name: str) -> None:
    with pytest.raises(ValueError, match=name):
        WheelPiConfig(**kwargs)


def test_non_finite_measurement_is_rejected() -> None:
    with pytest.raises(ValueError, match="non-finite"):
        WheelSpeedPi().update(1.0, math.nan, 0.0)
