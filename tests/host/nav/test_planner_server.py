"""The planner server: the worker process answers what the caller's thread would, bit for bit;
a dead worker is replaced by the caller's search; a snapshot carries the answer in flight; the
navigator takes each plan the configured number of ticks after asking, whoever searched it."""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import select
import signal
import subprocess
import sys
import time

import pytest

from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter
from jackson.host.control.navigator import Navigator, NavigatorConfig
from jackson.host.nav.astar import AStarConfig, CostGrid
from jackson.host.nav.costmap import Costmap, CostmapConfig
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.planner_server import (
    MISSES_TO_GIVE_UP,
    WAIT_S,
    InlinePlanner,
    PlanAnswer,
    PlanRequest,
    WorkerPlanner,
    solve,
)
from jackson.host.nav.types import Pose2D

from ..stage3_course import maze_map


def maze_requests() -> list[PlanRequest]:
    """Plans on a 20 m maze (coarse to fine), a 10 m one, and one with no path."""
    out = []
    for k, (size_m, start, goal) in enumerate(
        [(20.0, (0.5, 0.5), (19.5, 19.5)), (10.0, (0.5, 9.5), (9.5, 0.5))]
    ):
        cm = Costmap.from_map(maze_map(size_m, 1.0, 3 + k), CostmapConfig())
        out.append(PlanRequest(k + 1, CostGrid.of(cm), start, goal, AStarConfig()))
    walled = OccupancyGrid.empty(4.0, 3.0, 0.05, fill=0)
    walled.data[:, 38:42] = 100  # a wall across the whole map
    cm = Costmap.from_map(walled, CostmapConfig())
    out.append(PlanRequest(3, CostGrid.of(cm), (0.5, 1.5), (3.5, 1.5), AStarConfig()))
    return out


def same(a: PlanAnswer, b: PlanAnswer) -> bool:
    if a.id != b.id or a.error != b.error or (a.path is None) != (b.path is None):
        return False
    return a.path is None or (b.path is not None and a.path.tobytes() == b.path.tobytes())


@pytest.fixture
def worker() -> WorkerPlanner:
    said: list[str] = []
    planner = WorkerPlanner(say=said.append)
    planner.said = said  # type: ignore[attr-defined]
    assert planner.wait_ready(60.0)  # requests before then are searched on the caller's thread
    yield planner
    planner.close()


def test_the_worker_answers_what_the_callers_thread_would_bit_for_bit(
    worker: WorkerPlanner,
) -> None:
    inline = InlinePlanner()
    for request in maze_requests():
        inline.submit(request)
        worker.submit(request)
        assert worker.wait(60.0)  # in from the worker (not searched here after a short wait)
        want = inline.answer(request)
        got = worker.answer(request)
        assert same(got, want), request.id
        assert same(got, solve(request))
    assert want.path is None and "blocked" in str(want.error)  # the walled map: no path
    assert worker.alive and worker.said == [] and worker.late == 0  # type: ignore[attr-defined]
    assert worker.cpu_s > 0.0  # the searches' CPU, reported back


def test_a_killed_worker_is_replaced_by_the_callers_search(worker: WorkerPlanner) -> None:
    first, second, _ = maze_requests()
    worker.submit(first)
    assert worker.wait(60.0)
    assert same(worker.answer(first), solve(first))
    os.kill(worker._process.pid, signal.SIGKILL)
    worker._process.wait(timeout=10)
    worker.submit(second)  # sent into a closed pipe, or answered by nobody
    got = worker.answer(second)
    assert same(got, solve(second))
    assert not worker.alive
    assert len(worker.said) == 1 and "planning on the control thread" in worker.said[0]  # type: ignore[attr-defined]
    worker.submit(first)
    assert same(worker.answer(first), solve(first))  # and it goes on answering
    assert "a new worker in 10 s" in worker.said[0]  # type: ignore[attr-defined]


def test_a_worker_given_up_is_replaced_by_a_new_one_later(worker: WorkerPlanner) -> None:
    """After a give-up the searches run here until the wait is over; the next request then
    starts a new worker (searched here while it starts), which answers as the first did once
    ready. Each worker given up in a row (none answering in time between) doubles the wait;
    one answering in time resets it."""
    first, second, third = maze_requests()
    said = worker.said  # type: ignore[attr-defined]
    for k in (1, 2):
        os.kill(worker._process.pid, signal.SIGKILL)  # the first worker, then the new one
        worker._process.wait(timeout=10)
        worker.submit(first)
        assert same(worker.answer(first), solve(first)) and not worker.alive
        assert said[-1].endswith(f"a new worker in {10 * 2 ** (k - 1)} s")
        worker.submit(first)  # still waiting: searched here, no worker started
        assert not worker.alive and same(worker.answer(first), solve(first))
        worker._restart_at = time.monotonic()  # the wait is over (wall time, by design)
        worker.submit(second)  # starts the new worker; searched here while it starts
        assert worker.alive and worker.restarts == k
        assert said[-1] == f"planner: a new worker process started (restart {k})"
        assert same(worker.answer(second), solve(second))
        assert worker.wait_ready(60.0)
    assert worker._given_up == 2  # the new ones have answered nothing yet
    worker.submit(third)
    assert worker.wait(60.0)  # in from the second new worker
    assert same(worker.answer(third), solve(third))
    assert worker._given_up == 0 and worker.report()["restarts"] == 2  # reset: 10 s again
    worker.close()
    worker.submit(first)  # closed: no new worker, however long ago the last was given up
    assert not worker.alive and same(worker.answer(first), solve(first))


def test_a_request_goes_only_to_a_ready_worker_with_nothing_outstanding() -> None:
    """A 20 m map's request is larger than the socket's buffer: sent to a worker still
    importing, or still searching an earlier one, the send would wait (and fail after a
    quarter period). Such requests are searched on the caller's thread instead; one that
    finds the worker still on an answer already overdue counts as missed."""
    said: list[str] = []
    planner = WorkerPlanner(say=said.append)
    try:
        big = maze_requests()[0]
        planner.submit(big)  # at once: the worker is still starting
        assert not planner._in_worker and planner.wait(0.0)  # nothing in flight to wait for
        assert same(planner.answer(big), solve(big)) and planner._misses == 0
        assert planner.wait_ready(60.0)
        planner.submit(big)
        assert planner._in_worker and planner.wait(60.0)
        assert same(planner.answer(big), solve(big)) and planner.alive and said == []
        os.kill(planner._process.pid, signal.SIGSTOP)  # ready, then stuck on a request
        try:
            planner.submit(big)  # sent; its answer never comes
            assert same(planner.answer(big), solve(big)) and planner._misses == 1
            planner.submit(big)  # not sent: the worker still has the overdue one
            assert not planner._in_worker
            assert same(planner.answer(big), solve(big)) and planner._misses == 2
        finally:
            os.kill(planner._process.pid, signal.SIGCONT)
    finally:
        planner.close()


def test_a_stopped_worker_costs_a_quarter_period_per_plan_then_is_given_up(
    worker: WorkerPlanner,
) -> None:
    requests = maze_requests()
    worker.submit(requests[2])
    assert worker.wait(60.0)  # ready, and answering
    worker.answer(requests[2])
    os.kill(worker._process.pid, signal.SIGSTOP)
    try:
        for k in range(3):
            worker.submit(requests[k % 2])
            t0 = time.monotonic()
            assert same(worker.answer(requests[k % 2]), solve(requests[k % 2]))
            assert time.monotonic() - t0 < WAIT_S + 5.0  # the wait, then the search here
        # given up after 3 late answers, or sooner once its socket's buffer is full (a send
        # that would block fails after the same quarter period)
        assert not worker.alive and worker.late >= 2
        assert worker.report()["worker"] is False
        said = worker.said  # type: ignore[attr-defined]
        assert len(said) == 1 and "planning on the control thread" in said[0]
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(worker._process.pid, signal.SIGCONT)


def test_an_answer_late_only_on_a_fast_clock_does_not_count_against_the_worker() -> None:
    """In lockstep faster than the robot's clock, 3 control periods pass in less wall time
    than on the robot: an answer not in by then, within the real-time budget since its
    request, is searched here without counting against the worker; past it, it counts."""
    said: list[str] = []
    planner = WorkerPlanner(say=said.append, budget_s=60.0)
    try:
        assert planner.wait_ready(60.0)
        request = maze_requests()[0]
        os.kill(planner._process.pid, signal.SIGSTOP)  # answers nothing from now on
        try:
            for _ in range(MISSES_TO_GIVE_UP + 1):
                planner.submit(request)
                assert same(planner.answer(request), solve(request))
            assert planner.alive and planner._misses == 0 and planner.late == 4 and said == []
            planner.budget_s = 0.0  # the outstanding request is now late in real time too
            for _ in range(MISSES_TO_GIVE_UP):
                planner.submit(request)
                assert same(planner.answer(request), solve(request))
            assert not planner.alive and "missed 3 answers in a row" in said[0]
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.kill(planner._process.pid, signal.SIGCONT)
    finally:
        planner.close()


def test_a_snapshot_carries_the_answer_in_flight(worker: WorkerPlanner) -> None:
    request = maze_requests()[1]
    worker.submit(request)
    assert worker.wait(60.0)
    restored = pickle.loads(pickle.dumps(worker))
    assert isinstance(restored, InlinePlanner)
    assert same(restored.answer(request), solve(request))
    assert same(worker.answer(request), solve(request))  # the live one still answers
    assert isinstance(pickle.loads(pickle.dumps(worker)), InlinePlanner)  # nothing in flight


def drive(
    nav: Navigator, seconds: float, worker: WorkerPlanner | None = None
) -> list[tuple[float, float, str]]:
    """An ideal unicycle under the navigator's commands on its map: (v, w, state) per tick,
    a worker given the time the control periods would give it."""
    limiter = VelocityLimiter(nav.limits)
    pose, vel, out = Pose2D(0.5, 0.5, 0.0), (0.0, 0.0), []
    for k in range(round(seconds / 0.05)):
        t_s = 0.05 * k
        if worker is not None:
            assert worker.wait(60.0)
        cmd = nav.step(t_s, pose, vel, None)
        out.append((cmd.v_m_s, cmd.w_rad_s, cmd.state.value))
        vel = limiter.limit(cmd.v_m_s, cmd.w_rad_s, t_s)
        v, w = vel
        mid = pose.yaw + 0.025 * w
        pose = Pose2D(pose.x + 0.05 * v * math.cos(mid), pose.y + 0.05 * v * math.sin(mid),
                      pose.yaw + 0.05 * w)  # fmt: skip
    return out


def test_the_navigator_takes_each_plan_two_ticks_after_asking_whoever_searched_it(
    worker: WorkerPlanner,
) -> None:
    grid = OccupancyGrid.empty(6.0, 6.0, 0.05, fill=0)  # open floor (no scans: DWB sees none)
    config = NavigatorConfig(plan_delay_ticks=2)
    runs = []
    for planner in (None, worker):
        nav = Navigator(config, grid, LimiterConfig(), planner)
        nav.set_goal(Pose2D(3.5, 2.5))
        runs.append((drive(nav, 8.0, planner), nav.replans))
    (inline, inline_replans), (worked, worked_replans) = runs
    assert worked == inline and worked_replans == inline_replans >= 8  # 1 Hz, same plans
    assert worker.late == 0 and worker.cpu_s > 0.0  # every one searched by the worker
    assert worker.report() == {"worker": True, "late": 0, "cpu_s": worker.cpu_s, "restarts": 0}
    assert [s for _, _, s in inline[:3]] == ["planning", "planning", "following"]
    nav = Navigator(NavigatorConfig(), grid, LimiterConfig())  # 0: the asking tick takes it
    nav.set_goal(Pose2D(3.5, 2.5))
    assert drive(nav, 0.05)[0][2] == "following"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_a_stopped_worker_ends_with_a_killed_daemon() -> None:
    # a worker stopped with SIGSTOP cannot read the end of its socket: the kernel kills it
    # when the process that started it is killed
    script = (
        "import sys\n"
        "from jackson.host.nav.planner_server import WorkerPlanner\n"
        "w = WorkerPlanner()\n"
        "assert w._conn.poll(60)\n"  # it has said it is ready: past its first lines
        "print(w._process.pid, flush=True)\n"
        "sys.stdin.read()\n"
    )
    daemon = subprocess.Popen(
        [sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert daemon.stdout is not None
    worker = int(daemon.stdout.readline())
    ended = os.pidfd_open(worker)  # readable once the worker has ended
    try:
        os.kill(worker, signal.SIGSTOP)
        daemon.kill()
        daemon.wait()
        readable, _, _ = select.select([ended], [], [], 30.0)  # the kernel's kill
        assert readable == [ended]
    finally:
        os.close(ended)
        with contextlib.suppress(ProcessLookupError):
            os.kill(worker, signal.SIGKILL)
