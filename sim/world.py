"""The twin's static world in pymunk: walls, cylinders, obstacles that appear on a trigger;
and the floor's friction patches of one trial."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk

from jackson.sim.config import Cylinder, WorldSpec

ROBOT_COLLISION_TYPE = 1
OBSTACLE_COLLISION_TYPE = 2


class World:
    """Static geometry in a pymunk space, and the count of robot collisions with it.

    Walls are radius-0 segments and cylinders are static circles, as the paper's maze; a
    trigger inserts its cylinder once the robot is ``when_moved_m`` from its start position.
    """

    def __init__(self, spec: WorldSpec) -> None:
        self.spec = spec
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)  # the plane is horizontal; gravity is in the wheel loads
        self.space.iterations = 10
        self.space.collision_slop = 0.0005  # [m]; the default 0.1 suits pixels, not metres
        self.segments: list[tuple[float, float, float, float]] = []
        self.circles: list[tuple[float, float, float]] = []
        self.collisions = 0
        self._pending = sorted(spec.triggers, key=lambda t: t.when_moved_m)
        self.inserted: list[tuple[float, Cylinder]] = []  # (time, cylinder)
        for x1, y1, x2, y2 in spec.walls:
            seg = pymunk.Segment(self.space.static_body, (x1, y1), (x2, y2), 0.0)
            self._add_static(seg)
            self.segments.append((x1, y1, x2, y2))
        for c in spec.cylinders:
            self.add_cylinder(c)
        self.space.on_collision(ROBOT_COLLISION_TYPE, OBSTACLE_COLLISION_TYPE, begin=self._begin)

    def _add_static(self, shape: pymunk.Shape) -> None:
        shape.friction = 0.5
        shape.elasticity = 0.0
        shape.collision_type = OBSTACLE_COLLISION_TYPE
        self.space.add(shape)

    def _begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        self.collisions += 1

    def add_cylinder(self, c: Cylinder) -> None:
        self._add_static(pymunk.Circle(self.space.static_body, c.radius, (c.x, c.y)))
        self.circles.append((c.x, c.y, c.radius))

    def clearance(self, x: float, y: float) -> float:
        """Distance from a point to the nearest wall or cylinder surface (inf when none)."""
        best = math.inf
        if self.segments:
            seg = np.asarray(self.segments)
            a, b = seg[:, :2], seg[:, 2:]
            ab = b - a
            p = np.array([x, y])
            den = np.maximum((ab * ab).sum(axis=1), 1e-18)
            t = np.clip(((p - a) * ab).sum(axis=1) / den, 0.0, 1.0)
            d = np.hypot(*(a + ab * t[:, None] - p).T)
            best = float(d.min())
        if self.circles:
            c = np.asarray(self.circles)
            best = min(best, float((np.hypot(c[:, 0] - x, c[:, 1] - y) - c[:, 2]).min()))
        return best

    def check_triggers(self, moved_m: float, t_s: float) -> list[Cylinder]:
        """Insert every triggered obstacle whose distance has been reached; return them."""
        fired = []
        while self._pending and moved_m >= self._pending[0].when_moved_m:
            trig = self._pending.pop(0)
            self.add_cylinder(trig.cylinder)
            self.inserted.append((t_s, trig.cylinder))
            fired.append(trig.cylinder)
        return fired

    @staticmethod
    def distance(x0: float, y0: float, x1: float, y1: float) -> float:
        return math.hypot(x1 - x0, y1 - y0)


FIELD_CELLS = 128  # the field is a periodic tile of FIELD_CELLS x FIELD_CELLS cells
CELLS_PER_PATCH = 4  # cells per floor_patch_size_m


@dataclass(frozen=True)
class FrictionField:
    """Friction patches: a periodic tile of factors on the floor's mu, nearest cell.

    The tile repeats in x and y, so the field covers any floor; with the default 128 cells
    of a quarter patch size each it is 32 patch sizes across (9.6 m at 0.3 m).

    Attributes
    ----------
    cells : tuple of tuple of float
        ``cells[i][j]`` multiplies mu at x in cell ``i``, y in cell ``j`` [1].
    resolution_m : float
        Cell size [m].
    origin_x_m, origin_y_m : float
        Lower-left corner of cell (0, 0) [m].
    """

    cells: tuple[tuple[float, ...], ...]
    resolution_m: float
    origin_x_m: float = 0.0
    origin_y_m: float = 0.0

    @staticmethod
    def random(
        rng: np.random.Generator,
        sigma: float,
        patch_size_m: float,
        origin: tuple[float, float] = (0.0, 0.0),
    ) -> FrictionField:
        """White noise smoothed by a Gaussian kernel of SD ``patch_size_m`` (periodic),
        scaled to mean 1 and SD ``sigma``, truncated at 3 sigma.

        Parameters
        ----------
        rng : numpy.random.Generator
            Source of the noise (the trial's).
        sigma : float
            SD of the factor [1].
        patch_size_m : float
            SD of the smoothing kernel [m].
        origin : tuple of float
            Where cell (0, 0) starts (the start pose: the robot begins on a cell corner).

        Returns
        -------
        FrictionField
            The field.
        """
        # imported here: scipy's many objects would slow every full garbage collection of a
        # twin that has no patches
        from scipy.ndimage import gaussian_filter

        noise = rng.standard_normal((FIELD_CELLS, FIELD_CELLS))
        smooth = gaussian_filter(noise, CELLS_PER_PATCH, mode="wrap")
        unit = (smooth - smooth.mean()) / smooth.std()
        factor = 1.0 + sigma * np.clip(unit, -3.0, 3.0)
        return FrictionField(
            tuple(tuple(float(v) for v in row) for row in factor),
            patch_size_m / CELLS_PER_PATCH,
            origin[0],
            origin[1],
        )

    def factor(self, x: float, y: float) -> float:
        """The factor on mu at a point of the floor.

        Parameters
        ----------
        x, y : float
            World position [m].

        Returns
        -------
        float
            The multiplier of mu_s and mu_d there [1].
        """
        n, per_m = len(self.cells), self.cells_per_m
        i = math.floor((x - self.origin_x_m) * per_m) % n
        j = math.floor((y - self.origin_y_m) * per_m) % n
        return self.cells[i][j]

    @property
    def cells_per_m(self) -> float:
        """Cells per metre, 1 / ``resolution_m`` [1/m]."""
        return 1.0 / self.resolution_m
