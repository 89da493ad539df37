"""The critics of Nav2 bringup's DWB, one per module, behind one interface (:mod:`.base`).

============  =====  ==========================================================
critic        scale  module
============  =====  ==========================================================
RotateToGoal  32.0   :mod:`.rotate_to_goal`: the goal's yaw, inside the goal window
Oscillation   1.0    :mod:`.oscillation`: no reversal of an in-place rotation
BaseObstacle  0.02   :mod:`.base_obstacle`: no collision, the cost at the end
GoalAlign     24.0   :mod:`.goal_align`: the nose towards the goal
PathAlign     32.0   :mod:`.path_align`: the nose on the path (x resolution / 2)
PathDist      32.0   :mod:`.path_dist`: the end near the path
GoalDist      24.0   :mod:`.goal_dist`: the end near the goal
============  =====  ==========================================================

The four distance critics are one family, as in DWB: each reads a distance map at one point of
the roll-out (:mod:`.map_grid`, DWB's MapGridCritic); PathAlign is a PathDist scored at a point
projected ahead, GoalAlign a GoalDist with its target pushed on and the same forward point.
"""

from __future__ import annotations

from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic
from jackson.host.nav.dwb.critics.base_obstacle import BaseObstacleCritic
from jackson.host.nav.dwb.critics.goal_align import GoalAlignCritic
from jackson.host.nav.dwb.critics.goal_dist import GoalDistCritic
from jackson.host.nav.dwb.critics.oscillation import OscillationCritic
from jackson.host.nav.dwb.critics.path_align import PathAlignCritic
from jackson.host.nav.dwb.critics.path_dist import PathDistCritic
from jackson.host.nav.dwb.critics.rotate_to_goal import RotateToGoalCritic

__all__ = [
    "CRITICS",
    "BaseObstacleCritic",
    "Batch",
    "Context",
    "Critic",
    "GoalAlignCritic",
    "GoalDistCritic",
    "OscillationCritic",
    "PathAlignCritic",
    "PathDistCritic",
    "RotateToGoalCritic",
    "bringup_critics",
]

CRITICS = (
    RotateToGoalCritic.name,
    OscillationCritic.name,
    BaseObstacleCritic.name,
    GoalAlignCritic.name,
    PathAlignCritic.name,
    PathDistCritic.name,
    GoalDistCritic.name,
)
"""Critic names, in Nav2 bringup's order."""


def bringup_critics(config: DwbConfig) -> tuple[Critic, ...]:
    """Nav2 bringup's critics, in its order (:data:`CRITICS`).

    Parameters
    ----------
    config : DwbConfig
        Their parameters.

    Returns
    -------
    tuple of Critic
        New critics; GoalAlign and PathAlign stand aside while this RotateToGoal rotates.
    """
    rotate_to_goal = RotateToGoalCritic(config)
    return (
        rotate_to_goal,
        OscillationCritic(config),
        BaseObstacleCritic(config),
        GoalAlignCritic(config, rotate_to_goal),
        PathAlignCritic(config, rotate_to_goal),
        PathDistCritic(config),
        GoalDistCritic(config),
    )
