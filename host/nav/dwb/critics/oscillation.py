"""Oscillation: no reversal of an in-place rotation until the robot has moved.

Raw score 0. After a command rotating (at |v| <= ``oscillation_x_only_threshold``, 0 in
bringup) against the sign of the previous such command, it rejects every roll-out rotating
against the new sign, until the robot moved ``oscillation_reset_dist`` (0.05 m) or turned
``oscillation_reset_angle`` (0.2 rad) from where the flip happened. Scale 1.0.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angle
from jackson.host.nav.dwb.core.config import Command, DwbConfig
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class OscillationCritic(Critic):
    """Reject reversals of the in-place rotation until the robot has moved (stateful).

    Parameters
    ----------
    config : DwbConfig
        Scale, reset distance and angle, x-only threshold.

    Attributes
    ----------
    positive_only, negative_only : bool
        Which rotations are allowed since the last flip.
    """

    name = "Oscillation"

    def __init__(self, config: DwbConfig) -> None:
        self.config = config
        self.reset()
        self._stationary = Pose2D()
        self._pose = Pose2D()

    @property
    def scale(self) -> float:
        """``oscillation_scale``."""
        return self.config.oscillation_scale

    def reset(self) -> None:
        """Clear the rotation trend."""
        self._sign = 0
        self.positive_only = False
        self.negative_only = False

    def prepare(self, context: Context) -> bool:
        """Keep the pose the command will be chosen from (for :meth:`debrief`)."""
        self._pose = context.pose
        return True

    def allowed(self, w: FloatArray) -> BoolArray:
        """Which angular velocities the trend allows.

        Parameters
        ----------
        w : ndarray, shape (M,)
            Angular velocities [rad/s].

        Returns
        -------
        ndarray of bool, shape (M,)
            False for a rotation against the allowed sign.
        """
        if not (self.positive_only or self.negative_only):
            return np.ones(w.shape[0], bool)
        bad = (self.positive_only & (w < 0.0)) | (self.negative_only & (w > 0.0))
        return ~bad

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores (0) and legality (:meth:`allowed` of the angular targets)."""
        return np.zeros(batch.size), self.allowed(batch.w_rad_s)

    def debrief(self, command: Command) -> None:
        """Update the trend with the command chosen from the pose of :meth:`prepare`."""
        self.record(self._pose, command.v_m_s, command.w_rad_s)

    def record(self, pose: Pose2D, v_m_s: float, w_rad_s: float) -> None:
        """Update the trend with the command sent from ``pose``.

        Parameters
        ----------
        pose : Pose2D
            Robot pose when the command was chosen.
        v_m_s, w_rad_s : float
            The command [m/s], [rad/s].
        """
        c = self.config
        flipped = False
        if abs(v_m_s) <= c.oscillation_x_only_threshold_m_s and w_rad_s != 0.0:
            sign = 1 if w_rad_s > 0.0 else -1
            if self._sign == -sign:
                flipped = True
                self.positive_only = self.positive_only or sign > 0
                self.negative_only = self.negative_only or sign < 0
            self._sign = sign
        if flipped:
            self._stationary = pose
        if self.positive_only or self.negative_only:
            moved = pose.distance(self._stationary) > c.oscillation_reset_dist_m
            turned = abs(wrap_angle(pose.yaw - self._stationary.yaw)) > (
                c.oscillation_reset_angle_rad
            )
            if moved or turned:
                self.reset()
