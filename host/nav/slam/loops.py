"""Loop closure: a scan matched against the map the robot built the first time it was there
(:func:`close_loop`).

The candidates of node k are the nodes laid down at least ``min_chain_m`` of travel earlier
whose poses in the graph lie within ``search_m`` of node k's: the robot has come back. The
nearest of them and the nodes within ``context_m`` of travel around it are written into a map
of their own, at their poses in the graph, and node k's scan is matched against that map in a
window of 1 m and 0.3 rad around node k's pose, coarse to fine
(:func:`~jackson.host.nav.slam.matcher.search`). A match that scores at least ``min_score``
becomes an edge from that node to node k (slam_toolbox: loop_search_maximum_distance 3 m,
loop_match_minimum_chain_size 10 scans, a coarse and a fine response threshold). The window is
wider than the front end's (which only follows the robot from scan to scan), as the drift of
a whole loop is what it must find (1-1.5 % of the distance driven: a metre round a 64 m ring),
and the bar is higher, as a wrong closure bends the map.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from jackson.host.nav.slam.graph import Edge, PoseGraph
from jackson.host.nav.slam.matcher import Window, base_points, search
from jackson.host.nav.slam.occupancy import CountGrid, Insertion
from jackson.host.nav.types import Pose2D, Scan

LOOP_WINDOW = Window(
    xy_m=1.0,
    yaw_rad=0.3,
    coarse_xy_m=0.05,
    coarse_yaw_rad=0.025,
    fine_xy_m=0.005,
    fine_yaw_rad=0.0035,
    sigma_m=0.05,
    prior_sigma_m=2.0,
    prior_sigma_rad=2.0,
)


@dataclass(frozen=True)
class LoopConfig:
    """How loops are looked for and accepted (the module's notes).

    Attributes
    ----------
    min_chain_m : float
        Travel between two nodes before they may close a loop [m].
    search_m : float
        Largest distance between their poses in the graph [m].
    context_m : float
        Travel either side of the candidate whose scans make the map matched against [m].
    window : Window
        The match's window around node k's pose, its steps and sigma.
    min_score : float
        Mean likelihood in [0, 1] a closure needs.
    max_points : int
        Returns of node k's scan used by the match.
    sigma_m, sigma_rad : float
        The closure edge's standard deviations [m], [rad].
    max_spread_m : float
        A match whose nearly as good positions spread wider than this along some direction
        (:class:`~jackson.host.nav.slam.matcher.Match`) is not a closure [m]: a scan of a
        corridor matched against the same corridor, or against the other side of its wall,
        fits anywhere along it.
    """

    min_chain_m: float = 6.0
    search_m: float = 3.0
    context_m: float = 2.5
    window: Window = field(default_factory=lambda: LOOP_WINDOW)
    min_score: float = 0.6
    max_points: int = 270
    sigma_m: float = 0.03
    sigma_rad: float = 0.015
    max_spread_m: float = 0.1


@dataclass(frozen=True)
class Node:
    """What the graph keeps of each scan written into the map.

    Attributes
    ----------
    scan : Scan
        The scan, in the sensor frame.
    mount : Pose2D
        The sensor on the base.
    odom : Pose2D
        The base's odometry pose at the scan.
    travel_m : float
        Odometry travel from the first node [m].
    """

    scan: Scan
    mount: Pose2D
    odom: Pose2D
    travel_m: float


def close_loop(
    graph: PoseGraph, nodes: Sequence[Node], k: int, cfg: LoopConfig, insertion: Insertion
) -> tuple[Edge, float] | None:
    """A loop closure for node ``k`` and its match score, or None (no candidate, or no match
    good enough).

    Parameters
    ----------
    graph : PoseGraph
        The graph, node ``k`` its last.
    nodes : sequence of Node
        The graph's nodes' scans.
    k : int
        The node to close a loop from.
    cfg : LoopConfig
        The search.
    insertion : Insertion
        How the candidate's map is written (the mapper's own).
    """
    poses = graph.poses()
    travel = np.array([n.travel_m for n in nodes], np.float64)
    here = poses[k]
    older = travel <= travel[k] - cfg.min_chain_m
    dist = np.hypot(poses[:, 0] - here[0], poses[:, 1] - here[1])
    near = np.flatnonzero(older & (dist <= cfg.search_m))
    if near.size == 0:
        return None
    j = int(near[np.argmin(dist[near])])
    context = np.flatnonzero(older & (np.abs(travel - travel[j]) <= cfg.context_m))
    local = CountGrid(insertion)
    for i in context.tolist():
        local.write(nodes[i].scan, graph.pose(i).compose(nodes[i].mount))
    field = local.match_field(None, 0.0)
    node = nodes[k]
    bx, by = base_points(node.scan, node.mount, insertion.max_range_m, cfg.max_points)
    if bx.size == 0:
        return None
    match = search(field, bx, by, graph.pose(k), cfg.window)
    if match.score < cfg.min_score or match.widest_m() > cfg.max_spread_m:
        return None
    z = graph.pose(j).inverse().compose(match.pose)
    return Edge(j, k, z, cfg.sigma_m, cfg.sigma_rad, loop=True), match.score
