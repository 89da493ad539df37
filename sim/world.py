"""The twin's static world in pymunk: walls, cylinders, obstacles that appear on a trigger."""

from __future__ import annotations

import math

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
