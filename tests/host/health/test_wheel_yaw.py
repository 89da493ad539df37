"""The wheel yaw model: its prior from the configured geometry, and what the driving teaches
it."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from jackson.host.health import HealthConfig, wheel_yaw_prior

from .synthetic import ROBOT, Robot, drive, monitor


def test_the_wheel_yaw_prior_follows_the_configured_uncertainties() -> None:
    """sigma_c0 = sqrt(2 (sigma_r^2 + sigma_C^2)) / B and sigma_s0^2 = sigma_B^2 + sigma_g^2 +
    (sigma_r^2 + sigma_C^2) / 2, the bounds n of them about s = 1, c = 0."""
    cfg = HealthConfig()
    prior = wheel_yaw_prior(cfg, ROBOT)
    var_e = 0.005**2 + 0.009**2
    assert prior.per_metre_sigma == pytest.approx(math.sqrt(2.0 * var_e) / 0.198)
    assert prior.scale_sigma == pytest.approx(math.sqrt(0.05**2 + 0.015**2 + var_e / 2.0))
    assert prior.per_metre_bounds == pytest.approx((-0.294, 0.294), abs=1e-3)
    assert prior.scale_bounds == pytest.approx((0.789, 1.211), abs=1e-3)
    wide = wheel_yaw_prior(replace(cfg, ticks_per_rev_uncertainty=0.02), ROBOT)
    assert wide.per_metre_sigma > prior.per_metre_sigma


def test_a_term_the_driving_does_not_excite_keeps_its_prior() -> None:
    """Pivots say nothing of c, straights nothing of s: each stays at its prior."""
    pivots, robot = monitor(), Robot(41)
    for _ in range(10):
        drive(pivots, robot, 3.0, 0.0, 0.6)
        drive(pivots, robot, 3.0, 0.0, -0.6)
    assert pivots.model.scale_learned and pivots.model.per_metre == 0.0
    straights, robot = monitor(), Robot(42)
    drive(straights, robot, 30.0, 0.2, 0.0)
    assert straights.model.identified == [False, True] and straights.model.scale == 1.0
    assert abs(straights.model.per_metre) < 0.02
    assert pivots.transitions == [] and straights.transitions == []


@pytest.mark.parametrize(("slip_s", "slip"), [(1.0, 1.08), (1.0, 1.05), (2.0, 1.04)])
def test_a_bad_first_seed_neither_locks_the_model_nor_excludes_a_healthy_gyro(
    slip_s: float, slip: float
) -> None:
    """The first straight samples come out of a turn with the right wheel spinning (0.1 rad/s
    of yaw the robot does not make: c = 0.4 rad/m if taken for its geometry). A model that
    takes them (gain 1/n) reads a yaw of c v on every straight after, which the monitor
    takes for a gyro bias step; this robot's true c is 0."""
    mon, robot = monitor(), Robot(40)
    bounds = wheel_yaw_prior(HealthConfig(), ROBOT).per_metre_bounds
    drive(mon, robot, 1.0, 0.0, 0.0)
    drive(mon, robot, 0.5, 0.12, 0.6)  # turning in
    drive(mon, robot, slip_s, 0.25, 0.0, slip=(1.0, slip))  # out of the turn, spinning
    seen = []
    for _ in range(6):
        for v, w, span in ((0.25, 0.0, 4.0), (0.15, 0.4, 2.0)):
            verdicts = drive(mon, robot, span, v, w)
            assert all(x.use_gyro and x.lost is None for x in verdicts)
            seen.append(mon.model.per_metre)
    assert all(bounds[0] <= c <= bounds[1] for c in seen)
    assert abs(seen[-1]) < 0.05 and mon.model.identified[1]  # learned from the healthy data
    assert mon.transitions == [], mon.transitions[:2]


def test_a_model_that_forgets_nothing_keeps_its_prior() -> None:
    mon, robot = monitor(ratio_time_constant_s=0.0), Robot(44)
    drive(mon, robot, 10.0, 0.15, 0.4)
    assert (mon.model.scale, mon.model.per_metre) == (1.0, 0.0)
