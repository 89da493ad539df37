"""The values that cross the health monitor's boundary: a frame in, findings between the checks
and the states, a verdict and transitions out.

:class:`HealthInput` is what one telemetry frame tells the monitor; :class:`FrameFacts` what
the monitor knows of it once the IMU's own checks ran; a :class:`Finding` is one check's word on
one sensor; a :class:`Transition` a sensor's change of :class:`Health`; the :class:`Verdict`
what the EKF may use at the frame.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

SENSORS = ("imu", "encoder_left", "encoder_right", "link", "lidar")
ENCODERS = ("encoder_left", "encoder_right")


class Health(enum.Enum):
    """A sensor's health state (:mod:`jackson.host.health.states`)."""

    OK = "ok"
    SUSPECT = "suspect"
    EXCLUDED = "excluded"
    RECOVERED = "recovered"

    @property
    def usable(self) -> bool:
        """Whether the EKF may fuse this sensor (sample by sample, the gate still decides)."""
        return self is not Health.EXCLUDED


@dataclass(frozen=True)
class HealthInput:
    """What one telemetry frame tells the monitor.

    Attributes
    ----------
    t_s : float
        MCU time [s].
    imu_ok : bool
        The frame's IMU_OK flag.
    imu_raw : tuple of int
        The raw accel, gyro and temperature registers (for the freeze test).
    wz_rad_s : float or None
        The gyro's yaw rate less its bias; None while the bias is unknown or the IMU is not ok.
    wheel_rad_s : tuple of float
        Wheel speeds (left, right) over the frame [rad/s].
    ticks : tuple of int
        Counts (left, right) over the frame.
    dt_s : float
        The frame's interval [s] (0 for the first).
    wheel_cmd_rad_s : tuple of float
        Wheel speeds commanded over the frame [rad/s].
    commanded_still : bool
        The motors are braked or commanded to zero.
    accel_y_m_s2 : float or None
        The accelerometer's lateral specific force [m/s^2] (None without a live IMU): the
        third witness when the wheels and the gyro disagree while driving.
    accel_x_m_s2 : float or None
        The accelerometer's forward specific force [m/s^2] (None without a live IMU): a slipping
        wheel makes the wheels' forward speed run away from the robot's, a gyro fault does not.
    """

    t_s: float
    imu_ok: bool
    imu_raw: tuple[int, ...]
    wz_rad_s: float | None
    wheel_rad_s: tuple[float, float]
    ticks: tuple[int, int]
    dt_s: float
    wheel_cmd_rad_s: tuple[float, float]
    commanded_still: bool
    accel_y_m_s2: float | None = None
    accel_x_m_s2: float | None = None


@dataclass(frozen=True)
class FrameFacts:
    """What the monitor knows of a frame once the IMU's own checks (silence, freeze) ran: the
    input and what every later check reads of it.

    Attributes
    ----------
    h : HealthInput
        The frame.
    still : bool
        Standing still: commanded still and no count for ``zupt_after_s``.
    gyro_live : bool
        An IMU sample that is neither missing nor frozen, its bias known.
    trusted_wz : float or None
        The gyro's rate when it is live and its sensor usable [rad/s]; None otherwise.
    wheel_yaw_rad_s : float
        w_e = (r_R omega_R - r_L omega_L) / B: the wheels' own yaw rate [rad/s].
    speed_m_s : float
        v = (r_L omega_L + r_R omega_R) / 2: the wheels' forward speed [m/s].
    yaw_variance : float
        R_wz + sigma_q^2: the gyro's variance and the encoders' quantisation over the frame
        [(rad/s)^2].
    """

    h: HealthInput
    still: bool
    gyro_live: bool
    trusted_wz: float | None
    wheel_yaw_rad_s: float
    speed_m_s: float
    yaw_variance: float


@dataclass(frozen=True)
class ScanInput:
    """One LiDAR revolution as the LiDAR's checks see it.

    Attributes
    ----------
    t_s : float
        The scan's MCU time [s].
    ranges_m : ndarray of float
        Its ranges in the order measured [m]; ``inf`` (or 0) where there was no return.
    angles_rad : ndarray of float or None
        Its angles [rad] (None: not known, taken for a whole turn).
    """

    t_s: float
    ranges_m: npt.NDArray[np.float64]
    angles_rad: npt.NDArray[np.float64] | None = None


@dataclass(frozen=True)
class ByteCount:
    """The LiDAR's bytes read before the frame of MCU time ``t_s``: ``received`` in all,
    ``malformed`` of them skipped by its decoder (check bits or start flags wrong)."""

    t_s: float
    received: int
    malformed: int


@dataclass(frozen=True)
class LidarFrame:
    """A telemetry frame as the LiDAR's silence check sees it.

    Attributes
    ----------
    t_s : float
        MCU time [s].
    speed_m_s : float
        The wheels' forward speed [m/s].
    needed : bool
        A mission navigates by the scans.
    """

    t_s: float
    speed_m_s: float
    needed: bool


@dataclass(frozen=True)
class LinkInput:
    """One telemetry frame received, ``lost`` frames missing before it (by SEQ)."""

    t_s: float
    lost: int


@dataclass(frozen=True)
class Finding:
    """One check's word on one sensor at one instant, applied to the sensor's state in order.

    Attributes
    ----------
    sensor : str
        One of :data:`SENSORS`.
    t_s : float
        When [s] (MCU time).
    passed : bool
        True: the sensor passed the check (a clean sample towards recovery); False: it failed.
    exclude : bool
        A failure that excludes the sensor at once (not only makes it ``suspect``).
    reason : str
        Why it failed, for the log and the operator ('' for a pass).
    """

    sensor: str
    t_s: float
    passed: bool
    exclude: bool = False
    reason: str = ""


def failing(sensor: str, t_s: float, reason: str, *, exclude: bool) -> Finding:
    """A failing :class:`Finding`."""
    return Finding(sensor, t_s, False, exclude, reason)


def passing(sensor: str, t_s: float) -> Finding:
    """A passing :class:`Finding`."""
    return Finding(sensor, t_s, True)


@dataclass(frozen=True)
class Verdict:
    """What the EKF may use at this frame.

    Attributes
    ----------
    use_gyro : bool
        Fuse this gyro sample.
    use_left, use_right : bool
        The encoder may be used.
    stationary : bool
        Zero-velocity update (standing still).
    wheel_yaw_variance : float
        sigma_r^2 of this frame: the variance of the wheels' yaw rate when it replaces the gyro.
    lost : str or None
        Why the policy says stop (None: go on).
    hold_yaw : bool
        The wheels and the gyro disagree and neither can be blamed yet: the gyro is not fused
        (the wheels' yaw rate is, as with the IMU excluded) until it is resolved.
    wheel_yaw_rate_rad_s : float
        The yaw rate the wheels stand for through the learned model, (w_e - c v) / s [rad/s]:
        what the EKF fuses in the gyro's place.
    remeasure_gyro_bias : bool
        The gyro read non-zero standing still: its bias is to be measured again over the next
        standstill.
    """

    use_gyro: bool
    use_left: bool
    use_right: bool
    stationary: bool
    wheel_yaw_variance: float
    lost: str | None
    hold_yaw: bool = False
    wheel_yaw_rate_rad_s: float = 0.0
    remeasure_gyro_bias: bool = False


@dataclass(frozen=True)
class Transition:
    """A sensor's change of state, for the log and the operator."""

    t_s: float
    sensor: str
    old: Health
    new: Health
    reason: str
