"""The twin's ground-truth raster: walls and cylinders land in the cells they occupy."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pytest

from jackson.sim.config import Cylinder, Trigger, WorldSpec
from jackson.sim.raster import raster, reachable_free

RES = 0.05


def cells(occupied: npt.NDArray[np.bool_]) -> set[tuple[int, int]]:
    return {(int(r), int(c)) for r, c in zip(*np.nonzero(occupied), strict=True)}


def sampled_cells(
    x1: float, y1: float, x2: float, y2: float, x0: float, y0: float
) -> set[tuple[int, int]]:
    """Cells holding points every 10 um along the segment (interior points only)."""
    n = int(math.hypot(x2 - x1, y2 - y1) / 1e-5)
    t = (np.arange(1, n) + 0.5) / n
    col = np.floor((x1 + t * (x2 - x1) - x0) / RES).astype(int)
    row = np.floor((y1 + t * (y2 - y1) - y0) / RES).astype(int)
    return set(zip(row.tolist(), col.tolist(), strict=True))


def test_a_horizontal_wall_marks_one_row_of_cells() -> None:
    world = WorldSpec("w", walls=((0.0, 0.12, 1.0, 0.12),))
    occupied, x0, y0 = raster(world, RES, bounds=(0.0, 0.0, 1.5, 0.5))
    assert occupied.shape == (10, 30) and (x0, y0) == (0.0, 0.0)
    assert cells(occupied) == {(2, c) for c in range(20)}  # y 0.10-0.15, x 0-1.0


def test_a_diagonal_wall_marks_every_cell_it_passes_through() -> None:
    wall = (0.013, 0.031, 0.911, 0.402)
    world = WorldSpec("w", walls=(wall,))
    occupied, x0, y0 = raster(world, RES, bounds=(0.0, 0.0, 1.0, 0.5))
    marked = cells(occupied)
    assert marked == sampled_cells(*wall, x0, y0)
    for r, c in marked:  # edge-connected: free space cannot leak through the wall
        assert (r, c) == min(marked) or {(r - 1, c), (r, c - 1)} & marked


def test_a_wall_along_a_grid_line_marks_both_sides() -> None:
    world = WorldSpec("w", walls=((0.5, 0.1, 0.5, 0.3),))
    occupied, _, _ = raster(world, RES, bounds=(0.0, 0.0, 1.0, 0.5))
    assert cells(occupied) == {(r, c) for r in (2, 3, 4, 5) for c in (9, 10)}


def test_a_cylinder_marks_the_cells_within_its_radius_plus_half_a_cell() -> None:
    world = WorldSpec("w", cylinders=(Cylinder(0.61, -0.04, 0.125),))
    occupied, x0, y0 = raster(world, RES, bounds=(0.0, -0.5, 1.2, 0.5))
    rows, cols = np.indices(occupied.shape)
    dx = x0 + (cols + 0.5) * RES - 0.61
    dy = y0 + (rows + 0.5) * RES + 0.04
    assert np.array_equal(occupied, np.hypot(dx, dy) <= 0.125 + RES / 2)
    assert occupied[math.floor((-0.04 + 0.5) / RES), math.floor(0.61 / RES)]  # the centre
    assert abs(occupied.sum() - math.pi * (0.15 / RES) ** 2) < 4  # about 28 cells
    assert not occupied[math.floor((-0.04 + 0.5) / RES), math.floor((0.61 + 0.2) / RES)]


def test_default_bounds_cover_the_world_and_snap_to_the_resolution() -> None:
    trigger = Trigger(0.12, Cylinder(3.0, 0.0, 0.2))
    world = WorldSpec(
        "w",
        walls=((-1.23, -1.02, 1.87, -1.02),),
        cylinders=(Cylinder(0.9, 0.5, 0.125),),
        triggers=(trigger,),
    )
    occupied, x0, y0 = raster(world, RES)
    assert x0 == pytest.approx(-1.75) and y0 == pytest.approx(-1.55)  # -1.23 - 0.5, snapped
    assert round(x0 / RES) * RES == x0 and round(y0 / RES) * RES == y0
    assert x0 + occupied.shape[1] * RES == pytest.approx(2.4)  # 1.87 + 0.5, snapped up
    assert y0 + occupied.shape[0] * RES == pytest.approx(1.15)  # 0.5 + 0.125 + 0.5, up
    with_trigger, tx0, _ = raster(world, RES, include_triggers=True)
    assert tx0 == x0 and tx0 + with_trigger.shape[1] * RES == pytest.approx(3.7)
    assert with_trigger.sum() > occupied.sum()


def test_reachable_free_space_stops_at_closed_walls() -> None:
    room = ((-1.0, -1.0, 1.0, -1.0), (1.0, -1.0, 1.0, 1.0), (1.0, 1.0, -1.0, 1.0))
    world = WorldSpec("w", walls=(*room, (-1.0, 1.0, -0.3, -1.0)))  # closed by a diagonal
    occupied, x0, y0 = raster(world, RES)
    free = reachable_free(occupied, x0, y0, RES, (0.5, 0.0))
    assert free[math.floor(-y0 / RES), math.floor((0.5 - x0) / RES)]
    assert not free[0, 0] and not (free & occupied).any()
    assert not free[math.floor(-y0 / RES), math.floor((-0.9 - x0) / RES)]  # behind the diagonal
    assert not reachable_free(occupied, x0, y0, RES, (9.0, 9.0)).any()


@pytest.mark.parametrize(
    ("kwargs", "says"),
    [
        ({"resolution_m": 0.0}, "resolution_m"),
        ({"bounds": (1.0, 0.0, 0.0, 1.0)}, "bounds"),
        ({"margin_m": -1.0}, "margin_m"),
    ],
)
def test_bad_arguments_are_one_line(kwargs: dict[str, object], says: str) -> None:
    with pytest.raises(ValueError, match=says):
        raster(WorldSpec("w"), **kwargs)  # type: ignore[arg-type]
