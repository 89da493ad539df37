"""The mapper's pose graph: one node per scan written into the map, an edge per constraint
between two of them, and the poses that best agree with all the edges.

An edge ``i -> j`` says where node ``j`` lies seen from node ``i`` (``z = x_i⁻¹ ⊕ x_j``), with a
standard deviation in translation and in heading, and the translation's covariance may be
widened along some direction (``spread``): a scan matched in a corridor with nothing along it
fixes where the robot is across the corridor but hardly along it, so the optimisation puts a
loop's correction there, where the drift came from, as Karto's matcher covariance does.
Consecutive nodes are joined by the scan matcher's result (the front end); a loop closure joins
a node to one laid down much earlier that its scan was matched against.
:meth:`PoseGraph.optimise` finds the poses that minimise the weighted squared residuals, node 0
held fixed (it defines the map frame), by Levenberg-Marquardt on the sparse normal equations
(scipy.sparse, SuperLU), as slam_toolbox's sparse pose adjustment does with Ceres: a 2-D graph
of a few thousand nodes has a banded, very sparse Hessian and solves in tens of milliseconds.
Every edge is squared, without a robust kernel (slam_toolbox's default too): a closure is only
added once its scan match is sure (:mod:`.loops`), and a kernel cannot tell a true closure,
whose error before the optimisation is the whole drift of the loop (tens of standard
deviations), from a false one.

scipy rather than GTSAM: scipy is already required and installs everywhere the host runs
(aarch64, Python 3.10), while GTSAM is a large native package whose wheels do not cover every
platform, for a problem this small.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]

MAX_ITERATIONS = 30
STEP_TOLERANCE = 1e-7  # [m, rad] a step this small ends the iterations


@dataclass(frozen=True)
class Edge:
    """A constraint: node ``j`` seen from node ``i``.

    Attributes
    ----------
    i, j : int
        The nodes.
    z : Pose2D
        ``x_i⁻¹ ⊕ x_j`` as measured.
    sigma_m, sigma_rad : float
        Its standard deviations in translation [m] and heading [rad].
    loop : bool
        A loop closure rather than the chain of consecutive scans.
    spread : tuple of float
        Covariance added to the translation's ``sigma_m² I``, in node ``i``'s frame:
        (xx, xy, yy) [m²].
    """

    i: int
    j: int
    z: Pose2D
    sigma_m: float
    sigma_rad: float
    loop: bool = False
    spread: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def whitening(self) -> tuple[float, float, float, float]:
        """``(u11, u12, u22, 1 / sigma_rad)``: the upper Cholesky factor ``U`` of the
        translation's information matrix (``Uᵀ U = Σ⁻¹``) and the heading's weight."""
        v = self.sigma_m * self.sigma_m
        a, b, c = v + self.spread[0], self.spread[1], v + self.spread[2]
        det = a * c - b * b
        oxx, oxy, oyy = c / det, -b / det, a / det  # Σ⁻¹
        u11 = math.sqrt(oxx)
        u12 = oxy / u11
        return u11, u12, math.sqrt(oyy - u12 * u12), 1.0 / self.sigma_rad


@dataclass(frozen=True)
class Optimised:
    """What one optimisation did.

    Attributes
    ----------
    iterations : int
        Levenberg-Marquardt steps taken.
    cost_before, cost_after : float
        Half the weighted squared residuals before and after.
    max_shift_m : float
        The largest move of a node [m].
    """

    iterations: int
    cost_before: float
    cost_after: float
    max_shift_m: float


class PoseGraph:
    """Nodes (poses in the map frame) and the edges between them."""

    def __init__(self) -> None:
        self._poses: list[tuple[float, float, float]] = []
        self.edges: list[Edge] = []

    def __len__(self) -> int:
        return len(self._poses)

    def copy(self) -> PoseGraph:
        """A graph of the same nodes and edges that can change apart from this one."""
        other = PoseGraph()
        other._poses = list(self._poses)
        other.edges = list(self.edges)
        return other

    def add_node(self, pose: Pose2D) -> int:
        """A new node at ``pose``; its index."""
        self._poses.append((pose.x, pose.y, pose.yaw))
        return len(self._poses) - 1

    def add_edge(self, edge: Edge) -> None:
        """A constraint between two existing nodes."""
        if not (0 <= edge.i < len(self) and 0 <= edge.j < len(self)) or edge.i == edge.j:
            raise ValueError(f"edge {edge.i} -> {edge.j}: no such pair of nodes")
        self.edges.append(edge)

    def pose(self, k: int) -> Pose2D:
        """Node ``k``'s pose."""
        x, y, yaw = self._poses[k]
        return Pose2D(x, y, yaw)

    def poses(self) -> FloatArray:
        """Every node's (x, y, yaw), shape (n, 3)."""
        return np.array(self._poses, np.float64).reshape(-1, 3)

    def set_poses(self, poses: FloatArray) -> None:
        """Replace every node's pose (rows of x, y, yaw)."""
        if poses.shape != (len(self), 3):
            raise ValueError(f"expected {len(self)} poses, got shape {poses.shape}")
        self._poses = [
            (float(x), float(y), math.remainder(float(t), math.tau)) for x, y, t in poses
        ]

    def optimise(self) -> Optimised:
        """Move the nodes (node 0 fixed) to the poses that agree best with the edges.

        Returns
        -------
        Optimised
            Iterations, cost before and after, the largest move.
        """
        x0 = self.poses()
        n = len(x0)
        if n < 2 or not self.edges:
            return Optimised(0, 0.0, 0.0, 0.0)
        e = _EdgeArrays.of(self.edges)
        x = x0.copy()
        r, _ = _residuals(x, e)
        cost = before = 0.5 * float(r @ r)
        lam = 1e-4
        iterations = 0
        for iterations in range(1, MAX_ITERATIONS + 1):  # noqa: B007 (read after the loop)
            r, jac = _residuals(x, e, with_jacobian=True)
            assert jac is not None
            jac = jac.tocsc()[:, 3:]  # node 0 held fixed
            h = (jac.T @ jac).tocsc()
            g = jac.T @ r
            damped = h + sp.diags(lam * (h.diagonal() + 1e-9))
            step = -spla.spsolve(damped.tocsc(), g)
            trial = x.copy()
            trial[1:] += step.reshape(-1, 3)
            r_new, _ = _residuals(trial, e)
            new_cost = 0.5 * float(r_new @ r_new)
            if new_cost <= cost:
                x, cost, lam = trial, new_cost, max(lam / 10.0, 1e-9)
                if float(np.max(np.abs(step))) < STEP_TOLERANCE:
                    break
            else:
                lam *= 10.0
                if lam > 1e8:
                    break
        shift = float(np.max(np.hypot(x[:, 0] - x0[:, 0], x[:, 1] - x0[:, 1])))
        self.set_poses(x)
        return Optimised(iterations, before, cost, shift)


@dataclass(frozen=True)
class _EdgeArrays:
    i: npt.NDArray[np.intp]
    j: npt.NDArray[np.intp]
    z: FloatArray  # (m, 3)
    w: FloatArray  # (m, 4) u11, u12, u22 of the translation's whitening, the heading's weight
    loop: npt.NDArray[np.bool_]

    @staticmethod
    def of(edges: list[Edge]) -> _EdgeArrays:
        return _EdgeArrays(
            np.array([e.i for e in edges], np.intp),
            np.array([e.j for e in edges], np.intp),
            np.array([(e.z.x, e.z.y, e.z.yaw) for e in edges], np.float64),
            np.array([e.whitening() for e in edges], np.float64).reshape(-1, 4),
            np.array([e.loop for e in edges], np.bool_),
        )


def _residuals(
    x: FloatArray, e: _EdgeArrays, with_jacobian: bool = False
) -> tuple[FloatArray, sp.coo_matrix | None]:
    """The whitened residuals (3 per edge, flattened) and, if asked, their Jacobian."""
    xi, xj = x[e.i], x[e.j]
    c, s = np.cos(xi[:, 2]), np.sin(xi[:, 2])
    dx, dy = xj[:, 0] - xi[:, 0], xj[:, 1] - xi[:, 1]
    rx = c * dx + s * dy - e.z[:, 0]
    ry = -s * dx + c * dy - e.z[:, 1]
    rt = np.remainder(xj[:, 2] - xi[:, 2] - e.z[:, 2] + math.pi, math.tau) - math.pi
    u11, u12, u22, wt = e.w[:, 0], e.w[:, 1], e.w[:, 2], e.w[:, 3]
    r = np.stack((u11 * rx + u12 * ry, u22 * ry, wt * rt), axis=1).ravel()
    if not with_jacobian:
        return r, None
    m = len(e.i)
    zero = np.zeros(m)
    # rows: rx, ry, rt of each edge; columns: xi, yi, ti, xj, yj, tj
    jx = np.stack((-c, -s, -s * dx + c * dy, c, s, zero), 1)
    jy = np.stack((s, -c, -c * dx - s * dy, -s, c, zero), 1)
    blocks = np.stack(
        (
            jx * u11[:, None] + jy * u12[:, None],
            jy * u22[:, None],
            np.stack((zero, zero, -np.ones(m), zero, zero, np.ones(m)), 1) * wt[:, None],
        ),
        axis=1,
    )  # (m, 3, 6)
    rows = np.repeat(np.arange(3 * m).reshape(m, 3, 1), 6, axis=2)
    cols_i = 3 * e.i[:, None] + np.arange(3)[None, :]
    cols_j = 3 * e.j[:, None] + np.arange(3)[None, :]
    cols = np.broadcast_to(np.concatenate((cols_i, cols_j), 1)[:, None, :], (m, 3, 6))
    jac = sp.coo_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), (3 * m, x.size))
    return r, jac
