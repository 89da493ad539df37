"""The EKF's settings: the ``ekf:`` section of the host configuration and its process noise."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from jackson.host.estimation.ekf.model import STATE_NAMES


def check_threshold(name: str, value: float | None) -> None:
    """Refuse a Mahalanobis gate that is neither None (off) nor finite and > 0."""
    if value is not None and not 0.0 < value < math.inf:
        raise ValueError(f"{name} must be None or finite and > 0, got {value}")


@dataclass(frozen=True)
class ProcessNoise:
    """Diagonal of the EKF's Q per second of prediction; a step of dt adds dt Q.

    The defaults are robot_localization's process_noise_covariance for the planar states
    (dynamic process noise off).

    Attributes
    ----------
    x, y : float
        [m^2 per s].
    yaw : float
        [rad^2 per s].
    vx, vy : float
        [(m/s)^2 per s].
    vyaw : float
        [(rad/s)^2 per s].
    ax : float
        [(m/s^2)^2 per s].
    """

    x: float = 0.05
    y: float = 0.05
    yaw: float = 0.06
    vx: float = 0.025
    vy: float = 0.025
    vyaw: float = 0.02
    ax: float = 0.01

    def __post_init__(self) -> None:
        for name, q in zip(STATE_NAMES, self.diagonal, strict=True):
            if not 0.0 <= q < math.inf:
                raise ValueError(f"ProcessNoise.{name} must be finite and >= 0, got {q}")

    @property
    def diagonal(self) -> tuple[float, ...]:
        """The diagonal in state order [x, y, yaw, vx, vy, vyaw, ax]."""
        return (self.x, self.y, self.yaw, self.vx, self.vy, self.vyaw, self.ax)


DEFAULT_PROCESS_NOISE = ProcessNoise().diagonal


@dataclass(frozen=True)
class EkfConfig:
    """Settings of the EKF (Table 2; robot_localization defaults where the paper is silent).

    It is the ``ekf:`` section of the host configuration (:class:`jackson.host.config.HostConfig`).

    Attributes
    ----------
    frequency_hz : float
        Rate at which the daemon publishes the estimate [Hz] (Table 2: 30 Hz).
    sensor_timeout_s : float
        After this long without a measurement the daemon only predicts [s] (Table 2).
    process_noise : ProcessNoise
        Diagonal of Q per second.
    initial_covariance : float
        Diagonal of the initial P (robot_localization's initial_estimate_covariance, 1e-9).
    r_vx, r_vy : float
        R of the wheel odometry's v_x and v_y [(m/s)^2], Table 2.
    r_wz : float
        R of the IMU's yaw rate [(rad/s)^2], Table 2 (sigma_w = 4e-4 rad/s, Sec. 2.2.4).
    mahalanobis_wheel, mahalanobis_imu : float or None
        Innovation gate n (in standard deviations) for the wheel odometry and the gyro: a
        measurement with d^2 >= n^2 is rejected. None switches the gate off, as in the paper
        (robot_localization's *_rejection_threshold defaults to off).
    gyro_bias_window_s : float
        Start-up standstill over which the daemon estimates the gyro z bias
        (:class:`~jackson.host.estimation.ekf.GyroBiasEstimator`) [s]; 0 switches the estimate off.
    """

    frequency_hz: float = 30.0
    sensor_timeout_s: float = 0.2
    process_noise: ProcessNoise = field(default_factory=ProcessNoise)
    initial_covariance: float = 1e-9
    r_vx: float = 0.01
    r_vy: float = 0.001
    r_wz: float = 0.0004
    mahalanobis_wheel: float | None = None
    mahalanobis_imu: float | None = None
    gyro_bias_window_s: float = 2.0

    def __post_init__(self) -> None:
        for name in ("frequency_hz", "sensor_timeout_s", "initial_covariance", "r_vx", "r_vy"):
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"EkfConfig.{name} must be finite and > 0, got {value}")
        if not 0.0 < self.r_wz < math.inf:
            raise ValueError(f"EkfConfig.r_wz must be finite and > 0, got {self.r_wz}")
        if not 0.0 <= self.gyro_bias_window_s < math.inf:
            raise ValueError(
                f"EkfConfig.gyro_bias_window_s must be finite and >= 0, "
                f"got {self.gyro_bias_window_s}"
            )
        check_threshold("EkfConfig.mahalanobis_wheel", self.mahalanobis_wheel)
        check_threshold("EkfConfig.mahalanobis_imu", self.mahalanobis_imu)
