"""The patrol's floor: the goals it may send and the obstacles it drops.

Random goals are free points of the floor with :data:`CLEARANCE_M` of clearance, reachable from
the start and :data:`DROP_KEEPOUT_M` from every drop spot, sent at least :data:`MIN_TRIP_M` from
the robot; on a map the robot built, only those the map knows as free with
:data:`MAP_CLEARANCE_M` of clearance (an operator sends goals on the map they have). Drops are
cylinders on the floor's drop spots at random MCU times (the world's timed triggers). A map
the daemon is given must be one of the world, in its frame (:func:`check_map_frame`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml
from scipy import ndimage

from jackson.common.fields import read_yaml
from jackson.common.geometry import world_to_cell
from jackson.experiments.patrol.records import PatrolError, PatrolSpec
from jackson.host.nav.grid import OccupancyGrid
from jackson.sim.config import WORLDS_DIR, WorldSpec, resolve

CLEARANCE_M = 0.5  # [m] a random goal's distance to the nearest obstacle
MIN_TRIP_M = 2.5  # [m] a random goal's distance from the robot
DROP_KEEPOUT_M = 1.0  # [m] a random goal's distance from every drop spot
DROP_RADIUS_M = 0.15  # [m] a dropped cylinder
MAP_CLEARANCE_M = 0.3  # [m] a goal's distance to the nearest occupied cell of the daemon's map
ON_WALL_M = 0.15  # [m] a map's occupied cell this close to a true obstacle lies on it
MIN_ON_WALL = 0.5  # the share of a map's occupied cells on true obstacles in the world's frame


def goal_cells(
    world: WorldSpec, resolution_m: float = 0.05, grid: OccupancyGrid | None = None
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Candidate goal points (x, y arrays [m]): free, reachable from the start, with
    :data:`CLEARANCE_M` of clearance and :data:`DROP_KEEPOUT_M` from every drop spot; with a
    ``grid``, also known free on it with :data:`MAP_CLEARANCE_M` of clearance."""
    from jackson.sim.raster import raster, reachable_free

    occupied, ox, oy = raster(world, resolution_m)
    free = reachable_free(occupied, ox, oy, resolution_m, world.start_pose[:2])
    clearance = ndimage.distance_transform_edt(~occupied) * resolution_m
    ok = free & (clearance >= CLEARANCE_M)
    rows, cols = np.nonzero(ok)
    x = ox + (cols + 0.5) * resolution_m
    y = oy + (rows + 0.5) * resolution_m
    keep = np.ones(len(x), bool)
    spots = world.patrol.drop_spots if world.patrol is not None else ()
    for sx, sy in spots:
        keep &= np.hypot(x - sx, y - sy) >= DROP_KEEPOUT_M
    if grid is not None:
        keep &= _known_free(grid, x, y)
    return x[keep], y[keep]


def _known_free(grid: OccupancyGrid, x: npt.ArrayLike, y: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Points on known free cells of ``grid`` :data:`MAP_CLEARANCE_M` from its occupied ones."""
    occupied = grid.occupied()
    clear = ndimage.distance_transform_edt(~occupied) * grid.resolution_m >= MAP_CLEARANCE_M
    free = clear & (grid.data >= 0) & ~occupied
    r, c = grid.world_to_cell(x, y)
    on = grid.inside(r, c)
    out = np.zeros(np.shape(x), bool)
    out[on] = free[r[on], c[on]]
    return out


def check_map_frame(grid: OccupancyGrid, world: WorldSpec, name: str) -> float:
    """The share of the map's occupied cells lying within :data:`ON_WALL_M` of the world's true
    obstacles.

    Raises
    ------
    PatrolError
        Below :data:`MIN_ON_WALL` (or no occupied cell): not a map of this world in its frame.
    """
    from jackson.sim.raster import raster

    res = grid.resolution_m
    occupied, ox, oy = raster(world, res)
    near = ndimage.distance_transform_edt(~occupied) * res <= ON_WALL_M
    rows, cols = np.nonzero(grid.occupied())
    x, y = grid.cell_to_world(rows, cols)
    r, c = world_to_cell(x, y, ox, oy, res)
    inside = (r >= 0) & (r < near.shape[0]) & (c >= 0) & (c < near.shape[1])
    share = float(np.sum(near[r[inside], c[inside]]) / len(x)) if len(x) else 0.0
    if share < MIN_ON_WALL:
        raise PatrolError(
            f"map {name}: {100 * share:.0f} % of its occupied cells lie within {ON_WALL_M:g} m "
            f"of world {world.name}'s walls: not a map of this world in its frame (jackson map "
            "--world W builds one from the world's start pose)"
        )
    return share


def drops(
    world: WorldSpec, rng: np.random.Generator, horizon_s: float, period_s: float
) -> list[dict[str, Any]]:
    """Timed triggers: a cylinder on a random drop spot every ``period_s`` on average (an
    exponential gap, at least 10 s), each taken away after 20-90 s, up to ``horizon_s``."""
    spots = world.patrol.drop_spots if world.patrol is not None else ()
    out: list[dict[str, Any]] = []
    if not spots:
        return out
    t = 0.0
    while True:
        t += max(10.0, float(rng.exponential(period_s)))
        if t >= horizon_s:
            return out
        x, y = spots[int(rng.integers(len(spots)))]
        stay = float(rng.uniform(20.0, 90.0))
        out.append(
            {
                "at_s": round(t, 2),
                "remove_at_s": round(t + stay, 2),
                "add_cylinder": {"x": x, "y": y, "radius": DROP_RADIUS_M},
            }
        )


def patrol_world(spec: PatrolSpec, world: WorldSpec, horizon_s: float) -> Path:
    """The world file the twin runs: the floor with the patrol's timed drops added."""
    _, read = read_yaml(resolve(spec.world, WORLDS_DIR, "world"), "world")
    data = dict(read)  # the same number spellings as the twin's world loader
    rng = np.random.default_rng([spec.seed, 1])
    data["triggers"] = list(data.get("triggers") or []) + drops(
        world, rng, horizon_s, spec.drop_period_s
    )
    path = spec.out / "world.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path
