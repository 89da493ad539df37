"""Sensor health: innovation monitoring, a health state per sensor, and the degraded-mode policy.

The EKF fuses the wheels' forward speed and the gyro's yaw rate (Table 2); neither alone can
tell when it is wrong. :class:`HealthMonitor` watches them against each other and against the
command, per telemetry frame and on MCU time, and says which measurements the EKF may use.

**Cross-check.** The wheels give a yaw rate of their own, w_e = (r_R omega_R - r_L omega_L) / B.
A healthy robot's is w_e = s w_g + c v (:class:`WheelYawModel`, learned while every sensor is
ok: s the scrub of turns, c the yaw per metre of unequal wheels; each a Kalman filter from a
prior the configured geometry and its uncertainties give, :func:`wheel_yaw_prior`). The
residual r = w_e - (s w_g + c v) has the variance

    sigma_r^2 = R_wz + sigma_q^2 + (dw_e / 2)^2 + (kappa_a v alpha)^2 + (kappa w_g)^2
                + (kappa_v v)^2 + P_s w_g^2 + P_c (v - rho w_g)^2

with R_wz the gyro's variance (``gyro_noise_rad_s``^2, not the EKF's tuning), sigma_q^2 the
encoders' quantisation (one count of each wheel over the frame, a triangular error of 1/6
count^2 per wheel), dw_e / 2 the lag of the wheels' frame mean behind the gyro's sample under
angular acceleration, kappa_a v alpha the tyres' creep while the yaw rate changes at speed
(alpha the smaller of the wheels' and the gyro's change of yaw rate over the last 0.25 s, per
second; ``creep_tolerance_s``; one sign through a turn-in, so the windowed test counts its
mean as a model error that does not average down), kappa, kappa_v how much s and c vary on
a healthy robot (``scale_tolerance``, ``straight_tolerance_rad_m``), and P_s, P_c the model's
own variances (:meth:`WheelYawModel.variance`: P_s once s is identified, c's prior variance
with the lever v - rho w_g until c is).

**Tests.** Per frame, the normalised innovation squared NIS = r^2 / sigma_r^2 against the
chi-square(1) quantile of ``gate_probability``: a failing sample is not fused (a spike). Over
the last ``window_s`` the mean residual against its standard deviation, the random part
averaged down and the model's errors not, at the normal quantile of ``window_probability``: a
slow fault (a bias step, a slipping wheel) that no single sample shows. And, without any
model: no ``IMU_OK`` for ``imu_silence_s`` (a dead IMU), raw registers frozen for ``stuck_s``
(a stuck IMU: a live MPU-6050's noise changes its low bits every sample), a gyro that does not
read zero standing still (a bias), and a wheel with no count for ``encoder_stuck_s`` while the
other wheel and the gyro (or, without a gyro, the command) say it turns (a cut encoder wire).

**Isolation.** A dead or stuck IMU, isolated spikes and a disagreement standing still are the
gyro's; a failing sample while one wheel did not count is that wheel's. A lasting disagreement
while driving is a slipping wheel or a gyro bias step; the accelerometer's lateral force
(a_y = v w follows the true yaw rate) is the witness: it sides with the gyro (the wheel that
reads more than the gyro and the other wheel allow is excluded) or with the wheels (the gyro
is). When it cannot decide, the forward speed can (:meth:`HealthMonitor.speed_gap`: a slipping
wheel raises the wheels' speed by half its slip, which the accelerometer's integral does not
follow). When neither can tell them apart the disagreement is ambiguous: both are suspect, the
wheels' yaw stands in for the gyro's, and one that outlasts ``ambiguity_s`` is the gyro's.
docs/health.md has the details and the figures.

**The LiDAR** (:meth:`HealthMonitor.scan`, per revolution): its range noise from the second
differences of neighbouring returns (robust to edges: the median), against ``lidar_noise_m``;
revolutions missing by the scans' spacing; silence. A scan too rough to trust is not used.

**States** per sensor (``imu``, ``encoder_left``, ``encoder_right``, ``lidar``), with
hysteresis:
``ok`` -> ``suspect`` (a failing sample: not fused) -> ``excluded`` (a failing test above: not
fused until it passes again) -> ``recovered`` (``recover_s`` of passing samples after an
exclusion: fused again) -> ``ok`` (``recovered_hold_s`` later). ``suspect`` returns to ``ok``
after ``recover_s`` without a failure.

**Policy** (``imu_lost``, ``encoder_lost``: ``continue`` or ``stop``): with the IMU excluded the
EKF takes the yaw rate from the wheels with its variance sigma_r^2 (honestly larger); with one
encoder excluded, the forward speed from the other wheel and the gyro,
v = r_i omega_i -+ w_g B / 2; with the IMU and an encoder, or both encoders, lost the robot
brakes (the mission is aborted); so does a navigation mission with the LiDAR excluded
(``lidar_lost``), which has nothing left to see obstacles with. **Zero-velocity updates**: when
the robot is commanded still and neither wheel has counted for ``zupt_after_s``, it stands
still: the EKF fuses zero velocities and adds no process noise to the pose, so a parked robot's
covariance stays bounded.
"""

from __future__ import annotations

import enum
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.common.robot import LIDAR_RANGE_NOISE_M
from jackson.common.window import SummedWindow
from jackson.host.estimation.odometry import RobotGeometry
from jackson.protocol.rplidar import A1M8_SCAN_PERIOD_S

POLICIES = ("continue", "stop")
SILENT_TICKS = 3.0  # a wheel expected to make this many counts in a frame and making none
RECOVER_Z_FRACTION = 0.5  # a sensor out of ok passes the windowed test only within half its band
CREEP_MEMORY_S = 0.25  # [s] the creep term's yaw acceleration is the change over this span
SPEED_WITNESS_LEAD_S = 0.5  # [s] the speed witness's reference, before the disagreement was seen
SPEED_WITNESS_FRAMES = 5  # frames averaged for the speed witness's two levels
SPEED_WITNESS_BIAS_S = 1.5  # [s] over which the forward accelerometer's bias is measured
LIDAR_LEARN_SCANS = 20  # the revolution period is learned over the first scans
LIDAR_MIN_TRIPLETS = 30  # neighbouring returns needed to judge a scan's noise
LIDAR_SILENCE_PERIODS = 1.5  # a silence shorter than this many revolutions is the stream's own
# spacing (a revolution every 0.135 s, read at 50 ms frames: gaps of 0.10 and 0.15 s)
# the A1M8's revolution, until the monitor has learned the sensor's own
LIDAR_PERIOD_S = A1M8_SCAN_PERIOD_S
LIDAR_MIN_SPAN_RAD = math.pi  # a revolution covering less than this is not a turn (garbage)
LIDAR_JUNK_TURNS = 3  # that many such revolutions within lidar_garbage_s: garbage on the line
SPIKE_AFTERMATH = 0.25  # a spike ends with a residual below half the gate's (NIS a quarter)
WITNESS_Z = 3.0  # the accelerometer must tell the two hypotheses apart by this many sigma
UNLEARNED_SCALE_TOLERANCE = 0.15  # kappa before s is learned: scrub of up to 15 % in turns
SENSORS = ("imu", "encoder_left", "encoder_right", "link", "lidar")


class Health(enum.Enum):
    """A sensor's health state (module docstring)."""

    OK = "ok"
    SUSPECT = "suspect"
    EXCLUDED = "excluded"
    RECOVERED = "recovered"

    @property
    def usable(self) -> bool:
        """Whether the EKF may fuse this sensor (sample by sample, the gate still decides)."""
        return self is not Health.EXCLUDED


@dataclass(frozen=True)
class HealthConfig:
    """The ``health:`` section of the host configuration (module docstring for each test).

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
        Forgetting time of the learned wheel yaw model (:class:`WheelYawModel`) [s]; 0 keeps
        the prior (s = 1, c = 0).
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
        (:func:`wheel_yaw_prior`).
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
        :data:`LIDAR_SILENCE_PERIODS` revolution periods) holds the robot, braked, until one
        comes (:attr:`HealthMonitor.lidar_blind`): it drives at most this far on its last scan
        [m].
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
    def gate_nis(self) -> float:
        """The per-sample NIS threshold (chi-square(1) quantile)."""
        # scipy.special, not scipy.stats (the same quantile functions without the second of
        # import time), and imported here: `jackson brake` imports this module's config
        # through the host's and must start in well under a second
        from scipy.special import gammaincinv

        return 2.0 * float(gammaincinv(0.5, self.gate_probability))  # chi2(1).ppf

    @property
    def window_z(self) -> float:
        """The windowed test's threshold in standard deviations (two-sided normal quantile)."""
        from scipy.special import ndtri

        return float(ndtri(0.5 + 0.5 * self.window_probability))  # norm.ppf


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
    """

    use_gyro: bool
    use_left: bool
    use_right: bool
    stationary: bool
    wheel_yaw_variance: float
    lost: str | None
    hold_yaw: bool = False


@dataclass(frozen=True)
class Transition:
    """A sensor's change of state, for the log and the operator."""

    t_s: float
    sensor: str
    old: Health
    new: Health
    reason: str


@dataclass(frozen=True)
class WheelYawPrior:
    """What the configured geometry says of the wheel yaw model before any data
    (:func:`wheel_yaw_prior`): s = 1 and c = 0, give or take these sigmas, within these bounds.

    Attributes
    ----------
    scale_sigma : float
        sigma_s0: one sigma of s about 1 [-].
    per_metre_sigma : float
        sigma_c0: one sigma of c about 0 [rad/m].
    scale_bounds : tuple of float
        1 -+ n sigma_s0: the scales a healthy robot can plausibly have [-].
    per_metre_bounds : tuple of float
        -+ n sigma_c0 [rad/m].
    """

    scale_sigma: float
    per_metre_sigma: float
    scale_bounds: tuple[float, float]
    per_metre_bounds: tuple[float, float]


def wheel_yaw_prior(cfg: HealthConfig, robot: RobotGeometry) -> WheelYawPrior:
    """The prior of the wheel yaw model from the configured geometry and its uncertainties.

    Each wheel reads its floor speed u_i as e_i u_i, with e_i = (r_i / r_i,cfg)^-1 (C_i / C_i,cfg)
    (its true rolling radius and counts per revolution against the configured ones), of relative
    sigma sigma_e^2 = sigma_r^2 + sigma_C^2, independently per wheel. With the effective track B'
    (scrub) against the configured B, the gyro's scale g (w_g = g w) and u_R,L = v +- w B' / 2,

        w_e = (e_R u_R - e_L u_L) / B = (e_mean B' / (B g)) w_g + ((e_R - e_L) / B) v

    so s = e_mean B' / (B g) and c = (e_R - e_L) / B, and to first order

        sigma_s0^2 = sigma_B^2 + sigma_g^2 + sigma_e^2 / 2,    sigma_c0^2 = 2 sigma_e^2 / B^2.

    The bounds are ``model_bound_sigmas`` of each sigma about s = 1, c = 0.

    Parameters
    ----------
    cfg : HealthConfig
        ``wheel_radius_uncertainty`` (sigma_r), ``ticks_per_rev_uncertainty`` (sigma_C),
        ``wheel_separation_uncertainty`` (sigma_B), ``gyro_scale_uncertainty`` (sigma_g),
        ``model_bound_sigmas`` (n).
    robot : RobotGeometry
        The configured geometry (B).

    Returns
    -------
    WheelYawPrior
        sigma_s0, sigma_c0 and the bounds.
    """
    var_e = cfg.wheel_radius_uncertainty**2 + cfg.ticks_per_rev_uncertainty**2
    sigma_s = math.sqrt(
        cfg.wheel_separation_uncertainty**2 + cfg.gyro_scale_uncertainty**2 + 0.5 * var_e
    )
    sigma_c = math.sqrt(2.0 * var_e) / robot.wheel_separation_m
    n = cfg.model_bound_sigmas
    return WheelYawPrior(
        scale_sigma=sigma_s,
        per_metre_sigma=sigma_c,
        scale_bounds=(1.0 - n * sigma_s, 1.0 + n * sigma_s),
        per_metre_bounds=(-n * sigma_c, n * sigma_c),
    )


class WheelYawModel:
    """What a healthy robot's wheels say of its yaw rate, learned while all sensors are ok:
    w_e = s w_g + c v.

    c is a yaw the wheels read per metre driven (unequal wheel radii or encoder scales: the
    paper's raw odometry drifts by it), s the scale of the wheels' yaw against the gyro's (tyre
    scrub and creep in turns). Each is a scalar Kalman filter (recursive least squares) started
    at its prior (:func:`wheel_yaw_prior`: s0 = 1, c0 = 0 with variances P0 = sigma_0^2), so the
    first samples move it only by the weight their information has against the prior's:

        K = P h / (h^2 P + R),   theta <- theta + K (y - h theta),   P <- (1 - K h)^2 P + K^2 R

    until the term is identified (below), then the same with K h capped at dt / ``tau_s``: a
    low-pass over ``tau_s`` of driving, which a slow fault (a bias step) cannot move in the
    second the windowed test needs. For c, y = w_e - s w_g, h = v and R = R_0 + P_s w_g^2 (the
    scale's own uncertainty); for s, y = w_e - c v, h = w_g and R = R_0 + P_c v^2, so that an
    arc of curvature kappa informs s with c's error P_c / kappa^2: s is learned from tight
    turns until c is known. R_0 is the sample's noise (:meth:`learn`). Before each sample P
    grows by the forgetting factor 1 / lambda, lambda = 1 - dt / ``tau_s``, never beyond P0.

    **Identifiability.** c is learned only from nearly straight driving (curvature
    |w_g / v| <= 0.3 rad/m and |v| >= 0.1 m/s: there s w_g is small against c v, and its error
    is counted in R), s only from turns (|w_g| > 0.1 rad/s), and either only from steady samples
    (the gyro's rate changed by less than 0.5 rad/s^2: under angular acceleration the tyres
    creep and the wheels' frame mean lags the gyro's sample) whose innovation is within 3 sigma
    of its prediction (h^2 P + R: a slip is not the robot's geometry). A term keeps its prior
    (s = 1 or c = 0, variance P0) until it is identified: at least 20 samples, covering 0.5 rad
    of turn (s) or 2 m of driving (c), that carry 4 times the prior's information
    (sum h^2 / R >= 4 / P0: a posterior sigma under 0.45 of the prior's), so that one transient
    cannot make the model. Each stays within its bounds. A robot that never drives straight
    keeps c = 0 and its s absorbs c v / w (:attr:`absorbed`); learning them apart keeps a gyro
    bias step out of both over the second the windowed test needs.
    """

    IDENTIFY_SAMPLES = 20  # samples a term needs before it leaves its prior ...
    IDENTIFY_SPAN = (0.5, 2.0)  # ... the turn [rad] (s) and the distance [m] (c) they cover ...
    IDENTIFY_INFORMATION = 4.0  # ... and the information they carry, in prior informations
    STRAIGHT_CURVATURE = 0.3  # [rad/m] c is learned below this curvature |w_g / v| ...
    STRAIGHT_SPEED = 0.1  # [m/s] ... and above this speed
    TURN_RATE = 0.1  # [rad/s] s is learned above this gyro rate
    STEADY_ALPHA = 0.5  # [rad/s^2] learned only while the gyro's rate changes less than this
    LEARN_GATE = 3.0  # [sigma] innovations beyond this are not learned

    def __init__(self, tau_s: float, prior: WheelYawPrior | None = None) -> None:
        self.tau_s = tau_s
        if prior is None:
            prior = wheel_yaw_prior(HealthConfig(), RobotGeometry())
        self.prior = p = prior
        self._center = (1.0, 0.0)
        self._p0 = (p.scale_sigma**2, p.per_metre_sigma**2)
        self._bounds = (p.scale_bounds, p.per_metre_bounds)
        self._est = [1.0, 0.0]  # the filters' s and c
        self._var = list(self._p0)  # their variances
        self._info = [0.0, 0.0]  # information of the data learned (forgotten as P is)
        self._n = [0, 0]  # samples learned
        self._cross = 0.0  # sum(w_g v / R) over the scale's samples, forgotten as _info[0]
        self._span = [0.0, 0.0]  # [rad] turned and [m] driven by the samples learned
        self.identified = [False, False]  # s, c have left their priors

    @property
    def scale(self) -> float:
        """s: the filter's once identified, the prior's 1 before."""
        return self._est[0] if self.identified[0] else self._center[0]

    @property
    def per_metre(self) -> float:
        """c [rad/m]: the filter's once identified, the prior's 0 before."""
        return self._est[1] if self.identified[1] else self._center[1]

    @property
    def scale_variance(self) -> float:
        """P_s: the variance of :attr:`scale` (the prior's until identified)."""
        return self._var[0] if self.identified[0] else self._p0[0]

    @property
    def per_metre_variance(self) -> float:
        """P_c [(rad/m)^2]: the variance of :attr:`per_metre` (the prior's until identified)."""
        return self._var[1] if self.identified[1] else self._p0[1]

    @property
    def scale_learned(self) -> bool:
        """s is identified (before, it is the prior 1 +- 0.15 for the gates)."""
        return self.tau_s <= 0.0 or self.identified[0]

    def predict(self, wz: float, v: float) -> float:
        """The wheels' yaw rate a healthy robot shows at gyro rate wz and speed v."""
        return self.scale * wz + self.per_metre * v

    @property
    def absorbed(self) -> float:
        """rho = sum(w_g v / R) / sum(w_g^2 / R) over the scale's samples [m/rad]: while c is
        not identified, s has absorbed rho times c's error (s = sum(w_g y / R) / sum(w_g^2 / R))."""
        return self._cross / self._info[0] if self._info[0] > 0.0 else 0.0

    def variance(self, wz: float, v: float, *, prior: bool = True) -> float:
        """The variance of :meth:`predict` from the model's own uncertainty.

            P_s wz^2 + P_c v^2                       (both identified)
            P_s wz^2 + P0_c (v - rho wz)^2           (c not identified: s took rho dc of its
                                                      error dc; none is left where it learned)

        Parameters
        ----------
        wz, v : float
            The gyro's rate [rad/s] and the forward speed [m/s].
        prior : bool
            Count s, while not identified, by its prior variance (the EKF's stand-in yaw
            rate); False: not at all (the gates, which widen ``scale_tolerance`` to 0.15
            until s is identified).
        """
        p_s = self.scale_variance if prior or self.identified[0] else 0.0
        if self.identified[1]:
            return p_s * wz * wz + self._var[1] * v * v
        lever = v - self.absorbed * wz
        return p_s * wz * wz + self._p0[1] * lever * lever

    def true_rate(self, w_e: float, v: float) -> float:
        """The yaw rate the wheels' w_e stands for: (w_e - c v) / s."""
        return (w_e - self.per_metre * v) / self.scale

    def learn(
        self, w_e: float, wz: float, v: float, dt_s: float, noise_var: float, steady: bool
    ) -> None:
        """One healthy sample (a no-op with ``tau_s`` 0: s = 1, c = 0 stay).

        Parameters
        ----------
        w_e, wz : float
            The wheels' and the gyro's yaw rates [rad/s].
        v : float
            The wheels' forward speed [m/s].
        dt_s : float
            The frame's interval [s].
        noise_var : float
            R_0: the sample's noise variance about the model [(rad/s)^2] (the gyro's and the
            encoders' noise, and how much s and c vary on a healthy robot).
        steady : bool
            The gyro's rate changed by less than ``STEADY_ALPHA`` over the frame.
        """
        if self.tau_s <= 0.0 or not steady or dt_s <= 0.0:
            return
        forget = max(0.0, 1.0 - dt_s / self.tau_s)
        if abs(v) >= self.STRAIGHT_SPEED and abs(wz) <= self.STRAIGHT_CURVATURE * abs(v):
            r = noise_var + self._var[0] * wz * wz
            self._update(1, w_e - self._est[0] * wz, v, r, forget, abs(v) * dt_s)
        elif abs(wz) > self.TURN_RATE:
            r = noise_var + self._var[1] * v * v
            if self._update(0, w_e - self._est[1] * v, wz, r, forget, abs(wz) * dt_s):
                self._cross = forget * self._cross + wz * v / r

    def _update(self, i: int, y: float, h: float, r: float, forget: float, span: float) -> bool:
        """The scalar Kalman update of term i (0: s, 1: c) by y = h theta_i + noise(r), the
        sample covering ``span`` (rad turned or m driven); whether it was learned."""
        p0 = self._p0[i]
        p = min(self._var[i] / forget, p0) if forget > 0.0 else p0
        innovation = y - h * self._est[i]
        predicted = h * h * p + r
        if innovation * innovation > self.LEARN_GATE**2 * predicted:
            return False  # a slip or a transient: not the robot's geometry
        gain = p * h / predicted
        if self.identified[i]:
            # from then on a low-pass over tau_s: a slow fault must not be learned in seconds
            gain = math.copysign(min(abs(gain), (1.0 - forget) / abs(h)), gain)
        lo, hi = self._bounds[i]
        self._est[i] = min(hi, max(lo, self._est[i] + gain * innovation))
        self._var[i] = (1.0 - gain * h) ** 2 * p + gain * gain * r  # Joseph: any gain
        self._info[i] = forget * self._info[i] + h * h / r
        self._n[i] += 1
        self._span[i] += span
        if (
            not self.identified[i]
            and self._n[i] >= self.IDENTIFY_SAMPLES
            and self._span[i] >= self.IDENTIFY_SPAN[i]
            and self._info[i] * p0 >= self.IDENTIFY_INFORMATION
        ):
            self.identified[i] = True
        return True


class _SensorState:
    """One sensor's state machine (module docstring)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.state = Health.OK
        self.since_s = 0.0  # when the current state began
        self.clean_since_s: float | None = None  # first passing sample of the current clean run
        self.reason = ""

    def fail(self, t_s: float, exclude: bool, reason: str, out: list[Transition]) -> None:
        self.clean_since_s = None
        new = Health.EXCLUDED if exclude else Health.SUSPECT
        if self.state is Health.EXCLUDED or self.state is new:
            return
        self._go(t_s, new, reason, out)

    def pass_(self, t_s: float, cfg: HealthConfig, out: list[Transition]) -> None:
        if self.clean_since_s is None:
            self.clean_since_s = t_s
        clean = t_s - self.clean_since_s
        if self.state is Health.EXCLUDED and clean >= cfg.recover_s - 1e-9:
            self._go(t_s, Health.RECOVERED, f"passed its tests for {clean:.1f} s", out)
        elif self.state is Health.SUSPECT and clean >= cfg.recover_s - 1e-9:
            self._go(t_s, Health.OK, f"passed its tests for {clean:.1f} s", out)
        elif self.state is Health.RECOVERED and t_s - self.since_s >= cfg.recovered_hold_s - 1e-9:
            self._go(t_s, Health.OK, f"{cfg.recovered_hold_s:.0f} s since it recovered", out)

    def _go(self, t_s: float, new: Health, reason: str, out: list[Transition]) -> None:
        out.append(Transition(t_s, self.name, self.state, new, reason))
        self.state, self.since_s, self.reason = new, t_s, reason


TRANSITIONS_KEPT = 1000  # the newest health transitions a monitor keeps (a daemon runs for days)


class Recent(list):  # type: ignore[type-arg]
    """A list that keeps only its newest ``maxlen`` items (appended or added with ``+=``); it
    compares, indexes and pickles as a list."""

    maxlen = TRANSITIONS_KEPT  # until __init__ (or unpickling) sets the instance's own

    def __init__(self, maxlen: int) -> None:
        super().__init__()
        self.maxlen = maxlen

    def _trim(self) -> None:
        if len(self) > self.maxlen:
            del self[: len(self) - self.maxlen]

    def append(self, item: object) -> None:
        super().append(item)
        self._trim()

    def __iadd__(self, items: object) -> Recent:  # type: ignore[misc]
        super().__iadd__(items)  # type: ignore[arg-type]
        self._trim()
        return self


class HealthMonitor:
    """The health of the IMU and the two encoders, per telemetry frame (module docstring).

    Parameters
    ----------
    cfg : HealthConfig
        Thresholds and policy.
    robot : RobotGeometry
        Wheel radii, separation and counts per revolution the host believes.

    Attributes
    ----------
    sensors : dict of str to Health
        Each sensor's state now.
    transitions : list of Transition
        Every change so far, in order.
    nis : dict of str to float
        The last NIS per test ("yaw_rate": per sample, "window": the windowed mean's squared
        z score).
    counts : dict of str to int
        Failing samples, exclusions and zero-velocity updates so far.
    """

    def __init__(self, cfg: HealthConfig, robot: RobotGeometry) -> None:
        self.cfg = cfg
        self.robot = robot
        self.gyro_variance = cfg.gyro_noise_rad_s**2
        self._gate = cfg.gate_nis
        self._z = cfg.window_z
        self._s = {name: _SensorState(name) for name in SENSORS}
        self.transitions: list[Transition] = Recent(TRANSITIONS_KEPT)
        self.nis = {"yaw_rate": 0.0, "window": 0.0}
        self.counts = {"gated": 0, "excluded": 0, "zupt": 0}
        self._imu_ok_s: float | None = None
        self._raw: tuple[int, ...] | None = None
        self._raw_since_s = 0.0
        self._moved_s = [0.0, 0.0]
        self._still_since_s: float | None = None
        # (t, res, var, om_l, om_r, wz, v); the windowed test's sums kept exactly as samples
        # come and go (the same sums as math.fsum's, without re-summing the window each frame):
        # res, |wz|, |v|, var, wz, v
        self._window: SummedWindow[tuple[float, float, float, float, float, float, float]] = (
            SummedWindow(((1, False), (5, True), (6, True), (2, False), (5, False), (6, False)))
        )
        self._window_creep: SummedWindow[tuple[float, float]] = SummedWindow(
            ((1, False),)
        )  # (t, kappa_a v alpha)
        self._still: deque[tuple[float, float]] = deque()
        self._link: deque[tuple[float, int]] = deque()
        self._link_missing = 0  # the sum of the window's lost counts
        self.remeasure_bias = False  # the gyro read non-zero standing still: measure its bias
        # failing samples of the last window: (t, res, var, om_l, om_r, wz, v)
        self._fails: deque[tuple[float, float, float, float, float, float, float]] = deque()
        self._run: list[
            tuple[float, float, float, float, float, float, float]
        ] = []  # failing in a row
        self._run_nis = 0.0
        self._prev_we: float | None = None
        # (t, a_y, v, w_g, w_e, ticks_l, ticks_r) of the last 3 windows, for the witness
        self._hist: deque[tuple[float, float, float, float, float, int, int, float]] = deque()
        self.model = WheelYawModel(cfg.ratio_time_constant_s, wheel_yaw_prior(cfg, robot))
        self._prev_wz: float | None = None  # the gyro's last live rate (for steadiness)
        # (t, w_e, w_g) over the last CREEP_MEMORY_S: the yaw acceleration, for the creep term
        self._alpha: deque[tuple[float, float, float]] = deque()
        self._window_judged = False  # the windowed test ran on the last sample
        self._ambiguous_since: float | None = None  # wheels and gyro disagree, nobody to blame
        self._calm_since: float | None = None  # the disagreement has been gone since
        self._ambiguous_size = 0.0  # [rad/s] the disagreement that began the ambiguity
        self._window_mean = 0.0  # [rad/s] the last windowed mean residual
        self._imu_disagreement = 0.0  # [rad/s] the disagreement that excluded the IMU
        self._last_charge_mean = 0.0
        self._t0: float | None = None
        # the LiDAR
        self.lidar_needed = False  # a mission navigates by the scans (set by the core)
        self.lidar_roughness_m = 0.0  # [m] the last scan's estimated range noise
        self.lidar_missing = 0.0  # fraction of revolutions missing over the last window
        self.lidar_counts = {"scans": 0, "unused": 0}
        self._lidar_last_s: float | None = None
        self._lidar_first_s: float | None = None
        self._lidar_window_from = 0.0  # the spacing's window is full from here + window
        self._lidar_period_s: float | None = None  # learned over the first scans
        self._lidar_times: deque[float] = deque()
        self._lidar_useless = 0  # useless scans in a row
        self._lidar_bytes: deque[tuple[float, int, int]] = deque()  # (t, bytes, malformed)
        self._lidar_garbage_since: float | None = None  # garbage on the line since
        self._lidar_junk: deque[float] = deque()  # when revolutions that are not a turn came
        self._lidar_used_s: float | None = None  # the last scan that could be used
        self.lidar_blind = False  # navigating without a usable scan too long: hold the robot
        self._speed_m_s = 0.0  # the wheels' forward speed at the last frame

    @property
    def sensors(self) -> dict[str, Health]:
        return {name: s.state for name, s in self._s.items()}

    def state(self, sensor: str) -> Health:
        """The state of ``imu``, ``encoder_left`` or ``encoder_right``."""
        return self._s[sensor].state

    def reason(self, sensor: str) -> str:
        """Why the sensor entered its current state ('' while it never left ``ok``)."""
        return self._s[sensor].reason

    @property
    def ratio(self) -> float:
        """The learned wheel/gyro yaw-rate scale s."""
        return self.model.scale

    def _quantisation_variance(self, dt_s: float) -> float:
        r = self.robot
        if dt_s <= 0.0:
            return 0.0
        per_count = [
            r.wheel_radius_left_m * 2.0 * math.pi / r.ticks_per_rev_left,
            r.wheel_radius_right_m * 2.0 * math.pi / r.ticks_per_rev_right,
        ]
        return sum((c / (r.wheel_separation_m * dt_s)) ** 2 / 6.0 for c in per_count)

    def update(self, h: HealthInput) -> Verdict:
        """Judge one frame; the new transitions are appended to :attr:`transitions`."""
        cfg = self.cfg
        out: list[Transition] = []
        t = h.t_s
        if self._t0 is None:
            self._t0 = self._imu_ok_s = self._raw_since_s = t
            self._moved_s = [t, t]
        imu = self._s["imu"]
        enc = (self._s["encoder_left"], self._s["encoder_right"])
        om_l, om_r = h.wheel_rad_s
        w_e = self._wheel_yaw_rate(om_l, om_r)
        wz = h.wz_rad_s

        # standstill: commanded still and no count for zupt_after_s
        if h.commanded_still and h.ticks == (0, 0):
            if self._still_since_s is None:
                self._still_since_s = t
        else:
            self._still_since_s = None
        still = self._still_since_s is not None and t - self._still_since_s >= cfg.zupt_after_s
        stationary = cfg.zupt and still

        # the IMU without a model: dead, frozen
        imu_frozen = False
        if h.imu_ok:
            self._imu_ok_s = t
            if h.imu_raw != self._raw:
                self._raw, self._raw_since_s = h.imu_raw, t
            imu_frozen = t - self._raw_since_s >= cfg.stuck_s - 1e-9
            if imu_frozen:
                imu.fail(
                    t, True, f"registers frozen for {t - self._raw_since_s:.2f} s (stuck)", out
                )
        else:
            self._raw, self._raw_since_s = None, t
            assert self._imu_ok_s is not None
            if t - self._imu_ok_s >= cfg.imu_silence_s - 1e-9:
                imu.fail(t, True, f"no IMU_OK for {t - self._imu_ok_s:.2f} s (dead)", out)
        gyro_live = h.imu_ok and not imu_frozen and wz is not None
        prev_we, self._prev_we = self._prev_we, (w_e if h.dt_s > 0.0 else None)
        prev_wz, self._prev_wz = self._prev_wz, (wz if gyro_live else None)
        trusted_wz = wz if gyro_live and imu.state.usable else None

        # the encoders without the cross-check: a wheel that must turn but does not count
        for i in range(2):
            expected = self._expected_wheel(i, h, trusted_wz)
            tpr = (self.robot.ticks_per_rev_left, self.robot.ticks_per_rev_right)[i]
            expected_ticks = abs(expected) * h.dt_s * tpr / (2.0 * math.pi)
            driven = abs(expected) > cfg.driven_wheel_rad_s or expected_ticks >= SILENT_TICKS
            if trusted_wz is None and h.ticks[1 - i] == 0:
                # judged by the command alone, two silent wheels are a drive that does not
                # move (the interlock, a stall, the motor supply), not two cut encoders
                driven = False
            if h.ticks[i] != 0 or not driven:
                self._moved_s[i] = t
            elif t - self._moved_s[i] >= cfg.encoder_stuck_s - 1e-9:
                why = (
                    f"no count for {t - self._moved_s[i]:.2f} s while the wheel should turn at "
                    f"{expected:+.1f} rad/s (stuck or cut)"
                )
                enc[i].fail(t, True, why, out)

        var = self.gyro_variance + self._quantisation_variance(h.dt_s)
        charged: set[str] = set()
        skip = [False, False]  # a wheel's sample not to fuse at this frame
        spike = False
        # standing still, the gyro must read zero: its bias is checked (and measured again)
        self.remeasure_bias = False
        if gyro_live and still and wz is not None:
            self._still.append((t, wz))
            while self._still and self._still[0][0] <= t - cfg.window_s + 1e-9:
                self._still.popleft()
            n = len(self._still)
            if n >= 5 and self._still[-1][0] - self._still[0][0] >= 0.45 * cfg.window_s:
                mean = math.fsum(x[1] for x in self._still) / n
                if mean * mean / (self.gyro_variance / n) >= self._z**2:
                    imu.fail(t, True, f"reads {mean:+.4f} rad/s standing still (bias)", out)
                    charged.add("imu")
                    self.remeasure_bias = True
                    self._still.clear()
        else:
            self._still.clear()

        # the cross-check, when the gyro and both wheels are live
        wheels_live = all(e.state.usable for e in enc) and h.dt_s > 0.0
        if (
            gyro_live
            and h.dt_s > 0.0
            and wz is not None
            and h.accel_y_m_s2 is not None
            and h.accel_x_m_s2 is not None
        ):
            v = 0.5 * (
                self.robot.wheel_radius_left_m * om_l + self.robot.wheel_radius_right_m * om_r
            )
            self._hist.append(
                (t, h.accel_y_m_s2, v, wz, w_e, h.ticks[0], h.ticks[1], h.accel_x_m_s2)
            )
            keep = 3.0 * cfg.window_s + cfg.ambiguity_s  # the witnesses' reach back
            while self._hist and self._hist[0][0] <= t - keep:
                self._hist.popleft()
        v_now = 0.5 * (
            self.robot.wheel_radius_left_m * om_l + self.robot.wheel_radius_right_m * om_r
        )
        if gyro_live and wheels_live and wz is not None and not still:
            # the wheels' rate is the frame's mean, the gyro's a sample: under angular
            # acceleration they differ by up to half the change over the frame (the wheels'
            # change: a gyro spike must not widen its own gate)
            lag = 0.5 * (w_e - prev_we) if prev_we is not None else 0.0
            # the tyres creep while the yaw rate changes at speed: alpha is the smaller of the
            # wheels' and the gyro's change over the last CREEP_MEMORY_S (a fault in one of
            # them does not widen its own gate; the span keeps their noise out of it, and
            # the creep outlasts the push a little)
            self._alpha.append((t, w_e, wz))
            while self._alpha and self._alpha[0][0] < t - CREEP_MEMORY_S - 1e-9:
                self._alpha.popleft()
            t_a, we_a, wz_a = self._alpha[0]
            alpha = 0.0
            if t - t_a > 0.5 * CREEP_MEMORY_S:
                alpha = min(abs(w_e - we_a), abs(wz - wz_a)) / (t - t_a)
            creep = cfg.creep_tolerance_s * abs(v_now) * alpha
            lag2 = lag * lag + creep * creep
            var_r = (
                var
                + lag2
                + (self._kappa() * abs(wz)) ** 2
                + (cfg.straight_tolerance_rad_m * v_now) ** 2
                + self.model.variance(wz, v_now, prior=False)
            )
            res = w_e - self.model.predict(wz, v_now)
            nis = res * res / var_r
            self.nis["yaw_rate"] = nis
            spike = nis >= self._gate
            while self._fails and self._fails[0][0] <= t - cfg.window_s + 1e-9:
                self._fails.popleft()
            silent = [
                i
                for i in range(2)
                if h.ticks[i] == 0 and self._expected_ticks(i, h, wz) >= SILENT_TICKS
            ]
            if spike and len(silent) == 1:  # a wheel that should turn and did not count
                i = silent[0]
                enc[i].fail(t, False, f"yaw-rate NIS {nis:.1f}: the wheel did not count", out)
                charged.add(enc[i].name)
                skip[i] = True
                spike = False
            elif spike:
                self.counts["gated"] += 1
                self._fails.append((t, res, var_r, om_l, om_r, wz, v_now))
                self._run.append((t, res, var_r, om_l, om_r, wz, v_now))
                self._run_nis = nis
                if len(self._run) >= cfg.spikes_to_exclude:
                    # failing frame after frame: not spikes but a persistent disagreement
                    mean = math.fsum(x[1] for x in self._run) / len(self._run)
                    span = self._run[-1][0] - self._run[0][0] + h.dt_s
                    charged |= self._charge(t, list(self._run), mean, span, out)
                    self._run.clear()
                    self._fails.clear()
                else:
                    charged.add("imu")  # not fused; judged when the run of failures ends
            fails = list(self._fails)
            if (
                not spike
                and self._run
                and len(fails) >= cfg.spikes_to_exclude
                and (all(x[1] > 0.0 for x in fails) or all(x[1] < 0.0 for x in fails))
            ):
                # failing often, and always the same way: a disagreement that the frames'
                # quantisation lets through now and then (a slow slip), not spikes
                mean = math.fsum(x[1] for x in fails) / len(fails)
                span = fails[-1][0] - fails[0][0] + h.dt_s
                charged |= self._charge(t, fails, mean, span, out)
                self._run.clear()
                self._fails.clear()
            if not spike and self._run and nis >= SPIKE_AFTERMATH * self._gate:
                # the residual is still large after the failing samples: not a spike but the
                # onset of a disagreement that only just passes now (the failing samples stay
                # in the window's count, and were not fused)
                self._run.clear()
            if not spike and self._run:  # a run shorter than a persistent one: spikes
                exclude = len(self._fails) >= cfg.spikes_to_exclude
                why = (
                    f"{len(self._fails)} yaw-rate samples beyond the gate in "
                    f"{cfg.window_s:.1f} s (spikes)"
                    if exclude
                    else f"yaw-rate NIS {self._run_nis:.1f} beyond the gate {self._gate:.1f} "
                    "(a spike)"
                )
                imu.fail(self._run[-1][0], exclude, why, out)
                charged.add("imu")
                self._run.clear()
            if not spike and not any(skip) and not charged:
                self._window.append((t, res, var + lag * lag, om_l, om_r, wz, v_now))
                self._window_creep.append((t, creep))
                while self._window and self._window[0][0] <= t - cfg.window_s + 1e-9:
                    self._window.popleft()
                while self._window_creep and self._window_creep[0][0] <= t - cfg.window_s + 1e-9:
                    self._window_creep.popleft()
                charged |= self._window_test(t, out)
                # learned only from a robot healthy for a while: a slow fault must not be
                # learned as the robot's geometry between two alarms
                quiet = not self.transitions or t - self.transitions[-1].t_s >= cfg.recovered_hold_s
                healthy = quiet and all(x.state is Health.OK for x in self._s.values())
                judged = self._window_judged  # a sample the windowed test could not judge yet
                if not charged and healthy and judged and self._ambiguous_since is None:
                    steady = (
                        prev_wz is not None
                        and abs(wz - prev_wz) <= WheelYawModel.STEADY_ALPHA * h.dt_s
                    )
                    noise = (
                        var
                        + lag2
                        + (cfg.scale_tolerance * wz) ** 2
                        + (cfg.straight_tolerance_rad_m * v_now) ** 2
                    )
                    known = list(self.model.identified)
                    self.model.learn(w_e, wz, v_now, h.dt_s, noise, steady)
                    if self.model.identified != known:
                        # the window's residuals were the prior's, its variance now the
                        # posterior's: judge the identified model on residuals of its own
                        self._window.clear()
                        self._window_creep.clear()
        elif not gyro_live or not wheels_live:
            self._window.clear()
            self._window_creep.clear()

        # passes: a sensor whose tests ran and passed this frame
        # (an excluded IMU only where a test could check it: the wheels live, or standing still)
        imu_passed = gyro_live and "imu" not in charged and not spike
        if imu.state is not Health.OK and self.nis["window"] >= (RECOVER_Z_FRACTION * self._z) ** 2:
            imu_passed = False  # hysteresis: back in only well inside the band
        if imu.state is not Health.EXCLUDED:
            self._imu_disagreement = 0.0
        elif abs(self._window_mean) >= 0.5 * self._imu_disagreement > 0.0:
            imu_passed = False  # and only once the disagreement that excluded it has gone
        if imu_passed and (imu.state is not Health.EXCLUDED or wheels_live or still):
            imu.pass_(t, cfg, out)
        for i, e in enumerate(enc):
            if self._moved_s[i] != t or e.name in charged:
                continue
            if e.state is Health.EXCLUDED:
                if h.ticks[i] != 0 and self._wheel_agrees(i, h, trusted_wz):
                    e.pass_(t, cfg, out)
            else:
                e.pass_(t, cfg, out)

        r = self.robot
        self._speed_m_s = 0.5 * (
            r.wheel_radius_left_m * h.wheel_rad_s[0] + r.wheel_radius_right_m * h.wheel_rad_s[1]
        )
        self._lidar_silence(t, out)
        hold = self._ambiguous_since is not None and imu.state is not Health.EXCLUDED
        self.transitions += out
        self.counts["excluded"] += sum(1 for x in out if x.new is Health.EXCLUDED)
        if stationary:
            self.counts["zupt"] += 1
        return Verdict(
            use_gyro=gyro_live and not spike and imu.state.usable and not hold,
            use_left=enc[0].state.usable and not skip[0],
            use_right=enc[1].state.usable and not skip[1],
            stationary=bool(stationary),
            wheel_yaw_variance=var
            + (cfg.scale_tolerance * abs(w_e)) ** 2
            + (cfg.straight_tolerance_rad_m * v_now) ** 2
            + self.model.variance(w_e, v_now),
            lost=self._lost(),
            hold_yaw=hold,
        )

    def lidar_bytes(self, t_s: float, received: int, malformed: int) -> None:
        """The LiDAR's bytes read before the frame of MCU time ``t_s``: ``received`` in all,
        ``malformed`` of them skipped by its decoder (check bits or start flags wrong).

        More than ``lidar_garbage_fraction`` malformed over ``lidar_garbage_s`` makes the LiDAR
        ``suspect`` (its scans unused); garbage that lasts twice as long excludes it.
        """
        cfg, st = self.cfg, self._s["lidar"]
        window = self._lidar_bytes
        window.append((t_s, received, malformed))
        while window and window[0][0] <= t_s - cfg.lidar_garbage_s + 1e-9:
            window.popleft()
        total = sum(b for _, b, _ in window)
        bad = sum(m for _, _, m in window)
        out: list[Transition] = []
        junk = self._lidar_junk
        while junk and junk[0] <= t_s - cfg.lidar_garbage_s + 1e-9:
            junk.popleft()
        # garbage: too many bytes failing the node checks, or "revolutions" decoded from random
        # bytes that pass them (a real sensor sends none that cover less than half a turn)
        many_junk = len(junk) >= LIDAR_JUNK_TURNS
        if (total >= 50 and bad > cfg.lidar_garbage_fraction * total) or many_junk:
            if self._lidar_garbage_since is None:
                self._lidar_garbage_since = t_s
            if self.lidar_needed:
                self.lidar_blind = True  # its scans cannot be trusted: hold until clean ones come
            lasted = t_s - self._lidar_garbage_since
            exclude = lasted >= cfg.lidar_garbage_s - 1e-9
            why = (
                f"{bad} of its {total} bytes malformed and {len(junk)} revolutions that are not "
                f"a turn in {cfg.lidar_garbage_s:g} s: garbage on the line (a loose cable, another "
                "baud rate, another device?)"
            )
            st.fail(t_s, exclude, why, out)
        elif not junk and (total < 50 or bad <= 0.5 * cfg.lidar_garbage_fraction * total):
            self._lidar_garbage_since = None
        self.transitions += out
        self.counts["excluded"] += sum(1 for x in out if x.new is Health.EXCLUDED)

    def scan(
        self,
        t_s: float,
        ranges_m: npt.NDArray[np.float64],
        angles_rad: npt.NDArray[np.float64] | None = None,
    ) -> bool:
        """Judge one LiDAR revolution; whether the scan may be used (mapping, localisation,
        the costmaps). New transitions are appended to :attr:`transitions`.

        Parameters
        ----------
        t_s : float
            The scan's MCU time [s].
        ranges_m : ndarray of float
            Its ranges in the order measured [m]; ``inf`` (or 0) where there was no return.

        angles_rad : ndarray of float or None
            Its angles [rad]: a revolution spanning less than half a turn is not a turn
            (decoded garbage) and is not used.

        Returns
        -------
        bool
            False for a scan too noisy to trust or not a turn, while garbage arrives, and
            while the LiDAR is excluded.
        """
        cfg, st = self.cfg, self._s["lidar"]
        out: list[Transition] = []
        if angles_rad is not None and len(angles_rad) > 1:
            a = np.mod(np.asarray(angles_rad, dtype=float), 2.0 * math.pi)
            gaps = np.diff(np.sort(a))
            span = 2.0 * math.pi - max(float(gaps.max()), 2.0 * math.pi - float(a.max() - a.min()))
            if span < LIDAR_MIN_SPAN_RAD:
                self._lidar_junk.append(t_s)
                self.lidar_counts["unused"] += 1
                why = f"a revolution spanning {math.degrees(span):.0f} deg: not a turn"
                st.fail(t_s, False, why, out)
                self.transitions += out
                return False
        self.lidar_counts["scans"] += 1
        # spacing: revolutions the window should hold against those that came
        if self._lidar_first_s is None:
            self._lidar_first_s = self._lidar_window_from = t_s
        last = self._lidar_last_s
        if last is not None and t_s - last >= cfg.lidar_silence_s - 1e-9:
            # back after a silence (judged by itself): the spacing is counted afresh
            self._lidar_times.clear()
            self._lidar_window_from = t_s
        n = self.lidar_counts["scans"]
        if self._lidar_period_s is None and n > LIDAR_LEARN_SCANS:
            self._lidar_period_s = (t_s - self._lidar_first_s) / (n - 1)
        self._lidar_last_s = t_s
        self._lidar_times.append(t_s)
        while self._lidar_times and self._lidar_times[0] <= t_s - cfg.lidar_window_s + 1e-9:
            self._lidar_times.popleft()
        period = self._lidar_period_s
        spacing_ok = True
        full = t_s - self._lidar_window_from >= cfg.lidar_window_s - 1e-9
        if period is not None and period > 0.0 and full:
            expected = cfg.lidar_window_s / period
            self.lidar_missing = max(0.0, 1.0 - len(self._lidar_times) / expected)
            if self.lidar_missing > cfg.lidar_loss_fraction:
                got = len(self._lidar_times)
                why = (
                    f"{got} revolutions in {cfg.lidar_window_s:.0f} s where {expected:.0f} were "
                    f"due ({self.lidar_missing:.0%} lost)"
                )
                st.fail(t_s, False, why, out)
                spacing_ok = False
            elif self.lidar_missing > 0.5 * cfg.lidar_loss_fraction:
                spacing_ok = False  # hysteresis: back only well inside
        # roughness: the second differences of neighbouring returns; a smooth surface's are
        # nil at this spacing, white noise's have 6 sigma^2; edges are outliers (the median)
        r = np.asarray(ranges_m, dtype=float)
        ok = np.isfinite(r) & (r > 0.0)
        r = np.where(ok, r, 0.0)
        both = ok[:-2] & ok[1:-1] & ok[2:]
        use = True
        smooth = True
        if int(np.count_nonzero(both)) >= LIDAR_MIN_TRIPLETS:
            d2 = (r[:-2] - 2.0 * r[1:-1] + r[2:])[both]
            sigma = float(1.4826 * np.median(np.abs(d2)) / math.sqrt(6.0))
            self.lidar_roughness_m = sigma
            if sigma > cfg.lidar_useless_m:
                self._lidar_useless += 1
                why = f"range noise {sigma * 100:.1f} cm: beyond {cfg.lidar_useless_m * 100:.0f} cm"
                exclude = self._lidar_useless >= cfg.lidar_rough_scans
                st.fail(t_s, exclude, why + (" scan after scan" if exclude else ""), out)
                use = smooth = False
            else:
                self._lidar_useless = 0
                if sigma > cfg.lidar_rough_factor * cfg.lidar_noise_m:
                    why = (
                        f"range noise {sigma * 100:.1f} cm: beyond {cfg.lidar_rough_factor:g} x "
                        f"{cfg.lidar_noise_m * 100:.0f} cm"
                    )
                    st.fail(t_s, False, why, out)
                    smooth = False
                elif sigma > 0.5 * cfg.lidar_rough_factor * cfg.lidar_noise_m + 0.5 * (
                    cfg.lidar_noise_m
                ):
                    smooth = False  # hysteresis
        if smooth and spacing_ok:
            st.pass_(t_s, cfg, out)
        if st.state is Health.EXCLUDED or self._lidar_garbage_since is not None:
            use = False
        if not use:
            self.lidar_counts["unused"] += 1
        else:
            self._lidar_used_s = t_s
            self.lidar_blind = False
        self.transitions += out
        self.counts["excluded"] += sum(1 for x in out if x.new is Health.EXCLUDED)
        return use

    def lidar_gone(self, t_s: float, why: str) -> None:
        """The LiDAR's port failed (a read error: unplugged): excluded at once."""
        out: list[Transition] = []
        self._s["lidar"].fail(t_s, True, why, out)
        self.transitions += out
        self.counts["excluded"] += sum(1 for x in out if x.new is Health.EXCLUDED)

    def lidar_silence_limit_s(self) -> float:
        """How long the LiDAR may be silent now [s]: ``lidar_silence_s``, shorter while the
        robot drives, so that it covers at most ``lidar_blind_m`` on its last scan (never
        under :data:`LIDAR_SILENCE_PERIODS` revolutions, the stream's own spacing)."""
        cfg = self.cfg
        period = self._lidar_period_s or LIDAR_PERIOD_S
        floor = LIDAR_SILENCE_PERIODS * period
        speed = abs(self._speed_m_s)
        blind = cfg.lidar_blind_m / speed if speed > 1e-6 else math.inf
        return max(floor, min(cfg.lidar_silence_s, blind))

    def _lidar_silence(self, t_s: float, out: list[Transition]) -> None:
        """A LiDAR that scanned and stopped (dead, unplugged, its motor stalled) is excluded
        after ``lidar_silence_s``. Sooner, while a mission navigates by it, no usable scan
        (silence, garbage, noise) for the time the robot needs to cover ``lidar_blind_m``
        at its speed makes it blind: :attr:`lidar_blind` holds the robot (braked) until a
        usable scan comes, without ending the mission."""
        last = self._lidar_last_s
        if last is not None and t_s - last >= self.cfg.lidar_silence_s - 1e-9:
            why = f"no scan for {t_s - last:.2f} s (dead, unplugged or its motor stopped)"
            self._s["lidar"].fail(t_s, True, why, out)
            return
        used = self._lidar_used_s if self._lidar_used_s is not None else last
        if not self.lidar_needed or used is None or self.lidar_blind:
            return
        limit = self.lidar_silence_limit_s()
        if t_s - used >= limit - 1e-9:
            self.lidar_blind = True
            self.counts["blind"] = self.counts.get("blind", 0) + 1
            why = (
                f"no usable scan for {t_s - used:.2f} s at {abs(self._speed_m_s):.2f} m/s: "
                f"braked until one comes ({self._s['lidar'].reason or 'silence'})"
            )
            self._s["lidar"].fail(t_s, False, why, out)

    def _expected_ticks(self, i: int, h: HealthInput, wz: float) -> float:
        """Counts wheel i should have made over the frame, by the other wheel and the gyro."""
        tpr = (self.robot.ticks_per_rev_left, self.robot.ticks_per_rev_right)[i]
        return abs(self._expected_wheel(i, h, wz)) * h.dt_s * tpr / (2.0 * math.pi)

    def link(self, t_s: float, lost: int) -> None:
        """One telemetry frame received, ``lost`` frames missing before it (by SEQ)."""
        cfg, st = self.cfg, self._s["link"]
        window = self._link
        window.append((t_s, lost))
        missing = self._link_missing + lost
        while window and window[0][0] <= t_s - cfg.link_window_s + 1e-9:
            missing -= window.popleft()[1]
        self._link_missing = missing
        total = len(window) + missing
        out: list[Transition] = []
        if missing >= 2 and missing > cfg.link_loss_fraction * total:
            why = f"{missing} of {total} frames lost in {cfg.link_window_s:.0f} s"
            st.fail(t_s, False, why, out)
        elif missing <= 0.5 * cfg.link_loss_fraction * total:
            st.pass_(t_s, cfg, out)
        self.transitions += out

    def _kappa(self) -> float:
        """The scale tolerance: the prior's until the robot's scale s has been learned."""
        if self.model.scale_learned:
            return self.cfg.scale_tolerance
        return max(self.cfg.scale_tolerance, UNLEARNED_SCALE_TOLERANCE)

    def _wheel_yaw_rate(self, om_l: float, om_r: float) -> float:
        r = self.robot
        return (r.wheel_radius_right_m * om_r - r.wheel_radius_left_m * om_l) / r.wheel_separation_m

    def _expected_wheel(self, i: int, h: HealthInput, wz: float | None) -> float:
        """Wheel i's speed implied by the other wheel and the gyro, or by the command."""
        r = self.robot
        if wz is None:
            return h.wheel_cmd_rad_s[i]
        # the other wheel's speed stands for v (this wheel's own reading may be the fault)
        other = (
            r.wheel_radius_right_m * h.wheel_rad_s[1],
            r.wheel_radius_left_m * h.wheel_rad_s[0],
        )
        yaw = self.model.predict(wz, other[i]) * r.wheel_separation_m
        if i == 0:  # r_L om_L = r_R om_R - (s wz + c v) B
            return (r.wheel_radius_right_m * h.wheel_rad_s[1] - yaw) / r.wheel_radius_left_m
        return (r.wheel_radius_left_m * h.wheel_rad_s[0] + yaw) / r.wheel_radius_right_m

    def _wheel_agrees(self, i: int, h: HealthInput, wz: float | None) -> bool:
        """An excluded wheel's speed agrees with the other wheel and the gyro again."""
        if wz is None or h.dt_s <= 0.0:
            return True
        expected = self._expected_wheel(i, h, wz)
        r = self.robot
        sigma_yaw = math.sqrt(self.gyro_variance + self._quantisation_variance(h.dt_s))
        tol = (
            3.0
            * sigma_yaw
            * r.wheel_separation_m
            / min(r.wheel_radius_left_m, r.wheel_radius_right_m)
        )
        return abs(h.wheel_rad_s[i] - expected) <= tol + self.cfg.scale_tolerance * abs(expected)

    def _window_test(self, t: float, out: list[Transition]) -> set[str]:
        """The windowed mean of the residual; the sensor it charges, if it fails."""
        cfg = self.cfg
        n = len(self._window)
        span = self._window[-1][0] - self._window[0][0] if n else 0.0
        self._window_judged = not (n < 5 or span < 0.8 * cfg.window_s)
        if n < 5 or span < 0.8 * cfg.window_s:
            self.nis["window"] = 0.0
            self._window_mean = 0.0 if n < 5 else self._window_mean
            return set()
        window = self._window
        mean = window.sum(0) / n
        # the random part averages down; the scale disagreement (scrub) does not
        rate = window.sum(1) / n
        speed = window.sum(2) / n
        var_mean = window.sum(3) / (n * n)
        var_mean += (self._kappa() * rate) ** 2 + (cfg.straight_tolerance_rad_m * speed) ** 2
        # the creep of a turn-in has one sign all along: it does not average down either
        creep = self._window_creep.sum(0) / max(len(self._window_creep), 1)
        var_mean += creep * creep
        # the learned model's own error does not average down either: P_s mean(w_g)^2 +
        # P_c mean(v)^2 of the terms identified
        var_mean += self.model.variance(
            window.sum(4) / n,
            window.sum(5) / n,
            prior=False,
        )
        z2 = mean * mean / var_mean
        self.nis["window"] = z2
        self._window_mean = mean
        if z2 < self._z**2:
            calm = z2 < (RECOVER_Z_FRACTION * self._z) ** 2
            # where the test is blunt (a fast turn) a calm window is not enough: the residual
            # itself must have gone, to half the disagreement that began the ambiguity
            calm = calm and abs(mean) < 0.5 * self._ambiguous_size
            if self._ambiguous_since is not None and calm:
                if self._calm_since is None:
                    self._calm_since = t
                if t - self._calm_since >= cfg.recover_s - 1e-9:
                    self._ambiguous_since = None  # the disagreement ended: a passing slip
            else:
                self._calm_since = None
            return set()
        charged = self._charge(t, list(self._window), mean, span, out)
        self._window.clear()
        self._window_creep.clear()
        return charged

    def _charge(
        self,
        t: float,
        samples: list[tuple[float, float, float, float, float, float, float]],
        mean: float,
        span: float,
        out: list[Transition],
    ) -> set[str]:
        """A persistent disagreement while driving: charged to the wheel that reads more than
        the gyro and the other wheel allow (module docstring)."""
        self._last_charge_mean = mean
        n = len(samples)
        om_l = math.fsum(x[3] for x in samples) / n
        om_r = math.fsum(x[4] for x in samples) / n
        wz = math.fsum(x[5] for x in samples) / n
        v = math.fsum(x[6] for x in samples) / n
        r = self.robot
        head = f"wheel and gyro yaw rates disagree by {mean:+.3f} rad/s over {span:.2f} s"
        # a wheel that made no count all along although the other and the gyro say it turned
        t0 = samples[0][0] - 1e-9
        frames = [x for x in self._hist if x[0] >= t0]
        for i, wheel in enumerate(("left", "right")):
            if frames and all(x[5 + i] == 0 for x in frames):
                return self._exclude(
                    ("encoder_left", "encoder_right")[i],
                    t,
                    f"{head}: the {wheel} wheel made no count (encoder stuck or cut)",
                    out,
                )
        yaw = self.model.predict(wz, v) * r.wheel_separation_m
        excess_l = abs(om_l) - abs((r.wheel_radius_right_m * om_r - yaw) / r.wheel_radius_left_m)
        excess_r = abs(om_r) - abs((r.wheel_radius_left_m * om_l + yaw) / r.wheel_radius_right_m)
        side = 0 if excess_l >= excess_r else 1
        # the witnesses look at everything since the disagreement began (more with each try)
        since = t0 if self._ambiguous_since is None else self._ambiguous_since
        verdict = self._witness(since)
        axis = "lateral force"
        if verdict == "undecided":
            verdict, slip_side = self._speed_witness(since)
            axis = "forward speed"
            if slip_side is not None:
                side = slip_side
        if verdict != "undecided":
            self._ambiguous_since = None
        if verdict == "wheels right":
            why = f"{head}; the accelerometer's {axis} sides with the wheels (a gyro fault)"
            return self._exclude("imu", t, why, out)
        if verdict == "undecided":
            if self._ambiguous_since is None:
                self._ambiguous_since = samples[0][0]
                self._ambiguous_size = abs(mean)
            lasted = t - self._ambiguous_since
            if lasted >= self.cfg.ambiguity_s - 1e-9:
                why = (
                    f"{head}, for {lasted:.1f} s: longer than a slipping wheel, so the gyro "
                    "(a bias step; measured again at the next standstill)"
                )
                return self._exclude("imu", t, why, out)
            why = (
                f"{head}; the accelerometer cannot tell the gyro from the "
                f"{('left', 'right')[side]} wheel: the wheels' yaw rate stands in"
            )
            name = ("encoder_left", "encoder_right")[side]
            self._s["imu"].fail(t, False, why, out)
            self._s[name].fail(t, False, why, out)
            return {"imu", name}
        why = (
            f"{head}; the accelerometer's {axis} sides with the gyro: the "
            f"{('left', 'right')[side]} "
            f"wheel reads {max(excess_l, excess_r):.2f} rad/s more than the gyro and the other "
            "wheel allow (slipping)"
        )
        return self._exclude(("encoder_left", "encoder_right")[side], t, why, out)

    def _exclude(self, name: str, t: float, why: str, out: list[Transition]) -> set[str]:
        if name == "imu":
            self._imu_disagreement = abs(self._last_charge_mean)
        self._s[name].fail(t, True, why, out)
        return {name}

    def _witness(self, t0: float) -> str:
        """Which of the gyro and the wheels the accelerometer's lateral force agrees with, from
        the change since before the disagreement began: a_y = v w changes with the true yaw
        rate. "gyro right", "wheels right" or "undecided"."""
        before = [x for x in self._hist if t0 - self.cfg.window_s <= x[0] < t0]
        during = [x for x in self._hist if x[0] >= t0]
        if len(before) < 5 or len(during) < 3:
            return "undecided"

        def mean(
            rows: list[tuple[float, float, float, float, float, int, int, float]], k: int
        ) -> float:
            return math.fsum(x[k] for x in rows) / len(rows)

        v = mean(during, 2)
        d_a = mean(during, 1) - mean(before, 1)
        d_g = v * (mean(during, 3) - mean(before, 3))
        model = self.model
        d_e = v * (
            model.true_rate(mean(during, 4), mean(during, 2))
            - model.true_rate(mean(before, 4), mean(before, 2))
        )
        a_before = [x[1] - x[2] * x[3] for x in before]  # lateral force less v w: its noise
        m = math.fsum(a_before) / len(a_before)
        var = math.fsum((a - m) ** 2 for a in a_before) / (len(a_before) - 1)
        sigma = math.sqrt(var / len(before) + var / len(during))
        if abs(d_g - d_e) < WITNESS_Z * sigma:
            return "undecided"
        return "gyro right" if abs(d_a - d_g) < abs(d_a - d_e) else "wheels right"

    def _speed_witness(self, t0: float) -> tuple[str, int | None]:
        """The forward accelerometer between a slipping wheel and a gyro fault.

        Parameters
        ----------
        t0 : float
            When the disagreement began [s].

        Returns
        -------
        verdict : str
            "gyro right", "wheels right" or "undecided".
        side : int or None
            The slipping wheel (0 left, 1 right) when the verdict is "gyro right".
        """
        gap = self.speed_gap(t0)
        if gap is None:
            return "undecided", None
        g, x_slip, sigma_g = gap
        if abs(x_slip) < WITNESS_Z * sigma_g:
            return "undecided", None
        # nearest of the three: 0 (gyro), +x (right wheel), -x (left wheel)
        d = [abs(g), abs(g - x_slip), abs(g + x_slip)]
        best = int(np.argmin(d))
        if best == 0:
            return "wheels right", None
        return "gyro right", 1 if best == 1 else 0

    def speed_gap(self, t0: float) -> tuple[float, float, float] | None:
        """How far the wheels' forward speed ran from the accelerometer's since a disagreement.

        A wheel that slips by Δ [m/s] raises the wheels' yaw rate by ±Δ/B and their forward
        speed by Δ/2; a gyro fault leaves the wheels' speed true. The wheels' speed less the
        accelerometer's integral drifts with the accelerometer's bias, measured over
        ``SPEED_WITNESS_BIAS_S`` before the reference ``t0 - SPEED_WITNESS_LEAD_S``; the gap's
        change since the reference, less that drift, is compared with 0 (the gyro at fault) and
        ±(w_e - w_g)·B/2 (the right or the left wheel).

        Parameters
        ----------
        t0 : float
            When the disagreement began [s].

        Returns
        -------
        tuple of float or None
            The gap's change g [m/s], the slip x [m/s] the gyro implies (its sign: + for the
            right wheel) and g's standard deviation; None without enough frames.
        """
        # the disagreement is noticed a few frames after it began: the speeds are compared
        # from SPEED_WITNESS_LEAD_S before, the accelerometer's bias measured before that
        t_ref = t0 - SPEED_WITNESS_LEAD_S
        rows = [x for x in self._hist if t_ref - SPEED_WITNESS_BIAS_S <= x[0]]
        n_before = sum(1 for x in rows if x[0] < t_ref)
        n_during = len(rows) - n_before
        if n_before < 10 or n_during < 3 or rows[-1][0] < t0:
            return None
        t = np.array([x[0] for x in rows])
        a_x = np.array([x[7] for x in rows])
        v_e = np.array([x[2] for x in rows])
        # the gap's increments: the wheels' speed change less the accelerometer's (trapezoid)
        d = np.diff(v_e) - 0.5 * (a_x[1:] + a_x[:-1]) * np.diff(t)
        # the noise: the accelerometer's (white; from its successive differences, which the
        # robot's slow accelerations hardly touch) integrated, and the wheels' speed, whose
        # counts telescope: a level over k frames is off by the quantisation of its distance
        dt = float(np.mean(np.diff(t)))
        ab = a_x[:n_before]
        var_a = float(np.mean(np.diff(ab) ** 2)) / 2.0 * dt * dt  # per increment
        r = self.robot
        count = [
            2.0 * math.pi * r.wheel_radius_left_m / r.ticks_per_rev_left / dt,
            2.0 * math.pi * r.wheel_radius_right_m / r.ticks_per_rev_right / dt,
        ]
        var_frame = (count[0] ** 2 + count[1] ** 2) / 24.0  # one frame's speed, both wheels
        k = min(SPEED_WITNESS_FRAMES, n_during, n_before - 1)
        # the gap's level over the last k frames against its level over the k frames before
        # t_ref, less the bias's drift between them (from the levels at the ends of the bias
        # window: [m/s^2] the accelerometer's bias, and scale errors)
        gap = np.concatenate(([0.0], np.cumsum(d)))
        before_at = slice(n_before - k, n_before)
        t_b = float(np.mean(t[before_at]) - np.mean(t[:k]))
        drift = float(np.mean(gap[before_at]) - np.mean(gap[:k])) / t_b
        span = float(np.mean(t[-k:]) - np.mean(t[before_at]))
        g = float(np.mean(gap[-k:]) - np.mean(gap[before_at])) - drift * span
        steps = max(n_during, 1)  # increments between the two levels' frames, about
        var_drift = (2.0 * var_frame / (k * k) + (n_before - k) * var_a) / (t_b * t_b)
        sigma_g = math.sqrt(2.0 * var_frame / (k * k) + steps * var_a + span * span * var_drift)
        # the slip the gyro implies: the change of the wheels' yaw-rate excess since t_ref
        excess = [x[4] - self.model.predict(x[3], x[2]) for x in rows]
        now = math.fsum(excess[-k:]) / k
        ref = math.fsum(excess[n_before - k : n_before]) / k
        x_slip = (now - ref) * 0.5 * self.robot.wheel_separation_m
        return g, x_slip, sigma_g

    def _lost(self) -> str | None:
        cfg = self.cfg
        imu_out = not self._s["imu"].state.usable
        enc_out = [not self._s[n].state.usable for n in ("encoder_left", "encoder_right")]
        lidar = self._s["lidar"]
        if self.lidar_needed and lidar.state is Health.EXCLUDED and cfg.lidar_lost == "stop":
            return f"the LiDAR excluded ({lidar.reason}): no obstacle detection"
        if all(enc_out):
            return "both encoders excluded: no odometry"
        if imu_out and any(enc_out):
            return "the IMU and an encoder excluded: no yaw rate and no forward speed"
        if imu_out and cfg.imu_lost == "stop":
            return f"the IMU excluded ({self._s['imu'].reason}) and health.imu_lost is stop"
        if any(enc_out) and cfg.encoder_lost == "stop":
            side = "left" if enc_out[0] else "right"
            return f"the {side} encoder excluded and health.encoder_lost is stop"
        return None
