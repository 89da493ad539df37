"""The ``health:`` section of the host configuration: every threshold and policy of the checks.

Each field names the check that reads it (:mod:`jackson.host.health`); docs/health.md has the
defaults with their reasons. The chi-square and normal quantiles the tests are drawn at are
computed here once from the two probabilities.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

from jackson.common.robot import LIDAR_RANGE_NOISE_M

POLICIES = ("continue", "stop")


def two_sided_z(probability: float) -> float:
    """The z within which a standard normal falls with ``probability``: ``norm.ppf((1 + p) /
    2)``, from the standard library's :class:`statistics.NormalDist` at the tail ``(1 - p) /
    2``: within 1e-14 of scipy's ``ndtri`` there, and its square within 5e-14 of scipy's
    chi-square(1) quantile, relative, at every probability the config accepts
    (``tests/host/health/test_policy.py``). Not scipy: importing ``scipy.special`` took
    0.3-0.7 s of every command that builds a health monitor (``jackson run square`` included),
    and ``jackson brake`` imports this module through the host's config."""
    return -NormalDist().inv_cdf(0.5 * (1.0 - probability))


@dataclass(frozen=True)
class HealthConfig:
    """The ``health:`` section of the host configuration (each check: :mod:`jackson.host.health`).

    Attributes
    ----------
    enabled : bool
        False: every measurement is fused as in the paper, no zero-velocity updates.
    gyro_noise_rad_s : float
        The gyro's yaw-rate noise, one sigma per frame [rad/s], that the gates are drawn
        around (the EKF's ``r_wz`` is a tuning of the filter and may be set much smaller).
    gate_probability : float
        Per-sample chi-square(1) gate on the wheel/gyro residual.
    window_s : float
        Span of the windowed mean test and of the spike count [s].
    window_probability : float
        Two-sided confidence of the windowed mean test.
    scale_tolerance : float
        kappa: how much a healthy robot's wheel/gyro yaw scale varies (pivots against arcs).
    straight_tolerance_rad_m : float
        kappa_v: how much its yaw per metre driven varies [rad/m].
    creep_tolerance_s : float
        kappa_a: the yaw rate the wheels over-read per (m/s x rad/s^2) while the robot's yaw
        rate changes at speed (the tyres' creep under the traction that turns it) [s].
    ratio_time_constant_s : float
        Forgetting time of the learned wheel yaw model
        (:class:`~jackson.host.health.wheel_yaw.WheelYawModel`) [s]; 0 keeps the prior (s = 1,
        c = 0).
    wheel_radius_uncertainty : float
        sigma_r: how far each wheel's effective rolling radius may be from the configured one
        on a healthy robot, relative, one sigma (tyre wear, load, the measurement) [-].
    ticks_per_rev_uncertainty : float
        sigma_C: the same for each encoder's counts per revolution, relative [-].
    wheel_separation_uncertainty : float
        sigma_B: how far the effective track may be from the configured one, relative (tyre
        scrub makes a turning robot's wheels over-read its yaw by several per cent) [-].
    gyro_scale_uncertainty : float
        sigma_g: the gyro's scale error, relative (the MPU-6050's sensitivity tolerance) [-].
    model_bound_sigmas : float
        The learned s and c stay within this many prior sigmas of the configured geometry
        (:func:`~jackson.host.health.wheel_yaw.wheel_yaw_prior`).
    spikes_to_exclude : int
        Failing samples within ``window_s`` that exclude the IMU.
    imu_silence_s, stuck_s, encoder_stuck_s : float
        Silence and freeze detectors [s].
    driven_wheel_rad_s : float
        A wheel expected to turn faster than this must count [rad/s].
    recover_s : float
        Passing samples needed to leave ``suspect`` or ``excluded`` [s].
    ambiguity_s : float
        How long the yaw rate is held while the wheels and the gyro disagree and the
        accelerometer cannot tell which is wrong; then the gyro is excluded [s].
    recovered_hold_s : float
        ``recovered`` becomes ``ok`` after this [s].
    zupt : bool
        Zero-velocity updates when commanded still.
    zupt_after_s : float
        Standstill needed before the first zero-velocity update [s].
    zupt_variance : float
        R of each zero velocity [(m/s)^2, (rad/s)^2, (m/s^2)^2].
    link_window_s : float
        Span over which the link's frame loss is counted [s].
    link_loss_fraction : float
        The link is ``suspect`` when more than this fraction of the frames in the window were
        lost (by the frames' sequence numbers: lost on the line or dropped as corrupt), and
        ``ok`` again once the fraction is below half of it for ``recover_s``.
    imu_lost, encoder_lost : str
        "continue" (degraded mode) or "stop" (brake and abort the mission).
    lidar_noise_m : float
        The LiDAR's own range noise, one sigma [m] (the A1M8's 0.01 m).
    lidar_rough_factor : float
        A scan whose estimated range noise exceeds this many ``lidar_noise_m`` is rough: the
        LiDAR is ``suspect`` (its scans still used).
    lidar_useless_m : float
        A scan noisier than this [m] is not used; ``lidar_rough_scans`` of them in a row
        exclude the LiDAR.
    lidar_rough_scans : int
        Useless scans in a row that exclude the LiDAR.
    lidar_silence_s : float
        No scan for this long, once scans came, excludes the LiDAR (dead or unplugged) [s];
        sooner while the robot drives (``lidar_blind_m``).
    lidar_blind_m : float
        While a mission navigates at v, no usable scan for ``lidar_blind_m / |v|`` (at least
        :data:`~jackson.host.health.lidar_silence.LIDAR_SILENCE_PERIODS` revolution periods)
        holds the robot, braked, until one comes
        (:attr:`~jackson.host.health.lidar.LidarHealth.blind`): it drives at most this far on
        its last scan [m].
    lidar_garbage_fraction, lidar_garbage_s : float
        More than this fraction of the LiDAR's bytes malformed (check bits or start flags
        wrong) over ``lidar_garbage_s`` makes it ``suspect`` and its scans unused; garbage that
        lasts twice that long excludes it [-, s].
    lidar_window_s, lidar_loss_fraction : float
        More than this fraction of the revolutions missing over the window makes the LiDAR
        ``suspect`` [s, -].
    lidar_lost : str
        "stop" (brake and abort a navigation mission when the LiDAR is excluded) or "continue"
        (navigate on the last costmap: blind to anything new).
    """

    enabled: bool = True
    gyro_noise_rad_s: float = 0.02
    gate_probability: float = 0.999999
    window_s: float = 1.0
    window_probability: float = 0.9999
    scale_tolerance: float = 0.03
    straight_tolerance_rad_m: float = 0.03
    creep_tolerance_s: float = 0.4
    ratio_time_constant_s: float = 60.0
    wheel_radius_uncertainty: float = 0.005
    ticks_per_rev_uncertainty: float = 0.009
    wheel_separation_uncertainty: float = 0.05
    gyro_scale_uncertainty: float = 0.015
    model_bound_sigmas: float = 4.0
    spikes_to_exclude: int = 3
    imu_silence_s: float = 0.25
    stuck_s: float = 0.5
    encoder_stuck_s: float = 0.5
    driven_wheel_rad_s: float = 2.0
    recover_s: float = 2.0
    ambiguity_s: float = 3.0
    recovered_hold_s: float = 10.0
    zupt: bool = True
    zupt_after_s: float = 0.25
    zupt_variance: float = 1.0e-6
    link_window_s: float = 5.0
    link_loss_fraction: float = 0.01
    imu_lost: str = "continue"
    encoder_lost: str = "continue"
    lidar_noise_m: float = LIDAR_RANGE_NOISE_M
    lidar_rough_factor: float = 3.0
    lidar_useless_m: float = 0.10
    lidar_rough_scans: int = 3
    lidar_silence_s: float = 1.0
    lidar_blind_m: float = 0.06
    lidar_garbage_fraction: float = 0.2
    lidar_garbage_s: float = 0.5
    lidar_window_s: float = 5.0
    lidar_loss_fraction: float = 0.1
    lidar_lost: str = "stop"

    def __post_init__(self) -> None:
        for name in ("gate_probability", "window_probability"):
            p = getattr(self, name)
            if not 0.5 < p < 1.0:
                raise ValueError(f"HealthConfig.{name} must be in (0.5, 1), got {p}")
        for name in (
            "gyro_noise_rad_s",
            "window_s",
            "imu_silence_s",
            "stuck_s",
            "encoder_stuck_s",
            "recover_s",
            "ambiguity_s",
            "recovered_hold_s",
            "zupt_variance",
            "link_window_s",
            "lidar_noise_m",
            "lidar_rough_factor",
            "lidar_useless_m",
            "lidar_silence_s",
            "lidar_blind_m",
            "lidar_garbage_s",
            "lidar_window_s",
            "model_bound_sigmas",
        ):
            v = getattr(self, name)
            if not 0.0 < v < math.inf:
                raise ValueError(f"HealthConfig.{name} must be finite and > 0, got {v}")
        for name in (
            "scale_tolerance",
            "straight_tolerance_rad_m",
            "creep_tolerance_s",
            "ratio_time_constant_s",
            "zupt_after_s",
            "wheel_radius_uncertainty",
            "ticks_per_rev_uncertainty",
            "wheel_separation_uncertainty",
            "gyro_scale_uncertainty",
        ):
            v = getattr(self, name)
            if not 0.0 <= v < math.inf:
                raise ValueError(f"HealthConfig.{name} must be finite and >= 0, got {v}")
        if not 0.0 < self.lidar_garbage_fraction < 1.0:
            raise ValueError(
                "HealthConfig.lidar_garbage_fraction must be in (0, 1), got "
                f"{self.lidar_garbage_fraction}"
            )
        if not 0.0 < self.lidar_loss_fraction < 1.0:
            raise ValueError(
                "HealthConfig.lidar_loss_fraction must be in (0, 1), got "
                f"{self.lidar_loss_fraction}"
            )
        if self.lidar_rough_scans < 1:
            raise ValueError(
                f"HealthConfig.lidar_rough_scans must be >= 1, got {self.lidar_rough_scans}"
            )
        if not 0.0 < self.link_loss_fraction < 1.0:
            raise ValueError(
                f"HealthConfig.link_loss_fraction must be in (0, 1), got {self.link_loss_fraction}"
            )
        if self.spikes_to_exclude < 1:
            raise ValueError(
                f"HealthConfig.spikes_to_exclude must be >= 1, got {self.spikes_to_exclude}"
            )
        for name in ("imu_lost", "encoder_lost", "lidar_lost"):
            if getattr(self, name) not in POLICIES:
                raise ValueError(f"HealthConfig.{name} must be one of {POLICIES}")

    @property
    def gyro_variance(self) -> float:
        """R_wz: the gyro's yaw-rate variance the gates are drawn around [(rad/s)^2]."""
        return self.gyro_noise_rad_s**2

    @property
    def gate_nis(self) -> float:
        """The per-sample NIS threshold (chi-square(1) quantile: the square of the two-sided
        normal quantile, :func:`two_sided_z`)."""
        return two_sided_z(self.gate_probability) ** 2

    @property
    def window_z(self) -> float:
        """The windowed test's threshold in standard deviations (two-sided normal quantile)."""
        return two_sided_z(self.window_probability)
