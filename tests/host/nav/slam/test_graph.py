"""The pose graph: a loop whose odometry drifted is pulled shut by one closure, node 0 stays
where it is, and the graph saved beside a map comes back with the same map."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from jackson.host.nav.slam.graph import Edge, PoseGraph
from jackson.host.nav.slam.mapper import Mapper, MappingConfig
from jackson.host.nav.slam.store import GraphFileError, load_graph, save_graph
from jackson.host.nav.types import Pose2D, Scan


def _square_loop(n: int, rng: np.random.Generator) -> tuple[PoseGraph, list[Pose2D]]:
    """A 40 m square driven in ``n`` steps, its odometry edges noisy: the chain drifts."""
    truth = [Pose2D()]
    for k in range(1, n):
        turn = math.pi / 2 if k % (n // 4) == 0 else 0.0
        truth.append(truth[-1].compose(Pose2D(40.0 / n, 0.0, turn)))
    graph = PoseGraph()
    est = Pose2D()
    graph.add_node(est)
    for k in range(1, n):
        z = truth[k - 1].inverse().compose(truth[k])
        noisy = Pose2D(
            z.x + rng.normal(0, 0.002), z.y + rng.normal(0, 0.002), z.yaw + rng.normal(0, 0.003)
        )
        est = est.compose(noisy)
        graph.add_node(est)
        graph.add_edge(Edge(k - 1, k, noisy, 0.01, 0.005))
    return graph, truth


def test_one_closure_pulls_a_drifted_loop_shut_and_node_0_stays() -> None:
    graph, truth = _square_loop(400, np.random.default_rng(0))
    end = graph.pose(len(graph) - 1)
    assert end.distance(truth[-1]) > 0.3  # the drift before: measured 0.44 m
    z = truth[-1].inverse().compose(truth[0])
    graph.add_edge(Edge(len(graph) - 1, 0, z, 0.02, 0.01, loop=True))
    result = graph.optimise()
    assert result.cost_after < 0.01 * result.cost_before
    assert graph.pose(0) == Pose2D()
    closed = graph.pose(len(graph) - 1).inverse().compose(graph.pose(0))
    assert math.hypot(closed.x - z.x, closed.y - z.y) < 0.05  # the loop shut within 5 cm
    poses = graph.poses()
    worst = max(math.hypot(p[0] - t.x, p[1] - t.y) for p, t in zip(poses, truth, strict=True))
    assert worst < 0.2  # one closure: the middle keeps part of the drift (measured 0.13 m)


def test_an_edge_whitens_by_its_covariance() -> None:
    edge = Edge(0, 1, Pose2D(), 0.01, 0.005, spread=(0.003, 0.001, 0.0005))
    u11, u12, u22, wt = edge.whitening()
    u = np.array(((u11, u12), (0.0, u22)))
    cov = np.array(((0.0001 + 0.003, 0.001), (0.001, 0.0001 + 0.0005)))
    assert np.allclose(u.T @ u, np.linalg.inv(cov))
    assert wt == pytest.approx(200.0)


def _corridor_then_room(spread: float) -> PoseGraph:
    """Ten 1 m steps along x, the first five matched in a corridor (wide along x by
    ``spread`` [m²]), the last five in a room; a closure from the start says the end lies
    0.3 m short of where the chain put it."""
    graph = PoseGraph()
    for k in range(11):
        graph.add_node(Pose2D(float(k), 0.0, 0.0))
    for k in range(1, 11):
        extra = (spread, 0.0, 0.0) if k <= 5 else (0.0, 0.0, 0.0)
        graph.add_edge(Edge(k - 1, k, Pose2D(1.0, 0.0, 0.0), 0.01, 0.005, spread=extra))
    graph.add_edge(Edge(0, 10, Pose2D(9.7, 0.0, 0.0), 0.01, 0.005, loop=True))
    return graph


def test_a_loop_correction_goes_where_the_matches_could_not_see_along() -> None:
    graph = _corridor_then_room(0.005)  # a 7 cm spread, as a corridor's match in +-0.1 m
    graph.optimise()
    x = graph.poses()[:, 0]
    corridor, room = x[5] - x[0], x[10] - x[5]
    assert corridor == pytest.approx(4.7, abs=0.01)  # the corridor takes the 0.3 m
    assert room == pytest.approx(5.0, abs=0.01)  # the room, seen well, keeps its length
    assert np.allclose(graph.poses()[:, 1:], 0.0, atol=1e-9)  # across: nothing to correct
    even = _corridor_then_room(0.0)
    even.optimise()
    assert even.poses()[5, 0] == pytest.approx(5.0 - 0.15 * 10 / 11)  # without: shared alike


def test_a_graph_without_edges_or_with_one_node_is_left_alone() -> None:
    graph = PoseGraph()
    graph.add_node(Pose2D(1.0, 2.0, 0.3))
    assert graph.optimise().iterations == 0 and graph.pose(0) == Pose2D(1.0, 2.0, 0.3)
    with pytest.raises(ValueError, match="no such pair"):
        graph.add_edge(Edge(0, 1, Pose2D(), 0.1, 0.1))


def test_a_saved_graph_loads_with_the_same_map_and_goes_on(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    config = MappingConfig(scan_matching=False)
    mapper = Mapper(config)
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    for k in range(30):
        ranges = np.full(360, 2.0) + rng.normal(0, 0.01, 360)
        mapper.update(Scan(0.1 * k, angles, ranges), Pose2D(0.06 * k, 0.0, 0.0))
    mapper.finish()  # the map to save: every scan written again, walls first
    wide = Edge(3, 9, Pose2D(0.36, 0.0, 0.0), 0.01, 0.005, spread=(0.004, 0.0005, 0.0001))
    mapper.graph.add_edge(wide)  # a match along a corridor: its spread is saved
    path = tmp_path / "built_map.graph.npz"
    save_graph(mapper, path)
    again = load_graph(path, config)
    assert np.array_equal(again.grid().data, mapper.grid().data)
    assert len(again.graph) == 30 and again.graph.edges == mapper.graph.edges
    with np.load(path) as f:  # a file from before edges had a spread (format 1) loads
        old = {k: f[k] for k in f.files if k != "edge_spread"}
    np.savez_compressed(tmp_path / "old.npz", **(old | {"format": np.array(1)}))
    edges = load_graph(tmp_path / "old.npz", config).graph.edges
    assert edges[-1] == dataclasses.replace(wide, spread=(0.0, 0.0, 0.0))
    pose = again.update(Scan(3.0, angles, np.full(360, 2.0)), Pose2D(0.5, 0.0, 0.0))
    assert len(again.graph) == 31 and pose == Pose2D(0.5, 0.0, 0.0)
    with pytest.raises(GraphFileError, match=r"resolution 0\.05 m"):
        load_graph(path, MappingConfig(resolution_m=0.1))
    (tmp_path / "junk.npz").write_bytes(b"not a graph")
    with pytest.raises(GraphFileError, match=r"junk\.npz: not a pose-graph file"):
        load_graph(tmp_path / "junk.npz")
