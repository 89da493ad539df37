"""The largest loop's closure error: how far round it the front end alone had drifted, and how
far the optimised pose graph still is, both against the ground truth.

A saved pose graph (``built_map.graph.npz``, :mod:`jackson.host.nav.slam.store`) holds every
node's optimised pose and scan time, and every edge ``i -> j`` with its measured relative pose
``z = x_i⁻¹ ⊕ x_j`` and whether it closes a loop. The *largest loop* is the loop-closure edge
whose two nodes lie farthest apart along the robot's travel (the nodes' ``travel`` counts; by
node index when the file has none). For its nodes ``i < j``:

- **before** optimisation: the relative pose the front end alone gives, the chain edges'
  ``z`` composed from ``i`` to ``j`` (``z_{i,i+1} ⊕ ... ⊕ z_{j-1,j}``);
- **after**: the relative pose of the two nodes' final, optimised poses, ``x_i⁻¹ ⊕ x_j``;

each compared with the true relative pose of the base at the two scans' times (the ground
truth, ``ground_truth.csv``, interpolated there: positions linearly, the heading unwrapped).
The error of a relative pose is the distance between its translation and the true one [m]
(both in node ``i``'s frame, so the frame's own error does not count) and the difference of
the headings, wrapped [rad]. The closure error before is the drift the loop closure had to
take out; the one after is what the optimised map still carries across the loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from jackson.experiments.metrics.inputs import MetricInputError
from jackson.experiments.metrics.map_quality import truth_path

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int_]
BoolArray = npt.NDArray[np.bool_]

GRAPH_KEYS = ("poses", "scan_t", "edge_nodes", "edge_z", "edge_loop")
TRUTH_SLACK_S = 0.5  # [s] a scan this far outside the ground truth's span is still judged


@dataclass(frozen=True, eq=False)
class GraphFile:
    """The parts of a saved pose graph a closure error needs.

    Attributes
    ----------
    poses : ndarray, shape (n, 3)
        Every node's optimised pose (x [m], y [m], yaw [rad]) in the map frame.
    scan_t : ndarray, shape (n,)
        Each node's scan time [s].
    travel : ndarray, shape (n,) or None
        Distance travelled up to each node [m]; None when the file has none.
    edge_nodes : ndarray of int, shape (m, 2)
        Each edge's nodes ``i, j``.
    edge_z : ndarray, shape (m, 3)
        Each edge's measured ``x_i⁻¹ ⊕ x_j``.
    edge_loop : ndarray of bool, shape (m,)
        Whether the edge closes a loop.
    """

    poses: FloatArray
    scan_t: FloatArray
    travel: FloatArray | None
    edge_nodes: IntArray
    edge_z: FloatArray
    edge_loop: BoolArray

    @property
    def closures(self) -> int:
        """Loop-closure edges."""
        return int(np.count_nonzero(self.edge_loop))

    def trajectory_m(self) -> float:
        """Length of the optimised trajectory through the nodes [m]."""
        if len(self.poses) < 2:
            return 0.0
        return float(np.sum(np.hypot(*np.diff(self.poses[:, :2], axis=0).T)))


@dataclass(frozen=True)
class LargestLoop:
    """The largest loop's closure error (module docstring).

    Attributes
    ----------
    closures : int
        Loop-closure edges in the graph.
    i, j : int
        The largest loop's nodes, ``i < j``.
    travel_m : float
        Travel between them along the chain [m] (nan when the graph has no travel counts).
    before_m, before_rad : float
        Error of the chain's relative pose [m, rad], the front end alone.
    after_m, after_rad : float
        Error of the optimised poses' relative pose [m, rad].
    """

    closures: int
    i: int
    j: int
    travel_m: float
    before_m: float
    before_rad: float
    after_m: float
    after_rad: float


def read_graph(path: str | Path) -> GraphFile:
    """The nodes and edges of a saved pose graph (``built_map.graph.npz``).

    Raises
    ------
    MetricInputError
        A missing or unreadable file, or one without the nodes and edges.
    """
    try:
        with np.load(path) as f:
            missing = [k for k in GRAPH_KEYS if k not in f.files]
            if missing:
                raise MetricInputError(f"{path}: not a pose graph (no {', '.join(missing)})")
            data = {k: f[k] for k in f.files}
    except (OSError, ValueError, EOFError) as exc:
        if isinstance(exc, MetricInputError):
            raise
        raise MetricInputError(f"{path}: not a pose-graph file ({exc})") from exc
    poses = np.asarray(data["poses"], np.float64).reshape(-1, 3)
    travel = data.get("travel")
    return GraphFile(
        poses=poses,
        scan_t=np.asarray(data["scan_t"], np.float64),
        travel=None if travel is None else np.asarray(travel, np.float64),
        edge_nodes=np.asarray(data["edge_nodes"], np.int64).reshape(-1, 2),
        edge_z=np.asarray(data["edge_z"], np.float64).reshape(-1, 3),
        edge_loop=np.asarray(data["edge_loop"], np.bool_),
    )


def largest_loop(graph: GraphFile) -> tuple[int, int] | None:
    """The nodes ``(i, j)``, ``i < j``, of the loop-closure edge spanning the most travel
    (the most nodes when the graph has no travel counts); None without a loop closure."""
    pairs = np.sort(graph.edge_nodes[graph.edge_loop], axis=1)
    if len(pairs) == 0:
        return None
    span = (pairs[:, 1] - pairs[:, 0]).astype(np.float64)
    if graph.travel is not None:
        travel = graph.travel[pairs[:, 1]] - graph.travel[pairs[:, 0]]
        best = int(np.lexsort((span, travel))[-1])  # the most travel, then the most nodes
    else:
        best = int(np.argmax(span))
    return int(pairs[best, 0]), int(pairs[best, 1])


def chain_relative(graph: GraphFile, i: int, j: int) -> FloatArray:
    """The chain edges' measured relative poses composed from node ``i`` to node ``j > i``:
    where the front end alone puts ``j`` seen from ``i`` (x, y, yaw).

    Raises
    ------
    MetricInputError
        Two consecutive nodes between them without a chain edge.
    """
    chain = {
        (int(a), int(b)): k
        for k, ((a, b), loop) in enumerate(zip(graph.edge_nodes, graph.edge_loop, strict=True))
        if not loop and b == a + 1
    }
    rel: FloatArray = np.zeros(3)
    for k in range(i, j):
        edge = chain.get((k, k + 1))
        if edge is None:
            raise MetricInputError(f"no chain edge {k} -> {k + 1}: the chain is broken")
        rel = compose(rel, graph.edge_z[edge])
    return rel


def loop_closure_error(
    graph: str | Path | GraphFile, truth: str | Path | tuple[npt.ArrayLike, npt.ArrayLike]
) -> LargestLoop | None:
    """The largest loop's closure error before and after optimisation (module docstring).

    Parameters
    ----------
    graph : str, Path or GraphFile
        The saved pose graph (``built_map.graph.npz``) or what :func:`read_graph` read of it.
    truth : str, Path or (t, poses)
        The base's true path: a ``ground_truth.csv`` (columns ``t_s, x_m, y_m, yaw_rad``), or
        its times [s], shape (N,), and poses (x, y, yaw), shape (N, 3), on the scans' clock.

    Returns
    -------
    LargestLoop or None
        None when the graph closes no loop.

    Raises
    ------
    MetricInputError
        An unreadable graph or ground truth, a broken chain, or a loop's scans outside the
        ground truth's time span.
    """
    g = graph if isinstance(graph, GraphFile) else read_graph(graph)
    pair = largest_loop(g)
    if pair is None:
        return None
    t, poses = _truth(truth)
    i, j = pair
    t_ij = g.scan_t[[i, j]]
    if np.any(t_ij < t[0] - TRUTH_SLACK_S) or np.any(t_ij > t[-1] + TRUTH_SLACK_S):
        raise MetricInputError(
            f"nodes {i} and {j} were scanned at {t_ij[0]:.2f} s and {t_ij[1]:.2f} s, outside the "
            f"ground truth's {t[0]:.2f}-{t[-1]:.2f} s: not the same run or clock"
        )
    unwrapped = np.column_stack((poses[:, :2], np.unwrap(poses[:, 2])))
    true_i, true_j = (np.array([np.interp(s, t, c) for c in unwrapped.T]) for s in t_ij)
    truth_rel = relative(true_i, true_j)
    before = chain_relative(g, i, j)
    after = relative(g.poses[i], g.poses[j])
    travel = math.nan if g.travel is None else float(g.travel[j] - g.travel[i])
    return LargestLoop(
        closures=g.closures,
        i=i,
        j=j,
        travel_m=travel,
        before_m=float(np.hypot(*(before[:2] - truth_rel[:2]))),
        before_rad=abs(math.remainder(float(before[2] - truth_rel[2]), math.tau)),
        after_m=float(np.hypot(*(after[:2] - truth_rel[:2]))),
        after_rad=abs(math.remainder(float(after[2] - truth_rel[2]), math.tau)),
    )


def compose(a: npt.ArrayLike, b: npt.ArrayLike) -> FloatArray:
    """``a ⊕ b`` of two poses (x, y, yaw): ``b`` given in ``a``'s frame, in ``a``'s parent."""
    ax, ay, at = (float(v) for v in np.asarray(a, np.float64))
    bx, by, bt = (float(v) for v in np.asarray(b, np.float64))
    c, s = math.cos(at), math.sin(at)
    return np.array([ax + c * bx - s * by, ay + s * bx + c * by, math.remainder(at + bt, math.tau)])


def relative(a: npt.ArrayLike, b: npt.ArrayLike) -> FloatArray:
    """``a⁻¹ ⊕ b``: pose ``b`` seen from pose ``a`` (x, y, yaw)."""
    ax, ay, at = (float(v) for v in np.asarray(a, np.float64))
    bx, by, bt = (float(v) for v in np.asarray(b, np.float64))
    c, s = math.cos(at), math.sin(at)
    dx, dy = bx - ax, by - ay
    return np.array([c * dx + s * dy, -s * dx + c * dy, math.remainder(bt - at, math.tau)])


def _truth(
    truth: str | Path | tuple[npt.ArrayLike, npt.ArrayLike],
) -> tuple[FloatArray, FloatArray]:
    """The true path's times (increasing) and poses."""
    if isinstance(truth, (str, Path)):
        t, x, y, yaw = truth_path(Path(truth))
        poses = np.column_stack((x, y, yaw))
    else:
        t = np.asarray(truth[0], np.float64)
        poses = np.asarray(truth[1], np.float64)
    if t.ndim != 1 or poses.shape != (len(t), 3) or len(t) < 2:
        raise MetricInputError(
            f"ground truth: expected times (N,) and poses (N, 3), N >= 2, got {t.shape} and "
            f"{poses.shape}"
        )
    if np.any(np.diff(t) < 0):
        raise MetricInputError("ground truth: its times go backwards")
    return t, poses
