"""A DWB-style local planner: sample (v, w), roll each out, score it with weighted critics.

Each control period (1 / controller_frequency; Nav2 bringup: 20 Hz) the planner
(:class:`DwbPlanner`, :mod:`.planner`)

1. samples the dynamic window: the velocities reachable from the current one within
   ``sim_time`` under the limiter's bounds, ``vx_samples`` x ``vtheta_samples`` targets
   (:mod:`.window`);
2. applies the minimum in-place rotation speed (DWB's min_speed_theta; REFERENCE: 0.30 rad/s)
   to the targets with v = 0 (:mod:`.window`);
3. rolls every target out for ``sim_time`` (1.7 s), ramping from the current velocity at the
   limiter's bounds, at DWB's granularity (:mod:`.rollouts`);
4. prepares every critic with the cycle's context (:class:`~.critics.base.Context`): pose,
   velocity, goal, costmap, the global path's cells in the window (:mod:`.path`) and the
   distance maps over the costmap (:mod:`.distance`);
5. scores all roll-outs at once, critic by critic, J = sum_i scale_i raw_i over the critics
   whose scale is not 0, in Nav2 bringup's order (Eq. 11 of the paper, with bringup's critics
   and scales, :mod:`.critics`); a critic may also reject a roll-out (BaseObstacle rejects
   the colliding ones, :mod:`.critics.base_obstacle`);
6. returns the lowest total's target (as DWB does; the limiter ramps towards it), or no
   command when every roll-out is rejected (DWB's "no legal trajectories"), with the share
   each critic rejected; the critics are then debriefed with the command.

The cycle is vectorised over all targets, and evaluates only what it reads: the roll-outs are
kept factored by axis (:class:`~.rollouts.Rollouts`), the arrays the critics read (end poses,
every 16th pose, cells) are computed once per cycle and shared (:class:`~.critics.base.Batch`),
the poses of the collision test only for the roll-outs that come near an obstacle, and the
whole trajectory only for the one chosen.

Where this differs from Nav2's DWB, measured on the paper's Stage 3 course in closed loop:

* the window spans ``sim_time``, not one period (Nav2's LimitedAccelGenerator): from rest the
  one-period window only holds 4 cm roll-outs, which leave the cell-quantised distance maps
  unchanged, and the robot never started;
* distances stop at obstacles: through them, GoalDist and GoalAlign (48 per cell together,
  Manhattan) pull the robot straight at the cylinder whenever the goal lies within the window;
  in 6 of 8 runs of the course the robot was still trapped in front of it after 60 s;
* collisions are tested against the obstacles' returns, not cells, with an escape rule for a
  robot already touching one (see :mod:`jackson.host.nav.costmap`);
* GoalAlign and PathAlign are off while RotateToGoal turns the stopped robot to the goal's
  yaw: a turn of d rad moves their 0.1 m forward point by 2 d cells (48 d) while RotateToGoal
  gains only 32 d, so the robot never turned.
"""

from __future__ import annotations

from jackson.host.nav.dwb.core.config import Command, DwbConfig
from jackson.host.nav.dwb.core.distance import grid_distance, grid_graph
from jackson.host.nav.dwb.core.path import densify, own_granularity, prune_path
from jackson.host.nav.dwb.core.rollouts import Rollouts
from jackson.host.nav.dwb.core.window import velocity_profile
from jackson.host.nav.dwb.critics import (
    CRITICS,
    BaseObstacleCritic,
    Batch,
    Context,
    Critic,
    GoalAlignCritic,
    GoalDistCritic,
    OscillationCritic,
    PathAlignCritic,
    PathDistCritic,
    RotateToGoalCritic,
    bringup_critics,
)
from jackson.host.nav.dwb.critics.base import _CULL_STEPS
from jackson.host.nav.dwb.planner import DwbPlanner

__all__ = [
    "CRITICS",
    "_CULL_STEPS",
    "BaseObstacleCritic",
    "Batch",
    "Command",
    "Context",
    "Critic",
    "DwbConfig",
    "DwbPlanner",
    "GoalAlignCritic",
    "GoalDistCritic",
    "OscillationCritic",
    "PathAlignCritic",
    "PathDistCritic",
    "Rollouts",
    "RotateToGoalCritic",
    "bringup_critics",
    "densify",
    "grid_distance",
    "grid_graph",
    "own_granularity",
    "prune_path",
    "velocity_profile",
]
