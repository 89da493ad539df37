"""The patrol's loop: the twin and the daemon started as users start them, and the daemon driven
through its control socket step after step (:class:`Patrol`)."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import yaml

from jackson.experiments.patrol.floor import (
    MIN_TRIP_M,
    check_map_frame,
    goal_cells,
    patrol_world,
)
from jackson.experiments.patrol.localisation import (
    daemon_map_poses,
    localisation_errors,
    read_truth,
)
from jackson.experiments.patrol.paths import MIN_SHORTEST_M, ShortestPaths, path_length
from jackson.experiments.patrol.processes import TruthTail, cpu_s, rss_mb
from jackson.experiments.patrol.records import (
    GoalOutcome,
    PatrolError,
    PatrolResult,
    PatrolSpec,
    Sample,
)
from jackson.experiments.patrol.report import plot_patrol, summarise
from jackson.host.config import DEFAULT_CONFIG, dump_config, load_config
from jackson.host.nav.costmap import CostmapConfig
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.service.control import ControlError, ask
from jackson.sim.config import load_world

GOAL_TOLERANCE_M = 0.25  # [m] REFERENCE: xy_goal_tolerance
REST_M = 0.01  # [m] the truth moving less than this over 1 s of MCU time: at rest
WALL_PER_GOAL_S = 1800.0  # [s] of wall time a goal may take before the patrol gives up on it
READY_S = 180.0  # [s] of wall time for the twin and the daemon to come up
# [s] of wall time either end of the lockstep waits for the other before it gives up: a patrol
# shares its machine for hours, and a process descheduled for seconds is alive, not stalled
STALL_S = 120.0


class Patrol:
    """Runs one :class:`PatrolSpec` (:mod:`jackson.experiments.patrol`)."""

    def __init__(self, spec: PatrolSpec) -> None:
        self.spec = spec
        self.out = spec.out
        self.world = load_world(spec.world)
        if self.world.patrol is None:
            raise PatrolError(
                f"world {spec.world}: no patrol: section (drop_spots, unreachable); a patrol "
                "needs one (docs/patrol.md)"
            )
        self.grid = self._map()
        self.rng = np.random.default_rng([spec.seed, 2])
        self.cand_x, self.cand_y = goal_cells(self.world, grid=self.grid)
        self.goal_points = (len(self.cand_x), len(goal_cells(self.world)[0]))
        if len(self.cand_x) < 10:
            raise PatrolError(f"world {spec.world}: fewer than 10 free points to send goals to")
        self.result = PatrolResult()
        self.socket = self.out / "daemon.sock"
        self.truth = TruthTail(self.out / "truth.csv")
        self.sim: subprocess.Popen[str] | None = None
        self.daemon: subprocess.Popen[bytes] | None = None
        self._t0 = time.monotonic()
        self._last_sample = -math.inf
        self.last_status: dict[str, Any] = {}

    # ------------------------------------------------------------------ set-up

    def _map(self) -> OccupancyGrid:
        """The map the daemon gets: ``spec.map_yaml`` (checked to lie in the world's frame),
        else the world's own raster."""
        from jackson.experiments.stage3 import world_grid

        if self.spec.map_yaml is None:
            return world_grid(self.world)
        grid = OccupancyGrid.load(self.spec.map_yaml)  # MapFileError: one line
        check_map_frame(grid, self.world, str(self.spec.map_yaml))
        return grid

    def start(self) -> None:
        out = self.out
        out.mkdir(parents=True, exist_ok=True)
        horizon = (
            self.spec.robot_hours * 3600.0
            if self.spec.robot_hours is not None
            else self.spec.goals * 60.0
        )
        world_file = patrol_world(self.spec, self.world, horizon)
        self.grid.save(out / "map.yaml")
        cfg = load_config(self.spec.config or DEFAULT_CONFIG)
        cfg = dataclasses.replace(
            cfg,
            recording_folder=out / "runs",
            recording_budget_mb=self.spec.budget_mb,
        )
        (out / "host.yaml").write_text(yaml.safe_dump(dump_config(cfg), sort_keys=False))
        jackson = [sys.executable, "-m", "jackson"]
        for stale in (out / "mcu", out / "lidar"):
            if stale.is_symlink():
                stale.unlink()
        self.sim = subprocess.Popen(
            [
                *jackson, "sim", "--world", str(world_file), "--robot", self.spec.robot,
                "--seed", str(self.spec.seed), "--link", str(out / "mcu"),
                "--lidar-link", str(out / "lidar"), "--i2c", str(out / "i2c.sock"),
                "--truth", str(out / "truth.csv"),
                "--heartbeat-timeout", str(STALL_S), "--stall-timeout", str(STALL_S),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )  # fmt: skip
        assert self.sim.stdout is not None
        lines = []
        for line in self.sim.stdout:
            lines.append(line)
            if "waiting for HELLO" in line:
                break
        else:
            raise PatrolError("jackson sim ended before it was ready: " + "".join(lines)[-400:])
        x, y, yaw = self.world.start_pose
        log = (out / "daemon.log").open("wb")
        self.daemon = subprocess.Popen(
            [
                *jackson, "daemon", "--config", str(out / "host.yaml"),
                "--port", str(out / "mcu"), "--i2c", f"unix:{out / 'i2c.sock'}",
                "--lidar", str(out / "lidar"), "--map", str(out / "map.yaml"),
                "--start", f"{x},{y},{yaw}", "--socket", str(self.socket),
                "--stall-timeout", str(STALL_S),
            ],
            stdout=log,
            stderr=subprocess.STDOUT,
        )  # fmt: skip
        deadline = time.monotonic() + READY_S
        while time.monotonic() < deadline:
            self._check_alive()
            try:
                self.status()
                return
            except ControlError:
                time.sleep(0.2)
        raise PatrolError(f"the daemon did not open {self.socket} in {READY_S:g} s")

    def _check_alive(self) -> None:
        assert self.daemon is not None and self.sim is not None
        if self.daemon.poll() is not None:
            self.result.daemon_exit = self.daemon.returncode
            tail = (self.out / "daemon.log").read_text(errors="replace")[-600:]
            raise PatrolError(f"the daemon exited ({self.daemon.returncode}): {tail}")
        if self.sim.poll() is not None:
            raise PatrolError(f"the twin exited ({self.sim.returncode})")

    # ------------------------------------------------------------------ talking to it

    def _ask(self, request: dict[str, Any], timeout_s: float | None = 30.0) -> Iterator[Any]:
        return ask(self.socket, request, timeout_s)

    def status(self) -> dict[str, Any]:
        for answer in self._ask({"op": "status"}):
            self.last_status = answer["status"]
        return self.last_status

    def t_s(self) -> float:
        t = self.status().get("t_s")
        return float(t) if t is not None else 0.0

    def wait_mcu(self, t_s: float) -> None:
        """Wait until the MCU clock passes ``t_s`` (sampling meanwhile)."""
        while self.t_s() < t_s:
            self._check_alive()
            self.sample()
            time.sleep(0.05)

    def send(self, x: float, y: float, wait: bool) -> tuple[dict[str, Any], dict[str, Any] | None]:
        """A goal; its first answer and (``wait``) its result."""
        first: dict[str, Any] = {}
        result = None
        for answer in self._ask(
            {"op": "goal", "x": x, "y": y, "yaw": 0.0, "wait": wait}, WALL_PER_GOAL_S
        ):
            if "ok" in answer:
                first = answer
                if not answer["ok"]:
                    return first, None
            elif "result" in answer:
                result = answer["result"]
            self.sample()
        return first, result

    def follow(self, goal_id: int) -> dict[str, Any]:
        result: dict[str, Any] = {}
        for answer in self._ask({"op": "wait", "id": goal_id}, WALL_PER_GOAL_S):
            if "result" in answer:
                result = answer["result"]
            elif "ok" in answer and not answer["ok"]:
                return {"status": "unknown", "reason": answer["error"]}
            self.sample()
        return result

    def truth_at_end(self, t_end_s: float) -> tuple[float, float] | None:
        """The truth when a goal ended (waiting for the twin's file to reach it)."""
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            newest = self.truth.poll()
            if newest is not None and newest >= t_end_s:
                return self.truth.at(t_end_s)
            time.sleep(0.05)
        return self.truth.at(t_end_s)

    def at_rest(self, t_s: float) -> bool:
        """The truth stands still (< 1 cm over a second of MCU time) within 3 s after
        ``t_s``."""
        end = t_s + 3.0
        while True:
            newest = self.truth.poll() or 0.0
            if newest >= t_s + 1.0 and self.truth.moved_since(newest - 1.0) < REST_M:
                return True
            if newest >= end:
                return False
            self._check_alive()
            time.sleep(0.05)

    # ------------------------------------------------------------------ the steps

    def pick(self) -> tuple[float, float]:
        """A random reachable goal at least :data:`MIN_TRIP_M` from the robot."""
        pose = self.last_status.get("pose") or {}
        px, py = pose.get("x", 0.0), pose.get("y", 0.0)
        far = np.hypot(self.cand_x - px, self.cand_y - py) >= MIN_TRIP_M
        idx = np.flatnonzero(far) if far.any() else np.arange(len(self.cand_x))
        k = int(self.rng.choice(idx))
        return round(float(self.cand_x[k]), 3), round(float(self.cand_y[k]), 3)

    def step(self, n: int) -> GoalOutcome:
        u_unreach, u_cancel, u_preempt, u_teleop = self.spec.mix
        r = float(self.rng.random())
        t0 = self.t_s()
        if r < u_unreach:
            if self.world.patrol is None or not self.world.patrol.unreachable:
                return self._goal(n, "goal", *self.pick(), t0)  # a floor with nothing shut off
            return self._unreachable(n, t0)
        r -= u_unreach
        if r < u_cancel:
            return self._cancel(n, t0)
        r -= u_cancel
        if r < u_preempt:
            return self._preempt(n, t0)
        r -= u_preempt
        if r < u_teleop:
            return self._teleop(n, t0)
        return self._goal(n, "goal", *self.pick(), t0)

    def _goal(self, n: int, kind: str, x: float, y: float, t0: float) -> GoalOutcome:
        first, result = self.send(x, y, wait=True)
        if not first.get("ok"):
            return GoalOutcome(n, kind, 0, x, y, "rejected", first.get("error", ""), t0, t0,
                               math.nan, False)  # fmt: skip
        return self._finish(n, kind, first["goal"]["id"], x, y, result or {}, t0)

    def _finish(
        self, n: int, kind: str, goal_id: int, x: float, y: float, result: dict[str, Any],
        t0: float,
    ) -> GoalOutcome:  # fmt: skip
        t_end = result.get("t_end_s") or self.t_s()
        truth = self.truth_at_end(t_end)
        err = math.hypot(truth[0] - x, truth[1] - y) if truth is not None else math.nan
        status = result.get("status", "unknown")
        ok = status == "succeeded" and err <= GOAL_TOLERANCE_M
        return GoalOutcome(n, kind, goal_id, x, y, status, result.get("reason", ""), t0, t_end,
                           err, ok, int(result.get("recoveries") or 0))  # fmt: skip

    def _unreachable(self, n: int, t0: float) -> GoalOutcome:
        spots = self.world.patrol.unreachable if self.world.patrol is not None else ()
        x, y = spots[int(self.rng.integers(len(spots)))] if spots else (1e3, 1e3)
        first, _ = self.send(x, y, wait=False)
        t1 = self.t_s()
        refused = not first.get("ok")
        goal = first.get("goal") or {}
        return GoalOutcome(n, "unreachable", int(goal.get("id", 0)), x, y,
                           goal.get("status", "rejected" if refused else "?"),
                           first.get("error", ""), t0, t1, math.nan,
                           refused and t1 - t0 <= 15.0)  # fmt: skip

    def _start(
        self, n: int, kind: str, t0: float, most_s: float
    ) -> tuple[int, float, float] | GoalOutcome:
        """A random goal sent without waiting, then 3 to ``most_s`` s of MCU time: its id and
        target, or the step's outcome when it was refused."""
        x, y = self.pick()
        first, _ = self.send(x, y, wait=False)
        if not first.get("ok"):
            return GoalOutcome(n, kind, 0, x, y, "rejected", first.get("error", ""), t0, t0,
                               math.nan, False)  # fmt: skip
        self.wait_mcu(t0 + float(self.rng.uniform(3.0, most_s)))
        return int(first["goal"]["id"]), x, y

    def _cancel(self, n: int, t0: float) -> GoalOutcome:
        started = self._start(n, "cancel", t0, 10.0)
        if isinstance(started, GoalOutcome):
            return started
        goal_id, x, y = started
        for _ in self._ask({"op": "cancel", "id": goal_id}):
            pass
        result = self.follow(goal_id)
        t_end = float(result.get("t_end_s") or self.t_s())
        rest = self.at_rest(t_end)
        status = result.get("status", "unknown")
        # a goal reached before the cancel landed is fine too
        ok = (status == "canceled" and rest) or status == "succeeded"
        return GoalOutcome(n, "cancel", goal_id, x, y, status, result.get("reason", ""), t0,
                           t_end, math.nan, ok)  # fmt: skip

    def _preempt(self, n: int, t0: float) -> GoalOutcome:
        started = self._start(n, "preempt", t0, 10.0)
        if isinstance(started, GoalOutcome):
            return started
        old_id, _, _ = started
        x2, y2 = self.pick()
        second = self._goal(n, "preempt", x2, y2, self.t_s())  # its path starts here
        old = self.follow(old_id)
        preempted = old.get("status") == "canceled" and "preempted" in old.get("reason", "")
        second.ok = second.ok and (preempted or old.get("status") == "succeeded")
        second.reason = f"{second.reason}; goal {old_id}: {old.get('status')} {old.get('reason')}"
        return second

    def _teleop(self, n: int, t0: float) -> GoalOutcome:
        started = self._start(n, "teleop", t0, 8.0)
        if isinstance(started, GoalOutcome):
            return started
        goal_id, x, y = started
        t_burst = self.t_s()
        while self.t_s() < t_burst + 2.0:  # a turn on the spot: 2 s of MCU time
            for _ in self._ask({"op": "drive", "v": 0.0, "w": 0.6}):
                pass
        result = self.follow(goal_id)
        status = self._status_after_teleop(t_burst)
        ok = (
            result.get("status") == "aborted" and "teleop" in result.get("reason", "")
        ) or result.get("status") == "succeeded"
        ok = ok and status == "idle"
        return GoalOutcome(n, "teleop", goal_id, x, y, str(result.get("status")),
                           f"{result.get('reason', '')}; then {status}", t0,
                           float(result.get("t_end_s") or t_burst), math.nan, ok)  # fmt: skip

    def _status_after_teleop(self, t_burst: float) -> str:
        """The service's state once the velocity commands have stopped (the watchdog's 0.6 s
        and the limiter's ramp): it must be idle, not navigating again."""
        self.wait_mcu(self.t_s() + 2.0)
        return str(self.status().get("state"))

    # ------------------------------------------------------------------ sampling

    def sample(self, force: bool = False) -> None:
        now = time.monotonic() - self._t0
        if not force and now - self._last_sample < self.spec.sample_s:
            return
        assert self.daemon is not None and self.sim is not None
        self._last_sample = now
        st = self.status()
        sample = Sample(
            now,
            float(st.get("t_s") or 0.0),
            rss_mb(self.daemon.pid, with_children=True),  # its planner worker with it
            rss_mb(self.sim.pid),
            cpu_s(self.daemon.pid, with_children=True),
            cpu_s(self.sim.pid),
            float((st.get("disk") or {}).get("used_mb") or 0.0),
            len(self.result.outcomes),
        )
        self.result.samples.append(sample)
        path = self.out / "soak.csv"  # as it goes: a soak cut short keeps its samples
        cols = [f.name for f in dataclasses.fields(Sample)]
        new = not path.exists() or len(self.result.samples) == 1
        with path.open("w" if new else "a", newline="") as f:
            w = csv.writer(f)
            if new:
                w.writerow(cols)
            w.writerow([getattr(sample, c) for c in cols])

    # ------------------------------------------------------------------ the whole patrol

    def run(self, progress: Any = None) -> PatrolResult:
        try:
            self.start()
            self.sample(force=True)
            n = 0
            while True:
                if self.spec.robot_hours is not None:
                    if self.t_s() >= self.spec.robot_hours * 3600.0:
                        break
                elif n >= self.spec.goals:
                    break
                self._check_alive()
                outcome = self.step(n)
                self.result.outcomes.append(outcome)
                self._write_outcomes()
                n += 1
                if progress is not None:
                    progress(self, outcome)
            self.sample(force=True)
        except (PatrolError, ControlError) as exc:
            self.result.failure = str(exc)
        finally:
            self.stop()
        self.write()
        return self.result

    def stop(self) -> None:
        """SIGINT to the daemon (it brakes, closes its run folder) and to the twin; the twin's
        contact count and the daemon's sensor exclusions are read from their output."""
        if self.daemon is not None and self.daemon.poll() is None:
            self.daemon.send_signal(signal.SIGINT)
            try:
                self.daemon.wait(60)
            except subprocess.TimeoutExpired:
                self.daemon.kill()
                self.daemon.wait()
            self.result.daemon_exit = self.daemon.returncode
        if self.sim is not None:
            if self.sim.poll() is None:
                self.sim.send_signal(signal.SIGINT)
            try:
                rest, _ = self.sim.communicate(timeout=60)
            except subprocess.TimeoutExpired:
                self.sim.kill()
                rest, _ = self.sim.communicate()
            for line in (rest or "").splitlines():
                if line.startswith("twin:") and " collisions" in line:
                    words = line.split(", ")
                    for w in words:
                        if w.endswith(" collisions"):
                            self.result.contacts = int(w.split()[0])
            (self.out / "twin.log").write_text(rest or "")
        log = self.out / "daemon.log"
        if log.exists():
            self.result.suspicions = sum(
                "-> suspect" in line
                for line in log.read_text(errors="replace").splitlines()
                if line.startswith("daemon: health:")
            )
            self.result.exclusions = [
                line
                for line in log.read_text(errors="replace").splitlines()
                if line.startswith("daemon: health:") and "-> excluded" in line
            ]

    # ------------------------------------------------------------------ outputs

    def _write_outcomes(self) -> None:
        cols = [f.name for f in dataclasses.fields(GoalOutcome)]
        with (self.out / "patrol.csv").open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(cols)
            for o in self.result.outcomes:
                w.writerow([getattr(o, c) for c in cols])

    def measure(self) -> None:
        """The daemon's localisation error over the patrol and each reached goal's path
        against the shortest (:mod:`.localisation`, :mod:`.paths`), from the truth and the
        daemon's run folders."""
        try:
            truth = read_truth(self.out / "truth.csv")
        except (OSError, ValueError):
            return  # the twin never wrote a row: nothing to measure against
        estimate, self.result.unread_bags = daemon_map_poses(self.out / "runs")
        if len(estimate):
            self.result.localisation = localisation_errors(estimate, truth)
        shortest = ShortestPaths.of_world(self.world, CostmapConfig().robot_radius_m)
        for o in self.result.outcomes:
            if o.kind not in ("goal", "preempt") or not o.ok:
                continue
            inside = (truth.t_s > o.t_sent_s) & (truth.t_s < o.t_end_s)
            ends = truth.xy_at([o.t_sent_s, o.t_end_s])
            o.path_m = path_length(np.vstack((ends[:1], truth.xy_at(truth.t_s[inside]), ends[1:])))
            a, b = (float(ends[0, 0]), float(ends[0, 1])), (float(ends[1, 0]), float(ends[1, 1]))
            o.shortest_m = shortest.length_m(a, b)
            if o.shortest_m >= MIN_SHORTEST_M:
                o.path_ratio = o.path_m / o.shortest_m

    def write(self) -> dict[str, Any]:
        self.measure()
        self._write_outcomes()
        summary = summarise(self.spec, self.result, self.goal_points)
        (self.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        plot_patrol(self.out / "patrol.png", self.world, self.result, summary, self.grid)
        return summary
