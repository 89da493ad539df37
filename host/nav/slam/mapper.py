"""Online mapping with scan matching and a pose graph: what slam_toolbox does for the robot.

:class:`Mapper` keeps the map's cells as counts (:mod:`jackson.host.nav.slam.occupancy`), a
pose graph of the scans written into it (:mod:`jackson.host.nav.slam.graph`) and the
map -> odom correction. For each scan it is given the odometry (or EKF) pose of the base; it

1. predicts the map-frame pose, ``map_to_odom ⊕ odom_pose``;
2. returns that prediction unless the robot has moved at least ``min_travel_m`` or turned at
   least ``min_heading_rad`` since the last integrated scan (or this is the first scan), as
   slam_toolbox's ``minimum_travel_distance`` / ``minimum_travel_heading`` (0.5 m / 0.5 rad by
   default there; a 0.2 m robot in a 3 m maze needs 0.05 m / 0.05 rad);
3. searches a window around the prediction (default +-0.1 m, +-0.1 rad, and in heading at
   least ``turn_window_s`` times the turn rate since the scan before: a revolution paired with
   a pose a frame late while the robot spins at 1 rad/s is turned as a whole by about 0.1 rad,
   30 cm at 3 m, at the edge of the default window) for the pose at which
   the scan best agrees with the map near the robot
   (:func:`~jackson.host.nav.slam.matcher.search`); the best pose replaces the prediction when
   its score reaches ``min_match_score``, otherwise the prediction stands;
4. adds the scan to the graph as a node, joined to the one before by the relative pose of the
   two (an edge of ``chain_sigma_m`` / ``chain_sigma_rad``, wider when the match failed, and
   wider along the directions the match could not tell apart: its spread, when
   ``chain_spread``), and writes it into the map;
5. every ``loop_every`` nodes (or ``look_share`` of the graph's nodes, when more), looks for a
   loop closure (:mod:`jackson.host.nav.slam.loops`):
   a place visited at least ``loop.min_chain_m`` of travel earlier whose scans match this one.
   A closure that disagrees with the graph by more than half a cell or 0.3 degrees optimises
   the graph and writes every scan again at its new pose, so walls seen twice become one. The
   look runs in a thread of its own and its result is taken at the next look, whatever the
   machine's speed (:mod:`jackson.host.nav.slam.backend`);
6. updates ``map_to_odom = node ⊕ odom_pose⁻¹`` from the node's pose in the graph.

The graph can be saved beside the map and loaded to go on mapping (:mod:`.slam.store`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.likelihood import LikelihoodField, PointField
from jackson.host.nav.slam.backend import BackEnd, Closure, look
from jackson.host.nav.slam.graph import Edge, PoseGraph
from jackson.host.nav.slam.loops import LoopConfig, Node
from jackson.host.nav.slam.matcher import Window, base_points, search
from jackson.host.nav.slam.occupancy import CountGrid, Insertion
from jackson.host.nav.types import Pose2D, Scan

FloatArray = npt.NDArray[np.float64]

ORIGIN = Pose2D()  # the identity pose: a sensor mounted on the base origin
RESUMED_WIDEN = 100.0  # the chain edge into a resumed map's first new scan: 1 m, 0.5 rad wide


@dataclass(frozen=True)
class MappingConfig:
    """Parameters of :class:`Mapper`.

    Attributes
    ----------
    resolution_m : float
        Cell edge [m] (slam_toolbox's default resolution).
    occupancy_threshold : float
        Share of the scans that saw a cell that must have ended a beam in it for it to be
        occupied (slam_toolbox's 0.1; :mod:`jackson.host.nav.slam.occupancy`).
    min_observations : int
        Scans that must have seen a cell before it is known (slam_toolbox's minimum
        pass-through 2): a lone return beyond a wall stays unknown.
    max_range_m : float
        Returns farther than this clear up to it and mark no hit [m] (REFERENCE: the robot's
        8 m software cap); the loop closures match within it too.
    match_range_m : float
        The front end matches the returns within this against the map [m] (the A1M8's 12 m):
        door frames and wall ends far along a corridor pin how far the robot has come, which
        the side walls do not (docs/mapping.md, "Range").
    no_return_free_m : float
        Beams with no return clear this far [m]; 0 clears nothing.
    trace_step_cells : float
        Spacing of the points sampled along a beam to find the cells it crosses [cells].
    grow_margin_m : float
        Room added beyond a scan whenever the grid grows [m].
    min_travel_m : float
        Odometry travel since the last integrated scan that makes the next one integrate [m].
    min_heading_rad : float
        Odometry turn since the last integrated scan that makes the next one integrate [rad].
    scan_matching : bool
        Correct the pose by scan matching; False integrates at the odometry prediction.
    search_xy_m, search_yaw_rad : float
        Half-widths of the search window around the prediction [m], [rad].
    coarse_xy_step_m, coarse_yaw_step_rad : float
        Steps of the first, exhaustive level of the search [m], [rad].
    fine_xy_step_m, fine_yaw_step_rad : float
        Steps of the last level [m], [rad] (slam_toolbox: 0.01 m, 0.00349 rad).
    refine_match : bool
        Place the match between the last level's steps, at the peak of a parabola through its
        scores (:class:`~jackson.host.nav.slam.matcher.Window`): a pose on the steps' lattice
        errs by up to half a step, 0.1 degrees in heading, which the map then carries on.
    match_sigma_m : float
        Standard deviation of the likelihood field's Gaussian [m].
    prior_sigma_m, prior_sigma_rad : float
        Standard deviations of the Gaussian weight around the prediction [m], [rad].
    min_match_score : float
        Mean likelihood in [0, 1] a match needs to be accepted.
    min_match_points : int
        Returns a scan needs before it is matched at all.
    max_match_points : int
        Returns used by the search, evenly thinned out of the scan's (every return is still
        written into the map).
    turn_window_s : float
        The search's heading half-width is at least this times the odometry's turn rate since
        the scan before [s].
    chain_sigma_m, chain_sigma_rad : float
        Standard deviations of the edge between consecutive nodes whose match was accepted
        [m], [rad]; four times these when it was not (the odometry alone).
    chain_spread : bool
        Add the match's spread (the positions that scored nearly as well, less the one coarse
        step every match has) to the chain edge's translation covariance, as Karto does: a
        loop's correction then goes along corridors, where the front end could not see how
        far the robot went, instead of bending every edge alike.
    loop_closure : bool
        Look for loop closures and optimise the graph.
    loop_every : int
        Nodes between two looks for a closure, at least.
    look_share : float
        ... and at least this share of the graph's nodes: a look's result lands at the next
        look, and writing the map again takes longer the more nodes there are (about 1 ms a
        node here, twice for the two passes; the robot lays one down every 0.1-0.2 s).
    loop : LoopConfig
        How closures are found and accepted.
    background : bool
        Look for closures in a thread of their own (the result lands at the same node either
        way); False looks in the caller's thread.
    wall_hits, wall_share, wall_margin_m : int, float, float
        Beams end at walls: a cell hit by ``wall_hits`` scans or more, and by ``wall_share``
        of the scans that saw it, stops a beam that crosses it more than ``wall_margin_m``
        before its return, which is then not written (0 hits: beams pass everything;
        :class:`~jackson.host.nav.slam.occupancy.Insertion`).
    wall_extent_sigmas, wall_extent_floor_m : float
        Only the beams that pass within ``wall_extent_sigmas`` standard deviations of a wall
        cell's returns (their mean and covariance, widened by ``wall_extent_floor_m``) end
        there: a beam that passes a wall's end inside the end's cell goes on (0: every beam
        that crosses a wall cell ends there).
    """

    resolution_m: float = 0.05
    occupancy_threshold: float = 0.1
    min_observations: int = 2
    max_range_m: float = 8.0
    match_range_m: float = 12.0
    no_return_free_m: float = 0.0
    trace_step_cells: float = 0.5
    grow_margin_m: float = 1.0
    min_travel_m: float = 0.05
    min_heading_rad: float = 0.05
    scan_matching: bool = True
    search_xy_m: float = 0.1
    search_yaw_rad: float = 0.1
    coarse_xy_step_m: float = 0.05
    coarse_yaw_step_rad: float = 0.05
    fine_xy_step_m: float = 0.005
    fine_yaw_step_rad: float = 0.0035
    refine_match: bool = True
    match_sigma_m: float = 0.05
    prior_sigma_m: float = 0.5
    prior_sigma_rad: float = 1.0
    min_match_score: float = 0.5
    min_match_points: int = 30
    max_match_points: int = 540
    turn_window_s: float = 0.15
    chain_sigma_m: float = 0.01
    chain_sigma_rad: float = 0.005
    chain_spread: bool = True
    loop_closure: bool = True
    loop_every: int = 10
    look_share: float = 0.05
    loop: LoopConfig = field(default_factory=LoopConfig)
    background: bool = True
    wall_hits: int = 3
    wall_share: float = 0.3
    wall_margin_m: float = 0.1
    wall_extent_sigmas: float = 2.0
    wall_extent_floor_m: float = 0.005

    def __post_init__(self) -> None:
        positive = (
            "resolution_m",
            "max_range_m",
            "match_range_m",
            "trace_step_cells",
            "coarse_xy_step_m",
            "coarse_yaw_step_rad",
            "fine_xy_step_m",
            "fine_yaw_step_rad",
            "match_sigma_m",
            "prior_sigma_m",
            "prior_sigma_rad",
            "chain_sigma_m",
            "chain_sigma_rad",
            "turn_window_s",
            "wall_extent_floor_m",
        )
        for name in positive:
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"MappingConfig.{name}: expected a number > 0, got {value}")
        nonnegative = (
            "no_return_free_m",
            "grow_margin_m",
            "wall_margin_m",
            "wall_extent_sigmas",
            "look_share",
            "min_travel_m",
            "min_heading_rad",
            "search_xy_m",
            "search_yaw_rad",
        )
        for name in nonnegative:
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"MappingConfig.{name}: expected a number >= 0, got {value}")
        if self.trace_step_cells > 1.0:
            raise ValueError(
                f"MappingConfig.trace_step_cells: expected at most 1 cell, "
                f"got {self.trace_step_cells}"
            )
        for name in ("min_match_score", "occupancy_threshold", "wall_share"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"MappingConfig.{name}: expected 0..1, got {value}")
        for name in ("min_match_points", "min_observations", "loop_every"):
            if getattr(self, name) < 1:
                raise ValueError(f"MappingConfig.{name}: expected >= 1, got {getattr(self, name)}")
        if self.max_match_points < self.min_match_points:
            raise ValueError(
                f"MappingConfig.max_match_points: expected >= min_match_points "
                f"({self.min_match_points}), got {self.max_match_points}"
            )

    def insertion(self) -> Insertion:
        """How scans are written into the map."""
        return Insertion(
            self.resolution_m,
            self.occupancy_threshold,
            self.min_observations,
            self.max_range_m,
            self.no_return_free_m,
            self.trace_step_cells,
            self.grow_margin_m,
            self.wall_hits,
            self.wall_share,
            self.wall_margin_m,
            self.wall_extent_sigmas,
            self.wall_extent_floor_m,
        )

    def window(self) -> Window:
        """The front end's search window."""
        return Window(
            self.search_xy_m,
            self.search_yaw_rad,
            self.coarse_xy_step_m,
            self.coarse_yaw_step_rad,
            self.fine_xy_step_m,
            self.fine_yaw_step_rad,
            self.match_sigma_m,
            self.prior_sigma_m,
            self.prior_sigma_rad,
            self.refine_match,
        )


class Mapper:
    """Builds an occupancy grid from scans and odometry, correcting the pose by scan matching
    and closing loops in a pose graph (the module's notes).

    Parameters
    ----------
    config : MappingConfig
        Parameters.

    Attributes
    ----------
    config : MappingConfig
        Parameters.
    map_to_odom : Pose2D
        The correction ``node ⊕ odom_pose⁻¹`` from the last integrated scan; identity before
        the first, so the map frame is the odometry frame at the first scan.
    graph : PoseGraph
        One node per integrated scan, in order.
    nodes : list of Node
        Their scans, mounts, odometry poses and travel.
    scans_integrated : int
        Scans written into the map.
    matches_accepted, matches_rejected : int
        Scan matches whose score reached ``min_match_score`` or did not (a scan with fewer
        than ``min_match_points`` returns counts as rejected).
    last_match_score : float
        Score of the last match, NaN before the first.
    loops_closed, optimisations : int
        Closures added, and those that moved the graph (and rewrote the map).
    next_look : int
        The node at which the last look's result is taken and the next look starts.
    """

    def __init__(self, config: MappingConfig = MappingConfig()) -> None:
        self.config = config
        self.map_to_odom = Pose2D()
        self.graph = PoseGraph()
        self.nodes: list[Node] = []
        self.scans_integrated = 0
        self.matches_accepted = 0
        self.matches_rejected = 0
        self.last_match_score = math.nan
        self.loops_closed = 0
        self.optimisations = 0
        self._cells = CountGrid(config.insertion())
        self._window = config.window()
        self._last_odom: Pose2D | None = None
        self._seen: tuple[float, Pose2D] | None = None  # the last scan's time and odometry
        self._backend = BackEnd(config.background)
        self.next_look = config.loop_every  # the node at which the next look is taken

    # ------------------------------------------------------------------ public

    def update(self, scan: Scan, odom_pose: Pose2D, mount: Pose2D = ORIGIN) -> Pose2D:
        """Take one scan with the odometry pose of the base at its time.

        Parameters
        ----------
        scan : Scan
            The scan, in the sensor frame.
        odom_pose : Pose2D
            The base's pose in the odometry frame (wheel odometry or the EKF).
        mount : Pose2D
            The sensor's pose on the base.

        Returns
        -------
        Pose2D
            The base's map-frame pose: the scan's node's pose in the graph when it was
            integrated, else ``map_to_odom ⊕ odom_pose``.
        """
        cfg = self.config
        predicted = self.map_to_odom.compose(odom_pose)
        seen, self._seen = self._seen, (scan.t_s, odom_pose)
        rate = 0.0  # the odometry's turn rate since the scan before [rad/s]
        if seen is not None and scan.t_s > seen[0]:
            rate = abs(math.remainder(odom_pose.yaw - seen[1].yaw, math.tau)) / (scan.t_s - seen[0])
        last = self._last_odom
        if last is not None:
            turned = abs(math.remainder(odom_pose.yaw - last.yaw, math.tau))
            if odom_pose.distance(last) < cfg.min_travel_m and turned < cfg.min_heading_rad:
                return predicted
        corrected, spread = predicted, None
        if self.nodes and cfg.scan_matching:
            corrected, spread = self._match(scan, mount, predicted, rate)
        matched = spread is not None
        k = self.graph.add_node(corrected)
        travel = self.nodes[-1].travel_m if self.nodes else 0.0
        if last is not None:
            travel += odom_pose.distance(last)
        self.nodes.append(Node(scan, mount, odom_pose, travel))
        if k > 0:
            # a resumed map's first new scan: where the robot is now says nothing of where the
            # saved graph ended, so only the match ties it in
            widen = RESUMED_WIDEN if last is None else 1.0 if matched else 4.0
            before = self.graph.pose(k - 1)
            z = before.inverse().compose(corrected)
            extra = (0.0, 0.0, 0.0)
            if spread is not None and cfg.chain_spread and last is not None:
                extra = _in_frame(spread, before.yaw, cfg.coarse_xy_step_m**2 / 12.0)
            sigma_m, sigma_rad = widen * cfg.chain_sigma_m, widen * cfg.chain_sigma_rad
            self.graph.add_edge(Edge(k - 1, k, z, sigma_m, sigma_rad, spread=extra))
        self._cells.write(scan, corrected.compose(mount))
        if cfg.loop_closure and k >= self.next_look:
            self._apply(self._backend.take())  # the look from the last one
            self._backend.submit(self.graph, self.nodes, k, cfg.loop, self._cells.insertion)
            self.next_look = self._look_after(k)
        node = self.graph.pose(k)
        self.map_to_odom = node.compose(odom_pose.inverse())
        self._last_odom = odom_pose
        self.scans_integrated += 1
        return node

    @property
    def resolution_m(self) -> float:
        """Cell edge [m]."""
        return self.config.resolution_m

    def grid(self) -> OccupancyGrid:
        """The map: 100 occupied, 0 free, -1 unknown (a copy; one unknown cell at the origin
        before the first scan)."""
        return self._cells.grid()

    def likelihood_field(self) -> LikelihoodField:
        """The cell-centred likelihood field of the current map (what a localiser would use)."""
        return LikelihoodField.from_grid(self.grid())

    def match_field(self, centre_xy: tuple[float, float] | None = None) -> PointField:
        """The field the scan matcher uses: the mean return of every occupied cell, over the
        cells within ``match_range_m`` + ``search_xy_m`` + 1 m of ``centre_xy`` (None: all)."""
        reach = self.config.match_range_m + self.config.search_xy_m + 1.0
        return self._cells.match_field(centre_xy, reach)

    def finish(self) -> None:
        """Take the look still running, if any, look once more from the last node (a survey
        that ends where it began closes its loop here, maybe after the last look), and write
        every scan again at its pose in the graph, walls first (:meth:`rewrite`): the map to
        save."""
        self._apply(self._backend.take())
        k = len(self.nodes) - 1
        optimised = self.optimisations
        if self.config.loop_closure and k > 0:
            snapshot = self.graph.copy()
            self._apply(
                look(snapshot, list(self.nodes), k, self.config.loop, self._cells.insertion)
            )
        if self.nodes and self.optimisations == optimised:
            self.rewrite()  # (an optimisation at the last node already wrote every scan so)
        if self.nodes and self._last_odom is not None:
            self.map_to_odom = self.graph.pose(len(self.nodes) - 1).compose(
                self._last_odom.inverse()
            )

    def resume(self) -> None:
        """Go on from a graph loaded into :attr:`graph` and :attr:`nodes` (:mod:`.slam.store`):
        the map written again, the next scan matched against it and joined to the last node
        by its match only. The odometry frame is taken as the map frame (the robot is started
        at its pose in the map, ``jackson daemon --start``)."""
        self.rewrite()
        self.scans_integrated = len(self.nodes)
        self.loops_closed = sum(1 for e in self.graph.edges if e.loop)
        self.map_to_odom = Pose2D()
        self._last_odom = None
        self.next_look = self._look_after(len(self.nodes) - 1)

    def rewrite(self) -> None:
        """Write every node's scan again at its pose in the graph (after it moved), in two
        passes (:meth:`~jackson.host.nav.slam.occupancy.CountGrid.write_all`)."""
        self._cells.write_all(
            [
                (node.scan, self.graph.pose(k).compose(node.mount))
                for k, node in enumerate(self.nodes)
            ]
        )

    # ------------------------------------------------------------------ internals

    def _look_after(self, k: int) -> int:
        """The node at which the look started at node ``k`` is taken: ``loop_every`` nodes
        later, or ``look_share`` of the graph later when that is more."""
        return k + max(self.config.loop_every, math.ceil(self.config.look_share * k))

    def _match(
        self, scan: Scan, mount: Pose2D, predicted: Pose2D, rate_rad_s: float
    ) -> tuple[Pose2D, FloatArray | None]:
        """The accepted scan-matched pose and the match's spread, or ``predicted`` and None;
        counts it. The heading window widens with the turn rate ``rate_rad_s``."""
        cfg = self.config
        window = self._window
        if cfg.turn_window_s * rate_rad_s > window.yaw_rad:
            window = dataclasses.replace(window, yaw_rad=cfg.turn_window_s * rate_rad_s)
        bx, by = base_points(scan, mount, cfg.match_range_m, cfg.max_match_points)
        if bx.size < cfg.min_match_points:
            self.matches_rejected += 1
            return predicted, None
        field = self.match_field((predicted.x, predicted.y))
        match = search(field, bx, by, predicted, window)
        self.last_match_score = match.score
        if match.score >= cfg.min_match_score:
            self.matches_accepted += 1
            return match.pose, match.spread
        self.matches_rejected += 1
        return predicted, None

    def _apply(self, closure: Closure | None) -> None:
        """A look's result: its edge added; when it moved the graph, every node to ``k`` put
        where it says and the ones added since moved with node ``k``, and the map its cells
        with the newer nodes' scans written on top."""
        if closure is None or closure.edge is None:
            return
        self.graph.add_edge(closure.edge)
        self.loops_closed += 1
        if closure.poses is None or closure.cells is None:
            return
        k = closure.k
        old_k = self.graph.pose(k)
        poses = self.graph.poses()
        poses[: k + 1] = closure.poses
        new_k = Pose2D(*(float(v) for v in closure.poses[k]))
        moved = new_k.compose(old_k.inverse())
        for i in range(k + 1, len(poses)):
            p = moved.compose(self.graph.pose(i))
            poses[i] = (p.x, p.y, p.yaw)
        self.graph.set_poses(poses)
        self._cells = closure.cells
        for i in range(k + 1, len(self.nodes)):
            node = self.nodes[i]
            self._cells.write(node.scan, self.graph.pose(i).compose(node.mount))
        self.optimisations += 1


def _in_frame(spread: FloatArray, yaw: float, floor: float) -> tuple[float, float, float]:
    """A match's map-frame position spread less ``floor`` on its diagonal (the one coarse step
    every match has), turned into the frame of a node at heading ``yaw``: (xx, xy, yy)."""
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array(((c, -s), (s, c)))
    extra = spread - floor * np.eye(2)
    local = rot.T @ extra @ rot
    w, v = np.linalg.eigh(local)
    local = (v * np.maximum(w, 0.0)) @ v.T  # no direction narrower than the edge's own sigma
    return float(local[0, 0]), float(local[0, 1]), float(local[1, 1])
