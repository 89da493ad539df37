"""A LiDAR revolution as the sensor would have measured it standing at one pose (deskewing).

An RPLIDAR's head turns clockwise from its zero mark once a revolution and measures as it
turns: the return at heading ``h`` (``-angle`` in the sensor frame, wrapped to [0, 2 pi)) is
measured a share ``h / 2 pi`` of the way through the revolution. A robot that moves meanwhile
measures each return from another pose: at the robot's 0.26 m/s and 1 rad/s the first and the
last returns of an A1M8's 0.135 s revolution were taken 3.5 cm and 7.7 degrees apart, and
paired with one pose the revolution is bent (a wall ahead breaks where the turn began, the
matcher turns the whole scan by part of the motion, and the map turns with it). :func:`deskew`
puts every return where the sensor at one instant of the revolution would have seen it, from
the base's motion over the revolution (its odometry: the EKF's base pose at the revolution's
start and end), the pose between them taken linearly (an arc's chord differs from it by its
sagitta, 0.4 mm at the figures above), as Cartographer's and LIO pipelines deskew with the
odometry.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.host.nav.types import Pose2D, Scan

FloatArray = npt.NDArray[np.float64]

MIN_MOTION_M = 1e-6  # [m] less motion than this over a revolution, and the rad below: as is
MIN_MOTION_RAD = 1e-7


def beam_shares(angles_rad: npt.ArrayLike) -> FloatArray:
    """The share of the revolution gone by when each return was measured, in [0, 1): its
    heading (``-angle`` wrapped to [0, 2 pi)) over a full turn."""
    return np.mod(-np.asarray(angles_rad, np.float64), math.tau) / math.tau


def deskew(scan: Scan, mount: Pose2D, motion: Pose2D, at: float = 1.0) -> Scan:
    """The revolution with every return moved to where the sensor would have seen it from the
    base's pose a share ``at`` of the way through the revolution (1: its end).

    Parameters
    ----------
    scan : Scan
        The revolution as measured, in the sensor frame.
    mount : Pose2D
        The sensor's pose on the base.
    motion : Pose2D
        The base's pose at the revolution's end in its frame at the revolution's start
        (``start⁻¹ ⊕ end`` of the odometry).
    at : float
        Where in the revolution the returned scan is taken, in [0, 1].

    Returns
    -------
    Scan
        The same beams (no return stays no return, at its angle); each return's angle and
        range from the sensor at that pose, the angle wrapped to [-pi, pi). ``scan`` itself
        when the base did not move.
    """
    turn = math.remainder(motion.yaw, math.tau)
    if math.hypot(motion.x, motion.y) < MIN_MOTION_M and abs(turn) < MIN_MOTION_RAD:
        return scan
    r = np.asarray(scan.ranges_m, np.float64)
    a = np.asarray(scan.angles_rad, np.float64)
    ok = np.isfinite(r) & (r > 0.0)
    # the base's pose at each return's instant in its frame at ``at``: B(at)⁻¹ ⊕ B(g), with
    # B(g) = g ⊕ motion taken linearly
    d = beam_shares(a[ok]) - at
    c, s = math.cos(at * turn), math.sin(at * turn)
    px = d * (c * motion.x + s * motion.y)
    py = d * (-s * motion.x + c * motion.y)
    pyaw = d * turn
    # the return in the base frame at its instant, then in the frame at ``at``
    ang = a[ok] + mount.yaw
    qx = mount.x + r[ok] * np.cos(ang)
    qy = mount.y + r[ok] * np.sin(ang)
    cp, sp = np.cos(pyaw), np.sin(pyaw)
    wx = px + cp * qx - sp * qy - mount.x
    wy = py + sp * qx + cp * qy - mount.y
    # into the sensor frame at ``at``
    cm, sm = math.cos(mount.yaw), math.sin(mount.yaw)
    sx, sy = cm * wx + sm * wy, -sm * wx + cm * wy
    ranges = r.copy()
    angles = a.copy()
    ranges[ok] = np.hypot(sx, sy)
    angles[ok] = np.remainder(np.arctan2(sy, sx) + math.pi, math.tau) - math.pi
    return Scan(
        scan.t_s, angles, ranges.astype(scan.ranges_m.dtype), scan.range_min_m, scan.range_max_m
    )
