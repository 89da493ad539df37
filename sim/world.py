"""The twin's world in pymunk: walls, cylinders, obstacles that appear on a trigger (and timed
ones that leave again); and the floor's friction patches of one trial."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pymunk

from jackson.common.geometry import wrap_angle
from jackson.sim.config import DROP_CLEARANCE_M, ConfigError, Cylinder, Trigger, WorldSpec
from jackson.sim.lidar import Obstacles

ROBOT_COLLISION_TYPE = 1
OBSTACLE_COLLISION_TYPE = 2
MAX_CONTACTS = 1000  # contacts kept with their time and place (every one is counted)


@dataclass(frozen=True)
class Contact:
    """The robot's body touching a wall or a cylinder: when, where the robot was, and what.

    Attributes
    ----------
    t_s : float
        The twin's time of the physics step [s].
    x_m, y_m, yaw_rad : float
        The robot's body then (world frame) [m, m, rad]; the heading in (-pi, pi].
    obstacle : str
        What it touched: ``wall (x1, y1)-(x2, y2)`` or ``cylinder at (x, y) r R`` [m].
    """

    t_s: float
    x_m: float
    y_m: float
    yaw_rad: float
    obstacle: str

    def line(self) -> str:
        """One line for the twin's log."""
        return (
            f"contact at {self.t_s:.2f} s: the robot at ({self.x_m:.2f}, {self.y_m:.2f}) m, "
            f"{math.degrees(self.yaw_rad):.0f} deg, touched the {self.obstacle}"
        )


def _describe(shape: pymunk.Shape) -> str:
    if isinstance(shape, pymunk.Segment):
        a, b = shape.a, shape.b
        return f"wall ({a.x:.2f}, {a.y:.2f})-({b.x:.2f}, {b.y:.2f})"
    if isinstance(shape, pymunk.Circle):
        c = shape.offset
        return f"cylinder at ({c.x:.2f}, {c.y:.2f}) r {shape.radius:.2f}"
    return type(shape).__name__


_DUE_S = 1e-9  # [s] an event this close after the check's instant is due at it


class World:
    """Static geometry in a pymunk space and for the ray caster, and the count of robot
    collisions with it.

    Walls are radius-0 segments and cylinders are static circles, as the paper's maze. A
    trigger inserts its cylinder once the robot is ``when_moved_m`` from its start position,
    or at ``at_s`` of MCU time; a timed drop waits while the robot's body (its radius plus
    :data:`~jackson.sim.config.DROP_CLEARANCE_M`) overlaps the cylinder, and leaves again at
    ``remove_at_s`` (a drop still waiting then never happens). :meth:`check_triggers` does
    all of it; :meth:`next_check_step` tells the twin when it next has something to do.

    Attributes
    ----------
    segments, circles : list of tuple
        The walls ``(x1, y1, x2, y2)`` and the cylinders present now ``(x, y, r)`` [m].
    obstacles : Obstacles
        The same for the LiDAR's ray caster; a removal replaces the object, an insertion
        extends it.
    inserted, removed : list of (float, Cylinder)
        Each triggered cylinder when it appeared, and each timed one when it left [s].
    cancelled : list of Trigger
        Timed drops that waited for the robot until their ``remove_at_s`` and never happened.
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
        self.contacts: list[Contact] = []  # the first MAX_CONTACTS
        self.t_s = 0.0  # the time of the step being integrated (the twin sets it)
        triggers = spec.triggers
        self._by_distance = sorted(
            (t for t in triggers if t.when_moved_m is not None), key=lambda t: t.when_moved_m or 0.0
        )
        self._by_time = sorted(
            (t for t in triggers if t.at_s is not None), key=lambda t: t.at_s or 0.0
        )
        self._leaving: list[tuple[float, Cylinder, pymunk.Circle]] = []  # sorted by time
        self.inserted: list[tuple[float, Cylinder]] = []  # (time, cylinder)
        self.removed: list[tuple[float, Cylinder]] = []
        self.cancelled: list[Trigger] = []
        for x1, y1, x2, y2 in spec.walls:
            seg = pymunk.Segment(self.space.static_body, (x1, y1), (x2, y2), 0.0)
            self._add_static(seg)
            self.segments.append((x1, y1, x2, y2))
        self.obstacles = Obstacles(self.segments)
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
        robot, obstacle = arbiter.shapes  # in the handler's order: the robot's first
        body = robot.body
        if len(self.contacts) < MAX_CONTACTS and body is not None:
            self.contacts.append(
                Contact(
                    self.t_s,
                    body.position.x,
                    body.position.y,
                    wrap_angle(body.angle),
                    _describe(obstacle),
                )
            )

    def add_cylinder(self, c: Cylinder) -> pymunk.Circle:
        """Insert a cylinder into the space, the clearance and the ray caster; return its
        shape."""
        shape = pymunk.Circle(self.space.static_body, c.radius, (c.x, c.y))
        self._add_static(shape)
        self.circles.append((c.x, c.y, c.radius))
        self.obstacles.add_circle(c.x, c.y, c.radius)
        return shape

    def remove_cylinder(self, c: Cylinder, shape: pymunk.Circle) -> None:
        """Take a cylinder ``add_cylinder`` inserted (its ``shape``) out of the world again."""
        self.space.remove(shape)
        self.circles.remove((c.x, c.y, c.radius))
        self.obstacles = Obstacles(self.segments, self.circles)

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

    @property
    def pending(self) -> bool:
        """Whether a trigger has yet to insert or remove a cylinder."""
        return bool(self._by_distance or self._by_time or self._leaving)

    @property
    def _pending(self) -> bool:  # the twin's loop before next_check_step: check every step
        return self.pending

    def next_check_step(self, step: int, dt: float) -> int:
        """The first physics step after ``step`` at which :meth:`check_triggers` may change
        the world (``sys.maxsize``: never).

        A distance trigger, or a timed drop waiting for the robot to move off, needs every
        step; otherwise the next ``at_s`` or ``remove_at_s``.

        Parameters
        ----------
        step : int
            The physics step now.
        dt : float
            The physics step [s].

        Returns
        -------
        int
            That step.
        """
        if self._by_distance:
            return step + 1
        due_s = min(
            (self._by_time[0].at_s or 0.0) if self._by_time else math.inf,
            self._leaving[0][0] if self._leaving else math.inf,
        )
        if due_s == math.inf:
            return sys.maxsize
        return max(step + 1, math.ceil(due_s / dt - 1e-6))

    def check_triggers(
        self,
        moved_m: float,
        t_s: float,
        robot_xy: tuple[float, float] | None = None,
        robot_radius_m: float = 0.0,
    ) -> list[Cylinder]:
        """Insert every triggered obstacle that is due, remove every timed one whose time
        has come; return the ones inserted.

        Parameters
        ----------
        moved_m : float
            Distance of the robot from its start position [m].
        t_s : float
            MCU time now [s].
        robot_xy : tuple of float or None
            Where the robot is [m]; a timed drop waits while its body overlaps the cylinder
            (None: the caller does not say, and no drop waits).
        robot_radius_m : float
            The robot's outer radius about ``robot_xy`` [m].

        Returns
        -------
        list of Cylinder
            The cylinders inserted now.
        """
        fired = []
        while self._by_distance and moved_m >= (self._by_distance[0].when_moved_m or 0.0):
            trig = self._by_distance.pop(0)
            if robot_xy is not None:
                self._refuse_on_robot(trig, robot_xy, moved_m)
            fired.append(self._insert(trig, t_s))
        waiting = []
        while self._by_time and (self._by_time[0].at_s or 0.0) <= t_s + _DUE_S:
            trig = self._by_time.pop(0)
            c = trig.cylinder
            if trig.remove_at_s is not None and trig.remove_at_s <= t_s + _DUE_S:
                self.cancelled.append(trig)
            elif robot_xy is not None and (
                math.hypot(c.x - robot_xy[0], c.y - robot_xy[1])
                < c.radius + robot_radius_m + DROP_CLEARANCE_M
            ):
                waiting.append(trig)
            else:
                fired.append(self._insert(trig, t_s))
        self._by_time[:0] = waiting
        while self._leaving and self._leaving[0][0] <= t_s + _DUE_S:
            _, c, shape = self._leaving.pop(0)
            self.remove_cylinder(c, shape)
            self.removed.append((t_s, c))
        return fired

    def _refuse_on_robot(
        self, trig: Trigger, robot_xy: tuple[float, float], moved_m: float
    ) -> None:
        """A distance trigger's cylinder that would land on the robot's axle centre is a world
        file the physics cannot play (the robot would stand inside it): one line naming it."""
        c = trig.cylinder
        if math.hypot(c.x - robot_xy[0], c.y - robot_xy[1]) < c.radius:
            k = self.spec.triggers.index(trig)
            raise ConfigError(
                f"world {self.spec.name}: triggers[{k}].add_cylinder: the cylinder (radius "
                f"{c.radius:g} m at {c.x:g}, {c.y:g}) drops onto the robot, at "
                f"({robot_xy[0]:.3f}, {robot_xy[1]:.3f}) after {moved_m:.3f} m: place it off "
                "the robot's way"
            )

    def _insert(self, trig: Trigger, t_s: float) -> Cylinder:
        shape = self.add_cylinder(trig.cylinder)
        self.inserted.append((t_s, trig.cylinder))
        if trig.remove_at_s is not None:
            self._leaving.append((trig.remove_at_s, trig.cylinder, shape))
            self._leaving.sort(key=lambda e: e[0])
        return trig.cylinder

    @staticmethod
    def distance(x0: float, y0: float, x1: float, y1: float) -> float:
        return math.hypot(x1 - x0, y1 - y0)


FIELD_CELLS = 128  # the field is a periodic tile of FIELD_CELLS x FIELD_CELLS cells
CELLS_PER_PATCH = 4  # cells per floor_patch_size_m


def periodic_gaussian(
    a: npt.NDArray[np.float64], sigma: float, axis: int
) -> npt.NDArray[np.float64]:
    """``a`` smoothed along ``axis`` by a Gaussian of SD ``sigma`` [cells], periodic: what
    scipy's ``gaussian_filter1d(a, sigma, axis, mode="wrap")`` gives, bit for bit (its kernel,
    ``exp(-x^2 / 2 sigma^2)`` over 4 sigma normalised by its sum, and its symmetric sum, the
    farthest pair of cells first; ``tests/sim/test_imperfections.py`` compares the two).
    Written out because importing scipy.ndimage for this one filter took a third of a second
    of every ``jackson run`` (a twin draws its floor's patches before it starts).
    """
    radius = int(4.0 * float(sigma) + 0.5)
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / (sigma * sigma) * x**2)
    weights = phi / phi.sum()
    out: npt.NDArray[np.float64] = a * weights[radius]
    for j in range(radius, 0, -1):
        out = out + (np.roll(a, j, axis) + np.roll(a, -j, axis)) * weights[radius - j]
    return out


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
        noise = rng.standard_normal((FIELD_CELLS, FIELD_CELLS))
        smooth = periodic_gaussian(periodic_gaussian(noise, CELLS_PER_PATCH, 0), CELLS_PER_PATCH, 1)
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
