"""The navigation service seen live in Foxglove, without ROS: a core listener that publishes
over the Foxglove WebSocket protocol (:class:`~jackson.common.liveview.LiveServer`).

| topic       | schema (JSON or protobuf) | frame     | when                                    |
|-------------|---------------------------|-----------|-----------------------------------------|
| /map        | foxglove.Grid             | map       | on subscribe, then every 10 s           |
| /scan       | foxglove.LaserScan        | laser     | every LiDAR revolution                  |
| /pose       | foxglove.PoseInFrame      | map       | 10 Hz                                   |
| /tf         | foxglove.FrameTransforms  | (below)   | 10 Hz                                   |
| /footprint  | foxglove.SceneUpdate      | base_link | on subscribe, then every 10 s           |
| /plan       | foxglove.PosesInFrame     | map       | each new plan (empty: none), subscribe  |
| /local_plan | foxglove.PosesInFrame     | map       | 10 Hz while navigating (DWB's choice)   |
| /goal       | foxglove.PosesInFrame     | map       | each new goal (empty: none), subscribe  |
| /health     | jackson.Health (JSON)     |           | 1 Hz                                    |

Rates are on MCU time, like everything the core does; stamps and log times are MCU time
(:mod:`jackson.common.liveview`). The map's Grid carries the occupancy (``occupancy``, int8,
-1 unknown, 0-100) and its colours (``red``, ``green``, ``blue``, ``alpha``), so the 3D panel
draws it as a map without settings. The transforms follow the daemon's ROS tree: map -> odom
is the localiser's correction composed with the start pose (odometry starts at zero there),
odom -> base_link the robot's odometry pose, base_link -> laser the LiDAR's mounting.

The listener runs on the frame loop's thread, so it costs that thread as little as it can: a
topic no client subscribed to is not built at all (``has_sinks``), the map's Grid is built once,
and the SDK's server sends on threads of its own (a slow client loses its oldest messages,
never stalls the loop). An error while publishing turns the live view off with one line; the
robot is never stopped for it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
from foxglove import Channel
from foxglove.channels import (
    FrameTransformsChannel,
    GridChannel,
    LaserScanChannel,
    PoseInFrameChannel,
    PosesInFrameChannel,
    SceneUpdateChannel,
)
from foxglove.messages import (
    Color,
    FrameTransforms,
    Grid,
    LinePrimitive,
    LinePrimitiveLineType,
    PackedElementField,
    PackedElementFieldNumericType,
    Point3,
    PoseInFrame,
    PosesInFrame,
    SceneEntity,
    SceneUpdate,
    Vector2,
)

from jackson.common.liveview import (
    HEALTH_PERIOD_S,
    MAP_PERIOD_S,
    POSE_PERIOD_S,
    Every,
    LiveServer,
    ServedView,
    laser_scan,
    pose,
    stamp_ns,
    timestamp,
    transform,
)
from jackson.host.core.results import CoreListener, FrameResult
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D, Scan
from jackson.host.ros.names import FRAMES
from jackson.host.service.navigation import NavigationService

MAP_FRAME = "map"
TOPICS = (
    "/map",
    "/scan",
    "/pose",
    "/tf",
    "/footprint",
    "/plan",
    "/local_plan",
    "/goal",
    "/health",
)
"""Every topic the live view serves."""

LATCHED = frozenset({"/map", "/footprint", "/plan", "/goal"})
"""Topics sent again to a client that subscribes (they change seldom)."""

FOOTPRINT_SIDES = 36  # the outline's segments
LOCAL_PLAN_POSES = 20  # /local_plan: DWB's trajectory thinned to this many poses (its cost)
FREE_RGB = 235  # grey level of a free cell (0 % occupied); an occupied cell is 0 (black)
UNKNOWN_RGBA = (90, 100, 115, 160)

HEALTH_SCHEMA: dict[str, Any] = {
    "title": "jackson.Health",
    "type": "object",
    "properties": {
        "t_s": {"type": "number", "description": "MCU time [s]"},
        "frames": {"type": "integer"},
        "state": {"type": "string", "enum": ["idle", "navigating", "teleop"]},
        "unavailable": {"type": ["string", "null"], "description": "why goals are refused"},
        "braked": {"type": "boolean"},
        "pose": {"type": "object"},
        "goal": {"type": ["object", "null"]},
        "eta_s": {"type": ["number", "null"]},
        "goals": {"type": "object", "description": "finished goals by how they ended"},
        "sensors": {"type": "object", "description": "each sensor's health state"},
        "problems": {"type": "array", "items": {"type": "string"}},
    },
}


def map_grid(grid: OccupancyGrid) -> Grid:
    """The occupancy grid as a Foxglove Grid in the map frame: per cell the occupancy (int8)
    and its colour (RGBA), rows from the lowest y as in the grid."""
    occ = grid.data.astype(np.int16)
    known = occ >= 0
    grey = np.where(known, np.round(FREE_RGB * (1.0 - np.clip(occ, 0, 100) / 100.0)), 0)
    cells = np.empty((*occ.shape, 5), np.uint8)
    cells[..., 0] = grid.data.view(np.uint8)
    for k in (1, 2, 3):
        cells[..., k] = np.where(known, grey, UNKNOWN_RGBA[k - 1])
    cells[..., 4] = np.where(known, 255, UNKNOWN_RGBA[3])
    t = PackedElementFieldNumericType
    fields = [
        PackedElementField(name="occupancy", offset=0, type=t.Int8),
        PackedElementField(name="red", offset=1, type=t.Uint8),
        PackedElementField(name="green", offset=2, type=t.Uint8),
        PackedElementField(name="blue", offset=3, type=t.Uint8),
        PackedElementField(name="alpha", offset=4, type=t.Uint8),
    ]
    return Grid(
        timestamp=timestamp(0.0),
        frame_id=MAP_FRAME,
        pose=pose(grid.origin_x_m, grid.origin_y_m, 0.0),
        column_count=grid.width,
        cell_size=Vector2(x=grid.resolution_m, y=grid.resolution_m),
        row_stride=5 * grid.width,
        cell_stride=5,
        fields=fields,
        data=cells.tobytes(),
    )


def footprint(radius_m: float, frame: str) -> SceneUpdate:
    """The robot's outline (the costmap's circle of ``radius_m``) and a line to its front, in
    the base frame, locked to it."""
    a = np.linspace(0.0, 2.0 * math.pi, FOOTPRINT_SIDES, endpoint=False)
    ring = [Point3(x=radius_m * math.cos(t), y=radius_m * math.sin(t), z=0.0) for t in a]
    color = Color(r=0.2, g=0.7, b=1.0, a=1.0)
    lines = [
        LinePrimitive(
            type=LinePrimitiveLineType.LineLoop, thickness=0.02, points=ring, color=color
        ),
        LinePrimitive(
            type=LinePrimitiveLineType.LineStrip,
            thickness=0.02,
            points=[Point3(x=0.0, y=0.0, z=0.0), Point3(x=radius_m, y=0.0, z=0.0)],
            color=color,
        ),
    ]
    entity = SceneEntity(
        timestamp=timestamp(0.0), frame_id=frame, id="footprint", frame_locked=True, lines=lines
    )
    return SceneUpdate(entities=[entity])


def poses_in_frame(t_s: float, points: npt.NDArray[np.float64], frame: str) -> PosesInFrame:
    """A path, shape (N, 2) or (N, 3) with yaw (else each point faces the next), as
    PosesInFrame; no points: an empty message, which clears the path from a panel."""
    n = len(points)
    if n and points.shape[1] >= 3:
        yaws = points[:, 2]
    elif n > 1:
        d = np.diff(points[:, :2], axis=0)
        yaws = np.append(np.arctan2(d[:, 1], d[:, 0]), np.arctan2(d[-1, 1], d[-1, 0]))
    else:
        yaws = np.zeros(n)
    return PosesInFrame(
        timestamp=timestamp(t_s),
        frame_id=frame,
        poses=[
            pose(float(x), float(y), float(yaw))
            for x, y, yaw in zip(points[:, 0], points[:, 1], yaws, strict=True)
        ],
    )


def thinned(points: npt.NDArray[np.float64], most: int) -> npt.NDArray[np.float64]:
    """At most ``most`` of the points, evenly picked, the first and the last kept."""
    n = len(points)
    if n <= most:
        return points
    return points[np.round(np.linspace(0, n - 1, most)).astype(np.intp)]


def _finite(value: float) -> float | None:
    """JSON has no nan nor inf: None for them."""
    return value if math.isfinite(value) else None


class LiveView(CoreListener, ServedView):
    """Publishes the navigation service over a :class:`LiveServer` (module docstring).

    Parameters
    ----------
    service : NavigationService
        The daemon's service: its status, navigator, map and localiser.
    server : LiveServer
        The server (not started: :meth:`start` does).
    sensors : callable
        Each sensor's health state now (``{"imu": "ok", ...}``).
    problems : callable
        The link's and the motor path's problems now, one phrase each.
    tell : callable
        One line for the operator (the live view went off).

    Attributes
    ----------
    published : dict of str to int
        Messages sent per topic.
    off : str or None
        Why the live view stopped publishing (None while it serves).
    """

    def __init__(
        self,
        service: NavigationService,
        server: LiveServer,
        *,
        sensors: Callable[[], Mapping[str, str]],
        problems: Callable[[], list[str]],
        tell: Callable[[str], None],
    ) -> None:
        super().__init__(server, TOPICS, tell)
        self.service = service
        self.sensors = sensors
        self.problems = problems
        ctx = server.context
        self.map_ch = GridChannel("/map", context=ctx)
        self.scan_ch = LaserScanChannel("/scan", context=ctx)
        self.pose_ch = PoseInFrameChannel("/pose", context=ctx)
        self.tf_ch = FrameTransformsChannel("/tf", context=ctx)
        self.footprint_ch = SceneUpdateChannel("/footprint", context=ctx)
        self.plan_ch = PosesInFrameChannel("/plan", context=ctx)
        self.local_plan_ch = PosesInFrameChannel("/local_plan", context=ctx)
        self.goal_ch = PosesInFrameChannel("/goal", context=ctx)
        self.health_ch = Channel("/health", schema=HEALTH_SCHEMA, context=ctx)
        nav = service.nav
        static = nav.static_map
        self._grid = map_grid(static) if static is not None else None
        self._footprint = footprint(nav.navigator.config.costmap.robot_radius_m, FRAMES.base_link)
        self._mount = nav.config.lidar_mount
        self._map_every = Every(MAP_PERIOD_S)
        self._pose_every = Every(POSE_PERIOD_S)
        self._health_every = Every(HEALTH_PERIOD_S)
        self._plan: npt.NDArray[np.float64] | None = None  # the last /plan sent
        self._goal_id: int | None = -1  # the goal /goal shows (-1: none sent yet)
        self._local_plan_shown = False

    # ------------------------------------------------------------------ the frame loop

    def on_scan(self, scan: Scan) -> None:
        if self.off is not None or len(scan.angles_rad) < 2 or not self.scan_ch.has_sinks():
            return
        try:
            a = scan.angles_rad
            msg = laser_scan(scan.t_s, FRAMES.laser, float(a[0]), float(a[-1]), scan.ranges_m)
            self.scan_ch.log(msg, log_time=stamp_ns(scan.t_s))
            self.published["/scan"] += 1
        except Exception as exc:  # the robot goes on without its live view
            self._fail(exc)

    def on_result(self, result: FrameResult) -> None:
        if self.off is not None:
            return
        try:
            self._publish(result)
        except Exception as exc:  # the robot goes on without its live view
            self._fail(exc)

    def _publish(self, result: FrameResult) -> None:
        t_s = result.t_s
        again = self.server.subscribed() & LATCHED
        if self._map_every.due(t_s):
            again |= {"/map", "/footprint"}
        if "/map" in again and self._grid is not None and self.map_ch.has_sinks():
            self.map_ch.log(self._grid, log_time=stamp_ns(t_s))
            self.published["/map"] += 1
        if "/footprint" in again and self.footprint_ch.has_sinks():
            self.footprint_ch.log(self._footprint, log_time=stamp_ns(t_s))
            self.published["/footprint"] += 1
        if self._pose_every.due(t_s):
            self._poses(t_s, again)
        if self._health_every.due(t_s) and self.health_ch.has_sinks():
            self.health_ch.log(self.health(result), log_time=stamp_ns(t_s))
            self.published["/health"] += 1

    def _poses(self, t_s: float, again: set[str]) -> None:
        """At 10 Hz: /pose, /tf, /goal and /plan when they changed, /local_plan."""
        st = self.service.status
        nav = self.service.nav
        log_ns = stamp_ns(t_s)
        if self.pose_ch.has_sinks():
            p = st.pose
            msg = PoseInFrame(
                timestamp=timestamp(t_s), frame_id=MAP_FRAME, pose=pose(p.x, p.y, p.yaw)
            )
            self.pose_ch.log(msg, log_time=log_ns)
            self.published["/pose"] += 1
        if self.tf_ch.has_sinks():
            corr = nav.map_to_odom.compose(nav.config.start)  # odometry starts at the start
            odom = corr.inverse().compose(st.pose)
            m = self._mount
            tfs = FrameTransforms(
                transforms=[
                    transform(t_s, MAP_FRAME, FRAMES.odom, corr.x, corr.y, corr.yaw),
                    transform(t_s, FRAMES.odom, FRAMES.base_link, odom.x, odom.y, odom.yaw),
                    transform(t_s, FRAMES.base_link, FRAMES.laser, m.x, m.y, m.yaw),
                ]
            )
            self.tf_ch.log(tfs, log_time=log_ns)
            self.published["/tf"] += 1
        goal = st.goal
        goal_id = goal.goal_id if goal is not None else None
        if (goal_id != self._goal_id or "/goal" in again) and self.goal_ch.has_sinks():
            g: Pose2D | None = goal.pose if goal is not None else None
            points = np.array([[g.x, g.y, g.yaw]]) if g is not None else np.empty((0, 3))
            self.goal_ch.log(poses_in_frame(t_s, points, MAP_FRAME), log_time=log_ns)
            self.published["/goal"] += 1
            self._goal_id = goal_id
        if self.plan_ch.has_sinks():
            plan = nav.navigator.plan if goal is not None else np.empty((0, 2))
            last = self._plan
            if last is None or "/plan" in again or not np.array_equal(plan, last):
                self.plan_ch.log(poses_in_frame(t_s, plan, MAP_FRAME), log_time=log_ns)
                self.published["/plan"] += 1
                self._plan = plan
        if self.local_plan_ch.has_sinks():
            local = nav.navigator.local_plan if goal is not None else np.empty((0, 3))
            local = thinned(local, LOCAL_PLAN_POSES)
            if len(local) or self._local_plan_shown:
                self.local_plan_ch.log(poses_in_frame(t_s, local, MAP_FRAME), log_time=log_ns)
                self.published["/local_plan"] += 1
                self._local_plan_shown = bool(len(local))

    def health(self, result: FrameResult) -> dict[str, Any]:
        """The /health message: the service's state and goal, the pose with its spread, the
        sensors' health states, the link's problems and the goal counts."""
        st = self.service.status
        cov = st.covariance
        rec = st.goal
        return {
            "t_s": result.t_s,
            "frames": result.frame,
            "state": st.state.value,
            "unavailable": st.unavailable,
            "braked": result.braked,
            "pose": {
                "x": st.pose.x,
                "y": st.pose.y,
                "yaw": st.pose.yaw,
                "std_x_m": math.sqrt(max(cov[0], 0.0)),
                "std_y_m": math.sqrt(max(cov[4], 0.0)),
                "std_yaw_rad": math.sqrt(max(cov[8], 0.0)),
            },
            "goal": None if rec is None else rec.as_dict(),
            "eta_s": _finite(st.eta_s),
            "goals": dict(self.service.book.counts),
            "sensors": dict(self.sensors()),
            "problems": self.problems(),
        }
