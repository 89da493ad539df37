"""The planner's parameters and its answer: :class:`DwbConfig` and :class:`Command`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from jackson.protocol.messages import TELEMETRY_RATE_HZ_DEFAULT

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class DwbConfig:
    """Sampling, simulation and critic parameters (Nav2 bringup's DWB values by default).

    Attributes
    ----------
    controller_frequency_hz : float
        Control rate [Hz]: the telemetry rate (protocol/schema.yaml, 20), since the
        navigator steps once per telemetry frame.
    vx_samples, vtheta_samples : int
        Samples across the window per axis (20, 20).
    sim_time_s : float
        Roll-out length [s] (1.7).
    linear_granularity_m, angular_granularity_rad : float
        Largest step between roll-out poses [m], [rad] (0.05, 0.025).
    min_vel_x_m_s : float
        Lowest linear velocity sampled [m/s] (0: no reversing).
    min_speed_theta_rad_s : float
        Lowest |w| of an in-place rotation [rad/s] (REFERENCE: 0.30).
    xy_goal_tolerance_m : float
        Distance at which RotateToGoal takes over [m] (REFERENCE: 0.25).
    trans_stopped_velocity_m_s : float
        Speed below which the robot counts as stopped at the goal [m/s] (0.25).
    rotate_to_goal_scale, rotate_to_goal_slowing_factor, rotate_to_goal_lookahead_time_s
        RotateToGoal (32.0, 5.0, -1.0: the trajectory's end).
    oscillation_scale, oscillation_reset_dist_m, oscillation_reset_angle_rad
        Oscillation (1.0, 0.05 m, 0.2 rad).
    oscillation_x_only_threshold_m_s : float
        The rotation trend is tracked only at |v| at or below this [m/s] (0: DWB's value
        when min_speed_xy is 0, as in bringup).
    base_obstacle_scale : float
        BaseObstacle (0.02).
    goal_align_scale, goal_align_forward_point_distance_m
        GoalAlign (24.0, 0.1 m).
    path_align_scale, path_align_forward_point_distance_m
        PathAlign (32.0, 0.1 m).
    path_dist_scale, goal_dist_scale : float
        PathDist (32.0), GoalDist (24.0).
    prune_distance_m, forward_prune_distance_m : float
        How much of the global path behind and ahead of the robot the critics use [m]
        (2.0, 2.0; both capped at half the local window).
    short_circuit_trajectory_evaluation : bool
        Ask a critic whose legality is costly (BaseObstacle's collision test,
        :class:`~jackson.host.nav.dwb.critics.base.DeferredLegality`) only about the roll-outs
        in order of total up to the first legal one, as Nav2's DWB stops scoring a trajectory
        once it cannot win (true, as in bringup). The command is the same;
        :attr:`Command.legal` then counts the roll-outs not found illegal.
    """

    controller_frequency_hz: float = float(TELEMETRY_RATE_HZ_DEFAULT)
    vx_samples: int = 20
    vtheta_samples: int = 20
    sim_time_s: float = 1.7
    linear_granularity_m: float = 0.05
    angular_granularity_rad: float = 0.025
    min_vel_x_m_s: float = 0.0
    min_speed_theta_rad_s: float = 0.30
    xy_goal_tolerance_m: float = 0.25
    trans_stopped_velocity_m_s: float = 0.25
    rotate_to_goal_scale: float = 32.0
    rotate_to_goal_slowing_factor: float = 5.0
    rotate_to_goal_lookahead_time_s: float = -1.0
    oscillation_scale: float = 1.0
    oscillation_reset_dist_m: float = 0.05
    oscillation_reset_angle_rad: float = 0.2
    oscillation_x_only_threshold_m_s: float = 0.0
    base_obstacle_scale: float = 0.02
    goal_align_scale: float = 24.0
    goal_align_forward_point_distance_m: float = 0.1
    path_align_scale: float = 32.0
    path_align_forward_point_distance_m: float = 0.1
    path_dist_scale: float = 32.0
    goal_dist_scale: float = 24.0
    prune_distance_m: float = 2.0
    forward_prune_distance_m: float = 2.0
    short_circuit_trajectory_evaluation: bool = True

    def __post_init__(self) -> None:
        for name in (
            "controller_frequency_hz", "sim_time_s", "linear_granularity_m",
            "angular_granularity_rad", "xy_goal_tolerance_m", "prune_distance_m",
            "forward_prune_distance_m",
        ):  # fmt: skip
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"DwbConfig.{name} must be finite and > 0, got {value}")
        for name in ("vx_samples", "vtheta_samples"):
            if getattr(self, name) < 1:
                raise ValueError(f"DwbConfig.{name} must be >= 1, got {getattr(self, name)}")
        for name in (
            "min_vel_x_m_s", "min_speed_theta_rad_s", "trans_stopped_velocity_m_s",
            "rotate_to_goal_scale", "rotate_to_goal_slowing_factor", "oscillation_scale",
            "oscillation_x_only_threshold_m_s", "base_obstacle_scale", "goal_align_scale",
            "goal_align_forward_point_distance_m", "path_align_scale",
            "path_align_forward_point_distance_m", "path_dist_scale", "goal_dist_scale",
        ):  # fmt: skip
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"DwbConfig.{name} must be finite and >= 0, got {value}")

    @property
    def sim_period_s(self) -> float:
        """One control period [s]."""
        return 1.0 / self.controller_frequency_hz


@dataclass(frozen=True)
class Command:
    """The local planner's choice for one control period.

    Attributes
    ----------
    v_m_s, w_rad_s : float
        Velocity command [m/s], [rad/s]; (0, 0) when ``valid`` is False.
    trajectory : ndarray, shape (K, 3)
        The chosen roll-out (x [m], y [m], yaw [rad], map frame): /local_plan; empty when
        no trajectory was legal.
    scores : Mapping of str to float
        Weighted score (scale x raw) of each critic for the chosen trajectory.
    total : float
        Sum of ``scores``.
    valid : bool
        Whether any trajectory was legal.
    reason : str
        Why no trajectory was legal (share of samples each critic rejected), else "".
    samples, legal : int
        Trajectories evaluated and accepted (with the short circuit, those not found illegal:
        the roll-outs after the chosen one in the order of total are not asked about).
    """

    v_m_s: float
    w_rad_s: float
    trajectory: FloatArray
    scores: Mapping[str, float] = field(default_factory=dict)
    total: float = math.inf
    valid: bool = True
    reason: str = ""
    samples: int = 0
    legal: int = 0
