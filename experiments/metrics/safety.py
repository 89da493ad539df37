"""Stage 3 clearance and safety: d_min, safety vector (Eq. 16 and 21)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from jackson.common.robot import ENVELOPE_X_M as ENVELOPE_X_M  # Eq. A21, re-exported
from jackson.common.robot import ENVELOPE_Y_M as ENVELOPE_Y_M
from jackson.experiments.metrics.inputs import (
    FloatArray,
    MetricInputError,
    as_series,
    check_same_length,
)

CYLINDER_RADIUS_M = 0.125  # [m] Stage 3 dynamic cylinder r_c


class Cylinder(NamedTuple):
    """A vertical cylinder seen from above: centre (x_m, y_m) and radius_m [m]."""

    x_m: float
    y_m: float
    radius_m: float


STAGE3_CYLINDER = Cylinder(0.6091, -0.0364, CYLINDER_RADIUS_M)  # map frame (Sec. 4.3)


# ---- Stage 3 clearance and safety (Eq. 16, 21) -------------------------------------------------


def envelope_to_circle_distance(
    pose: npt.ArrayLike,
    cylinder: Cylinder | tuple[float, float, float],
    envelope_x_m: tuple[float, float] = ENVELOPE_X_M,
    envelope_y_m: tuple[float, float] = ENVELOPE_Y_M,
) -> FloatArray:
    """d_geom(B_robot(t), C_cyl) of Eq. 21 at each pose: rectangle-to-circle distance.

    The circle centre c is taken into the robot frame, l = R(-yaw) (c - p), where the
    envelope is the axis-aligned box [x0, x1] x [y0, y1] (App. D.3). The signed distance of
    l to the box is

        outside:  sqrt(max(x0 - lx, 0, lx - x1)^2 + max(y0 - ly, 0, ly - y1)^2)
        inside:   -min(lx - x0, x1 - lx, ly - y0, y1 - ly)

    and the clearance is that minus the radius: > 0 a gap, 0 touching, < 0 overlapping.
    Exact, not sampled on the edges.

    Parameters
    ----------
    pose : array_like, shape (N, 3) or (3,)
        Robot poses x [m], y [m], yaw [rad].
    cylinder : Cylinder or tuple of float
        Centre x, centre y and radius [m].
    envelope_x_m, envelope_y_m : tuple of float
        Envelope bounds in the robot frame [m].

    Returns
    -------
    numpy.ndarray, shape (N,)
        Clearance at each pose [m].
    """
    poses = np.atleast_2d(np.asarray(pose, dtype=np.float64))
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise MetricInputError(f"pose must have shape (N, 3), got {np.shape(pose)}")
    cx, cy, radius = (float(v) for v in cylinder)
    (x0, x1), (y0, y1) = envelope_x_m, envelope_y_m
    if not (x0 < x1 and y0 < y1 and radius >= 0.0):
        raise MetricInputError("envelope bounds must be increasing and the radius >= 0")
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    dx, dy = cx - poses[:, 0], cy - poses[:, 1]
    lx = c * dx + s * dy
    ly = -s * dx + c * dy
    ox = np.maximum(np.maximum(x0 - lx, lx - x1), 0.0)
    oy = np.maximum(np.maximum(y0 - ly, ly - y1), 0.0)
    inside_depth = np.minimum(np.minimum(lx - x0, x1 - lx), np.minimum(ly - y0, y1 - ly))
    signed = np.where(inside_depth > 0.0, -inside_depth, np.hypot(ox, oy))
    return signed - radius


def d_min(
    poses: npt.ArrayLike,
    cylinder: Cylinder | tuple[float, float, float] = STAGE3_CYLINDER,
    *,
    envelope_x_m: tuple[float, float] = ENVELOPE_X_M,
    envelope_y_m: tuple[float, float] = ENVELOPE_Y_M,
    t_s: npt.ArrayLike | None = None,
    t_ins_s: float | None = None,
) -> float:
    """Minimum obstacle clearance d_min = min_{t >= t_ins} d_geom(B_robot(t), C_cyl) (Eq. 21).

    B_robot is the conservative oriented collision envelope x in [-0.135, 0.135177] m,
    y in [-0.135439, 0.135] m (Eq. A21), C_cyl the cylinder (r_c = 0.125 m); the distance is
    exact (:func:`envelope_to_circle_distance`): 0 when touching and negative when the
    envelope and the cylinder overlap.

    Parameters
    ----------
    poses : array_like, shape (N, 3)
        Robot poses x [m], y [m], yaw [rad], in the cylinder's frame.
    cylinder : Cylinder or tuple of float
        Centre x, centre y and radius [m]; the paper's Stage 3 cylinder by default.
    envelope_x_m, envelope_y_m : tuple of float
        Envelope bounds in the robot frame [m].
    t_s : array_like, shape (N,), optional
        Time stamps of the poses [s]; needed with ``t_ins_s``.
    t_ins_s : float, optional
        Cylinder insertion time [s]; only poses at t >= t_ins count. All poses without it.

    Returns
    -------
    float
        d_min [m].
    """
    dist = envelope_to_circle_distance(poses, cylinder, envelope_x_m, envelope_y_m)
    if t_ins_s is not None:
        if t_s is None:
            raise MetricInputError("t_ins_s needs the pose time stamps t_s")
        t = as_series("t_s", t_s)
        check_same_length("t_s", t, "poses", dist)
        dist = dist[t >= t_ins_s]
        if dist.size == 0:
            raise MetricInputError(f"no pose at or after the insertion time {t_ins_s} s")
    return float(np.min(dist))


@dataclass(frozen=True)
class SafetyVector:
    """S_vector = [P_success, C_count, d_min, E_recovery, t_nav] (Eq. 16 / A20).

    Attributes
    ----------
    p_success : float
        Successful goal completions over all attempted runs, aborted ones included.
    c_count : int
        Physical contact or collision events.
    d_min : float
        Minimum clearance to the obstacle [m] (Eq. 21).
    e_recovery : int
        Recovery actions invoked by the navigation stack.
    t_nav : float
        Navigation time from NavigateToPose feedback [s].
    """

    p_success: float
    c_count: int
    d_min: float
    e_recovery: int
    t_nav: float

    def as_tuple(self) -> tuple[float, int, float, int, float]:
        """The vector in the paper's order."""
        return (self.p_success, self.c_count, self.d_min, self.e_recovery, self.t_nav)


def safety_vector(
    successes: int,
    attempts: int,
    collisions: int,
    d_min_m: float,
    recoveries: int,
    t_nav_s: float,
) -> SafetyVector:
    """The safety-performance vector of Eq. 16, P_success = successes / attempts.

    Parameters
    ----------
    successes : int
        Runs that reached the goal.
    attempts : int
        All attempted runs, including unsuccessful and aborted ones (Sec. 2.5.5), > 0.
    collisions : int
        Contact events C_count.
    d_min_m : float
        Minimum clearance [m] (:func:`d_min`, or its summary over runs).
    recoveries : int
        Recovery actions E_recovery.
    t_nav_s : float
        Navigation time [s].

    Returns
    -------
    SafetyVector
    """
    if attempts <= 0:
        raise MetricInputError(f"attempts must be > 0, got {attempts}")
    if not 0 <= successes <= attempts:
        raise MetricInputError(f"successes must be in [0, {attempts}], got {successes}")
    if collisions < 0 or recoveries < 0:
        raise MetricInputError("collisions and recoveries are counts, >= 0")
    return SafetyVector(
        p_success=successes / attempts,
        c_count=int(collisions),
        d_min=float(d_min_m),
        e_recovery=int(recoveries),
        t_nav=float(t_nav_s),
    )
