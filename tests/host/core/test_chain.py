"""The actuation chain's wheel-speed PI: on external velocity commands by default, never on a
mission's unless ``wheel_pi.enabled`` (the paper's Stage 1-2 robot drove open loop)."""

from __future__ import annotations

import dataclasses

import pytest

from jackson.host.actuation.deadband import wheel_duty
from jackson.host.actuation.kinematics import inverse
from jackson.host.actuation.output import NullOutput
from jackson.host.actuation.wheel_pi import WheelPiConfig
from jackson.host.config import DEFAULT_CONFIG, HostConfig, load_config
from jackson.host.core.chain import ActuationChain
from jackson.host.estimation.odometry import OdometryState

V_M_S = 0.15  # [m/s] the command, reached at once (a steady state: no ramp left)


def _lagging(chain: ActuationChain, t_s: float) -> OdometryState:
    """Both wheels 10 % slower than commanded at the frame before (the loaded twin, open
    loop)."""
    om_l, om_r = chain.wheel_cmd
    return OdometryState(
        t_s=t_s, wheel_velocity_left_rad_s=0.9 * om_l, wheel_velocity_right_rad_s=0.9 * om_r
    )


def _duties(cfg: HostConfig, *, external: bool, frames: int = 40) -> list[tuple[float, float]]:
    chain = ActuationChain(cfg, NullOutput())
    out = []
    for k in range(frames):
        t_s = 0.05 * k
        odo = _lagging(chain, t_s)
        _, _, duties = chain.apply(t_s, V_M_S, 0.0, False, odo, external=external)
        out.append(duties)
    return out


def _feed_forward(cfg: HostConfig) -> float:
    r = cfg.robot
    om_l, _ = inverse(
        V_M_S, 0.0, r.wheel_radius_left_m, r.wheel_radius_right_m, r.wheel_separation_m
    )
    return wheel_duty(om_l, "left", cfg.deadband)


def test_the_shipped_config_closes_the_loop_on_external_commands_only() -> None:
    cfg = load_config(DEFAULT_CONFIG)
    assert cfg.wheel_pi == WheelPiConfig(enabled=False, external=True)
    mission = _duties(cfg, external=False)
    external = _duties(cfg, external=True)
    ff = _feed_forward(cfg)
    # a mission's command: the open-loop feed-forward, as before (once up to speed)
    assert mission[-1][0] == pytest.approx(ff) and mission[-1][1] > 0.0
    # an external one: the PI adds duty while the wheels lag, more and more (its integral)
    assert external[-1][0] > external[20][0] > ff + 0.02


def test_enabled_closes_it_on_missions_too_and_neither_leaves_it_open() -> None:
    cfg = HostConfig()
    on = dataclasses.replace(cfg, wheel_pi=WheelPiConfig(enabled=True))
    assert _duties(on, external=False) == _duties(on, external=True)
    off = dataclasses.replace(cfg, wheel_pi=WheelPiConfig(external=False))
    assert _duties(off, external=True) == _duties(off, external=False)
    assert _duties(off, external=True)[-1][0] == pytest.approx(_feed_forward(cfg))


def test_a_mission_after_external_commands_starts_from_the_feed_forward() -> None:
    # the integrators are reset when the loop opens: nothing of the teleop's correction stays
    cfg = HostConfig()
    chain = ActuationChain(cfg, NullOutput())
    for k in range(40):
        chain.apply(0.05 * k, V_M_S, 0.0, False, _lagging(chain, 0.05 * k), external=True)
    t_s = 2.0
    _, _, duties = chain.apply(t_s, V_M_S, 0.0, False, _lagging(chain, t_s), external=False)
    assert duties[0] == pytest.approx(_feed_forward(cfg))
    assert all(pi.integral == 0.0 for pi in chain.pi or ())


def _still(t_s: float) -> OdometryState:
    return OdometryState(t_s=t_s)


def test_a_command_above_the_limits_reaches_the_wheels_clipped_and_ramped() -> None:
    cfg = HostConfig()
    out = NullOutput()
    chain = ActuationChain(cfg, out)
    limits = cfg.limits
    v1, w1, _ = chain.apply(0.0, 5.0, 9.0, False, _still(0.0))
    v2, w2, _ = chain.apply(0.05, 5.0, 9.0, False, _still(0.05))
    # the first frame starts the ramp, the next grows by at most one period's acceleration
    assert 0.0 <= v1 <= v2 <= limits.max_v_m_s and 0.0 <= w1 <= w2 <= limits.max_w_rad_s
    assert v2 - v1 == pytest.approx(limits.max_accel_m_s2 * 0.05)
    v_end = w_end = 0.0
    for k in range(2, 200):
        v_end, w_end, _ = chain.apply(0.05 * k, 5.0, 9.0, False, _still(0.05 * k))
    assert (v_end, w_end) == (limits.max_v_m_s, limits.max_w_rad_s)
    # what reached the output is the deadband-compensated duty of the limited command
    r = cfg.robot
    om_l, om_r = inverse(
        v_end, w_end, r.wheel_radius_left_m, r.wheel_radius_right_m, r.wheel_separation_m
    )
    assert out.last == (
        wheel_duty(om_l, "left", cfg.deadband),
        wheel_duty(om_r, "right", cfg.deadband),
    )
    assert chain.wheel_cmd == (om_l, om_r) and not chain.braked


def test_a_brake_zeroes_everything_and_the_next_command_ramps_from_rest() -> None:
    chain = ActuationChain(HostConfig(), NullOutput())
    for k in range(40):
        chain.apply(0.05 * k, 0.3, 0.0, False, _still(0.05 * k))
    assert chain.apply(2.0, 0.3, 0.0, True, _still(2.0)) == (0.0, 0.0, (0.0, 0.0))
    assert chain.braked and chain.commanded_still and chain.wheel_cmd == (0.0, 0.0)
    assert chain.output.last == (0.0, 0.0)  # type: ignore[attr-defined]
    v, _, _ = chain.apply(2.05, 0.3, 0.0, False, _still(2.05))
    assert v < 0.3  # the limiter was reset: no jump back to full speed


def test_raw_duties_bypass_the_chain_and_zero_duties_count_as_braked() -> None:
    out = NullOutput()
    chain = ActuationChain(HostConfig(), out)
    assert chain.raw(0.42, -0.37) == (0.42, -0.37) and out.last == (0.42, -0.37)
    assert not chain.braked
    chain.raw(0.0, 0.0)
    assert chain.braked
