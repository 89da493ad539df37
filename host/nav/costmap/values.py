"""The costmap's parameters and the inflation cost function; the cost values
(:mod:`jackson.host.nav.cost_values`, re-exported).

The inflation layer spreads every lethal cell over the distance d from its centre:

    c(d) = 254                                       d = 0 (the lethal cell itself)
    c(d) = 253                                       0 < d <= r_inscribed
    c(d) = floor(252 exp(-k (d - r_inscribed)))      r_inscribed < d <= r_inflation
    c(d) = 0                                         d > r_inflation

with k the cost scaling factor (REFERENCE Stage 3: r_inscribed = robot radius 0.16 m,
r_inflation = 0.25 m, k = 10.0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.common.robot import ENVELOPE_X_M, ENVELOPE_Y_M
from jackson.host.nav.cost_values import FREE_SPACE as FREE_SPACE
from jackson.host.nav.cost_values import INSCRIBED_INFLATED_OBSTACLE as INSCRIBED_INFLATED_OBSTACLE
from jackson.host.nav.cost_values import LETHAL_OBSTACLE as LETHAL_OBSTACLE
from jackson.host.nav.cost_values import MAX_NON_OBSTACLE as MAX_NON_OBSTACLE
from jackson.host.nav.cost_values import NO_INFORMATION as NO_INFORMATION

FloatArray = npt.NDArray[np.float64]
CostArray = npt.NDArray[np.uint8]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int_]


@dataclass(frozen=True)
class CostmapConfig:
    """Robot shape, inflation and the obstacle layer's ranges.

    Attributes
    ----------
    robot_radius_m : float
        Inscribed radius used by the inflation (REFERENCE: robot radius 0.16 m).
    inflation_radius_m : float
        Distance from an obstacle cell beyond which no cost is added (REFERENCE: 0.25 m).
    cost_scaling_factor : float
        k of the exponential decay [1/m] (REFERENCE: 10.0).
    footprint_x_m, footprint_y_m : tuple of float
        The oriented collision envelope, robot frame [m] (REFERENCE App. D.3), checked on top
        of the inscribed circle by :meth:`Costmap.footprint_collides`.
    obstacle_max_range_m, obstacle_min_range_m : float
        Returns farther or nearer than these do not mark (Nav2 bringup: 2.5 m, 0 m).
    raytrace_max_range_m, raytrace_min_range_m : float
        Rays are cleared up to this length; returns nearer than the minimum clear nothing
        (Nav2 bringup: 3.0 m, 0 m).
    lethal_threshold_percent : int
        A static-map cell at or above this occupancy is lethal (map_server's occupied
        threshold, 65 %).
    track_unknown_space : bool
        Keep unknown cells as NO_INFORMATION (True) or treat them as free (False).
    range_noise_m : float
        The LiDAR's range noise, one standard deviation [m] (REFERENCE: 0.010 m): the
        recoveries' body test (:meth:`Costmap.body_contacts`) tells a wall's noise from its
        extent with it.
    """

    robot_radius_m: float = 0.16
    inflation_radius_m: float = 0.25
    cost_scaling_factor: float = 10.0
    footprint_x_m: tuple[float, float] = ENVELOPE_X_M
    footprint_y_m: tuple[float, float] = ENVELOPE_Y_M
    obstacle_max_range_m: float = 2.5
    obstacle_min_range_m: float = 0.0
    raytrace_max_range_m: float = 3.0
    raytrace_min_range_m: float = 0.0
    lethal_threshold_percent: int = 65
    track_unknown_space: bool = False
    range_noise_m: float = 0.010

    def __post_init__(self) -> None:
        if not 0.0 < self.robot_radius_m < math.inf:
            raise ValueError(f"CostmapConfig.robot_radius_m must be > 0, got {self.robot_radius_m}")
        if not self.robot_radius_m <= self.inflation_radius_m < math.inf:
            raise ValueError(
                "CostmapConfig.inflation_radius_m must be >= robot_radius_m, "
                f"got {self.inflation_radius_m}"
            )
        if not 0.0 <= self.cost_scaling_factor < math.inf:
            raise ValueError(
                f"CostmapConfig.cost_scaling_factor must be >= 0, got {self.cost_scaling_factor}"
            )
        for name in ("footprint_x_m", "footprint_y_m"):
            low, high = getattr(self, name)
            if not low < 0.0 < high:
                raise ValueError(f"CostmapConfig.{name} must bracket 0, got {(low, high)}")
        for name in ("obstacle", "raytrace"):
            low, high = getattr(self, f"{name}_min_range_m"), getattr(self, f"{name}_max_range_m")
            if not 0.0 <= low < high:
                raise ValueError(
                    f"CostmapConfig.{name}_max_range_m must exceed {name}_min_range_m >= 0, "
                    f"got {low}, {high}"
                )
        if not 0.0 <= self.range_noise_m < math.inf:
            raise ValueError(f"CostmapConfig.range_noise_m must be >= 0, got {self.range_noise_m}")
        if not 0 < self.lethal_threshold_percent <= 100:
            raise ValueError(
                "CostmapConfig.lethal_threshold_percent must be in 1..100, "
                f"got {self.lethal_threshold_percent}"
            )

    @property
    def circumscribed_radius_m(self) -> float:
        """Distance from the robot's origin to the farthest corner of the footprint [m]."""
        return max(math.hypot(x, y) for x in self.footprint_x_m for y in self.footprint_y_m)


def inflation_cost(
    distance_m: npt.ArrayLike,
    inscribed_radius_m: float,
    inflation_radius_m: float,
    cost_scaling_factor: float,
) -> CostArray:
    """Nav2's inflation cost of a cell at ``distance_m`` from the nearest lethal cell.

    254 at d = 0, 253 for d <= r_inscribed, floor(252 exp(-k (d - r_inscribed))) up to the
    inflation radius, 0 beyond it.

    Parameters
    ----------
    distance_m : array_like
        Distances between cell centres [m].
    inscribed_radius_m : float
        r_inscribed [m].
    inflation_radius_m : float
        r_inflation [m].
    cost_scaling_factor : float
        k [1/m].

    Returns
    -------
    ndarray of uint8
        Costs, the shape of ``distance_m``.
    """
    d = np.asarray(distance_m, np.float64)
    decay = MAX_NON_OBSTACLE * np.exp(-cost_scaling_factor * (d - inscribed_radius_m))
    cost = np.where(d <= inflation_radius_m, np.floor(np.minimum(decay, MAX_NON_OBSTACLE)), 0)
    cost = np.where(d <= inscribed_radius_m, INSCRIBED_INFLATED_OBSTACLE, cost)
    cost = np.where(d <= 0.0, LETHAL_OBSTACLE, cost)
    return cost.astype(np.uint8)


def occupancy_from_costs(costs: npt.NDArray[np.uint8]) -> npt.NDArray[np.int8]:
    """Costs as ``nav_msgs/OccupancyGrid`` values, the way Nav2 publishes a costmap.

    0 -> 0, 1..252 -> 1 + 97 (c - 1) / 251 (integer division), 253 -> 99, 254 -> 100,
    255 -> -1.

    Parameters
    ----------
    costs : ndarray of uint8
        Costmap values.

    Returns
    -------
    ndarray of int8
        Occupancy values, same shape.
    """
    c = costs.astype(np.int32)
    out = np.where(c == 0, 0, 1 + (97 * (c - 1)) // 251)
    out = np.where(c == INSCRIBED_INFLATED_OBSTACLE, 99, out)
    out = np.where(c == LETHAL_OBSTACLE, 100, out)
    out = np.where(c == NO_INFORMATION, -1, out)
    return out.astype(np.int8)
