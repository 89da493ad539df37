"""Stage 3 as a command source of the daemon: localise (or map) on the LiDAR, navigate to goals.

:class:`NavigateMission` is a :class:`jackson.host.control.base.Mission` that also takes scans
(:meth:`NavigateMission.on_scan`, called by :class:`jackson.host.core.HostCore` with each
LiDAR revolution, stamped on MCU time). Per telemetry frame it

1. places the robot in the map: the EKF's odometry pose composed with the map -> odom
   correction of the localiser;
2. steps the :class:`jackson.host.control.navigator.Navigator` (costmaps, A*, DWB, recoveries) with
   that pose, the EKF's velocities and the newest scan's returns in the map frame;
3. returns the navigator's (v, w), which go through the daemon's actuation chain (limits,
   kinematics, deadband compensation) like any mission's.

Two localisers (``localisation``):

* ``amcl``: a particle filter on a known map (:class:`jackson.host.nav.amcl.ParticleFilter`),
  started at the given start pose, as Nav2 with an initial pose;
* ``slam``: a map built as the robot drives (:class:`jackson.host.nav.slam.mapper.Mapper`, scan
  matching against the map so far), as slam_toolbox; the navigator's static map is then a
  blank grid over ``extent`` whose unknown space counts as free, so the robot explores on what
  its scans show.

Frames: the map frame is the world frame the start pose and the goals are given in. The EKF's
odometry starts at (0, 0, 0), so the odometry pose handed to the localiser is ``start ⊕ odom``;
the correction the localiser reports is then relative to the start-anchored odometry.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.control.base import NavState
from jackson.host.control.guard import route_timeout_s
from jackson.host.control.navigator import (
    NavCommand,
    Navigator,
    NavigatorConfig,
    NavigatorState,
)
from jackson.host.control.route import check_route
from jackson.host.lidar.scan_timer import ScanTimer
from jackson.host.nav.amcl import AmclConfig, ParticleFilter
from jackson.host.nav.deskew import deskew
from jackson.host.nav.ekf_lag import base_pose
from jackson.host.nav.grid import UNKNOWN, OccupancyGrid
from jackson.host.nav.planner_server import Planner
from jackson.host.nav.slam.mapper import Mapper, MappingConfig
from jackson.host.nav.types import Pose2D, Scan

Localisation = Literal["amcl", "slam"]
START_MOVING_M_S = 0.01  # [m/s] time zero: the first command faster than this (REFERENCE)


@dataclass(frozen=True)
class NavigateConfig:
    """What a navigation run needs besides the map.

    Attributes
    ----------
    start : Pose2D
        The robot's pose in the map frame when the daemon starts (its odometry origin).
    goals : tuple of Pose2D
        Visited in order; the mission is done when the last is reached. Empty for the
        navigation service (:mod:`jackson.host.service`), which takes its goals as they come.
    localisation : str
        ``amcl`` (needs a map) or ``slam`` (builds one).
    extent : tuple of 4 float
        (x_min, y_min, x_max, y_max) [m] of the navigator's blank map in ``slam`` mode.
    lidar_mount : Pose2D
        The LiDAR's pose in the base frame.
    deskew : bool
        Take each revolution as the sensor would have measured it from the base's pose at
        its end, from the base's motion over it (:mod:`jackson.host.nav.deskew`), before the
        localiser, the mapper and the costmaps see it; False takes it as measured (a replay
        of a run recorded before revolutions were deskewed).
    seed : int
        Seed of the particle filter's random numbers (a run is reproducible).
    navigator : NavigatorConfig
        Costmaps, planner, DWB, recoveries.
    amcl : AmclConfig
        The particle filter.
    mapping : MappingConfig
        The mapper.
    map_update_s : float
        In ``slam`` mode, the global costmap's static layer takes the mapper's map every this
        many seconds of scan time (slam_toolbox publishes /map every 5 s and Nav2's static
        layer takes it); 0 never: the planner then knows only the obstacle layer's marks,
        which the rays of every scan clear again, a thin partition seen along its length
        with them.
    """

    start: Pose2D
    goals: tuple[Pose2D, ...]
    localisation: Localisation = "amcl"
    extent: tuple[float, float, float, float] = (-2.0, -2.0, 2.0, 2.0)
    lidar_mount: Pose2D = field(default_factory=Pose2D)
    deskew: bool = True
    seed: int = 0
    navigator: NavigatorConfig = field(default_factory=NavigatorConfig)
    amcl: AmclConfig = field(default_factory=AmclConfig)
    mapping: MappingConfig = field(default_factory=MappingConfig)
    map_update_s: float = 5.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.map_update_s < math.inf:
            raise ValueError(
                f"NavigateConfig.map_update_s must be a number >= 0, got {self.map_update_s}"
            )
        if self.localisation not in ("amcl", "slam"):
            raise ValueError(
                f"NavigateConfig.localisation must be amcl or slam, got {self.localisation!r}"
            )
        x0, y0, x1, y1 = self.extent
        if not (x1 > x0 and y1 > y0):
            raise ValueError(f"NavigateConfig.extent must be x0 < x1, y0 < y1, got {self.extent}")


FRAMES_KEPT = 6
"""Telemetry frames the mission keeps for pairing a revolution with the base's motion over it
(0.25 s at 20 Hz: an A1M8's 0.135 s revolution and the frame it came with)."""

RECENT_SAMPLES = 200
"""Control ticks a daemon's navigation keeps (10 s at 20 Hz) when it does not keep them all."""


@dataclass(frozen=True)
class NavSample:
    """One control tick of the mission, for the run folder (``nav.csv``)."""

    t_s: float
    x_m: float  # the robot in the map frame, as the mission believes
    y_m: float
    yaw_rad: float
    v_cmd: float
    w_cmd: float
    state: str
    goal_index: int
    distance_to_goal_m: float


class NavigateMission:
    """Localise on the LiDAR and drive through ``config.goals`` (a daemon mission).

    Parameters
    ----------
    config : NavigateConfig
        Start, goals, localiser and their settings.
    limits : LimiterConfig
        The daemon's velocity and acceleration limits (the local planner samples within them).
    static_map : OccupancyGrid or None
        The known map (``amcl``); None in ``slam`` mode.
    keep_samples : bool
        Keep every control tick in :attr:`samples` (a trial's metrics and ``nav.csv``); the
        long-running daemon keeps only the last :data:`RECENT_SAMPLES`, so its memory stays
        flat (a tick kept is about 0.3 kB: 20 MB per robot-hour at 20 Hz).
    planner : Planner or None
        Where the navigator's global plans are searched when
        ``config.navigator.plan_delay_ticks`` > 0 (the daemon: a
        :class:`~jackson.host.nav.planner_server.WorkerPlanner`; default: on the frame loop).

    Raises
    ------
    RouteError
        The start or a goal lies off the map, in unknown space, on or beside an obstacle, or
        apart from the start (:func:`jackson.host.control.route.check_route`).

    Attributes
    ----------
    done : bool
        The last goal was reached, or navigation failed (see :attr:`failure`).
    failure : str or None
        Why navigation gave up (the navigator's reason), or None.
    samples : list or deque of NavSample
        Every control tick (``keep_samples``), else the last :data:`RECENT_SAMPLES`.
    t_start_s, t_goal_s : float or None
        MCU time of the first command above 0.01 m/s, and of reaching the last goal.
    scans : int
        Scans taken.
    """

    name = "navigate"

    def __init__(
        self,
        config: NavigateConfig,
        limits: LimiterConfig,
        static_map: OccupancyGrid | None = None,
        *,
        keep_samples: bool = True,
        planner: Planner | None = None,
    ) -> None:
        self.config = config
        # the guard's limit (TimedMission): a survey of a whole floor gets the time it needs
        self.timeout_s = route_timeout_s(
            [(config.start.x, config.start.y), *((g.x, g.y) for g in config.goals)]
        )
        self.done = False
        self.failure: str | None = None
        self.samples: list[NavSample] | deque[NavSample] = (
            [] if keep_samples else deque(maxlen=RECENT_SAMPLES)
        )
        self.t_start_s: float | None = None
        self.t_goal_s: float | None = None
        self.scans = 0
        self.goal_index = 0
        self._scan_points: npt.NDArray[np.float64] | None = None
        self._odom = Pose2D()  # start ⊕ the EKF's odometry pose, at the last tick or scan
        # when each revolution began and ended: the last frames' (MCU time, odometry pose, the
        # base's pose at that time: _base_pose), enough for a revolution and a frame, the timer
        self._frames: deque[tuple[float, Pose2D, Pose2D]] = deque(maxlen=FRAMES_KEPT)
        self._scan_timer = ScanTimer()
        self._last_scan_t_s: float | None = None
        self.static_map = static_map
        self.mapper: Mapper | None = None
        self._map_sent_s = -math.inf  # scan time the mapper's map last went to the planner
        self.filter: ParticleFilter | None = None
        if config.localisation == "amcl":
            if static_map is None:
                raise ValueError("amcl localisation needs a map (jackson map makes one)")
            self.filter = ParticleFilter(
                static_map, config.amcl, np.random.default_rng(config.seed)
            )
            self.filter.initialise(config.start)
            nav_map = static_map
        else:
            self.mapper = Mapper(config.mapping)
            x0, y0, x1, y1 = config.extent
            nav_map = OccupancyGrid.empty(
                x1 - x0, y1 - y0, config.mapping.resolution_m, x0, y0, UNKNOWN
            )
        nav_config = config.navigator
        if self.mapper is not None:  # unknown space is free until a scan shows otherwise
            nav_config = dataclasses.replace(nav_config, global_track_unknown_space=False)
        self.map_to_odom = Pose2D()  # the localiser's correction (identity until it has one)
        self._requested: Pose2D | None = None  # a goal from another thread (ROS /goal_pose)
        self.navigator = Navigator(nav_config, nav_map, limits, planner)
        if static_map is not None:  # a start or goal the map rules out: before anything moves
            check_route(
                static_map, config.start, config.goals, nav_config, self.navigator.static_costmap
            )
        if config.goals:
            self.navigator.set_goal(config.goals[0])
        else:
            self.done = True  # idle until a goal is given
        self.last: NavCommand | None = None

    # ------------------------------------------------------------------ inputs

    def _odom_pose(self, s: NavState) -> Pose2D:
        return self.config.start.compose(Pose2D(s.x_m, s.y_m, s.yaw_rad))

    def pose_map(self) -> Pose2D:
        """The robot in the map frame: the correction composed with the start-anchored
        odometry."""
        return self.map_to_odom.compose(self._odom)

    def on_scan(self, scan: Scan, s: NavState) -> None:
        """One LiDAR revolution, with the EKF's state at the MCU time of the frame it came
        with."""
        self._odom = self._odom_pose(s)
        self.scans += 1
        mount = self.config.lidar_mount
        # the odometry when the revolution ended, not at the frame it came with (up to 50 ms
        # later: 1.3 cm at 0.26 m/s, and the estimate trailed the robot by as much)
        at_end, base_at_end, t_end_s, t_start_s = self._odom_at_revolution_end(scan, s)
        if self.config.deskew and t_start_s is not None:
            motion = self._base_at(t_start_s).inverse().compose(base_at_end)
            scan = deskew(scan, mount, motion)
        if self.filter is not None:
            self.filter.update(at_end, scan, mount)
            self.map_to_odom = self.filter.map_to_odom(at_end)
            self.filter.update(self._odom, None, mount)  # and on to this frame
        elif self.mapper is not None:
            # the base's pose, not the EKF's, which trails it by a frame (ekf_lag), stamped
            # with the revolution's end (the graph's times, trajectory.csv)
            placed = self.mapper.update(dataclasses.replace(scan, t_s=t_end_s), base_at_end, mount)
            # the correction for the EKF's odometry: where the scan placed the base, against the
            # EKF's pose at the same instant (the frame's lag taken up in it, as AMCL's is), so
            # that the navigator's pose is the base's now, not a frame ago; it holds for the
            # odometry's frame at any instant
            self.map_to_odom = placed.compose(at_end.inverse())
            every = self.config.map_update_s
            if every > 0.0 and t_end_s - self._map_sent_s >= every:
                self.navigator.global_costmap.set_static_map(self.mapper.grid())
                self._map_sent_s = t_end_s
        self._scan_points = scan.points(self.pose_map(), mount)

    def _odom_at_revolution_end(
        self, scan: Scan, s: NavState
    ) -> tuple[Pose2D, Pose2D, float, float | None]:
        """The odometry pose when the revolution ended, for the localiser, the base's pose then
        (:mod:`jackson.host.nav.ekf_lag`), for the mapper, and that MCU time: between the frame
        before and this one, where :class:`~jackson.host.lidar.scan_timer.ScanTimer` puts its
        end (the frame's own pose and time while the timer has no phase yet); and the MCU time
        the revolution began (None while the timer has no phase). A revolution
        paired with the frame it came with is up to a frame late: 0.05 rad of heading in a
        1 rad/s turn, which printed walls turned by as much."""
        self._add_frame(s)
        frames = self._frames
        since = frames[-2][0] if len(frames) > 1 else None
        if self._last_scan_t_s == s.t_s:
            since = s.t_s  # another revolution with the same frame: not alone in its window
        self._last_scan_t_s = s.t_s
        stamps = self._scan_timer.stamp([len(scan.angles_rad)], s.t_s, since)
        if not stamps or len(frames) < 2:
            return self._odom, frames[-1][2], s.t_s, None
        start, duration = stamps[-1]
        (t0, p0, b0), (t1, p1, b1) = frames[-2], frames[-1]
        f = min(1.0, max(0.0, (start + duration - t0) / (t1 - t0))) if t1 > t0 else 1.0
        return _between(p0, p1, f), _between(b0, b1, f), t0 + f * (t1 - t0), start

    def _base_at(self, t_s: float) -> Pose2D:
        """The base's pose at MCU time ``t_s`` from the frames kept (the oldest one's before
        them, the newest one's after)."""
        frames = self._frames
        if t_s <= frames[0][0]:
            return frames[0][2]
        for (t0, _, b0), (t1, _, b1) in itertools.pairwise(frames):
            if t_s <= t1:
                return _between(b0, b1, (t_s - t0) / (t1 - t0))
        return frames[-1][2]

    def _add_frame(self, s: NavState) -> None:
        """Keep this frame's odometry pose (``_odom``, set by the caller) for pairing
        revolutions with, and the base's pose at its time (the EKF's trails it by a frame:
        :mod:`jackson.host.nav.ekf_lag`)."""
        frames = self._frames
        if not frames or s.t_s > frames[-1][0]:
            period = s.t_s - frames[-1][0] if frames else 0.0
            base = base_pose(self._odom, s.v_m_s, s.w_rad_s, period)
            frames.append((s.t_s, self._odom, base))

    # ------------------------------------------------------------------ the tick

    def request_goal(self, goal: Pose2D) -> None:
        """A new single goal (map frame), taken at the next tick; safe from another thread."""
        self._requested = goal

    def track(self, s: NavState) -> Pose2D:
        """Follow the odometry to this tick (the localiser's motion update, without a scan);
        the robot's pose in the map frame."""
        self._odom = self._odom_pose(s)
        self._add_frame(s)
        if self.filter is not None:
            self.filter.update(self._odom, None, self.config.lidar_mount)
        return self.pose_map()

    def relocalise(self, pose: Pose2D) -> None:
        """The robot is at ``pose`` (map frame) now: the localiser starts again around it
        (``/initialpose``, ``jackson localise``); with the mapper, the correction jumps there."""
        self.map_to_odom = pose.compose(self._odom.inverse())
        if self.filter is not None:
            self.filter.initialise(pose)

    def command(self, s: NavState) -> tuple[float, float]:
        """(v [m/s], w [rad/s]) for this tick, from the navigator."""
        requested, self._requested = self._requested, None
        if requested is not None:
            self.config = dataclasses.replace(self.config, goals=(requested,))
            self.goal_index = 0
            self.done = False
            self.failure = None
            self.t_goal_s = None
            self.navigator.set_goal(requested)
        if self.done:
            return 0.0, 0.0
        pose = self.track(s)
        cmd = self.navigator.step(s.t_s, pose, (s.v_m_s, s.w_rad_s), self._scan_points)
        self._scan_points = None
        self.last = cmd
        if cmd.state == NavigatorState.SUCCEEDED:
            if self.goal_index + 1 < len(self.config.goals):
                self.goal_index += 1
                self.navigator.set_goal(self.config.goals[self.goal_index])
            else:
                self.done = True
                self.t_goal_s = s.t_s
        elif cmd.state == NavigatorState.FAILED:
            self.done = True
            self.failure = cmd.reason or "navigation failed"
        v, w = (0.0, 0.0) if self.done else (cmd.v_m_s, cmd.w_rad_s)
        if self.t_start_s is None and abs(v) > START_MOVING_M_S:
            self.t_start_s = s.t_s
        self.samples.append(
            NavSample(
                s.t_s,
                pose.x,
                pose.y,
                pose.yaw,
                v,
                w,
                cmd.state.value,
                self.goal_index,
                cmd.distance_to_goal_m,
            )
        )
        return v, w

    def set_limits(self, limits: LimiterConfig) -> None:
        """New speed and acceleration bounds for the navigator, from the next tick on (the
        daemon's live settings)."""
        self.navigator.set_limits(limits)

    @property
    def recoveries(self) -> dict[str, int]:
        """Recoveries run for the current goal, by behaviour."""
        return dict(self.navigator.recoveries)

    def built_map(self) -> OccupancyGrid | None:
        """The map built in ``slam`` mode so far (None with ``amcl``)."""
        return self.mapper.grid() if self.mapper is not None else None

    def finish_map(self, map_yaml: Path) -> OccupancyGrid | None:
        """The survey is over: the last look for a loop closure taken, the map saved to
        ``map_yaml`` (map_server YAML + PGM) and its pose graph beside it
        (:mod:`jackson.host.nav.slam.store`); the map, None with ``amcl`` (nothing saved)."""
        if self.mapper is None:
            return None
        from jackson.host.nav.slam.store import graph_path, save_graph

        self.mapper.finish()
        grid = self.mapper.grid()
        grid.save(map_yaml)
        save_graph(self.mapper, graph_path(map_yaml))
        return grid


def _between(a: Pose2D, b: Pose2D, f: float) -> Pose2D:
    """The pose a share ``f`` of the way from ``a`` to ``b`` (in ``a``'s frame, linearly)."""
    step = a.inverse().compose(b)
    return a.compose(Pose2D(f * step.x, f * step.y, f * step.yaw))


def parse_pose(text: str, limit_m: float = 1e4) -> Pose2D:
    """A pose from the command line.

    Parameters
    ----------
    text : str
        ``x,y`` or ``x,y,yaw`` [m, m, rad]; the yaw defaults to 0.
    limit_m : float
        The largest ``|x|`` and ``|y|`` accepted [m].

    Returns
    -------
    Pose2D
        The pose.

    Raises
    ------
    ValueError
        One line naming the text: not two or three finite numbers, or a position beyond
        ``limit_m``.
    """
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise ValueError(f"expected x,y or x,y,yaw in metres and radians, got {text!r}")
    if abs(values[0]) > limit_m or abs(values[1]) > limit_m:
        raise ValueError(f"x and y must lie within ±{limit_m:g} m, got {text!r}")
    return Pose2D(values[0], values[1], values[2] if len(values) == 3 else 0.0)


def poses(texts: Sequence[str]) -> tuple[Pose2D, ...]:
    """:func:`parse_pose` of each."""
    return tuple(parse_pose(t) for t in texts)


MAP_NAME = "map"
"""A navigation run's folder keeps the map it navigated on as ``map.yaml`` + ``map.pgm``."""


def _pose_list(p: Pose2D) -> list[float]:
    return [p.x, p.y, p.yaw]


def navigate_meta(config: NavigateConfig) -> dict[str, object]:
    """What ``meta.json`` records of a navigation run, so a replay rebuilds the mission."""
    return {
        "start": _pose_list(config.start),
        "goals": [_pose_list(g) for g in config.goals],
        "localisation": config.localisation,
        "extent": list(config.extent),
        "lidar_mount": _pose_list(config.lidar_mount),
        "deskew": config.deskew,
        "amcl": dataclasses.asdict(config.amcl),
        "map_update_s": config.map_update_s,
        "plan_delay_ticks": config.navigator.plan_delay_ticks,
        "seed": config.seed,
        "map": f"{MAP_NAME}.yaml" if config.localisation == "amcl" else None,
    }
