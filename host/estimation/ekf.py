"""Planar EKF after robot_localization's constant-acceleration model (Table 2).

State (7), velocities in the body frame, pose in the odom frame:

    x = [x, y, yaw, vx, vy, vyaw, ax]   [m, m, rad, m/s, m/s, rad/s, m/s^2]

Process model f(x, dt), with c = cos(yaw), s = sin(yaw):

    x'    = x + (vx c - vy s) dt + 0.5 ax c dt^2
    y'    = y + (vx s + vy c) dt + 0.5 ax s dt^2
    yaw'  = wrap(yaw + vyaw dt)
    vx'   = vx + ax dt
    vy'   = vy,  vyaw' = vyaw,  ax' = ax

Its Jacobian F = df/dx is the identity plus

    F[x, yaw] = -(vx s + vy c) dt - 0.5 ax s dt^2
    F[x, vx]  = c dt,   F[x, vy] = -s dt,   F[x, ax] = 0.5 c dt^2
    F[y, yaw] =  (vx c - vy s) dt + 0.5 ax c dt^2
    F[y, vx]  = s dt,   F[y, vy] =  c dt,   F[y, ax] = 0.5 s dt^2
    F[yaw, vyaw] = dt,  F[vx, ax] = dt

Prediction (robot_localization scales Q, given per second, by the step):

    x = f(x, dt),   P = F P F^T + dt Q

Correction: z = H x + v with H selecting the measured states and R the measurement
covariance; innovation y = z - H x (angles wrapped to [-pi, pi)), S = H P H^T + R,
squared Mahalanobis distance d^2 = y^T S^-1 y. With a threshold n set for the sensor the
measurement is rejected when d^2 >= n^2 (robot_localization's rule); otherwise
K = P H^T S^-1, x = x + K y, P = (I - K H) P (I - K H)^T + K R K^T (Joseph form).

Fused, as in Table 2: the wheel odometry's v_x and v_y (= 0, the non-holonomic constraint)
with R = diag(0.01, 0.001), and the IMU's yaw rate with R = 0.0004. Time is always the
MCU's unwrapped clock in seconds, passed in by the caller: the filter never reads a clock.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angle

Vector = npt.NDArray[np.float64]
Matrix = npt.NDArray[np.float64]

# State indices.
X, Y, YAW, VX, VY, VYAW, AX = range(7)
STATE_SIZE = 7
STATE_NAMES = ("x", "y", "yaw", "vx", "vy", "vyaw", "ax")

MIN_MEASUREMENT_VARIANCE = 1e-9  # robot_localization's floor on a measurement variance
TIME_EPSILON_S = 1e-9  # [s] slack on time comparisons (0.2 s of 20 Hz frames is 0.19999...)

SENSOR_WHEEL = "wheel"
SENSOR_GYRO = "gyro"
SENSOR_YAW = "yaw"
SENSOR_WHEEL_YAW = "wheel_yaw"
SENSOR_ZUPT = "zupt"


_IDENTITY = np.eye(STATE_SIZE)


def transition(x: Vector, dt_s: float) -> Vector:
    """The process model f(x, dt) (module docstring); returns a new (7,) state.

    Worked on Python floats (the same IEEE double operations as on NumPy scalars, several
    times cheaper per operation).
    """
    out = np.array(x, dtype=np.float64)
    x_m, y_m, yaw, vx, vy, vyaw, ax = out.tolist()
    c, s = math.cos(yaw), math.sin(yaw)
    half_dt2 = 0.5 * dt_s * dt_s
    out[X] = x_m + (vx * c - vy * s) * dt_s + ax * c * half_dt2
    out[Y] = y_m + (vx * s + vy * c) * dt_s + ax * s * half_dt2
    out[YAW] = wrap_angle(yaw + vyaw * dt_s)
    out[VX] = vx + ax * dt_s
    return out


def transition_jacobian(x: Vector, dt_s: float) -> Matrix:
    """F = df/dx at the state before the step (derived in the module docstring)."""
    _, _, yaw, vx, vy, _, ax = np.asarray(x, dtype=np.float64).reshape(STATE_SIZE).tolist()
    c, s = math.cos(yaw), math.sin(yaw)
    half_dt2 = 0.5 * dt_s * dt_s
    jac = _IDENTITY.copy()
    jac[X, YAW] = -(vx * s + vy * c) * dt_s - ax * s * half_dt2
    jac[X, VX] = c * dt_s
    jac[X, VY] = -s * dt_s
    jac[X, AX] = c * half_dt2
    jac[Y, YAW] = (vx * c - vy * s) * dt_s + ax * c * half_dt2
    jac[Y, VX] = s * dt_s
    jac[Y, VY] = c * dt_s
    jac[Y, AX] = s * half_dt2
    jac[YAW, VYAW] = dt_s
    jac[VX, AX] = dt_s
    return jac


def _check_threshold(name: str, value: float | None) -> None:
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
        (:class:`GyroBiasEstimator`) [s]; 0 switches the estimate off.
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
        _check_threshold("EkfConfig.mahalanobis_wheel", self.mahalanobis_wheel)
        _check_threshold("EkfConfig.mahalanobis_imu", self.mahalanobis_imu)


@dataclass(frozen=True)
class EkfState:
    """A snapshot of the estimate.

    Attributes
    ----------
    t_s : float or None
        MCU time the state refers to [s]; None before the filter is initialised.
    x : tuple of 7 float
        [x, y, yaw, vx, vy, vyaw, ax] [m, m, rad, m/s, m/s, rad/s, m/s^2].
    covariance_diagonal : tuple of 7 float
        diag(P) in the same order.
    initialized : bool
        Whether a measurement (or :meth:`Ekf.set_state`) has initialised the filter.
    pose_cross : tuple of 3 float
        The pose block's off-diagonal terms (P_xy, P_x,yaw, P_y,yaw), for the full 3x3 pose
        covariance (:meth:`pose_covariance`; NEES needs the correlations).
    """

    t_s: float | None
    x: tuple[float, ...]
    covariance_diagonal: tuple[float, ...]
    initialized: bool
    pose_cross: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def pose_covariance(self) -> Matrix:
        """The 3x3 covariance of [x, y, yaw]."""
        d, (xy, xyaw, yyaw) = self.covariance_diagonal, self.pose_cross
        return np.array(
            [[d[X], xy, xyaw], [xy, d[Y], yyaw], [xyaw, yyaw, d[YAW]]], dtype=np.float64
        )

    @property
    def x_m(self) -> float:
        return self.x[X]

    @property
    def y_m(self) -> float:
        return self.x[Y]

    @property
    def yaw_rad(self) -> float:
        return self.x[YAW]

    @property
    def vx_m_s(self) -> float:
        return self.x[VX]

    @property
    def vy_m_s(self) -> float:
        return self.x[VY]

    @property
    def vyaw_rad_s(self) -> float:
        return self.x[VYAW]

    @property
    def ax_m_s2(self) -> float:
        return self.x[AX]

    @property
    def p_xx(self) -> float:
        return self.covariance_diagonal[X]

    @property
    def p_yy(self) -> float:
        return self.covariance_diagonal[Y]

    @property
    def p_yawyaw(self) -> float:
        return self.covariance_diagonal[YAW]


@dataclass(frozen=True)
class Innovation:
    """One measurement's innovation, for monitoring (accepted or not).

    Attributes
    ----------
    sensor : str
        "wheel", "gyro", "yaw" (or the name given to :meth:`Ekf.update_yaw`).
    t_s : float
        MCU time of the measurement [s].
    y : tuple of float
        z - H x, angles wrapped; zeros for the measurement that initialised the filter.
    S : tuple of tuple of float
        H P H^T + R.
    mahalanobis_sq : float
        y^T S^-1 y, the squared Mahalanobis distance.
    accepted : bool
        False when the gate rejected the measurement.
    """

    sensor: str
    t_s: float
    y: tuple[float, ...]
    S: tuple[tuple[float, ...], ...]
    mahalanobis_sq: float
    accepted: bool


class Ekf:
    """The planar EKF of the host (module docstring), robot_localization's behaviour.

    The equations are filterpy's ``ExtendedKalmanFilter`` (Joseph-form correction), written
    out for this filter's measurements, which each observe a few state components directly
    (H selects them): H P H^T is a block of P, P H^T some of its columns and K H a matrix with
    K in those columns. On the daemon's frame loop this takes a fifth of the time of
    filterpy's generic ``update`` (general matrix products with H, a checked inverse, deep
    copies of z, x and P on every call), which was most of the host's work per frame.
    tests/host/test_ekf.py keeps filterpy's ``update`` as the reference: the same
    measurements through both agree to rounding.

    The prediction is x = f(x, dt), P = F P F^T + dt Q, with F and dt Q kept for inspection
    (:attr:`F`). Like robot_localization, the filter starts uninitialised (state 0,
    P = 1e-9 I) and does not predict; the first measurement writes its components and their
    covariance straight into x and P and initialises it; from then on every measurement first
    predicts to its own time (never backwards: an older one is corrected without prediction)
    and then corrects.

    Attributes
    ----------
    config : EkfConfig
    rejected : dict of str to int
        Measurements the Mahalanobis gate rejected, per sensor.
    innovations : dict of str to Innovation
        The last innovation per sensor.
    """

    def __init__(self, config: EkfConfig | None = None) -> None:
        self.config = config if config is not None else EkfConfig()
        self._q_per_s: Matrix = np.diag(
            np.asarray(self.config.process_noise.diagonal, dtype=np.float64)
        )
        self._q_moving_diag = np.diagonal(self._q_per_s).copy()
        self._q_still_diag = self._q_moving_diag.copy()
        self._q_still_diag[[X, Y, YAW]] = 0.0
        self._q_still: Matrix = np.diag(self._q_still_diag)
        self.rejected: dict[str, int] = {}
        self.innovations: dict[str, Innovation] = {}
        self.stationary = False  # the robot stands still: no process noise on the pose
        self.reset()

    # ---- state -------------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the uninitialised filter: x = 0, P = initial_covariance I, no time."""
        self._x: Vector = np.zeros(STATE_SIZE)
        self._P: Matrix = np.eye(STATE_SIZE) * self.config.initial_covariance
        self._F: Matrix = np.eye(STATE_SIZE)
        self._t_s: float | None = None
        self._last_measurement_t_s: float | None = None
        self._initialized = False
        self._last = Innovation("", 0.0, (), (), 0.0, True)  # the last measurement's
        self.stationary = False
        self.rejected = {SENSOR_WHEEL: 0, SENSOR_GYRO: 0, SENSOR_YAW: 0}
        self.innovations = {}

    def set_state(
        self, t_s: float, x: Sequence[float], covariance_diagonal: Sequence[float] | None = None
    ) -> None:
        """Start the filter at a known state without a measurement (robot_localization's set_pose).

        Parameters
        ----------
        t_s : float
            MCU time of the state [s].
        x : sequence of 7 float
            [x, y, yaw, vx, vy, vyaw, ax]; yaw is wrapped.
        covariance_diagonal : sequence of 7 float, optional
            diag(P); default initial_covariance for every state. Off-diagonal terms are zero.
        """
        state = np.array(x, dtype=np.float64).reshape(STATE_SIZE)
        state[YAW] = wrap_angle(float(state[YAW]))
        if covariance_diagonal is None:
            p_diag = np.full(STATE_SIZE, self.config.initial_covariance)
        else:
            p_diag = np.asarray(covariance_diagonal, dtype=np.float64).reshape(STATE_SIZE)
        self._x = state
        self._P = np.diag(p_diag)
        self._t_s = t_s
        self._last_measurement_t_s = t_s
        self._initialized = True

    @property
    def initialized(self) -> bool:
        """True once a measurement (or :meth:`set_state`) has set the state."""
        return self._initialized

    @property
    def t_s(self) -> float | None:
        """MCU time the state refers to [s]; None before initialisation."""
        return self._t_s

    @property
    def last_measurement_t_s(self) -> float | None:
        """MCU time of the newest measurement processed, accepted or rejected [s]."""
        return self._last_measurement_t_s

    @property
    def x(self) -> Vector:
        """A copy of the state vector (7,)."""
        return self._x.copy()

    @property
    def P(self) -> Matrix:  # noqa: N802 - named as in the maths
        """A copy of the state covariance (7, 7)."""
        return self._P.copy()

    @property
    def F(self) -> Matrix:  # noqa: N802
        """The Jacobian of the last prediction step (7, 7)."""
        return self._F.copy()

    @property
    def Q(self) -> Matrix:  # noqa: N802
        """Process noise per second, diagonal (7, 7); a step of dt adds dt Q."""
        return self._q_per_s.copy()

    @property
    def y(self) -> Vector:
        """Innovation of the last measurement, accepted or not (angles wrapped)."""
        return np.array(self._last.y, dtype=np.float64)

    @property
    def S(self) -> Matrix:  # noqa: N802
        """Innovation covariance H P H^T + R of the last measurement."""
        return np.array(self._last.S, dtype=np.float64).reshape(len(self._last.y), -1)

    @property
    def mahalanobis_sq(self) -> float:
        """Squared Mahalanobis distance y^T S^-1 y of the last measurement (what is gated)."""
        return self._last.mahalanobis_sq

    @property
    def mahalanobis(self) -> float:
        """Mahalanobis distance sqrt(y^T S^-1 y) of the last measurement (filterpy's meaning)."""
        return math.sqrt(self._last.mahalanobis_sq)

    @property
    def x_m(self) -> float:
        return float(self._x[X])

    @property
    def y_m(self) -> float:
        return float(self._x[Y])

    @property
    def yaw_rad(self) -> float:
        return float(self._x[YAW])

    @property
    def vx_m_s(self) -> float:
        return float(self._x[VX])

    @property
    def vy_m_s(self) -> float:
        return float(self._x[VY])

    @property
    def vyaw_rad_s(self) -> float:
        return float(self._x[VYAW])

    @property
    def ax_m_s2(self) -> float:
        return float(self._x[AX])

    def state(self) -> EkfState:
        """A frozen snapshot of the estimate."""
        p = self._P
        return EkfState(
            t_s=self._t_s,
            x=tuple(self._x.tolist()),
            covariance_diagonal=tuple(np.diagonal(p).tolist()),
            initialized=self._initialized,
            pose_cross=_pose_cross(p),
        )

    def state_at(self, t_s: float) -> EkfState:
        """The snapshot predicted to MCU time t_s, leaving the filter untouched.

        For publishing at the output rate between measurements: the estimate is extrapolated
        (x = f(x, dt), P = F P F^T + dt Q) without moving the filter's own time, so a
        measurement stamped before t_s is still predicted to and corrected at its own time.
        Equals :meth:`state` when t_s is not after the state's time or before initialisation.
        """
        if not self._initialized or self._t_s is None or not t_s - self._t_s > 0.0:
            return self.state()
        dt_s = t_s - self._t_s
        x = self._x
        jac = transition_jacobian(x, dt_s)
        p = jac @ self._P @ jac.T + dt_s * self._q_matrix()
        return EkfState(
            t_s=t_s,
            x=tuple(transition(x, dt_s).tolist()),
            covariance_diagonal=tuple(p.diagonal().tolist()),
            initialized=True,
            pose_cross=_pose_cross(p),
        )

    # ---- prediction --------------------------------------------------------------------------
    def predict_to(self, t_s: float) -> None:
        """Advance the estimate to MCU time t_s: x = f(x, dt), P = F P F^T + dt Q.

        A no-op when t_s is not after the state's time, and before initialisation (like
        robot_localization, the filter does not predict until it has a state).
        """
        if not self._initialized or self._t_s is None:
            return
        dt_s = t_s - self._t_s
        if not dt_s > 0.0:  # also NaN
            return
        x = self._x
        jac = transition_jacobian(x, dt_s)
        self._F = jac
        self._P = jac @ self._P @ jac.T + dt_s * self._q_matrix()
        self._x = transition(x, dt_s)
        self._t_s = t_s

    def _q_matrix(self) -> Matrix:
        """Q per second as a matrix: without the pose's while :attr:`stationary`."""
        return self._q_still if self.stationary else self._q_per_s

    def _q_diag(self) -> Vector:
        """Q's diagonal per second: without the pose's while :attr:`stationary`."""
        return self._q_still_diag if self.stationary else self._q_moving_diag

    def timed_out(self, t_s: float) -> bool:
        """True when no measurement arrived within sensor_timeout_s before t_s.

        Also True before any measurement. The comparison allows TIME_EPSILON_S, so exactly
        0.2 s of silence counts even when the timestamps are sums of 0.05 s steps.
        """
        if self._last_measurement_t_s is None:
            return True
        silence_s = t_s - self._last_measurement_t_s
        return silence_s >= self.config.sensor_timeout_s - TIME_EPSILON_S

    # ---- measurements ------------------------------------------------------------------------
    def update_wheel(
        self, t_s: float, vx: float, vy: float = 0.0, variance_scale: float = 1.0
    ) -> bool:
        """Fuse the wheel odometry's body velocity: z = [vx, vy], R = diag(r_vx, r_vy).

        vy is the non-holonomic constraint (0 for a differential drive). Gated with
        mahalanobis_wheel. ``variance_scale`` multiplies R's vx term (one wheel and the gyro
        in place of two wheels).

        Returns
        -------
        bool
            False when the gate rejected the measurement (or every value was non-finite).
        """
        cfg = self.config
        return self._process(
            SENSOR_WHEEL,
            t_s,
            (vx, vy),
            _WHEEL,
            (cfg.r_vx * variance_scale, cfg.r_vy),
            cfg.mahalanobis_wheel,
        )

    def update_gyro(self, t_s: float, wz: float) -> bool:
        """Fuse the IMU's yaw rate [rad/s] (bias already removed): z = [vyaw], R = r_wz.

        Gated with mahalanobis_imu. Returns False when rejected.
        """
        cfg = self.config
        return self._process(SENSOR_GYRO, t_s, (wz,), _VYAW, (cfg.r_wz,), cfg.mahalanobis_imu)

    def update_yaw_rate(
        self, t_s: float, wz: float, variance: float, sensor: str = SENSOR_WHEEL_YAW
    ) -> bool:
        """Fuse a yaw rate other than the gyro's (the wheels', when the IMU is excluded):
        z = [vyaw], R = variance [(rad/s)^2]. Not gated."""
        return self._process(sensor, t_s, (wz,), _VYAW, (variance,), None)

    def update_zero_velocity(self, t_s: float, variance: float) -> bool:
        """A zero-velocity update: z = [vx, vy, vyaw, ax] = 0 with R = variance I.

        For a robot that stands still (with :attr:`stationary` set, so the prediction adds no
        pose noise either): its velocity covariance collapses and its pose covariance stops
        growing.
        """
        return self._process(SENSOR_ZUPT, t_s, (0.0,) * 4, _ZUPT, (variance,) * 4, None)

    def update_yaw(
        self,
        t_s: float,
        yaw: float,
        variance: float,
        mahalanobis_threshold: float | None = None,
        sensor: str = SENSOR_YAW,
    ) -> bool:
        """Fuse an absolute heading [rad]: z = [yaw], R = variance [rad^2].

        The innovation is wrapped to [-pi, pi): a measurement 350 deg from the state is a
        -10 deg innovation. For tests and future absolute-heading sensors; the paper fuses
        no orientation.

        Parameters
        ----------
        t_s : float
            MCU time of the measurement [s].
        yaw : float
            Measured heading [rad], any range.
        variance : float
            Its variance [rad^2].
        mahalanobis_threshold : float or None
            Gate n for this measurement (None = off).
        sensor : str
            Name the rejections and the innovation are filed under.

        Returns
        -------
        bool
            False when the gate rejected the measurement.
        """
        _check_threshold("mahalanobis_threshold", mahalanobis_threshold)
        return self._process(sensor, t_s, (yaw,), _YAW, (variance,), mahalanobis_threshold)

    def _process(
        self,
        sensor: str,
        t_s: float,
        z: tuple[float, ...],
        indices: tuple[int, ...],
        variances: tuple[float, ...],
        threshold: float | None,
    ) -> bool:
        """Gate and correct with z = H x + v, H selecting ``indices``, R = diag(variances)."""
        # robot_localization: non-finite values are left out of the update; variances are
        # taken as absolute values with a floor of 1e-9.
        if not all(map(math.isfinite, z)):
            keep = [i for i, v in enumerate(z) if math.isfinite(v)]
            if not keep:
                return False
            z = tuple(z[i] for i in keep)
            indices = tuple(indices[i] for i in keep)
            variances = tuple(variances[i] for i in keep)
        r = [
            v if v >= MIN_MEASUREMENT_VARIANCE else max(abs(v), MIN_MEASUREMENT_VARIANCE)
            for v in variances
        ]
        if YAW in indices:  # angles: measurement and innovation wrapped to [-pi, pi)
            z = tuple(wrap_angle(v) if i == YAW else v for v, i in zip(z, indices, strict=True))

        if self._last_measurement_t_s is None or t_s >= self._last_measurement_t_s:
            self._last_measurement_t_s = t_s

        if not self._initialized:
            self._initialize_from(sensor, t_s, z, indices, r)
            return True

        self.predict_to(t_s)
        x, p = self._x, self._P
        m = len(indices)
        first = indices[0]
        # P H^T: P's columns of the measured states (a view when they are adjacent)
        adjacent = indices == tuple(range(first, first + m))
        pht = p[:, first : first + m] if adjacent else p[:, list(indices)]
        y = [zi - float(x[i]) for zi, i in zip(z, indices, strict=True)]
        if YAW in indices:
            y = [wrap_angle(v) if i == YAW else v for v, i in zip(y, indices, strict=True)]
        if m == 1:  # S, S^-1 and d^2 on floats
            s = float(p[first, first]) + r[0]
            s_rows = [[s]]
            d2 = y[0] * (y[0] / s)
        elif m == 2:
            i, j = indices
            a, b = float(p[i, i]) + r[0], float(p[i, j])
            c, d = float(p[j, i]), float(p[j, j]) + r[1]
            s_rows = [[a, b], [c, d]]
            det = a * d - b * c
            s_inv = np.array([[d / det, -b / det], [-c / det, a / det]])
            d2 = y[0] * (d * y[0] - b * y[1]) / det + y[1] * (a * y[1] - c * y[0]) / det
        else:
            rows = slice(first, first + m) if adjacent else list(indices)
            s_matrix = pht[rows, :] + np.diag(r)
            s_rows = s_matrix.tolist()
            s_inv = np.linalg.inv(s_matrix)
            y_arr = np.array(y)
            d2 = float(y_arr @ (s_inv @ y_arr))
        accepted = threshold is None or d2 < threshold * threshold
        self._record(sensor, t_s, y, s_rows, d2, accepted)
        if not accepted:
            self.rejected[sensor] = self.rejected.get(sensor, 0) + 1
            return False

        i_kh = _IDENTITY.copy()  # I - K H: K in the measured states' columns
        if m == 1:  # K = P H^T / s, a column
            k1 = p[:, first] * (1.0 / s)
            x = x + k1 * y[0]
            i_kh[:, first] -= k1
            krk = (k1 * r[0])[:, np.newaxis] * k1
        else:
            k = pht @ s_inv  # K = P H^T S^-1, (7, m)
            x = x + k @ np.array(y)
            if adjacent:
                i_kh[:, first : first + m] -= k
            else:
                i_kh[:, list(indices)] -= k
            krk = (k * r) @ k.T  # R is diagonal
        x[YAW] = wrap_angle(float(x[YAW]))
        self._P = (i_kh @ p) @ i_kh.T + krk  # Joseph form
        self._x = x
        return True

    def _initialize_from(
        self,
        sensor: str,
        t_s: float,
        z: tuple[float, ...],
        indices: tuple[int, ...],
        r: list[float],
    ) -> None:
        """robot_localization's first measurement: measured states and their covariance block
        are copied from the measurement, the rest stay at 0 and initial_covariance."""
        r_matrix = np.diag(r)
        for row, i in enumerate(indices):
            self._x[i] = z[row]
            for col, j in enumerate(indices):
                self._P[i, j] = r_matrix[row, col]
        self._t_s = t_s
        self._initialized = True
        self._record(sensor, t_s, [0.0] * len(indices), r_matrix.tolist(), 0.0, True)

    def _record(
        self,
        sensor: str,
        t_s: float,
        y: list[float],
        s_rows: list[list[float]],
        d2: float,
        accepted: bool,
    ) -> None:
        innovation = Innovation(sensor, t_s, tuple(y), tuple(map(tuple, s_rows)), d2, accepted)
        self._last = innovation
        self.innovations[sensor] = innovation


_WHEEL = (VX, VY)
_VYAW = (VYAW,)
_YAW = (YAW,)
_ZUPT = (VX, VY, VYAW, AX)


def _pose_cross(p: Matrix) -> tuple[float, float, float]:
    """(P_xy, P_x,yaw, P_y,yaw) of a covariance whose first three states are x, y, yaw."""
    return (float(p[X, Y]), float(p[X, YAW]), float(p[Y, YAW]))


class GyroBiasEstimator:
    """The gyro z bias, averaged while the robot stands still at start-up.

    Samples are averaged while ``standing_still`` holds (both wheel velocities zero); the
    estimate is ready once the window spans at least ``window_s`` of MCU time and holds at
    least ``min_samples`` samples, and is frozen from then on. Motion (or time running
    backwards) before that restarts the window. The daemon subtracts :attr:`bias_rad_s` from
    the gyro rate before :meth:`Ekf.update_gyro`.

    Parameters
    ----------
    window_s : float
        Standstill needed [s] (default 2 s: 41 frames at 20 Hz); 0 switches the estimate
        off (the bias is 0 from the start).
    min_samples : int
        Fewest samples averaged.
    """

    def __init__(self, window_s: float = 2.0, min_samples: int = 20) -> None:
        if not 0.0 <= window_s < math.inf:
            raise ValueError(f"window_s must be finite and >= 0, got {window_s}")
        if min_samples < 1:
            raise ValueError(f"min_samples must be >= 1, got {min_samples}")
        self.window_s = window_s
        self.min_samples = min_samples
        self.reset()

    def reset(self) -> None:
        """Drop the samples and any estimate."""
        self._samples: list[float] = []
        self._t_first_s = 0.0
        self._t_last_s = 0.0
        self._bias_rad_s: float | None = 0.0 if self.window_s == 0.0 else None

    @property
    def bias_rad_s(self) -> float | None:
        """The mean gyro z rate over the still window [rad/s]; None until ready."""
        return self._bias_rad_s

    @property
    def ready(self) -> bool:
        return self._bias_rad_s is not None

    @property
    def sample_count(self) -> int:
        """Samples in the current window."""
        return len(self._samples)

    def add(self, t_s: float, wz: float, standing_still: bool) -> None:
        """Offer one gyro z sample [rad/s] taken at MCU time t_s [s]."""
        if self._bias_rad_s is not None:
            return
        if not math.isfinite(wz):
            return
        if not standing_still:
            self._samples.clear()
            return
        if self._samples and t_s < self._t_last_s:
            self._samples.clear()
        if not self._samples:
            self._t_first_s = t_s
        self._samples.append(wz)
        self._t_last_s = t_s
        span_s = t_s - self._t_first_s
        if len(self._samples) >= self.min_samples and span_s >= self.window_s - TIME_EPSILON_S:
            self._bias_rad_s = math.fsum(self._samples) / len(self._samples)


class OutputClock:
    """The instants of the filter's outputs: every ``1 / frequency_hz`` of MCU time (30 Hz, as
    robot_localization's ``frequency``), from the first multiple of the period at or after the
    first frame, prediction only between measurements.

    Parameters
    ----------
    frequency_hz : float
        Output rate [Hz].
    """

    def __init__(self, frequency_hz: float) -> None:
        self.frequency_hz = frequency_hz
        self._next_s: float | None = None

    def due(self, t_s: float) -> list[float]:
        """The output instants up to a frame at ``t_s`` [s] not yet given, in order."""
        period = 1.0 / self.frequency_hz
        if self._next_s is None:
            self._next_s = math.ceil(t_s / period) * period
        out = []
        while self._next_s <= t_s + 1e-9:
            out.append(self._next_s)
            self._next_s += period
        return out
