"""The EKF itself: prediction to each measurement's time and the gated Joseph-form correction
(the package docstring, :mod:`jackson.host.estimation.ekf`, gives the equations), with
filterpy's names for x, P, F, Q, y and S."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from jackson.common.geometry import wrap_angle
from jackson.host.estimation.ekf.config import EkfConfig, check_threshold
from jackson.host.estimation.ekf.model import (
    AX,
    IDENTITY,
    STATE_SIZE,
    TIME_EPSILON_S,
    VX,
    VY,
    VYAW,
    YAW,
    Matrix,
    Vector,
    X,
    Y,
    transition,
    transition_jacobian,
)
from jackson.host.estimation.ekf.state import EkfState, Innovation

MIN_MEASUREMENT_VARIANCE = 1e-9  # robot_localization's floor on a measurement variance

SENSOR_WHEEL = "wheel"
SENSOR_GYRO = "gyro"
SENSOR_YAW = "yaw"
SENSOR_WHEEL_YAW = "wheel_yaw"
SENSOR_ZUPT = "zupt"


class Ekf:
    """The planar EKF of the host (package docstring), robot_localization's behaviour.

    The equations are filterpy's ``ExtendedKalmanFilter`` (Joseph-form correction), written
    out for this filter's measurements, which each observe a few state components directly
    (H selects them): H P H^T is a block of P, P H^T some of its columns and K H a matrix with
    K in those columns. On the daemon's frame loop this takes a fifth of the time of
    filterpy's generic ``update`` (general matrix products with H, a checked inverse, deep
    copies of z, x and P on every call), which was most of the host's work per frame.
    tests/host/estimation/test_ekf.py keeps filterpy's ``update`` as the reference: the same
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
        check_threshold("mahalanobis_threshold", mahalanobis_threshold)
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

        i_kh = IDENTITY.copy()  # I - K H: K in the measured states' columns
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
