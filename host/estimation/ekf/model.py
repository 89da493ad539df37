"""The EKF's state and process model: the state's layout, f(x, dt) and its Jacobian F, as the
package docstring (:mod:`jackson.host.estimation.ekf`) derives them."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angle

Vector = npt.NDArray[np.float64]
Matrix = npt.NDArray[np.float64]

# State indices.
X, Y, YAW, VX, VY, VYAW, AX = range(7)
STATE_SIZE = 7
STATE_NAMES = ("x", "y", "yaw", "vx", "vy", "vyaw", "ax")

TIME_EPSILON_S = 1e-9  # [s] slack on time comparisons (0.2 s of 20 Hz frames is 0.19999...)

IDENTITY = np.eye(STATE_SIZE)


def transition(x: Vector, dt_s: float) -> Vector:
    """The process model f(x, dt) (package docstring); returns a new (7,) state.

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
    """F = df/dx at the state before the step (derived in the package docstring)."""
    _, _, yaw, vx, vy, _, ax = np.asarray(x, dtype=np.float64).reshape(STATE_SIZE).tolist()
    c, s = math.cos(yaw), math.sin(yaw)
    half_dt2 = 0.5 * dt_s * dt_s
    jac = IDENTITY.copy()
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
