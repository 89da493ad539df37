"""What the EKF reports: a frozen snapshot of its estimate and each measurement's innovation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jackson.host.estimation.ekf.model import AX, VX, VY, VYAW, YAW, Matrix, X, Y


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
        Whether a measurement (or :meth:`~jackson.host.estimation.ekf.Ekf.set_state`) has
        initialised the filter.
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
        "wheel", "gyro", "yaw" (or the name given to
        :meth:`~jackson.host.estimation.ekf.Ekf.update_yaw`).
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
