"""Standing still: zero-velocity updates once the robot is commanded still and does not count,
which keep a parked robot's covariance bounded."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from jackson.host.estimation.ekf import PAPER_EKF, Ekf

from .synthetic import DT, Robot, drive, monitor


def test_standing_still_needs_a_still_command_and_no_count() -> None:
    mon, robot = monitor(), Robot(8)
    verdicts = drive(mon, robot, 1.0, 0.0, 0.0)
    first = next(i for i, v in enumerate(verdicts) if v.stationary)
    assert first * DT == pytest.approx(0.25, abs=DT + 1e-9)
    assert not any(v.stationary for v in drive(mon, robot, 1.0, 0.1, 0.0))
    assert not any(v.stationary for v in drive(monitor(zupt=False), Robot(), 1.0, 0.0, 0.0))
    assert mon.counts["zupt"] == sum(v.stationary for v in verdicts)


def test_zero_velocity_updates_keep_a_parked_robots_covariance_bounded() -> None:
    """The paper's filter predicts a parked robot's pose ever more uncertain (0.05 m^2/s);
    with zero-velocity updates its velocity settles at once and its pose variance stops."""

    def park(zupt: Callable[[Ekf, float], None] | None) -> tuple[float, float, float]:
        ekf = Ekf(PAPER_EKF)
        t = 0.0
        for _ in range(100):  # driving at 0.2 m/s, then braking
            t += DT
            ekf.update_wheel(t, 0.2)
            ekf.update_gyro(t, 0.0)
        peak_vx = p_parked = 0.0
        for k in range(round(120.0 / DT)):
            t += DT
            if k == 5:
                p_parked = ekf.P[0, 0]
            if zupt is not None and k >= 5:
                zupt(ekf, t)
            else:
                ekf.update_wheel(t, 0.0)
                ekf.update_gyro(t, 0.0)
            if k * DT > 0.5:
                peak_vx = max(peak_vx, abs(ekf.vx_m_s))
        return p_parked, ekf.P[0, 0], peak_vx

    def zupt(ekf: Ekf, t: float) -> None:
        ekf.stationary = True
        ekf.update_zero_velocity(t, 1e-6)

    p0_paper, p_paper, vx_paper = park(None)
    p0_zupt, p_zupt, vx_zupt = park(zupt)
    assert p_paper - p0_paper > 5.0  # m^2 more after two minutes
    assert p_zupt - p0_zupt < 1e-9 and vx_zupt < 1e-4
    assert vx_paper > vx_zupt
