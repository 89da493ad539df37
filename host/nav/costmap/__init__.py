"""Layered 2-D costmaps as Nav2 builds them (``nav2_costmap_2d``).

- :mod:`.values`: the cost values, :class:`CostmapConfig` and Nav2's inflation cost;
- :mod:`.layers`: the static, obstacle and inflation layers behind one ``Layer`` interface;
- :mod:`.layered`: :class:`Costmap`, the master grid combining them, fixed over a map (the
  global costmap) or rolling with the robot (the local costmap);
- :mod:`.footprint`: the footprint collision checker the local costmap gives each version of
  its costs (DWB's collision critic and the recoveries ask it).

Every grid is placed by one :class:`~jackson.common.geometry.GridGeometry` (origin,
resolution, size), the arithmetic the occupancy grid and the likelihood field share.
"""

from jackson.common.robot import ENVELOPE_X_M as ENVELOPE_X_M
from jackson.common.robot import ENVELOPE_Y_M as ENVELOPE_Y_M
from jackson.host.nav.costmap.footprint import BODY_STEP_M as BODY_STEP_M
from jackson.host.nav.costmap.footprint import FootprintChecker as FootprintChecker
from jackson.host.nav.costmap.layered import Costmap as Costmap
from jackson.host.nav.costmap.layers import InflationLayer as InflationLayer
from jackson.host.nav.costmap.layers import Layer as Layer
from jackson.host.nav.costmap.layers import ObstacleLayer as ObstacleLayer
from jackson.host.nav.costmap.layers import StaticLayer as StaticLayer
from jackson.host.nav.costmap.values import FREE_SPACE as FREE_SPACE
from jackson.host.nav.costmap.values import (
    INSCRIBED_INFLATED_OBSTACLE as INSCRIBED_INFLATED_OBSTACLE,
)
from jackson.host.nav.costmap.values import LETHAL_OBSTACLE as LETHAL_OBSTACLE
from jackson.host.nav.costmap.values import MAX_NON_OBSTACLE as MAX_NON_OBSTACLE
from jackson.host.nav.costmap.values import NO_INFORMATION as NO_INFORMATION
from jackson.host.nav.costmap.values import CostmapConfig as CostmapConfig
from jackson.host.nav.costmap.values import inflation_cost as inflation_cost
from jackson.host.nav.costmap.values import occupancy_from_costs as occupancy_from_costs
