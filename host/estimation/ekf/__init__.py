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

The package, one idea a module:

- :mod:`~jackson.host.estimation.ekf.model`: the state's layout, f(x, dt) and F;
- :mod:`~jackson.host.estimation.ekf.filter`: :class:`Ekf`, the prediction and the gated
  correction, with filterpy's names;
- :mod:`~jackson.host.estimation.ekf.state`: the frozen :class:`EkfState` snapshot and the
  :class:`Innovation` of each measurement;
- :mod:`~jackson.host.estimation.ekf.config`: :class:`EkfConfig` and its :class:`ProcessNoise`;
- :mod:`~jackson.host.estimation.ekf.gyro_bias`: the start-up :class:`GyroBiasEstimator`;
- :mod:`~jackson.host.estimation.ekf.output_clock`: the 30 Hz :class:`OutputClock`.
"""

from jackson.host.estimation.ekf.config import (
    DEFAULT_PROCESS_NOISE,
    PAPER_EKF,
    PAPER_PROCESS_NOISE,
    EkfConfig,
    ProcessNoise,
)
from jackson.host.estimation.ekf.filter import (
    MIN_MEASUREMENT_VARIANCE,
    SENSOR_GYRO,
    SENSOR_WHEEL,
    SENSOR_WHEEL_YAW,
    SENSOR_YAW,
    SENSOR_ZUPT,
    Ekf,
)
from jackson.host.estimation.ekf.gyro_bias import GyroBiasEstimator
from jackson.host.estimation.ekf.model import (
    AX,
    STATE_NAMES,
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
from jackson.host.estimation.ekf.output_clock import OutputClock
from jackson.host.estimation.ekf.state import EkfState, Innovation

__all__ = [
    "AX",
    "DEFAULT_PROCESS_NOISE",
    "MIN_MEASUREMENT_VARIANCE",
    "PAPER_EKF",
    "PAPER_PROCESS_NOISE",
    "SENSOR_GYRO",
    "SENSOR_WHEEL",
    "SENSOR_WHEEL_YAW",
    "SENSOR_YAW",
    "SENSOR_ZUPT",
    "STATE_NAMES",
    "STATE_SIZE",
    "TIME_EPSILON_S",
    "VX",
    "VY",
    "VYAW",
    "YAW",
    "Ekf",
    "EkfConfig",
    "EkfState",
    "GyroBiasEstimator",
    "Innovation",
    "Matrix",
    "OutputClock",
    "ProcessNoise",
    "Vector",
    "X",
    "Y",
    "transition",
    "transition_jacobian",
]
