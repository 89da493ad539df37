"""The mapper's back end off the daemon's frame loop: a look for a loop closure, the graph's
optimisation and the map written again at the new poses, in a thread of its own
(:class:`BackEnd`), its result taken at a fixed node.

On a floor of a few hundred square metres the graph holds a few thousand nodes: optimising it
and writing every scan again takes seconds of CPU, which inside the frame loop would stall the
daemon long past the MCU's 200 ms failsafe. So :func:`look` runs on a snapshot of the graph (the
nodes are never changed once made) while the frame loop goes on, and the mapper takes its
result when it next looks, waiting for it then if the thread has not finished. The next look
comes ``loop_every`` nodes later, or a share of the graph's size later when that is more
(``MappingConfig.look_share``): writing the map again costs in proportion to the nodes, and
the robot lays nodes down at the same pace whatever the graph's size, so the wait stays
away on a large floor too. The result therefore always lands at the same node, however fast
the machine:
a run and its replay, idle or on a busy machine, build the same map. The nodes added meanwhile
move with the node the closure was found at (the drift between them is the front end's, and
small); the map is the thread's, with their scans written on top.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.host.nav.slam.graph import Edge, PoseGraph
from jackson.host.nav.slam.loops import LoopConfig, Node, close_loop
from jackson.host.nav.slam.occupancy import CountGrid, Insertion

FloatArray = npt.NDArray[np.float64]

SETTLED_M = 0.025  # [m] a closure the graph already agrees with this well: no optimisation
SETTLED_RAD = 0.005  # [rad]


@dataclass(frozen=True)
class Closure:
    """What one look found.

    Attributes
    ----------
    k : int
        The node it looked from.
    edge : Edge or None
        The loop closure, None when there was none.
    poses : ndarray or None
        The optimised poses of nodes 0..k, None when the graph did not move.
    cells : CountGrid or None
        Those nodes' scans written at those poses, None when the graph did not move.
    """

    k: int
    edge: Edge | None = None
    poses: FloatArray | None = None
    cells: CountGrid | None = None


def look(
    graph: PoseGraph, nodes: Sequence[Node], k: int, loops: LoopConfig, insertion: Insertion
) -> Closure:
    """Look for a closure of node ``k`` in ``graph`` (a copy: it is changed); optimise and write
    the map again when the graph does not already agree with it.

    Parameters
    ----------
    graph : PoseGraph
        A copy of the graph up to node ``k``.
    nodes : sequence of Node
        Its nodes' scans.
    k : int
        The node to look from.
    loops : LoopConfig
        The search.
    insertion : Insertion
        How the map is written.

    Returns
    -------
    Closure
        What was found.
    """
    found = close_loop(graph, nodes, k, loops, insertion)
    if found is None:
        return Closure(k)
    edge, _ = found
    graph.add_edge(edge)
    now = graph.pose(edge.i).inverse().compose(graph.pose(edge.j))
    off = edge.z.inverse().compose(now)
    if math.hypot(off.x, off.y) < SETTLED_M and abs(off.yaw) < SETTLED_RAD:
        return Closure(k, edge)
    graph.optimise()
    cells = CountGrid(insertion)
    cells.write_all(
        [(n.scan, graph.pose(i).compose(n.mount)) for i, n in enumerate(nodes[: k + 1])]
    )
    return Closure(k, edge, graph.poses(), cells)


class BackEnd:
    """One look at a time, in a worker thread (or in the caller's, ``threaded=False``).

    Parameters
    ----------
    threaded : bool
        Run the looks in a thread of their own.
    """

    def __init__(self, threaded: bool = True) -> None:
        self.threaded = threaded
        self._pool: ThreadPoolExecutor | None = None
        self._pending: Future[Closure] | Closure | None = None

    @property
    def busy(self) -> bool:
        """A look was submitted and not taken."""
        return self._pending is not None

    def submit(
        self,
        graph: PoseGraph,
        nodes: Sequence[Node],
        k: int,
        loops: LoopConfig,
        insertion: Insertion,
    ) -> None:
        """Start a look from node ``k`` on a copy of ``graph`` and the first ``k + 1`` nodes."""
        if self._pending is not None:
            raise RuntimeError("the back end's last look was not taken")
        snapshot, first = graph.copy(), list(nodes[: k + 1])
        if not self.threaded:
            self._pending = look(snapshot, first, k, loops, insertion)
            return
        if self._pool is None:
            self._pool = ThreadPoolExecutor(1, thread_name_prefix="jackson-loops")
        self._pending = self._pool.submit(look, snapshot, first, k, loops, insertion)

    def take(self) -> Closure | None:
        """The submitted look's result, waiting for it if need be (None: none submitted). An
        exception in the thread is raised here, in the caller's thread."""
        pending, self._pending = self._pending, None
        if isinstance(pending, Future):
            return pending.result()
        return pending

    def __getstate__(self) -> dict[str, object]:
        """For a core's snapshot: the look finished (waited for), the thread left out; the
        result is still taken at its node."""
        pending = self._pending
        return {
            "threaded": self.threaded,
            "_pool": None,
            "_pending": pending.result() if isinstance(pending, Future) else pending,
        }
