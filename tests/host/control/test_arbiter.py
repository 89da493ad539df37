"""The command arbiter's rule for a finished mission: its stop is ramped, then braked."""

from __future__ import annotations

import itertools

from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter
from jackson.host.control.arbiter import CommandArbiter, Conditions
from jackson.host.control.base import NavState


class Turning:
    """Drives a curve until told to finish, then stands still (done)."""

    name = "turning"

    def __init__(self) -> None:
        self.done = False

    def command(self, s: NavState) -> tuple[float, float]:
        return (0.0, 0.0) if self.done else (0.08, 0.16)


def conditions(wheel_cmd: tuple[float, float]) -> Conditions:
    return Conditions(
        imu_ok=True,
        bias_known=True,
        counts=(0, 0),
        wheel_cmd=wheel_cmd,
        sensors_lost=None,
        lidar_blind=False,
    )


def state() -> NavState:
    return NavState(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def test_a_done_mission_stops_through_the_limiter_and_brakes_once_still() -> None:
    mission = Turning()
    arbiter = CommandArbiter(0.6, mission, None, sensor_rules=False)
    limiter = VelocityLimiter(LimiterConfig(max_decel_m_s2=0.2, max_alpha_decel_rad_s2=0.8))
    t = 0.0
    wheel = (0.0, 0.0)
    for _ in range(40):  # driving: the limiter reaches the mission's command
        v, w, brake = arbiter.command(t, conditions(wheel), None, lambda _: None, state)
        assert not brake
        v, w = limiter.limit(v, w, t)
        wheel = (v - w, v + w)
        t += 0.05
    assert (v, w) == (0.08, 0.16)
    mission.done = True
    ramp = []
    while True:
        v_cmd, w_cmd, brake = arbiter.command(t, conditions(wheel), None, lambda _: None, state)
        if brake:
            break
        assert (v_cmd, w_cmd) == (0.0, 0.0)  # stop: shaped by the limiter, not braked
        v, w = limiter.limit(v_cmd, w_cmd, t)
        ramp.append((v, w))
        wheel = (v - w, v + w)
        t += 0.05
        assert len(ramp) < 100
    # 0.08 m/s at 0.2 m/s^2: 0.4 s, 8 frames of deceleration (one more for rounding); 0.16
    # rad/s at 0.8 rad/s^2 in 4
    assert 8 <= len(ramp) <= 9
    assert ramp[3][1] < 1e-9 < ramp[2][1]
    assert all(w1 <= w0 for (_, w0), (_, w1) in itertools.pairwise(ramp))
    assert ramp[-1] == (0.0, 0.0)
    # once still it stays braked
    assert arbiter.command(t, conditions((0.0, 0.0)), None, lambda _: None, state)[2]


def test_an_aborted_mission_brakes_at_once() -> None:
    mission = Turning()
    arbiter = CommandArbiter(0.6, mission, None, sensor_rules=False)
    v, w, brake = arbiter.command(0.0, conditions((2.0, 3.0)), "stalled", lambda _: None, state)
    assert (v, w, brake) == (0.0, 0.0, True)
