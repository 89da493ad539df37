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

    The defaults are the consistent profile's (docs/estimation.md): no noise on the position,
    which no measurement corrects, and on the heading only what the gyro's scale error and drift
    add, so that the covariance follows the real error. :data:`PAPER_PROCESS_NOISE` is Table 2's
    (robot_localization's process_noise_covariance for the planar states, dynamic process noise
    off), whose pose terms grow the position's variance to metres on a 4 m course.

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

    x: float = 0.0
    y: float = 0.0
    yaw: float = 2.0e-5
    vx: float = 2.5e-4
    vy: float = 0.025
    vyaw: float = 2.0e-4
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
PAPER_PROCESS_NOISE = ProcessNoise(x=0.05, y=0.05, yaw=0.06, vx=0.025, vy=0.025, vyaw=0.02)
"""Table 2's Q: robot_localization's defaults (the paper's profile, :data:`PAPER_EKF`)."""


@dataclass(frozen=True)
class EkfConfig:
    """Settings of the EKF: Table 2's rates and structure (robot_localization's where the paper
    is silent), with the consistent profile's Q and R by default (:data:`PAPER_EKF`: Table 2's).

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
        R of the wheel odometry's v_x and v_y [(m/s)^2]: 1 cm/s, the size of the wheels'
        7 mm/s quantisation (Table 2: 0.01), and Table 2's 0.001 for the v_y = 0 constraint.
    r_wz : float
        R of the IMU's yaw rate [(rad/s)^2]: 2 mrad/s, with q_vyaw scaled down in the same
        ratio, the gain of Table 2's 4e-4 without the variance the start-up bias window piles
        up before the robot moves (docs/estimation.md).
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
    r_vx: float = 1.0e-4
    r_vy: float = 0.001
    r_wz: float = 4.0e-6
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


PAPER_EKF = EkfConfig(process_noise=PAPER_PROCESS_NOISE, r_vx=0.01, r_wz=0.0004)
"""The paper's EKF (Table 2's Q and R): the profile ``host/config/jackson_bringup.yaml`` and
so the fidelity campaign use, to compare with the paper's figures; its covariance is orders of
magnitude too large (docs/estimation.md)."""
