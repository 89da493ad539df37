"""Distance maps over the local costmap, the grids the path and goal critics read.

A distance map holds, for every cell, the Manhattan distance [cells] to the nearest of some
source cells (the path's cells, its last one, GoalAlign's target), propagated through the cells
below inscribed only, as ROS 1's dwb_critics did (Nav2's version propagates through obstacles),
by one breadth-first search (:func:`grid_distance`). Cells no source reaches score the number
of cells. :class:`DistanceMaps` keeps the maps of the current costmap, so a map is searched
once per costmap and set of sources however many critics read it and however many cycles
pass before either changes.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order

from jackson.host.nav import native
from jackson.host.nav.costmap import INSCRIBED_INFLATED_OBSTACLE, Costmap

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]


def cell_index(costmap: Costmap, x_m: FloatArray, y_m: FloatArray) -> tuple[IntArray, BoolArray]:
    """Flat (row-major) index of the cell of each point, clipped onto the grid.

    Parameters
    ----------
    costmap : Costmap
        The grid.
    x_m, y_m : ndarray, shape (M,)
        Points, map frame [m].

    Returns
    -------
    tuple of ndarray, shape (M,)
        (index into a map of the grid's shape, raveled; whether the point lies on the grid).
    """
    rows, cols = costmap.shape
    r, c = costmap.world_to_cell(x_m, y_m)
    ok = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    np.minimum(np.maximum(r, 0, out=r), rows - 1, out=r)
    np.minimum(np.maximum(c, 0, out=c), cols - 1, out=c)
    r *= cols
    r += c
    return r, ok


def grid_graph(free: BoolArray) -> csr_matrix:
    """The 4-connected graph of a grid's free cells (unit edges, flat row-major indices).

    Parameters
    ----------
    free : ndarray of bool, shape (rows, cols)
        Cells that may be crossed.

    Returns
    -------
    scipy.sparse.csr_matrix
        Symmetric adjacency (every edge both ways), built row by row: cell i's neighbours
        are i - cols, i - 1, i + 1, i + cols, those free with i free.
    """
    rows, cols = free.shape
    n = rows * cols
    f = free.ravel()
    edge = np.zeros((4, n), bool)  # towards i - cols, i - 1, i + 1, i + cols
    np.logical_and(f[cols:], f[:-cols], out=edge[0, cols:])
    np.logical_and(f[1:], f[:-1], out=edge[1, 1:])
    edge[1, ::cols] = False  # no left neighbour in the first column
    np.logical_and(f[:-1], f[1:], out=edge[2, :-1])
    edge[2, cols - 1 :: cols] = False  # no right neighbour in the last column
    np.logical_and(f[:-cols], f[cols:], out=edge[3, :-cols])
    indptr = np.zeros(n + 1, np.int32)
    np.cumsum(edge.sum(axis=0, dtype=np.int32), out=indptr[1:])
    neighbour = np.arange(n, dtype=np.int32) + np.array([-cols, -1, 1, cols], np.int32)[:, None]
    indices = neighbour.T[edge.T]
    return csr_matrix((np.ones(len(indices)), indices, indptr), shape=(n, n))


def grid_distance(graph: csr_matrix, shape: tuple[int, int], sources: BoolArray) -> FloatArray:
    """Manhattan distance [cells] through the graph's cells to the nearest source.

    One breadth-first search (``scipy.sparse.csgraph.breadth_first_order``) from an extra
    node joined to every source; a cell's depth in the search tree is its distance + 1,
    found for all cells at once by pointer jumping (each cell adds its ancestor's depth
    and skips to the ancestor's ancestor, log2(depth) rounds). Cells no source reaches
    (obstacles, enclosed space) get DWB's obstacle score, the number of cells.

    Parameters
    ----------
    graph : scipy.sparse.csr_matrix
        From :func:`grid_graph`.
    shape : tuple of int
        (rows, cols).
    sources : ndarray of bool, shape (rows, cols)
        Source cells.

    Returns
    -------
    ndarray, shape (rows, cols)
        Distances.
    """
    n = shape[0] * shape[1]
    src = np.flatnonzero(sources).astype(graph.indices.dtype)
    indptr = np.append(graph.indptr, graph.indptr[-1] + len(src)).astype(graph.indptr.dtype)
    indices = np.concatenate((graph.indices, src))
    with_root = csr_matrix((np.ones(len(indices)), indices, indptr), shape=(n + 1, n + 1))
    order, pred = breadth_first_order(with_root, n, directed=True, return_predecessors=True)
    # in search order: each node's parent's position (the root its own) and depth
    pos = np.empty(n + 1, np.intp)
    pos[order] = np.arange(len(order))
    up = pred[order]
    up[0] = n
    parent = pos[up]
    depth = np.ones(len(order), np.intp)
    depth[0] = 0
    while parent.any():
        depth += depth[parent]
        parent = parent[parent]
    d = np.full(n + 1, float(n))
    d[order] = depth - 1.0
    return d[:n].reshape(shape)


class DistanceMaps:
    """The distance maps of the local costmap, searched on demand and kept while it stays the
    same (its identity and version).

    With the compiled nav library (:mod:`jackson.host.nav.native`) each map is one compiled
    breadth-first search over the free cells, the same distances; without it the graph of the
    free cells (:func:`grid_graph`) is built once per costmap and searched by
    :func:`grid_distance`. The maps of the last ``capacity`` sets of sources are kept (a cycle
    reads three: the path's cells, its last cell and GoalAlign's target), so critics that read
    the same map share it.

    Parameters
    ----------
    capacity : int
        Maps kept, least recently read dropped first.
    """

    def __init__(self, capacity: int = 4) -> None:
        self.capacity = capacity
        self._costmap_key: tuple[int, int] | None = None
        self._graph: csr_matrix | None = None
        self._free: BoolArray | None = None
        self._maps: OrderedDict[tuple[bytes, bytes], FloatArray] = OrderedDict()

    def to_cells(self, costmap: Costmap, rows: npt.ArrayLike, cols: npt.ArrayLike) -> FloatArray:
        """The distance map [cells] to the nearest of the cells (rows, cols) of ``costmap``.

        Parameters
        ----------
        costmap : Costmap
            The local costmap; its cells below inscribed may be crossed.
        rows, cols : array_like of int, shape (N,)
            The source cells, on the grid.

        Returns
        -------
        ndarray, shape (rows, cols)
            :func:`grid_distance` from them, read-only (shared by the critics that read it).
        """
        costmap_key = (id(costmap), costmap.version)
        if costmap_key != self._costmap_key or self._free is None:
            self._free = costmap.costs < INSCRIBED_INFLATED_OBSTACLE
            self._graph = None if native.LIB is not None else grid_graph(self._free)
            self._costmap_key = costmap_key
            self._maps.clear()
        r, c = np.asarray(rows, np.intp), np.asarray(cols, np.intp)
        key = (r.tobytes(), c.tobytes())
        found = self._maps.get(key)
        if found is not None:
            self._maps.move_to_end(key)
            return found
        sources = np.zeros(costmap.shape, bool)
        sources[r, c] = True
        if self._graph is None:
            d = native.grid_distance(self._free, sources)
        else:
            d = grid_distance(self._graph, costmap.shape, sources)
        d.flags.writeable = False
        self._maps[key] = d
        if len(self._maps) > self.capacity:
            self._maps.popitem(last=False)
        return d
