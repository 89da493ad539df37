"""The navigation service as an operator uses it: ``jackson sim`` and ``jackson daemon --lidar
--map`` as processes, goals sent with ``jackson goal``/``cancel``/``status``/``localise``."""

from __future__ import annotations

import math
import signal
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from jackson.experiments.patrol import TruthTail
from jackson.host.service.control import ask

from .harness import JACKSON, start_service, wait_for

WORLD = "hall_15m"
START = "1.5,1.5,0.55"


@dataclass
class Robot:
    tmp: Path
    sim: subprocess.Popen[str]
    daemon: subprocess.Popen[bytes]
    socket: Path
    run: Path
    truth: TruthTail

    def cli(self, *args: str, timeout: float = 300.0) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [JACKSON, *args, "--socket", str(self.socket)],
            capture_output=True,
            text=True,
            timeout=timeout,
        )

    def status(self) -> dict:  # type: ignore[type-arg]
        (answer,) = ask(self.socket, {"op": "status"})
        return answer["status"]  # type: ignore[no-any-return]

    def wait_state(self, state: str) -> None:
        wait_for(lambda: self.status()["state"] == state, timeout_s=120, what=f"state {state}")

    def goal(self, goal_id: int) -> dict:  # type: ignore[type-arg]
        answers = list(ask(self.socket, {"op": "wait", "id": goal_id}, 300.0))
        return answers[-1]["result"]  # type: ignore[no-any-return]


@pytest.fixture(scope="module")
def robot(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Robot]:
    tmp = tmp_path_factory.mktemp("service")
    sim, daemon, sock = start_service(tmp, WORLD, START, 5, tmp / "run", truth=True)
    r = Robot(tmp, sim, daemon, sock, tmp / "run", TruthTail(tmp / "truth.csv"))
    yield r
    for p in (daemon, sim):
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
    daemon.wait(60)
    sim.communicate(timeout=60)


def _truth_error(robot: Robot, t_s: float, x: float, y: float) -> float:
    wait_for(lambda: (robot.truth.poll() or 0.0) >= t_s, timeout_s=30, what="the truth file")
    at = robot.truth.at(t_s)
    assert at is not None
    return math.hypot(at[0] - x, at[1] - y)


def test_status_of_an_idle_service(robot: Robot) -> None:
    r = robot.cli("status")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("state: idle"), r.stdout
    assert "pose: x +1.50 m, y +1.50 m" in r.stdout and "disk: recordings" in r.stdout


def test_goal_wait_drives_there_on_the_ground_truth(robot: Robot) -> None:
    r = robot.cli("goal", "7.5,5", "--wait")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "succeeded: goal reached" in r.stdout
    result = robot.goal(1)
    assert _truth_error(robot, result["t_end_s"], 7.5, 5.0) <= 0.25
    assert robot.status()["state"] == "idle"


def test_a_goal_the_map_rules_out_is_one_line_and_exit_2(robot: Robot) -> None:
    r = robot.cli("goal", "4.0,6.5")  # a pillar
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "in an obstacle" in r.stderr
    assert robot.status()["goals"]["rejected"] >= 1


def test_a_second_goal_preempts_the_first_and_is_reached(robot: Robot) -> None:
    first = robot.cli("goal", "13,8.5")
    assert first.returncode == 0, first.stderr
    first_id = int(first.stdout.split()[1])
    t0 = robot.status()["t_s"]
    wait_for(lambda: robot.status()["t_s"] > t0 + 3.0, timeout_s=60, what="3 s of MCU time")
    second = robot.cli("goal", "2,8", "--wait")
    assert second.returncode == 0, second.stdout + second.stderr
    old = robot.goal(first_id)
    assert old["status"] == "canceled" and "preempted by goal" in old["reason"]


def test_cancel_brakes_and_the_service_idles(robot: Robot) -> None:
    sent = robot.cli("goal", "12,2")
    goal_id = int(sent.stdout.split()[1])
    t0 = robot.status()["t_s"]
    wait_for(lambda: robot.status()["t_s"] > t0 + 4.0, timeout_s=60, what="4 s of MCU time")
    r = robot.cli("cancel")
    assert r.returncode == 0 and f"canceling goal {goal_id}" in r.stdout
    result = robot.goal(goal_id)
    assert result["status"] == "canceled"
    robot.wait_state("idle")
    t_end = result["t_end_s"]
    wait_for(lambda: (robot.truth.poll() or 0.0) >= t_end + 2.0, timeout_s=60, what="2 s more")
    moved = robot.truth.moved_since(t_end + 1.0)
    assert moved < 0.01, f"moved {moved:.3f} m a second after the cancel"
    again = robot.cli("cancel")
    assert again.returncode == 2 and "nothing to cancel" in again.stderr


def test_velocity_commands_take_over_and_navigation_does_not_resume(robot: Robot) -> None:
    sent = robot.cli("goal", "7.5,8")
    goal_id = int(sent.stdout.split()[1])
    robot.wait_state("navigating")
    t0 = robot.status()["t_s"]
    while robot.status()["t_s"] < t0 + 1.5:
        list(ask(robot.socket, {"op": "drive", "v": 0.0, "w": 0.5}))
    result = robot.goal(goal_id)
    assert result["status"] == "aborted" and "teleop took over" in result["reason"]
    robot.wait_state("idle")
    t1 = robot.status()["t_s"]
    wait_for(lambda: robot.status()["t_s"] > t1 + 3.0, timeout_s=60, what="3 s of MCU time")
    assert robot.status()["state"] == "idle" and robot.status()["goal"] is None


def test_localise_and_a_run_that_replays_bit_for_bit(robot: Robot) -> None:
    pose = robot.status()["pose"]
    r = robot.cli("localise", f"{pose['x']:.3f},{pose['y']:.3f},{pose['yaw']:.3f}")
    assert r.returncode == 0, r.stderr
    robot.daemon.send_signal(signal.SIGINT)
    assert robot.daemon.wait(60) == 0
    text = (robot.tmp / "daemon.log").read_text()
    assert "service stopped: goals" in text and "localising from" in text
    runs = [p for p in robot.run.parent.iterdir() if p.is_dir() and (p / "log.jrec").exists()]
    assert runs
    for run in runs:
        rep = subprocess.run(
            [JACKSON, "replay", str(run)], capture_output=True, text=True, timeout=600
        )
        assert rep.returncode == 0 and "bit for bit" in rep.stdout, rep.stdout + rep.stderr
    gone = robot.cli("status")
    assert gone.returncode == 2 and "no jackson daemon" in gone.stderr
