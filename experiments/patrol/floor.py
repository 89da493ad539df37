"""The patrol's floor: the goals it may send and the obstacles it drops.

Random goals are free points of the floor with :data:`CLEARANCE_M` of clearance, reachable from
the start and :data:`DROP_KEEPOUT_M` from every drop spot, sent at least :data:`MIN_TRIP_M` from
the robot; drops are cylinders on the floor's drop spots at random MCU times (the world's timed
triggers).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml
from scipy import ndimage

from jackson.common.fields import read_yaml
from jackson.experiments.patrol.records import PatrolSpec
from jackson.sim.config import WORLDS_DIR, WorldSpec, resolve

CLEARANCE_M = 0.5  # [m] a random goal's distance to the nearest obstacle
MIN_TRIP_M = 2.5  # [m] a random goal's distance from the robot
DROP_KEEPOUT_M = 1.0  # [m] a random goal's distance from every drop spot
DROP_RADIUS_M = 0.15  # [m] a dropped cylinder


def goal_cells(
    world: WorldSpec, resolution_m: float = 0.05
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Candidate goal points (x, y arrays [m]): free, reachable from the start, with
    :data:`CLEARANCE_M` of clearance and :data:`DROP_KEEPOUT_M` from every drop spot."""
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
    return x[keep], y[keep]


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
