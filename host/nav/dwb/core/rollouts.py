"""The roll-outs of one cycle (step 3): every target simulated for ``sim_time``, kept factored.

Every target is rolled out for ``sim_time`` (1.7 s): the velocity ramps from the current one
towards the target at the limiter's bounds
(:func:`~jackson.host.nav.dwb.core.window.velocity_profile`, the limiter's ramp in continuous
time), the heading integrates it with the trapezoidal rule and the position with the midpoint
heading, in ceil(max(|v| T / 0.05 m, |w| T / 0.025 rad)) steps for the most demanding target (DWB's
granularity rule), shared by all roll-outs.

The roll-outs are kept factored and evaluated only where they are read: the velocity and heading
profiles are computed once per distinct linear and angular target (a 20 x 21 window has about
20 of each), every 16th and the end pose of all roll-outs (:meth:`Rollouts.coarse`), the poses
of the collision test only for the roll-outs that come near an obstacle
(:meth:`Rollouts.at_strides`), and the whole trajectory only for the one chosen
(:meth:`Rollouts.trajectory`). Every position is the running sum of its steps plus the start,
wherever it is made.

With the compiled library (:mod:`jackson.host.nav.native`) the tables and the coarse poses are
made by its loops, with numpy's operations in numpy's order: the same numbers bit for bit.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import numpy.typing as npt

from jackson.host.nav import native, native_grid
from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.core.kinematics import Kinematics
from jackson.host.nav.dwb.core.window import velocity_profile
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
ComplexArray = npt.NDArray[np.complex128]


class Rollouts:
    """The roll-outs of one cycle, kept factored: M targets from V linear and W angular ramps.

    The linear velocity of target m follows linear ramp ``iv[m]``, its angular velocity
    angular ramp ``iw[m]``, so step i (of K) of roll-out m advances

        ds_i = ds[iv, i],   (dx_i, dy_i) = ds_i (cos, sin)(yaw_mid[iw, i])

    and its pose j is yaw_j = yaw[iw, j], (x_j, y_j) = (x_0, y_0) + sum_{i < j} (dx_i, dy_i).
    A cycle reads only part of the M x (K + 1) poses: every 16th pose and the end pose of every
    roll-out (:meth:`coarse`: the end poses for the critics, the others to sort out the
    roll-outs far from obstacles), the poses at a
    stride of the others for the collision test (:meth:`at_strides`) and the whole of the
    chosen one (:meth:`trajectory`); nothing else is evaluated.

    Parameters
    ----------
    pose : Pose2D
        Start pose, map frame.
    t_s : ndarray, shape (K + 1,)
        Time of each pose [s].
    ds_m : ndarray, shape (V, K)
        Path length of each step of each linear ramp [m].
    yaw_rad : ndarray, shape (W, K + 1)
        Heading of each pose of each angular ramp [rad].
    yaw_mid_rad : ndarray, shape (W, K)
        Heading at the middle of each step [rad].
    iv, iw : ndarray of int, shape (M,)
        The ramps of each target.

    Attributes
    ----------
    pose, t_s, ds_m, yaw_rad, iv, iw
        As given.
    cos_sin : ndarray, shape (2 W, K)
        cos (first W rows) and sin (last W rows) of ``yaw_mid_rad``.
    """

    def __init__(
        self,
        pose: Pose2D,
        t_s: FloatArray,
        ds_m: FloatArray,
        yaw_rad: FloatArray,
        yaw_mid_rad: FloatArray,
        iv: IntArray,
        iw: IntArray,
    ) -> None:
        self.pose = pose
        self.t_s = t_s
        self.ds_m = ds_m
        self.yaw_rad = yaw_rad
        self.iv = iv
        self.iw = iw
        w = yaw_mid_rad.shape[0]
        self.cos_sin: FloatArray = np.empty((2 * w, yaw_mid_rad.shape[1]))
        np.cos(yaw_mid_rad, out=self.cos_sin[:w])
        np.sin(yaw_mid_rad, out=self.cos_sin[w:])
        self._heading: ComplexArray | None = None

    @classmethod
    def of_tables(
        cls,
        pose: Pose2D,
        t_s: FloatArray,
        ds_m: FloatArray,
        yaw_rad: FloatArray,
        cos_sin: FloatArray,
        iv: IntArray,
        iw: IntArray,
    ) -> Rollouts:
        """Roll-outs whose mid-step cosines and sines are made already (the compiled front's,
        :mod:`jackson.host.nav.dwb.front`); the other arguments as the constructor's.

        Parameters
        ----------
        pose, t_s, ds_m, yaw_rad, iv, iw
            As the constructor's.
        cos_sin : ndarray, shape (2 W, K)
            cos (first W rows) and sin (last W rows) of the mid-step headings.

        Returns
        -------
        Rollouts
            Holding the arrays given.
        """
        ro = cls.__new__(cls)
        ro.pose, ro.t_s, ro.ds_m, ro.yaw_rad, ro.iv, ro.iw = pose, t_s, ds_m, yaw_rad, iv, iw
        ro.cos_sin = cos_sin
        ro._heading = None
        return ro

    @property
    def steps(self) -> int:
        """K, the steps of every roll-out."""
        return int(self.ds_m.shape[1])

    @property
    def heading(self) -> ComplexArray:
        """cos + i sin of the mid-step headings (W, K): a step is ds * heading, x and y at once."""
        if self._heading is None:
            w = self.cos_sin.shape[0] // 2
            self._heading = np.empty((w, self.steps), np.complex128)
            self._heading.real = self.cos_sin[:w]
            self._heading.imag = self.cos_sin[w:]
        return self._heading

    def coarse(self, stride: int) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Every roll-out at poses 0, stride, 2 stride, ... and K, and its path length between.

        The positions are the running sums of the steps plus the start, as :meth:`full` and
        :meth:`at_strides` make them; the path length of a block is the difference of the
        running sums of |ds| at its ends. Compiled when :mod:`jackson.host.nav.native` is
        (the same sums), else by numpy over all the steps of every roll-out.

        Parameters
        ----------
        stride : int
            Steps per block.

        Returns
        -------
        tuple of ndarray
            (x [m], y [m]) of shape (B + 1, M) at the start pose and the ends of the B blocks
            (the last one may be shorter, it ends at pose K), and the path length of each
            block, shape (B, M) [m].
        """
        if native.LIB is not None:
            return native.dwb_coarse(
                self.ds_m, self.cos_sin, self.iv, self.iw, stride, (self.pose.x, self.pose.y)
            )
        k = self.steps
        w = self.cos_sin.shape[0] // 2
        poses = np.append(np.arange(0, k, stride), k)
        ds = self.ds_m[self.iv]
        at = np.empty((2, ds.shape[0], k + 1))
        at[:, :, 0] = 0.0
        np.cumsum(ds * self.cos_sin[self.iw], axis=1, out=at[0, :, 1:])
        np.cumsum(ds * self.cos_sin[w + self.iw], axis=1, out=at[1, :, 1:])
        run = np.empty((self.ds_m.shape[0], k + 1))
        run[:, 0] = 0.0
        np.cumsum(np.abs(self.ds_m), axis=1, out=run[:, 1:])
        length = (run[:, poses[1:]] - run[:, poses[:-1]]).take(self.iv, axis=0)
        return (
            at[0][:, poses].T + self.pose.x,
            at[1][:, poses].T + self.pose.y,
            np.ascontiguousarray(length.T),
        )

    def at_strides(
        self, rows: IntArray, stride: IntArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, IntArray]:
        """Some roll-outs, each at its own stride, folded into rows of equal length.

        Roll-out ``rows[i]`` is read at poses 0, s, 2 s, ... and K (s = ``stride[i]``). Its
        poses, padded with its last one, fill consecutive rows of as many poses as the
        coarsest stride gives, so that each roll-out's test is one row or a few (the padding
        repeats a pose already read).

        Parameters
        ----------
        rows : ndarray of int, shape (R,)
            The roll-outs.
        stride : ndarray of int, shape (R,)
            Steps between the poses read, 1 to K, per roll-out.

        Returns
        -------
        tuple of ndarray
            (x [m], y [m], yaw [rad]) of shape (P, C), the first row starting at the start
            pose, and the roll-out (of ``rows``) each row belongs to (P,).
        """
        k = self.steps
        # which of ``rows`` and which pose each element of the folded rows reads: the q-th
        # row of a roll-out reads poses (q width + j) s, j < width, the last one beyond K
        n_cols = k // stride + 1 + (k % stride > 0)
        width = int(n_cols.min())
        pieces = -(-n_cols // width)
        which = np.arange(len(rows)).repeat(pieces)
        q = np.arange(len(which)) - (pieces.cumsum() - pieces).repeat(pieces)
        col = (q[:, None] * width + np.arange(width)) * stride[which, None]
        np.minimum(col, k, out=col)
        # these roll-outs step by step, x + i y
        z = np.empty((len(rows), k + 1), np.complex128)
        z[:, 0] = 0.0
        np.cumsum(self.ds_m[self.iv[rows]] * self.heading[self.iw[rows]], axis=1, out=z[:, 1:])
        z += complex(self.pose.x, self.pose.y)
        owner = rows[which]
        at = z.take(which[:, None] * (k + 1) + col)
        yaw = self.yaw_rad.take(self.iw[owner, None] * (k + 1) + col)
        return at.real, at.imag, yaw, owner

    def trajectory(self, m: int) -> FloatArray:
        """Every pose of roll-out ``m``, step by step.

        Parameters
        ----------
        m : int
            The roll-out.

        Returns
        -------
        ndarray, shape (K + 1, 3)
            (x [m], y [m], yaw [rad]) per pose.
        """
        if native.LIB is not None:  # the same sums, in one call
            return native_grid.dwb_trajectory(
                self.ds_m, self.cos_sin, self.yaw_rad, (int(self.iv[m]), int(self.iw[m])),
                (self.pose.x, self.pose.y),
            )  # fmt: skip
        x, y, yaw = self.full(np.array([m]))
        return np.column_stack((x[0], y[0], yaw[0]))

    def full(self, rows: IntArray | None = None) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Every pose of some roll-outs (all by default), step by step.

        Parameters
        ----------
        rows : ndarray of int, shape (R,), or None
            The roll-outs; None for all M.

        Returns
        -------
        tuple of ndarray, shape (R, K + 1)
            (x [m], y [m], yaw [rad]), the start pose first.
        """
        iv = self.iv if rows is None else self.iv[rows]
        iw = self.iw if rows is None else self.iw[rows]
        ds = self.ds_m[iv]
        w = self.cos_sin.shape[0] // 2
        r, k = ds.shape
        x = np.empty((r, k + 1))
        y = np.empty((r, k + 1))
        x[:, 0], y[:, 0] = self.pose.x, self.pose.y
        np.cumsum(ds * self.cos_sin[iw], axis=1, out=x[:, 1:])
        np.cumsum(ds * self.cos_sin[w + iw], axis=1, out=y[:, 1:])
        x[:, 1:] += self.pose.x
        y[:, 1:] += self.pose.y
        return x, y, self.yaw_rad[iw]


def build_rollouts(
    config: DwbConfig,
    kinematics: Kinematics,
    pose: Pose2D,
    velocity: tuple[float, float],
    v: FloatArray,
    w: FloatArray,
) -> Rollouts:
    """Roll every target out from ``pose``, ramping towards it at the limiter's bounds.

    Parameters
    ----------
    config : DwbConfig
        ``sim_time_s`` and the granularities.
    kinematics : Kinematics
        Acceleration and deceleration bounds.
    pose : Pose2D
        Start pose (map frame).
    velocity : tuple of float
        Current (v [m/s], w [rad/s]).
    v, w : ndarray, shape (M,)
        Targets [m/s], [rad/s].

    Returns
    -------
    Rollouts
        K steps of sim_time / K, K = ceil(max(|v| T / 0.05 m, |w| T / 0.025 rad)).
    """
    c, kin = config, kinematics
    t_end = c.sim_time_s
    steps = max(
        float(np.abs(v).max()) * t_end / c.linear_granularity_m,
        float(np.abs(w).max()) * t_end / c.angular_granularity_rad,
    )
    k = max(1, math.ceil(steps - 1e-9))
    t = _pose_times(k, t_end)
    dt = t_end / k
    # the profiles depend on one axis each: computed per distinct target
    uv, iv = _distinct(v)
    uw, iw = _distinct(w)
    if native.LIB is not None:
        ds, yaw, mid = native.dwb_tables(
            (uv, velocity[0], kin.acc_lim_x_m_s2, kin.decel_lim_x_m_s2),
            (uw, velocity[1], kin.acc_lim_theta_rad_s2, kin.decel_lim_theta_rad_s2),
            t, dt, pose.yaw,
        )  # fmt: skip
        return Rollouts(pose, t, ds, yaw, mid, iv, iw)
    vel_v = velocity_profile(velocity[0], uv, t, kin.acc_lim_x_m_s2, kin.decel_lim_x_m_s2)
    vel_w = velocity_profile(
        velocity[1], uw, t, kin.acc_lim_theta_rad_s2, kin.decel_lim_theta_rad_s2
    )
    dyaw = 0.5 * (vel_w[:, 1:] + vel_w[:, :-1]) * dt
    yaw = np.empty_like(vel_w)
    yaw[:, 0] = 0.0
    np.cumsum(dyaw, axis=1, out=yaw[:, 1:])
    yaw += pose.yaw
    mid = yaw[:, :-1] + 0.5 * dyaw
    ds = 0.5 * (vel_v[:, 1:] + vel_v[:, :-1]) * dt
    return Rollouts(pose, t, ds, yaw, mid, iv, iw)


@functools.lru_cache(maxsize=256)
def _pose_times(k: int, t_end_s: float) -> FloatArray:
    """The K + 1 pose times of a roll-out of ``t_end_s`` in K steps [s] (read-only, shared)."""
    t = np.asarray(np.linspace(0.0, t_end_s, k + 1), np.float64)
    t.flags.writeable = False
    return t


def _distinct(a: FloatArray) -> tuple[FloatArray, IntArray]:
    """np.unique(a, return_inverse=True), without the sort when ``a`` is sorted already."""
    if a.size and np.all(a[1:] >= a[:-1]):
        new = np.empty(a.size, bool)
        new[0] = True
        np.not_equal(a[1:], a[:-1], out=new[1:])
        return a[new], np.cumsum(new) - 1
    values, inverse = np.unique(a, return_inverse=True)
    return values, inverse.ravel()
