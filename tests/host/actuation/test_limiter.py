"""The velocity limiter: speed clamps, acceleration ramps, a separate deceleration bound."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter, ramp

TICK_S = 0.05  # [s] 20 Hz control tick


def run(limiter: VelocityLimiter, v: float, w: float, t0_s: float, ticks: int) -> list[float]:
    """Feed a constant command for ``ticks`` ticks after t0_s; the linear outputs."""
    return [limiter.limit(v, w, t0_s + k * TICK_S)[0] for k in range(1, ticks + 1)]


def at_speed(v: float, w: float = 0.0) -> VelocityLimiter:
    """A default limiter settled at (v, w) by one long step, its last tick at t = 10 s."""
    limiter = VelocityLimiter()
    limiter.limit(0.0, 0.0, 0.0)
    assert limiter.limit(v, w, 10.0) == (v, w)
    return limiter


def test_first_call_stays_at_rest() -> None:
    limiter = VelocityLimiter()
    assert limiter.limit(0.3, 2.0, 123.0) == (0.0, 0.0)


def test_limiter_reaches_command_after_ramp_time() -> None:
    limiter = VelocityLimiter()  # 0.5 m/s^2: 0.2 m/s takes 0.4 s = 8 ticks
    limiter.limit(0.0, 0.0, 0.0)
    v = run(limiter, 0.2, 0.0, 0.0, 10)
    assert v[0] == pytest.approx(0.025)
    assert v[6] == pytest.approx(0.175)
    assert v[7] == pytest.approx(0.2)
    assert v[8:] == [pytest.approx(0.2)] * 2


def test_speeds_are_clamped_to_the_limits() -> None:
    limiter = VelocityLimiter()
    limiter.limit(0.0, 0.0, 0.0)
    assert limiter.limit(5.0, -50.0, 10.0) == (0.30, -2.0)
    assert limiter.limit(-5.0, 50.0, 20.0) == (-0.30, 2.0)


def test_decel_is_separate_from_accel() -> None:
    up = VelocityLimiter()
    up.limit(0.0, 0.0, 0.0)
    assert up.limit(0.3, 0.0, 0.1)[0] == pytest.approx(0.05)  # 0.5 m/s^2
    down = at_speed(0.3)
    assert down.limit(0.0, 0.0, 10.1)[0] == pytest.approx(0.2)  # 1.0 m/s^2
    assert down.limit(0.0, 0.0, 10.3)[0] == 0.0  # stopped in 0.3 s, not 0.6 s


def test_slowing_down_without_stopping_uses_decel() -> None:
    limiter = at_speed(0.3)
    assert limiter.limit(0.1, 0.0, 10.1)[0] == pytest.approx(0.2)
    assert limiter.limit(0.1, 0.0, 10.2)[0] == pytest.approx(0.1)  # no overshoot below 0.1


def test_sign_flip_decelerates_through_zero() -> None:
    limiter = at_speed(0.2)
    v = run(limiter, -0.2, 0.0, 10.0, 12)
    braking = [0.15, 0.10, 0.05, 0.0]  # 1.0 m/s^2 down to zero
    accelerating = [-0.025 * k for k in range(1, 9)]  # then 0.5 m/s^2 away from it
    assert v == pytest.approx(braking + accelerating)


def test_sign_flip_within_one_step_brakes_then_accelerates() -> None:
    limiter = at_speed(0.2)  # 0.2 s of the 0.3 s step brakes, 0.1 s accelerates
    assert limiter.limit(-0.2, 0.0, 10.3)[0] == pytest.approx(-0.05)


def test_angular_axis_has_its_own_bounds() -> None:
    limiter = VelocityLimiter()
    limiter.limit(0.0, 0.0, 0.0)
    assert limiter.limit(0.0, 2.0, 0.1) == pytest.approx((0.0, 0.3))  # 3 rad/s^2
    spinning = at_speed(0.0, 1.2)
    assert spinning.limit(0.0, 0.0, 10.1)[1] == pytest.approx(0.6)  # 6 rad/s^2


def test_time_stepping_back_holds_the_output() -> None:
    limiter = VelocityLimiter()
    limiter.limit(0.0, 0.0, 5.0)
    before = limiter.limit(0.3, 0.0, 5.1)
    assert limiter.limit(0.3, 0.0, 1.0) == before
    assert limiter.limit(0.3, 0.0, 1.1)[0] == pytest.approx(before[0] + 0.05)


def test_reset_returns_to_rest_and_forgets_the_time() -> None:
    limiter = at_speed(0.3, 1.0)
    limiter.reset()
    assert (limiter.v_m_s, limiter.w_rad_s) == (0.0, 0.0)
    assert limiter.limit(0.3, 1.0, 99.0) == (0.0, 0.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_command_is_rejected(bad: float) -> None:
    limiter = VelocityLimiter()
    with pytest.raises(ValueError, match="non-finite"):
        limiter.limit(bad, 0.0, 0.0)
    with pytest.raises(ValueError, match="non-finite"):
        limiter.limit(0.0, 0.0, bad)


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan])
def test_non_positive_bounds_are_rejected(bad: float) -> None:
    with pytest.raises(ValueError, match="max_decel_m_s2"):
        LimiterConfig(max_decel_m_s2=bad)


def test_ramp_from_rest_to_rest_is_rest() -> None:
    assert ramp(0.0, 0.0, 1.0, 1.0, 1.0) == 0.0


@given(
    commands=st.lists(
        st.tuples(st.floats(-1.0, 1.0), st.floats(-5.0, 5.0), st.floats(0.0, 0.2)),
        min_size=1,
        max_size=40,
    )
)
def test_output_stays_within_speed_and_rate_bounds(
    commands: list[tuple[float, float, float]],
) -> None:
    c = LimiterConfig()
    limiter = VelocityLimiter(c)
    t_s, v_prev, w_prev = 0.0, 0.0, 0.0
    limiter.limit(0.0, 0.0, t_s)
    for v_cmd, w_cmd, dt_s in commands:
        t_s += dt_s
        v, w = limiter.limit(v_cmd, w_cmd, t_s)
        assert abs(v) <= c.max_v_m_s and abs(w) <= c.max_w_rad_s
        assert abs(v - v_prev) <= c.max_decel_m_s2 * dt_s + 1e-12
        assert abs(w - w_prev) <= c.max_alpha_decel_rad_s2 * dt_s + 1e-12
        if abs(v) > abs(v_prev) and v * v_prev >= 0.0:
            assert abs(v) - abs(v_prev) <= c.max_accel_m_s2 * dt_s + 1e-12
        v_prev, w_prev = v, w
