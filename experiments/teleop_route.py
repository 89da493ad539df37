"""The route of a scripted teleop drive and the driver that follows it
(:mod:`jackson.experiments.teleop_twin` drives the twin with them).

The route (:func:`teleop_route`) is the survey ``jackson map --world`` drives: the world's
``survey`` waypoints (else its goal), then back to the start, each leg planned by A* on the
world's own raster with a wide inflation (0.6 m), so that the driver keeps to the middle of
corridors and doorways as a person does, away from the walls. The driver
(:class:`PurePursuit`) turns a pose into a velocity command, as a person with a joystick
turns what they see into stick movements.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from jackson.common.errors import JacksonError
from jackson.common.geometry import wrap_angle, wrap_angles

if TYPE_CHECKING:
    from jackson.sim.config import WorldSpec

FloatArray = npt.NDArray[np.float64]

LOOKAHEAD_M = 0.35  # [m] pure pursuit's look-ahead along the route
SPIN_ABOVE_RAD = 0.6  # [rad] heading error above which the driver turns on the spot
SPIN_RAD_S = 0.5  # [rad/s] the turn on the spot
MAX_TURN_RAD_S = 0.8  # [rad/s] the sharpest turn while driving
ARRIVED_M = 0.08  # [m] the route's end (or a cusp) reached
CUSP_RAD = math.radians(100.0)  # [rad] a turn sharper than this is where the route doubles back
ROUTE_SPACING_M = 0.05  # [m] between the route's points
SEARCH_AHEAD_M = 1.0  # [m] of route searched for the nearest point (never behind it)


class RouteError(JacksonError):
    """A route that cannot be planned (a waypoint in a wall, cut off from the start)."""


def survey_via(world: str, robot: str = "jackson_physical") -> tuple[tuple[float, float], ...]:
    """The waypoints of ``jackson map --world WORLD``'s survey after the start: the world's
    survey (else its goal), then the start again."""
    from jackson.experiments.stage3 import mapping_spec

    goals = mapping_spec(robot, world, 0, Path(".")).goals
    return tuple((g.x, g.y) for g in goals)


def teleop_route(
    world: WorldSpec, via: Sequence[tuple[float, float]], spacing_m: float = ROUTE_SPACING_M
) -> FloatArray:
    """The route from the world's start through ``via``: each leg planned by A* on the
    world's raster with a 0.6 m inflation (the middle of corridors and doors), joined, and
    resampled every ``spacing_m``.

    Parameters
    ----------
    world : WorldSpec
        The twin's world.
    via : sequence of (x, y)
        The waypoints after the start [m].
    spacing_m : float
        Distance between the route's points [m].

    Returns
    -------
    ndarray, shape (N, 2)
        The route [m], from the start.

    Raises
    ------
    RouteError
        A waypoint in or beside a wall, or cut off from the start.
    """
    from jackson.experiments.stage3 import check_world_route, world_grid
    from jackson.host.control.route import RouteError as BadWaypoint
    from jackson.host.nav.astar import NoPathError, astar
    from jackson.host.nav.costmap import Costmap, CostmapConfig
    from jackson.host.nav.types import Pose2D

    try:  # as jackson map refuses a survey's waypoints: in or beside a wall, or cut off
        check_world_route(world, tuple(Pose2D(float(x), float(y)) for x, y in via))
    except BadWaypoint as exc:
        raise RouteError(f"the route: {exc}") from exc
    costmap = Costmap.from_map(
        world_grid(world),
        CostmapConfig(inflation_radius_m=0.6, cost_scaling_factor=4.0),
        collision_checks=False,
    )
    points = [tuple(world.start_pose[:2]), *via]
    legs: list[FloatArray] = []
    for a, b in itertools.pairwise(points):
        try:
            leg = astar(costmap, (float(a[0]), float(a[1])), (float(b[0]), float(b[1])))
        except NoPathError as exc:
            raise RouteError(f"the route's leg to ({b[0]:g}, {b[1]:g}): {exc}") from exc
        legs.append(leg if not legs else leg[1:])
    return resample(np.vstack(legs), spacing_m)


def resample(path: npt.ArrayLike, spacing_m: float) -> FloatArray:
    """A polyline resampled every ``spacing_m`` of its length (its ends kept)."""
    p: FloatArray = np.asarray(path, dtype=np.float64)
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))))
    keep = np.concatenate(([True], np.diff(s) > 1e-9))
    p, s = p[keep], s[keep]
    if len(p) < 2:
        return p
    at = np.append(np.arange(0.0, s[-1], spacing_m), s[-1])
    out: FloatArray = np.column_stack((np.interp(at, s, p[:, 0]), np.interp(at, s, p[:, 1])))
    return out


@dataclass
class PurePursuit:
    """The driver: pure pursuit along a route at a fixed speed, turning on the spot where the
    point ahead lies more than :data:`SPIN_ABOVE_RAD` off the heading.

    The nearest route point is searched only ahead of the last one (within
    :data:`SEARCH_AHEAD_M`), so a route that passes a place twice is followed in order.
    Curvature 2 sin(alpha) / L to the point ``lookahead_m`` along the route (alpha: its bearing
    off the heading, L: its distance), the turn rate capped at :data:`MAX_TURN_RAD_S`. The point
    ahead never lies beyond the next cusp, where the route doubles back (by more than
    :data:`CUSP_RAD`, at a waypoint at the end of a corridor): the driver drives up to it and
    turns there, instead of turning early and leaving the corridor's end unseen.

    Attributes
    ----------
    route : ndarray, shape (N, 2)
        Evenly spaced points [m].
    speed_m_s : float
        Forward speed while driving [m/s].
    lookahead_m : float
        Look-ahead distance along the route [m].
    index : int
        The route point reached so far.
    """

    route: FloatArray
    speed_m_s: float
    lookahead_m: float = LOOKAHEAD_M
    index: int = 0
    s: FloatArray = field(init=False, repr=False)
    cusps: npt.NDArray[np.intp] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(self.route, axis=0).T))))
        self.cusps = cusps(self.route)

    @property
    def length_m(self) -> float:
        return float(self.s[-1])

    @property
    def progress_m(self) -> float:
        return float(self.s[self.index])

    def arrived(self, x: float, y: float) -> bool:
        end = self.route[-1]
        near_end = self.length_m - self.progress_m < self.lookahead_m
        return near_end and math.hypot(end[0] - x, end[1] - y) < ARRIVED_M

    def next_cusp(self) -> int:
        """The first cusp ahead of the point reached (the route's end if none)."""
        ahead = self.cusps[self.cusps > self.index]
        return int(ahead[0]) if ahead.size else len(self.route) - 1

    def command(self, x: float, y: float, yaw: float) -> tuple[float, float]:
        """(v [m/s], w [rad/s]) at the pose (x, y, yaw); (0, 0) once arrived."""
        cusp = self.next_cusp()
        near = math.hypot(self.route[cusp, 0] - x, self.route[cusp, 1] - y) < ARRIVED_M
        if near and cusp in self.cusps and self.s[cusp] - self.s[self.index] < SEARCH_AHEAD_M:
            self.index = cusp  # reached: the route goes on back the way it came
            cusp = self.next_cusp()
        # the nearest point ahead, never past the next cusp: the way back runs beside it
        stop = int(np.searchsorted(self.s, self.s[self.index] + SEARCH_AHEAD_M, side="right"))
        window = self.route[self.index : max(min(stop, cusp + 1), self.index + 1)]
        self.index += int(np.argmin(np.hypot(window[:, 0] - x, window[:, 1] - y)))
        if self.arrived(x, y):
            return 0.0, 0.0
        j = min(int(np.searchsorted(self.s, self.s[self.index] + self.lookahead_m)), cusp)
        dx, dy = self.route[j, 0] - x, self.route[j, 1] - y
        distance = math.hypot(dx, dy)
        alpha = wrap_angle(math.atan2(dy, dx) - yaw)
        if abs(alpha) > SPIN_ABOVE_RAD:
            return 0.0, math.copysign(SPIN_RAD_S, alpha)
        v = min(self.speed_m_s, max(0.05, distance))  # slowing over the last few centimetres
        w = 2.0 * v * math.sin(alpha) / max(distance, 1e-3)
        return v, max(-MAX_TURN_RAD_S, min(MAX_TURN_RAD_S, w))


def cusps(route: FloatArray, span: int = 3) -> npt.NDArray[np.intp]:
    """Indices of the points where a route doubles back: its heading over ``span`` points
    before and after differs by more than :data:`CUSP_RAD`; one index per cusp (the middle of
    the points that do)."""
    n = len(route)
    if n < 2 * span + 1:
        return np.zeros(0, np.intp)
    i = np.arange(span, n - span)
    before = route[i] - route[i - span]
    after = route[i + span] - route[i]
    turn = np.abs(
        wrap_angles(np.arctan2(after[:, 1], after[:, 0]) - np.arctan2(before[:, 1], before[:, 0]))
    )
    sharp = turn > CUSP_RAD
    out: list[int] = []
    start = None
    for k in range(len(i) + 1):
        if k < len(i) and sharp[k]:
            start = k if start is None else start
        elif start is not None:
            out.append(int(i[(start + k - 1) // 2]))
            start = None
    return np.array(out, np.intp)
