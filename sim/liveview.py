"""The twin's ground truth seen live in Foxglove (``jackson sim --live-view [HOST:]PORT``): the
world, the true pose and the true scan, over the Foxglove WebSocket protocol on a port of its
own (:class:`~jackson.common.liveview.LiveServer`), beside the daemon's view of the same robot.

| topic      | schema (protobuf)        | frame     | when                                      |
|------------|--------------------------|-----------|-------------------------------------------|
| /world     | foxglove.SceneUpdate     | world     | subscribe, every 10 s, a cylinder changes |
| /pose      | foxglove.PoseInFrame     | world     | 10 Hz of sim time                         |
| /tf        | foxglove.FrameTransforms | (below)   | 10 Hz of sim time                         |
| /footprint | foxglove.SceneUpdate     | base_link | on subscribe, every 10 s                  |
| /scan      | foxglove.LaserScan       | laser     | every scan of the twin's LiDAR            |

The transforms are world -> base_link (the true pose) -> laser (the LiDAR's mounting).
Walls are boxes 0.3 m high along their segments, cylinders cylinders; the footprint is the
robot's collision envelope. The world frame is the world file's, which a map made from the
world (``jackson map``, :func:`jackson.experiments.stage3.world_grid`) shares: the twin's
``world`` and the daemon's ``map`` coincide where the map does. Stamps are sim time, which is
the MCU time the daemon stamps with.

:meth:`TwinLiveView.on_advance` is the runner's observer (called after each advance of the
clock, once a host has said HELLO); a topic no client subscribed to is not built. A failure
while publishing turns the view off with one line on stderr; the twin goes on.
"""

from __future__ import annotations

import math
import sys

from foxglove import channels
from foxglove import messages as fm

from jackson.common.liveview import (
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
from jackson.sim.twin import Twin

WORLD_FRAME = "world"
BASE_FRAME = "base_link"
LASER_FRAME = "laser"
TOPICS = ("/world", "/pose", "/tf", "/footprint", "/scan")
"""Every topic the twin's view serves."""

WALL_HEIGHT_M = 0.3
WALL_THICKNESS_M = 0.03
WALL_RGBA = (0.75, 0.75, 0.78, 1.0)
CYLINDER_RGBA = (0.95, 0.55, 0.15, 1.0)
ROBOT_RGBA = (0.3, 1.0, 0.4, 1.0)


def _color(rgba: tuple[float, float, float, float]) -> fm.Color:
    return fm.Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])


def world_scene(
    t_s: float,
    walls: list[tuple[float, float, float, float]],
    circles: list[tuple[float, float, float]],
) -> fm.SceneUpdate:
    """The walls (boxes along their segments) and the cylinders present now, as one entity
    that replaces the previous one."""
    cubes = []
    for x1, y1, x2, y2 in walls:
        length = math.hypot(x2 - x1, y2 - y1)
        yaw = math.atan2(y2 - y1, x2 - x1)
        cubes.append(
            fm.CubePrimitive(
                pose=pose(0.5 * (x1 + x2), 0.5 * (y1 + y2), yaw, 0.5 * WALL_HEIGHT_M),
                size=fm.Vector3(x=length + WALL_THICKNESS_M, y=WALL_THICKNESS_M, z=WALL_HEIGHT_M),
                color=_color(WALL_RGBA),
            )
        )
    cylinders = [
        fm.CylinderPrimitive(
            pose=pose(x, y, 0.0, 0.5 * WALL_HEIGHT_M),
            size=fm.Vector3(x=2.0 * r, y=2.0 * r, z=WALL_HEIGHT_M),
            bottom_scale=1.0,
            top_scale=1.0,
            color=_color(CYLINDER_RGBA),
        )
        for x, y, r in circles
    ]
    entity = fm.SceneEntity(
        timestamp=timestamp(t_s),
        frame_id=WORLD_FRAME,
        id="world",
        cubes=cubes,
        cylinders=cylinders,
    )
    return fm.SceneUpdate(entities=[entity])


def envelope_scene(x_m: tuple[float, float], y_m: tuple[float, float]) -> fm.SceneUpdate:
    """The robot's collision envelope (a rectangle in the base frame) and a line to its
    front, locked to the base frame."""
    (x0, x1), (y0, y1) = x_m, y_m
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    lines = [
        fm.LinePrimitive(
            type=fm.LinePrimitiveLineType.LineLoop,
            thickness=0.02,
            points=[fm.Point3(x=x, y=y, z=0.0) for x, y in corners],
            color=_color(ROBOT_RGBA),
        ),
        fm.LinePrimitive(
            type=fm.LinePrimitiveLineType.LineStrip,
            thickness=0.02,
            points=[fm.Point3(x=0.0, y=0.0, z=0.0), fm.Point3(x=x1, y=0.0, z=0.0)],
            color=_color(ROBOT_RGBA),
        ),
    ]
    entity = fm.SceneEntity(
        timestamp=timestamp(0.0),
        frame_id=BASE_FRAME,
        id="footprint",
        frame_locked=True,
        lines=lines,
    )
    return fm.SceneUpdate(entities=[entity])


def _say(text: str) -> None:
    print(f"jackson sim: {text}", file=sys.stderr, flush=True)


class TwinLiveView(ServedView):
    """Publishes one twin's ground truth over a :class:`LiveServer` (module docstring).

    Parameters
    ----------
    twin : Twin
        The twin.
    server : LiveServer
        The server (not started: :meth:`start` does).

    Attributes
    ----------
    published : dict of str to int
        Messages sent per topic.
    off : str or None
        Why the view stopped publishing (None while it serves).
    """

    def __init__(self, twin: Twin, server: LiveServer) -> None:
        super().__init__(server, TOPICS, _say)
        self.twin = twin
        ctx = server.context
        self.world_ch = channels.SceneUpdateChannel("/world", context=ctx)
        self.pose_ch = channels.PoseInFrameChannel("/pose", context=ctx)
        self.tf_ch = channels.FrameTransformsChannel("/tf", context=ctx)
        self.footprint_ch = channels.SceneUpdateChannel("/footprint", context=ctx)
        self.scan_ch = channels.LaserScanChannel("/scan", context=ctx)
        spec = twin.robot_spec
        self._footprint = envelope_scene(spec.envelope_x_m, spec.envelope_y_m)
        lidar = twin._lidar
        self._lidar = lidar.spec if lidar is not None else None
        self._scans_done = twin.scans_taken
        self._world_version: tuple[int, int] | None = None
        self._world_every = Every(MAP_PERIOD_S)
        self._pose_every = Every(POSE_PERIOD_S)

    def on_advance(self, twin: Twin) -> None:
        """After an advance of sim time: new scans, the world when due, the pose at 10 Hz."""
        if self.off is not None:
            return
        try:
            self._publish(twin)
        except Exception as exc:  # the twin goes on without its live view
            self._fail(exc)

    def _publish(self, twin: Twin) -> None:
        t_s = twin.t_s
        log_ns = stamp_ns(t_s)
        again = self.server.subscribed()
        world = twin.world
        version = (len(world.inserted), len(world.removed))
        due = self._world_every.due(t_s)
        if (due or "/world" in again or version != self._world_version) and (
            self.world_ch.has_sinks()
        ):
            self.world_ch.log(world_scene(t_s, world.segments, world.circles), log_time=log_ns)
            self.published["/world"] += 1
            self._world_version = version
        if (due or "/footprint" in again) and self.footprint_ch.has_sinks():
            self.footprint_ch.log(self._footprint, log_time=log_ns)
            self.published["/footprint"] += 1
        new = twin.scans_taken - self._scans_done
        self._scans_done = twin.scans_taken
        spec = self._lidar
        if new > 0 and spec is not None and self.scan_ch.has_sinks():
            # the twin keeps its newest scans (jackson sim: SCAN_HISTORY): called after every
            # advance, this never falls that far behind
            for scan in list(twin.scans)[-new:]:
                msg = laser_scan(
                    scan.t_s, LASER_FRAME, spec.angle_min_rad, spec.angle_max_rad, scan.ranges
                )
                self.scan_ch.log(msg, log_time=stamp_ns(scan.t_s))
                self.published["/scan"] += 1
        if not self._pose_every.due(t_s):
            return
        truth = twin.truth()
        if self.pose_ch.has_sinks():
            msg_pose = fm.PoseInFrame(
                timestamp=timestamp(t_s),
                frame_id=WORLD_FRAME,
                pose=pose(truth.x, truth.y, truth.yaw),
            )
            self.pose_ch.log(msg_pose, log_time=log_ns)
            self.published["/pose"] += 1
        if self.tf_ch.has_sinks():
            tfs = [transform(t_s, WORLD_FRAME, BASE_FRAME, truth.x, truth.y, truth.yaw)]
            if spec is not None:
                tfs.append(
                    transform(
                        t_s,
                        BASE_FRAME,
                        LASER_FRAME,
                        spec.mount_x_m,
                        spec.mount_y_m,
                        spec.mount_yaw_rad,
                    )
                )
            self.tf_ch.log(fm.FrameTransforms(transforms=tfs), log_time=log_ns)
            self.published["/tf"] += 1
