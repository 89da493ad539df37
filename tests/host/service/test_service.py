"""The navigation service without a robot: its goal book, requests, state machine and socket."""

from __future__ import annotations

import json
import math
import os
import socket
import stat
import threading
from pathlib import Path

import numpy as np
import pytest

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.control.base import NavState, ServiceMission
from jackson.host.control.navigate import NavigateConfig
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D
from jackson.host.service.control import ControlError, ControlServer, ask
from jackson.host.service.goals import GoalBook, GoalStatus
from jackson.host.service.navigation import (
    NavigationService,
    Request,
    ServiceState,
    path_remaining_m,
)
from jackson.host.service.settings import ServiceSettings


def room(side_m: float = 6.0, res: float = 0.05) -> OccupancyGrid:
    """A walled square room with a closed box inside (its interior unreachable)."""
    n = round(side_m / res)
    data = np.zeros((n, n), np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    a, b = round(4.0 / res), round(5.5 / res)
    data[a, a:b] = data[b, a:b] = data[a:b, a] = data[a:b, b] = 100
    return OccupancyGrid(data, res, 0.0, 0.0)


def make_service(**settings: float) -> NavigationService:
    config = NavigateConfig(start=Pose2D(1.0, 1.0, 0.0), goals=())
    return NavigationService(
        config,
        LimiterConfig(),
        room(),
        ServiceSettings(**settings),  # type: ignore[arg-type]
    )


def at(service: NavigationService, t_s: float, x: float = 0.0) -> NavState:
    """The EKF's state in the odom frame (the service's odometry starts at its start pose)."""
    return NavState(t_s, x, 0.0, 0.0, 0.0, 0.0)


def test_service_is_a_service_mission_that_is_never_done() -> None:
    s = make_service()
    assert isinstance(s, ServiceMission)
    assert not s.done and s.idle and s.state == ServiceState.IDLE
    assert s.command(at(s, 0.05)) == (0.0, 0.0)


def test_goal_off_the_map_in_an_obstacle_or_cut_off_is_rejected_at_once() -> None:
    s = make_service()
    for pose, says in (
        (Pose2D(20.0, 1.0), "outside the map"),
        (Pose2D(4.0, 4.5), "obstacle"),
        (Pose2D(4.75, 4.75), "cannot be reached"),
        (Pose2D(math.nan, 1.0), "finite"),
    ):
        rec = s.submit_goal(pose)
        assert rec.status == GoalStatus.REJECTED and says in rec.reason
    assert s.take_requests() == []  # nothing reaches the frame loop
    assert s.book.counts["rejected"] == 4


def test_a_goal_becomes_active_at_the_next_frame_and_a_newer_one_preempts_it() -> None:
    s = make_service()
    first = s.submit_goal(Pose2D(3.0, 1.0))
    assert first.status == GoalStatus.PENDING
    taken = s.take_requests()
    assert [r.kind for r in taken] == ["goal"]
    s.command(at(s, 0.05))
    assert s.state == ServiceState.NAVIGATING
    assert s.book.get(first.goal_id).status == GoalStatus.ACTIVE  # type: ignore[union-attr]
    second = s.submit_goal(Pose2D(1.0, 3.0))
    s.take_requests()
    s.command(at(s, 0.10))
    old = s.book.get(first.goal_id)
    assert old is not None and old.status == GoalStatus.CANCELED
    assert f"preempted by goal {second.goal_id}" in old.reason
    assert s.active is not None and s.active.goal_id == second.goal_id


def test_cancel_ends_the_goal_and_the_service_idles() -> None:
    s = make_service()
    rec = s.submit_goal(Pose2D(3.0, 1.0))
    s.take_requests()
    s.command(at(s, 0.05))
    assert s.cancel() is not None
    s.take_requests()
    assert s.command(at(s, 0.10)) == (0.0, 0.0)
    end = s.book.get(rec.goal_id)
    assert end is not None and end.status == GoalStatus.CANCELED and s.idle
    assert s.cancel() is None  # nothing left to cancel


def test_velocity_commands_take_over_and_navigation_does_not_resume() -> None:
    s = make_service()
    rec = s.submit_goal(Pose2D(3.0, 1.0))
    s.take_requests()
    s.command(at(s, 0.05))
    s.external(0.10, live=True)
    end = s.book.get(rec.goal_id)
    assert end is not None and end.status == GoalStatus.ABORTED and "teleop" in end.reason
    assert s.state == ServiceState.TELEOP
    s.external(0.80, live=False)
    assert s.state == ServiceState.IDLE and s.command(at(s, 0.85)) == (0.0, 0.0)


def test_a_goal_times_out_on_mcu_time() -> None:
    s = make_service(goal_timeout_s=1.0)
    rec = s.submit_goal(Pose2D(3.0, 1.0))
    s.take_requests()
    s.command(at(s, 0.05))
    t = 0.10
    while s.active is not None and t < 3.0:
        s.command(at(s, t))
        t += 0.05
    end = s.book.get(rec.goal_id)
    assert end is not None and end.status == GoalStatus.ABORTED
    assert end.reason.startswith("timeout") and 1.0 < t < 1.2


def test_lost_sensors_end_the_goal_and_refuse_new_ones_until_back() -> None:
    s = make_service()
    rec = s.submit_goal(Pose2D(3.0, 1.0))
    s.take_requests()
    s.command(at(s, 0.05))
    s.sensors(0.10, "imu excluded")
    end = s.book.get(rec.goal_id)
    assert end is not None and end.status == GoalStatus.ABORTED and end.reason == "imu excluded"
    refused = s.submit_goal(Pose2D(3.0, 1.0))
    assert refused.status == GoalStatus.REJECTED and "imu excluded" in refused.reason
    s.sensors(0.15, None)
    assert s.submit_goal(Pose2D(3.0, 1.0)).status == GoalStatus.PENDING


def test_localise_moves_the_pose_and_a_pose_in_a_wall_is_refused() -> None:
    s = make_service()
    s.set_pose(Pose2D(2.0, 3.0, 1.0))
    s.take_requests()
    s.command(at(s, 0.05))
    assert s.status.pose.distance(Pose2D(2.0, 3.0)) < 1e-9
    from jackson.host.control.navigator import RouteError

    with pytest.raises(RouteError, match="obstacle"):
        s.set_pose(Pose2D(0.0, 0.0))


def test_requests_round_trip_through_the_log_encoding() -> None:
    r = Request("goal", 7, 1.5, -2.25, 0.5, "goal_pose")
    assert Request.decode(r.encode()) == r
    with pytest.raises(ValueError, match="not a service request"):
        Request.decode(b"\xff garbage")


def test_the_goal_book_forgets_all_but_its_history() -> None:
    book = GoalBook(history=3)
    for k in range(10):
        book.reject(Pose2D(k, 0.0), "socket", "no")
    assert [g.goal_id for g in book.history()] == [8, 9, 10]
    assert book.get(1) is None and book.counts["rejected"] == 10


def test_waiting_for_a_goal_returns_when_it_ends() -> None:
    book = GoalBook()
    rec = book.new(Pose2D(), "socket")
    from dataclasses import replace

    threading.Timer(0.05, lambda: book.update(replace(rec, status=GoalStatus.SUCCEEDED))).start()
    end = book.wait(rec.goal_id, timeout_s=5.0)
    assert end is not None and end.status == GoalStatus.SUCCEEDED


def test_path_remaining_is_the_plan_from_the_nearest_point() -> None:
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    assert path_remaining_m(path, Pose2D(1.0, 0.0)) == pytest.approx(1.0)
    assert path_remaining_m(path, Pose2D(0.0, -0.5)) == pytest.approx(2.5)
    assert math.isnan(path_remaining_m(np.empty((0, 2)), Pose2D()))


@pytest.fixture
def server(tmp_path: Path):  # type: ignore[no-untyped-def]
    s = make_service()
    driven: list[tuple[float, float]] = []
    path = tmp_path / "run" / "d.sock"
    srv = ControlServer(
        path, s, lambda: {"state": s.state.value}, lambda v, w: driven.append((v, w))
    )
    srv.start()
    yield srv, s, driven
    srv.stop()


def test_the_socket_is_for_the_daemons_user_and_group_only(server) -> None:  # type: ignore[no-untyped-def]
    srv, _, _ = server
    mode = stat.S_IMODE(os.stat(srv.path).st_mode)
    assert mode == 0o660


def test_socket_answers_status_goal_cancel_drive_and_bad_requests(server) -> None:  # type: ignore[no-untyped-def]
    srv, _, driven = server
    assert list(ask(srv.path, {"op": "status"})) == [{"ok": True, "status": {"state": "idle"}}]
    (ans,) = ask(srv.path, {"op": "goal", "x": 3.0, "y": 1.0})
    assert ans["ok"] and ans["goal"]["status"] == "pending"
    (ans,) = ask(srv.path, {"op": "goal", "x": 40.0, "y": 1.0})
    assert not ans["ok"] and "outside the map" in ans["error"]
    (ans,) = ask(srv.path, {"op": "cancel"})
    assert ans["ok"] and ans["goal"]["id"] == 1
    (ans,) = ask(srv.path, {"op": "drive", "v": 0.1, "w": 0.0})
    assert ans == {"ok": True} and driven == [(0.1, 0.0)]
    for bad, says in (
        ({"op": "fly"}, "op:"),
        ({"op": "goal", "x": "a", "y": 1}, "x:"),
        ({"op": "drive", "v": float("inf"), "w": 0}, "v:"),
        ({"op": "wait", "id": 99}, "no goal 99"),
    ):
        (ans,) = ask(srv.path, bad)
        assert not ans["ok"] and says in ans["error"]
    with socket.socket(socket.AF_UNIX) as raw:
        raw.connect(str(srv.path))
        raw.sendall(b"not json\n")
        answer = json.loads(raw.makefile("rb").readline())
    assert not answer["ok"]


def test_a_second_daemon_on_the_same_socket_is_refused(server) -> None:  # type: ignore[no-untyped-def]
    srv, s, _ = server
    with pytest.raises(ControlError, match="another jackson daemon"):
        ControlServer(srv.path, s, dict, lambda v, w: None)


def test_a_socket_left_by_a_killed_daemon_is_taken_over(tmp_path: Path) -> None:
    path = tmp_path / "d.sock"
    stale = socket.socket(socket.AF_UNIX)
    stale.bind(str(path))
    stale.close()  # the file stays, nobody listens
    srv = ControlServer(path, make_service(), dict, lambda v, w: None)
    srv.start()
    try:
        assert next(ask(path, {"op": "status"}))["ok"]
    finally:
        srv.stop()
    assert not path.exists()


def test_no_daemon_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ControlError, match="no jackson daemon is running here"):
        list(ask(tmp_path / "none.sock", {"op": "status"}))
