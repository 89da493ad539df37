"""The global planner off the control thread: a plan searched in a worker process while the
frame loop goes on, answered a fixed number of control ticks later.

A global plan on a 20 m map takes 15-25 ms of search (scikit-image's ``MCP_Geometric``, which
holds the interpreter's lock throughout, so a thread cannot take it off the control thread);
on a Jetson-class core three times that, most of a 50 ms control period. Nav2 runs its planner
as a server beside the controller for the same reason. Here the navigator's global planning
(:mod:`jackson.host.control.replanning`, ``plan_delay_ticks`` > 0) hands each search to a
planner as a :class:`PlanRequest` (a copy of the global costmap's costs, the start, the goal)
and takes the answer ``plan_delay_ticks`` control ticks later, whoever computed it:

- :class:`InlinePlanner` searches at once, on the caller's thread, and keeps the answer until
  it is asked for: trials on the twin, replays and tests;
- :class:`WorkerPlanner` sends the request to one worker process (a fresh interpreter running
  :func:`serve` over a socket pair, :data:`BOOT`; it shares nothing with the daemon's threads)
  and reads the answer when it is due, waiting
  at most :data:`WAIT_S` (a quarter of the control period) if the worker has not answered by
  then, and searching it on the caller's thread if it still has not (counted in
  :attr:`WorkerPlanner.late`: a worker still starting, or a machine too busy). A worker that
  dies, or misses :data:`MISSES_TO_GIVE_UP` answers in a row (stopped, stuck), is killed and
  replaced by the search on the caller's thread (one line said), and a new worker is started
  with the first request :data:`RESTART_AFTER_S` later, then twice as long after each worker
  given up in a row, at most :data:`RESTART_MAX_S` (a worker that answers in time resets the
  wait): a robot in service for days does not plan on its control thread for the rest of
  its run after one bad minute of its machine. A request goes to a worker only once it is
  ready and has answered the one before (a large map's request outgrows the socket's buffer,
  and a send to a worker not reading would wait); meanwhile requests are searched on the
  caller's thread, and one finding the worker still on an overdue answer counts as missed.
  Lateness counts against a worker only in wall time (``budget_s``: the plan's delay in
  control periods): a run in lockstep passes its ticks faster than the robot's clock.

Both give the same answer for the same request: the search is the same function of the same
copied costs (:func:`solve`), so which one ran changes when the CPU is spent, never a plan, and
a run replays bit for bit on either. The worker's CPU time comes back with each answer
(:attr:`WorkerPlanner.cpu_s`), so the daemon's CPU figures count it.

A planner pickles (a run folder's snapshot) as an :class:`InlinePlanner` holding the answer of
the request in flight, if any.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from jackson.host.nav.astar import AStarConfig, CostGrid, NoPathError, astar, path_cost

FloatArray = npt.NDArray[np.float64]

WAIT_S = 0.0125  # [s] the most a control step waits for an answer due (a quarter period)
MISSES_TO_GIVE_UP = 3  # answers in a row not in by then, once the worker is ready: given up
RESTART_AFTER_S = 10.0  # [s] from a worker given up to the start of the next (wall clock)
RESTART_MAX_S = 600.0  # [s] the longest wait, doubling with each worker given up in a row


@dataclass(frozen=True)
class PlanRequest:
    """One search: the costs to plan on, from where, to where.

    Attributes
    ----------
    id : int
        The request's number (each planner's own sequence).
    grid : CostGrid
        A copy of the global costmap's costs when the plan was asked for.
    start_xy, goal_xy : tuple of float
        Map-frame positions [m].
    config : AStarConfig
        The planner's parameters.
    kept : ndarray, shape (K, 2), or None
        The path followed now, from the start (the robot) on: priced beside the new one, for
        the replanning hysteresis (:mod:`jackson.host.control.replanning`); None without one.
    """

    id: int
    grid: CostGrid
    start_xy: tuple[float, float]
    goal_xy: tuple[float, float]
    config: AStarConfig
    kept: FloatArray | None = None


@dataclass(frozen=True)
class PlanAnswer:
    """A request's answer: the path, or why there is none.

    Attributes
    ----------
    id : int
        The request's number.
    path : ndarray, shape (N, 2), or None
        The path [m], map frame (:func:`~jackson.host.nav.astar.astar`); None without one.
    error : str or None
        The :class:`~jackson.host.nav.astar.NoPathError`'s message when there is no path.
    cost, kept_cost : float or None
        The new path's and the request's ``kept`` path's cost on the request's costs
        (:func:`~jackson.host.nav.astar.path_cost`); None without them.
    """

    id: int
    path: FloatArray | None
    error: str | None = None
    cost: float | None = None
    kept_cost: float | None = None


def solve(request: PlanRequest) -> PlanAnswer:
    """The answer to ``request``: :func:`~jackson.host.nav.astar.astar` on its copied costs,
    and both paths priced when it carries the one followed now."""
    try:
        path = astar(request.grid, request.start_xy, request.goal_xy, request.config)
    except NoPathError as exc:
        return PlanAnswer(request.id, None, str(exc))
    if request.kept is None:
        return PlanAnswer(request.id, path)
    cost = path_cost(path, request.grid, request.config)
    kept_cost = path_cost(request.kept, request.grid, request.config)
    return PlanAnswer(request.id, path, None, cost, kept_cost)


class Planner(Protocol):
    """Where the global planning's searches run (module docstring)."""

    def submit(self, request: PlanRequest) -> None:
        """Start the search of ``request`` (the one before it, unanswered, is dropped)."""
        ...

    def answer(self, request: PlanRequest) -> PlanAnswer:
        """The answer to ``request``, the last one submitted."""
        ...

    def close(self) -> None:
        """Stop any worker (the planner keeps answering, on the caller's thread)."""
        ...

    @property
    def cpu_s(self) -> float:
        """CPU time spent off the caller's process [s] (0 for a planner without a worker)."""
        ...

    def report(self) -> dict[str, Any]:
        """``health.json``'s ``planner`` entry: ``worker`` (in use), ``late``, ``cpu_s``."""
        ...


class InlinePlanner:
    """Searches each request at once on the caller's thread; the answer waits until asked."""

    def __init__(self) -> None:
        self._answer: PlanAnswer | None = None

    def submit(self, request: PlanRequest) -> None:
        """Search ``request`` now."""
        self._answer = solve(request)

    def answer(self, request: PlanRequest) -> PlanAnswer:
        """The answer to ``request`` (searched now if it is not the one held)."""
        held = self._answer
        self._answer = None
        return held if held is not None and held.id == request.id else solve(request)

    def close(self) -> None:
        """Nothing to stop."""

    @property
    def cpu_s(self) -> float:
        """0: every search ran on the caller's thread."""
        return 0.0

    def report(self) -> dict[str, Any]:
        """No worker: every search on the caller's thread."""
        return {"worker": False, "late": 0, "cpu_s": 0.0}


class WorkerPlanner:
    """Searches in one worker process (module docstring).

    Parameters
    ----------
    say : callable
        Tells the operator when the worker is given up (one line).
    budget_s : float or None
        The wall time an answer has on a robot that runs in real time: the plan's delay in
        control periods [s]. An answer not in when it falls due, sooner than this after its
        request was sent (a run in lockstep, faster than the robot's clock), is searched here
        but not counted against the worker. None: every answer not in when due counts.

    Attributes
    ----------
    late : int
        Answers that were not in when they fell due (the caller waited for them).
    restarts : int
        Workers started after one was given up.
    restart_after_s : float
        The wait before the next worker once one is given up [s] (:data:`RESTART_AFTER_S`).
    """

    def __init__(self, say: Callable[[str], None] = print, budget_s: float | None = None) -> None:
        self.say = say
        self.budget_s = budget_s
        self._sent_at = 0.0  # monotonic time the outstanding request was sent
        self.late = 0
        self.restarts = 0
        self.restart_after_s = RESTART_AFTER_S
        self._given_up = 0  # workers given up in a row (none answered in time since)
        self._closed = False
        self._restart_at: float | None = None  # monotonic time the next worker may start
        self._cpu_ready_s: float | None = None
        self._cpu_s = 0.0
        self._cpu_retired_s = 0.0  # the CPU of the workers given up
        self._lock = threading.Lock()  # sends and receives; a snapshot may read from its thread
        self._conn: Connection | None = None
        self._process: subprocess.Popen[bytes] | None = None
        self._sent: PlanRequest | None = None
        self._early: PlanAnswer | None = None  # an answer a snapshot read before it fell due
        self._misses = 0  # late answers in a row since the worker was ready
        self._outstanding: int | None = None  # the id of the request the worker has not answered
        self._in_worker = False  # the request in flight went to the worker
        self._busy_skip = False  # ... or did not: the worker still had an earlier one
        self._start()
        atexit.register(self.close)  # the daemon's end, however the worker is

    def _start(self) -> None:
        """Start a worker process and connect to it (given up at once if it cannot start)."""
        self._cpu_ready_s = None
        self._cpu_s = 0.0
        self._misses = 0
        self._outstanding = None
        parent, child = socket.socketpair()
        # a request the worker does not take in (stopped, stuck) fails after this long
        # rather than blocking the control thread once the socket's buffer is full
        sec, usec = divmod(round(WAIT_S * 1e6), 1_000_000)
        parent.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO, struct.pack("ll", sec, usec))
        self._conn = Connection(parent.detach())
        try:
            # its own session (a Ctrl-C on the daemon's terminal is the daemon's to handle) and
            # none of the daemon's output (a stopped worker would keep a reader of it waiting
            # after the daemon ended); it ends with its socket, at the latest with the daemon
            self._process = subprocess.Popen(
                [sys.executable, "-c", BOOT, str(child.fileno()), str(os.getpid())],
                pass_fds=(child.fileno(),),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
        except OSError as exc:
            self._give_up(f"cannot start ({exc})")
        finally:
            child.close()

    @property
    def alive(self) -> bool:
        """The worker is in use."""
        return self._conn is not None

    @property
    def cpu_s(self) -> float:
        """The workers' CPU time since each was ready, as of their last answers [s]."""
        return self._cpu_retired_s + self._cpu_s

    def report(self) -> dict[str, Any]:
        """Whether a worker is in use, the answers they were late with, their CPU [s], the
        workers started after one was given up."""
        return {"worker": self.alive, "late": self.late, "cpu_s": self.cpu_s,
                "restarts": self.restarts}  # fmt: skip

    def submit(self, request: PlanRequest) -> None:
        """Send ``request`` to the worker: only to a worker that is ready and has answered the
        requests before, so that a send never waits on one that does not read (a 20 m map's
        request is larger than the socket's buffer); otherwise it is searched here when it
        falls due. A new worker is started first when one was given up long enough ago."""
        with self._lock:
            self._sent = request
            self._in_worker = self._busy_skip = False
            if (
                self._conn is None
                and not self._closed
                and self._restart_at is not None
                and time.monotonic() >= self._restart_at
            ):
                self._restart_at = None
                self.restarts += 1
                self._start()
                if self._conn is not None:
                    self.say(f"planner: a new worker process started (restart {self.restarts})")
            if self._conn is not None and (
                self._cpu_ready_s is None or self._outstanding is not None
            ):
                self._receive(None, 0.0)  # take in what came since: ready, late answers
            if self._conn is None or self._cpu_ready_s is None:
                return  # none, or still starting: searched here
            if self._outstanding is not None:
                # an earlier answer, already due, still not in: a miss if it is late in real time
                self._busy_skip = not self._in_real_time()
                return
            try:
                self._conn.send(request)
            except (OSError, ValueError) as exc:
                self._give_up(f"is gone (a request could not be sent: {exc})")
                return
            self._outstanding = request.id
            self._sent_at = time.monotonic()
            self._in_worker = True

    def answer(self, request: PlanRequest) -> PlanAnswer:
        """The worker's answer to ``request``: read when in, waited for at most
        :data:`WAIT_S` when not, else searched here (late; after :data:`MISSES_TO_GIVE_UP`
        late answers in a row the worker is given up)."""
        with self._lock:
            early, self._early = self._early, None
            if early is not None and early.id == request.id:
                got: PlanAnswer | None = early
                self._misses = self._given_up = 0
            elif self._conn is not None and not self._in_worker:
                got = None  # not sent: the worker was starting, or busy with an overdue one
                self.late += 1
                if self._busy_skip:
                    self._misses += 1
                    if self._misses >= MISSES_TO_GIVE_UP:
                        self._give_up(f"missed {self._misses} answers in a row")
            elif self._conn is not None:
                got = self._receive(request, WAIT_S)
                if got is None and self._conn is not None:
                    self.late += 1
                    # not merely still starting, nor due sooner than on a robot in real time
                    if self._cpu_ready_s is not None and not self._in_real_time():
                        self._misses += 1
                        if self._misses >= MISSES_TO_GIVE_UP:
                            self._give_up(f"missed {self._misses} answers in a row")
                elif got is not None:
                    self._misses = self._given_up = 0  # in time: a next give-up waits least
            else:
                got = None
            self._sent = None
            self._in_worker = self._busy_skip = False
        return got if got is not None else solve(request)

    def wait_ready(self, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for the worker to be ready for requests (started and its
        imports done: requests before then are searched here); False without a worker."""
        deadline = time.monotonic() + timeout_s
        with self._lock:
            while self._conn is not None and self._cpu_ready_s is None:
                left = deadline - time.monotonic()
                if left <= 0.0:
                    return False
                self._receive(None, min(left, 0.05))
            return self._conn is not None

    def wait(self, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for the answer in flight (a run faster than the robot's
        clock: what the control periods before it falls due would give the worker); True once
        it is in (or nothing is in flight)."""
        with self._lock:
            sent = self._sent
            if sent is None or self._conn is None or not self._in_worker:
                return True
            if self._early is not None and self._early.id == sent.id:
                return True
            got = self._receive(sent, timeout_s)
            if got is not None:
                self._early = got
            return got is not None

    def close(self) -> None:
        """Stop the worker (it exits when its end of the socket closes); none starts again."""
        with self._lock:
            conn, self._conn = self._conn, None
            self._restart_at = None
            self._closed = True
        if conn is not None:
            with contextlib.suppress(OSError, ValueError):
                conn.send(None)
            conn.close()
        if self._process is not None:
            try:
                self._process.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled as an :class:`InlinePlanner` holding the answer of the request in flight
        (read from the worker now, and kept for the frame loop to take when it falls due)."""
        with self._lock:
            sent = self._sent
            if sent is not None and (self._early is None or self._early.id != sent.id):
                got = self._receive(sent, WAIT_S) if self._conn and self._in_worker else None
                self._early = got if got is not None else solve(sent)
            held = self._early if sent is not None else None
        return (_inline_holding, (held,))

    # ------------------------------------------------------------------ internals

    def _receive(self, request: PlanRequest | None, wait_s: float) -> PlanAnswer | None:
        """The answer to ``request`` from the socket (others dropped), waiting at most
        ``wait_s``; None when it is not in by then or the worker is gone (given up). With no
        request, what came in is taken (the ready message, late answers) and None returned."""
        conn = self._conn
        assert conn is not None
        deadline = time.monotonic() + wait_s
        while True:
            try:
                if not conn.poll(max(0.0, deadline - time.monotonic())):
                    return None
                message = conn.recv()
            except (EOFError, OSError) as exc:
                self._give_up(f"ended ({exc or 'its socket closed'})")
                return None
            except Exception as exc:  # an answer that does not unpickle: not ours to trust
                self._give_up(f"sent what cannot be read ({exc})")
                return None
            if isinstance(message, tuple) and len(message) == 2 and message[0] == "ready":
                self._cpu_ready_s = float(message[1])
                continue
            answer, cpu_s = message
            if self._cpu_ready_s is not None:
                self._cpu_s = float(cpu_s) - self._cpu_ready_s
            if answer.id == self._outstanding:
                self._outstanding = None  # the worker is free for the next request
            if request is not None and answer.id == request.id:
                return answer  # type: ignore[no-any-return]

    def _in_real_time(self) -> bool:
        """Whether the outstanding request was sent less than :attr:`budget_s` ago (its
        answer may not be in yet on a robot's clock either)."""
        budget = self.budget_s
        return budget is not None and time.monotonic() - self._sent_at < budget

    def _give_up(self, why: str) -> None:
        """Plan on the caller's thread until a new worker starts (:attr:`restart_after_s`,
        doubled for each worker given up in a row, at most :data:`RESTART_MAX_S`)."""
        wait_s = min(self.restart_after_s * 2.0**self._given_up, RESTART_MAX_S)
        self._given_up += 1
        self._restart_at = time.monotonic() + wait_s
        self._outstanding = None
        self._in_worker = False
        self._cpu_retired_s += self._cpu_s
        self._cpu_s = 0.0
        self.say(
            f"planner: the worker process {why}; planning on the control thread instead, "
            f"a new worker in {wait_s:.0f} s"
        )
        conn, self._conn = self._conn, None
        if conn is not None:
            conn.close()
        if self._process is not None and self._process.poll() is None:
            self._process.kill()
            self._process.wait()


def _inline_holding(answer: PlanAnswer | None) -> InlinePlanner:
    """An :class:`InlinePlanner` holding ``answer`` (a pickled planner's state)."""
    planner = InlinePlanner()
    planner._answer = answer
    return planner


def serve(conn: Connection) -> None:
    """The worker: answer each request until its socket closes or a None arrives."""
    conn.send(("ready", time.process_time()))
    while True:
        try:
            request = conn.recv()
        except (EOFError, OSError):
            return
        if request is None:
            return
        answer = solve(request)
        try:
            conn.send((answer, time.process_time()))
        except (OSError, ValueError):
            return


BOOT = """\
import ctypes, os, signal, sys
if sys.platform.startswith("linux"):  # killed by the kernel when the daemon ends, however
    try:
        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
if os.getppid() == int(sys.argv[2]):  # else the daemon ended before the kernel was told
    from jackson.host.nav.planner_server import serve_socket
    serve_socket(int(sys.argv[1]))
"""
"""The worker's interpreter's first lines (``python -c BOOT FD PID``), before any import of the
planner: on Linux the kernel kills the worker when the daemon ``PID`` ends, however it ends
(``PR_SET_PDEATHSIG``; a worker stopped with SIGSTOP never reads the end of its socket, and one
stopped while still importing would not have asked yet)."""


def serve_socket(fd: int) -> None:
    """:func:`serve` on the socket ``fd`` the daemon passed down."""
    serve(Connection(fd))
