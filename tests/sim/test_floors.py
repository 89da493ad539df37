"""The patrol floors: large, one navigable space, their drop spots open and their unreachable
points shut off, checked on the twin's ground-truth raster.

"Navigable" is the raster with every cell within ``ROBOT_M`` of an obstacle taken away, as a
planner sees it (the host's marks cells within its robot radius, 0.16 m, lethal; the twin's
robot reaches 0.19 m from its axle): a door or an aisle narrower than about 0.5 m cuts it.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from jackson.sim.config import WorldSpec, load_world
from jackson.sim.raster import raster, reachable_free
from jackson.sim.world import World

RES = 0.05  # [m] the host's map resolution
FLOORS = ("office_floor", "warehouse", "clinic_ring")
MIN_AREA_M2 = 150.0
DROP_CLEARANCE_M = 1.2  # [m] a drop spot's distance to any wall or cylinder
NAVIGABLE_CLEARANCE_M = 0.45  # [m] a point this far from everything can hold the robot
ROBOT_M = 0.25  # [m] cells this close to an obstacle are no place for the robot's centre
SAMPLES = 50


class Floor:
    """A world's raster and the free space connected to its start."""

    def __init__(self, name: str) -> None:
        self.spec: WorldSpec = load_world(name)
        self.world = World(self.spec)
        self.occupied, self.x0, self.y0 = raster(self.spec, RES)
        x, y, _ = self.spec.start_pose
        self.reachable = reachable_free(self.occupied, self.x0, self.y0, RES, (x, y))
        self.distance_m = ndimage.distance_transform_edt(~self.occupied) * RES
        lethal = self.occupied | (self.distance_m < ROBOT_M)
        self.navigable = reachable_free(lethal, self.x0, self.y0, RES, (x, y))

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return int((y - self.y0) // RES), int((x - self.x0) // RES)

    def free(self, x: float, y: float) -> bool:
        return not self.occupied[self.cell(x, y)]

    def connected(self, x: float, y: float) -> bool:
        return bool(self.reachable[self.cell(x, y)])

    def navigable_from_start(self, x: float, y: float) -> bool:
        return bool(self.navigable[self.cell(x, y)])

    def enclosures(self) -> tuple[np.ndarray, set[int]]:
        """Labels of the raster's free regions, and those of the listed unreachable points."""
        assert self.spec.patrol is not None
        labels, _ = ndimage.label(~self.occupied)
        return labels, {int(labels[self.cell(x, y)]) for x, y in self.spec.patrol.unreachable}

    def bounds(self) -> tuple[float, float, float, float]:
        walls = np.asarray(self.spec.walls)
        xs, ys = walls[:, [0, 2]], walls[:, [1, 3]]
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())


@pytest.fixture(scope="module", params=FLOORS)
def floor(request: pytest.FixtureRequest) -> Floor:
    return Floor(request.param)


def test_a_floor_covers_more_than_150_square_metres(floor: Floor) -> None:
    x_min, y_min, x_max, y_max = floor.bounds()
    assert (x_max - x_min) * (y_max - y_min) > MIN_AREA_M2


def test_the_start_and_the_goal_lie_in_open_connected_space(floor: Floor) -> None:
    x, y, _ = floor.spec.start_pose
    assert floor.free(x, y) and floor.connected(x, y)
    assert floor.world.clearance(x, y) > NAVIGABLE_CLEARANCE_M
    assert floor.spec.goal is not None
    assert floor.navigable_from_start(*floor.spec.goal)
    assert all(floor.navigable_from_start(*p) for p in floor.spec.survey)


def test_every_drop_spot_is_open_floor_reached_from_the_start(floor: Floor) -> None:
    patrol = floor.spec.patrol
    assert patrol is not None and 6 <= len(patrol.drop_spots) <= 10
    for x, y in patrol.drop_spots:
        assert floor.world.clearance(x, y) >= DROP_CLEARANCE_M, (x, y)
        assert floor.navigable_from_start(x, y), (x, y)


def test_every_unreachable_point_is_free_but_shut_off(floor: Floor) -> None:
    patrol = floor.spec.patrol
    assert patrol is not None and 2 <= len(patrol.unreachable) <= 4
    for x, y in patrol.unreachable:
        assert floor.free(x, y), (x, y)
        assert not floor.connected(x, y), (x, y)


def test_the_floor_is_one_navigable_space_apart_from_its_enclosures(floor: Floor) -> None:
    """50 random points with room for the robot, outside the listed enclosures, all connect
    to the start through space the robot fits (a door too narrow fails here)."""
    labels, shut = floor.enclosures()
    x_min, y_min, x_max, y_max = floor.bounds()
    rng = np.random.default_rng(7)
    found = 0
    for x, y in rng.uniform((x_min, y_min), (x_max, y_max), size=(20 * SAMPLES, 2)):
        if found == SAMPLES:
            break
        if floor.world.clearance(x, y) < NAVIGABLE_CLEARANCE_M:
            continue
        if int(labels[floor.cell(x, y)]) in shut:
            continue
        found += 1
        assert floor.navigable_from_start(x, y), (round(x, 2), round(y, 2))
    assert found == SAMPLES


def test_every_enclosure_with_room_for_the_robot_is_listed_unreachable(floor: Floor) -> None:
    """Every cell of the floor with room for the robot either connects to the start or lies
    in an enclosure the world lists (a closed room left off ``unreachable`` fails here)."""
    labels, shut = floor.enclosures()
    x_min, y_min, x_max, y_max = floor.bounds()
    rows, cols = np.indices(floor.occupied.shape)
    x = floor.x0 + (cols + 0.5) * RES
    y = floor.y0 + (rows + 0.5) * RES
    inside = (x > x_min) & (x < x_max) & (y > y_min) & (y < y_max)
    roomy = inside & (floor.distance_m >= NAVIGABLE_CLEARANCE_M + RES)
    stray = roomy & ~floor.navigable & ~np.isin(labels, list(shut))
    assert not stray.any(), list(zip(x[stray][:5].round(2), y[stray][:5].round(2), strict=True))
