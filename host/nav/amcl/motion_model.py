"""The odometry motion model of the particle filter: the role of Nav2's differential model.

Between two sensor updates the odometry reports a change of pose; every particle moves by its
own noisy draw of that change (Probabilistic Robotics, Table 5.6: a turn towards the direction
of travel, a straight line, a final turn, each with normal noise whose variance grows with the
squares of the three, weighted by ``alpha1``-``alpha4``). The model is sampled once per filter
update on the whole change since the previous one, so the cloud's growth does not depend on how
often odometry arrives.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angle, wrap_angles
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]

BEARING_MIN_TRANSLATION_M = 0.01
"""Below this odometry translation the bearing of the motion is not defined and ``rot1`` is 0
(an in-place turn), as in AMCL's differential model [m]."""


def sample_motion_model_odometry(
    particles: FloatArray,
    odom_from: Pose2D,
    odom_to: Pose2D,
    alphas: tuple[float, float, float, float],
    rng: np.random.Generator,
) -> FloatArray:
    """Move every particle by one noisy draw of the odometry change (Table 5.6).

    The odometry change from ``odom_from`` to ``odom_to`` is split into a turn towards the
    direction of travel, a straight line and a final turn::

        rot1  = atan2(y' - y, x' - x) - theta     (0 when the translation is under 0.01 m)
        trans = sqrt((x' - x)^2 + (y' - y)^2)
        rot2  = theta' - theta - rot1

    and each particle draws its own version of them::

        rot1^  = rot1  - N(0, alpha1 rot1^2 + alpha2 trans^2)
        trans^ = trans - N(0, alpha3 trans^2 + alpha4 rot1^2 + alpha4 rot2^2)
        rot2^  = rot2  - N(0, alpha1 rot2^2 + alpha2 trans^2)

    (the arguments of N are variances). As in AMCL, the rotations enter the noise terms folded
    onto the nearer of 0 and pi, so driving backwards (``rot1`` near pi) is as noisy as driving
    forwards rather than as noisy as a half turn.

    Parameters
    ----------
    particles : ndarray of float, shape (N, 3)
        Poses ``(x [m], y [m], yaw [rad])`` in the map frame.
    odom_from, odom_to : Pose2D
        Odometry poses (odometry frame) before and after the motion.
    alphas : tuple of float
        ``(alpha1, alpha2, alpha3, alpha4)``.
    rng : numpy.random.Generator
        Source of the three normal draws per particle.

    Returns
    -------
    ndarray of float, shape (N, 3)
        The moved particles, yaw wrapped to [-pi, pi).
    """
    a1, a2, a3, a4 = alphas
    dx, dy = odom_to.x - odom_from.x, odom_to.y - odom_from.y
    trans = math.hypot(dx, dy)
    rot1 = (
        0.0 if trans < BEARING_MIN_TRANSLATION_M else wrap_angle(math.atan2(dy, dx) - odom_from.yaw)
    )
    rot2 = wrap_angle(wrap_angle(odom_to.yaw - odom_from.yaw) - rot1)
    rot1_n = min(abs(rot1), abs(wrap_angle(rot1 - math.pi)))
    rot2_n = min(abs(rot2), abs(wrap_angle(rot2 - math.pi)))
    sd = np.sqrt(
        [
            a1 * rot1_n**2 + a2 * trans**2,
            a3 * trans**2 + a4 * rot1_n**2 + a4 * rot2_n**2,
            a1 * rot2_n**2 + a2 * trans**2,
        ]
    )
    n = len(particles)
    noise = rng.standard_normal((3, n)) * sd[:, None]
    rot1_hat = rot1 - noise[0]
    trans_hat = trans - noise[1]
    rot2_hat = rot2 - noise[2]
    out = np.empty_like(particles)
    heading = particles[:, 2] + rot1_hat
    out[:, 0] = particles[:, 0] + trans_hat * np.cos(heading)
    out[:, 1] = particles[:, 1] + trans_hat * np.sin(heading)
    out[:, 2] = wrap_angles(heading + rot2_hat)
    return out
