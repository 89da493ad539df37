"""The policy: what is left to navigate by decides whether the robot stops."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from jackson.host.health import HealthConfig, Transition
from jackson.host.health.policy import Policy
from jackson.host.health.states import SensorStates
from jackson.host.health.types import failing
from jackson.host.health.wheel_yaw import WheelYawModel


def _lost(cfg: HealthConfig, *excluded: str, lidar_needed: bool = False) -> str | None:
    states = SensorStates(cfg)
    out: list[Transition] = []
    states.apply([failing(name, 1.0, "broken", exclude=True) for name in excluded], out)
    return Policy(cfg, WheelYawModel(60.0)).lost(states, lidar_needed)


def test_one_sensor_lost_is_a_degraded_mode_and_two_stop_the_robot() -> None:
    cfg = HealthConfig()
    assert _lost(cfg) is None
    assert _lost(cfg, "imu") is None and _lost(cfg, "encoder_right") is None
    assert _lost(cfg, "encoder_left", "encoder_right") == "both encoders excluded: no odometry"
    lost = _lost(cfg, "imu", "encoder_left")
    assert lost is not None and "no yaw rate and no forward speed" in lost


def test_the_configured_policy_can_stop_at_the_first_loss() -> None:
    cfg = replace(HealthConfig(), imu_lost="stop", encoder_lost="stop")
    assert "imu_lost is stop" in str(_lost(cfg, "imu"))
    assert _lost(cfg, "encoder_right") == (
        "the right encoder excluded and health.encoder_lost is stop"
    )


def test_the_lidar_lost_stops_only_a_mission_that_navigates_by_it() -> None:
    cfg = HealthConfig()
    assert _lost(cfg, "lidar") is None
    assert str(_lost(cfg, "lidar", lidar_needed=True)).startswith("the LiDAR excluded (broken)")
    assert _lost(replace(cfg, lidar_lost="continue"), "lidar", lidar_needed=True) is None


def test_the_thresholds_are_scipys_quantiles_to_rounding() -> None:
    from scipy.special import gammaincinv, ndtri

    for p in np.concatenate((np.linspace(0.5001, 0.9999, 200), 1.0 - np.logspace(-4, -12, 30))):
        cfg = HealthConfig(gate_probability=float(p), window_probability=float(p))
        chi2 = 2.0 * float(gammaincinv(0.5, p))
        assert abs(cfg.gate_nis - chi2) <= 5e-14 * chi2
        assert abs(cfg.window_z + float(ndtri(0.5 * (1.0 - p)))) <= 1e-14 * cfg.window_z
