"""A patrol: one navigation service serving goal after goal on one floor, as in service.

``jackson patrol`` runs the processes users run: the twin (``jackson sim``, lockstep, with its
ground truth written as it goes) and the daemon (``jackson daemon`` in service mode, recording
with its disk budget), and drives the daemon through its control socket as an operator's
client would, for a number of goals or of robot-hours (the soak):

- **goals**: random free points of the floor with 0.5 m of clearance, reachable from the start,
  at least 2.5 m from where the robot is and 1 m from every drop spot; reached when the service
  says so *and* the ground truth ends within the goal tolerance (0.25 m);
- **unreachable goals**: the floor's enclosed points (``patrol.unreachable`` of the world file),
  which the service must refuse at once, with its reason;
- **cancels**: a goal cancelled after 3-10 s of MCU time: the goal must end ``canceled`` and the
  robot come to rest;
- **preemptions**: a second goal 3-10 s after the first: the first ends ``canceled``
  (preempted), the second is reached;
- **teleop bursts**: velocity commands (a turn on the spot) while a goal is active: the goal
  ends ``aborted`` (teleop took over), navigation does not resume, the service goes idle;
- **obstacles**: cylinders dropped at random MCU times on the floor's drop spots
  (``patrol.drop_spots``), each taken away again after 20-90 s (the world's timed triggers).

It samples both processes' resident memory and CPU, the MCU time and the recording folder's size
every ``sample_s`` of wall time (``soak.csv``), and writes every goal (``patrol.csv``), the
summary (``summary.json``) and a plot (``patrol.png``). The daemon must never exit: a patrol
whose daemon dies stops there and says so.
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import json
import math
import os
import signal
import subprocess
import sys
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml
from scipy import ndimage

from jackson.common.errors import JacksonError
from jackson.host.config import DEFAULT_CONFIG, dump_config, load_config
from jackson.host.service.control import ControlError, ask
from jackson.sim.config import WORLDS_DIR, WorldSpec, load_world, resolve

GOAL_TOLERANCE_M = 0.25  # [m] REFERENCE: xy_goal_tolerance
CLEARANCE_M = 0.5  # [m] a random goal's distance to the nearest obstacle
MIN_TRIP_M = 2.5  # [m] a random goal's distance from the robot
DROP_KEEPOUT_M = 1.0  # [m] a random goal's distance from every drop spot
DROP_RADIUS_M = 0.15  # [m] a dropped cylinder
REST_M = 0.01  # [m] the truth moving less than this over 1 s of MCU time: at rest
WALL_PER_GOAL_S = 1800.0  # [s] of wall time a goal may take before the patrol gives up on it
READY_S = 180.0  # [s] of wall time for the twin and the daemon to come up
# [s] of wall time either end of the lockstep waits for the other before it gives up: a patrol
# shares its machine for hours, and a process descheduled for seconds is alive, not stalled
STALL_S = 120.0


class PatrolError(JacksonError, RuntimeError):
    """The patrol could not start, or a process it runs died."""


@dataclass(frozen=True)
class PatrolSpec:
    """One patrol.

    Attributes
    ----------
    world : str
        A world with a ``patrol:`` section (name in sim/worlds or a path).
    out : Path
        The patrol's folder.
    seed : int
        Seeds the twin's noise, the goals and the drops.
    goals : int
        Goals to send (all kinds); ignored with ``robot_hours``.
    robot_hours : float or None
        Run until this much MCU time has passed (the soak).
    robot : str
        The twin's robot.
    config : Path or None
        Host configuration (default: the shipped one); its recording folder and budget are
        replaced by the patrol's.
    budget_mb : float
        The recording folder's budget [MB].
    drop_period_s : float
        Mean MCU time between two drops [s].
    mix : tuple of 4 float
        Shares of unreachable goals, cancels, preemptions and teleop bursts.
    sample_s : float
        Wall time between two samples of the processes [s].
    """

    world: str
    out: Path
    seed: int = 0
    goals: int = 70
    robot_hours: float | None = None
    robot: str = "jackson"
    config: Path | None = None
    budget_mb: float = 2000.0
    drop_period_s: float = 120.0
    mix: tuple[float, float, float, float] = (0.08, 0.08, 0.08, 0.05)
    sample_s: float = 20.0


@dataclass
class GoalOutcome:
    """One patrol step's outcome (a row of ``patrol.csv``)."""

    step: int
    kind: str  # goal, unreachable, cancel, preempt, teleop
    goal_id: int
    x: float
    y: float
    status: str
    reason: str
    t_sent_s: float  # MCU time when sent (the status before)
    t_end_s: float  # MCU time it ended
    truth_error_m: float  # truth at the end to the goal (nan for the kinds that do not arrive)
    ok: bool  # what this kind must do, done
    recoveries: int = 0

    @property
    def answered_s(self) -> float:
        return self.t_end_s - self.t_sent_s


@dataclass
class Sample:
    """A row of ``soak.csv``."""

    wall_s: float
    robot_s: float
    daemon_rss_mb: float
    twin_rss_mb: float
    daemon_cpu_s: float
    twin_cpu_s: float
    disk_mb: float
    goals: int


@dataclass
class PatrolResult:
    outcomes: list[GoalOutcome] = field(default_factory=list)
    samples: list[Sample] = field(default_factory=list)
    contacts: int | None = None
    exclusions: list[str] = field(default_factory=list)
    suspicions: int = 0  # health transitions to suspect (braked until the sensor passes again)
    daemon_exit: int | None = None
    failure: str | None = None


# ---------------------------------------------------------------------------- the floor


def goal_cells(
    world: WorldSpec, resolution_m: float = 0.05
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Candidate goal points (x, y arrays [m]): free, reachable from the start, with
    :data:`CLEARANCE_M` of clearance and :data:`DROP_KEEPOUT_M` from every drop spot."""
    from jackson.sim.raster import raster, reachable_free

    occupied, ox, oy = raster(world, resolution_m)
    free = reachable_free(occupied, ox, oy, resolution_m, world.start_pose[:2])
    clearance = ndimage.distance_transform_edt(~occupied) * resolution_m
    ok = free & (clearance >= CLEARANCE_M)
    rows, cols = np.nonzero(ok)
    x = ox + (cols + 0.5) * resolution_m
    y = oy + (rows + 0.5) * resolution_m
    keep = np.ones(len(x), bool)
    spots = world.patrol.drop_spots if world.patrol is not None else ()
    for sx, sy in spots:
        keep &= np.hypot(x - sx, y - sy) >= DROP_KEEPOUT_M
    return x[keep], y[keep]


def drops(
    world: WorldSpec, rng: np.random.Generator, horizon_s: float, period_s: float
) -> list[dict[str, Any]]:
    """Timed triggers: a cylinder on a random drop spot every ``period_s`` on average (an
    exponential gap, at least 10 s), each taken away after 20-90 s, up to ``horizon_s``."""
    spots = world.patrol.drop_spots if world.patrol is not None else ()
    out: list[dict[str, Any]] = []
    if not spots:
        return out
    t = 0.0
    while True:
        t += max(10.0, float(rng.exponential(period_s)))
        if t >= horizon_s:
            return out
        x, y = spots[int(rng.integers(len(spots)))]
        stay = float(rng.uniform(20.0, 90.0))
        out.append(
            {
                "at_s": round(t, 2),
                "remove_at_s": round(t + stay, 2),
                "add_cylinder": {"x": x, "y": y, "radius": DROP_RADIUS_M},
            }
        )


def patrol_world(spec: PatrolSpec, world: WorldSpec, horizon_s: float) -> Path:
    """The world file the twin runs: the floor with the patrol's timed drops added."""
    data = yaml.safe_load(resolve(spec.world, WORLDS_DIR, "world").read_text())
    rng = np.random.default_rng([spec.seed, 1])
    data["triggers"] = list(data.get("triggers") or []) + drops(
        world, rng, horizon_s, spec.drop_period_s
    )
    path = spec.out / "world.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


# ---------------------------------------------------------------------------- the processes


class TruthTail:
    """The twin's ground-truth file read as it grows; the last 30 s of MCU time kept."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._pos = 0
        self._partial = ""
        self.rows: deque[tuple[float, float, float]] = deque(maxlen=600 * 2)

    def poll(self) -> float | None:
        """Read what is new; the newest MCU time [s] (None before a row)."""
        try:
            with self.path.open("r", encoding="ascii") as f:
                f.seek(self._pos)
                chunk = f.read()
                self._pos = f.tell()
        except OSError:
            return None
        text = self._partial + chunk
        lines = text.split("\n")
        self._partial = lines.pop()
        for line in lines:
            if not line or line[0] not in "0123456789":
                continue
            parts = line.split(",")
            self.rows.append((float(parts[1]), float(parts[2]), float(parts[3])))
        return self.rows[-1][0] if self.rows else None

    def at(self, t_s: float) -> tuple[float, float] | None:
        """The truth position at MCU time ``t_s`` (the nearest kept row)."""
        if not self.rows:
            return None
        best = min(self.rows, key=lambda r: abs(r[0] - t_s))
        return best[1], best[2]

    def moved_since(self, t_s: float) -> float:
        """How far the robot moved from MCU time ``t_s`` to the newest row [m]."""
        then = self.at(t_s)
        if then is None or not self.rows:
            return math.inf
        return math.hypot(self.rows[-1][1] - then[0], self.rows[-1][2] - then[1])


def rss_mb(pid: int) -> float:
    """The resident set of process ``pid`` [MB] (``VmRSS``; NaN once it has ended)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return math.nan


def _cpu_s(pid: int) -> float:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return math.nan


class Patrol:
    """Runs one :class:`PatrolSpec` (module docstring)."""

    def __init__(self, spec: PatrolSpec) -> None:
        self.spec = spec
        self.out = spec.out
        self.world = load_world(spec.world)
        if self.world.patrol is None:
            raise PatrolError(
                f"world {spec.world}: no patrol: section (drop_spots, unreachable); a patrol "
                "needs one (docs/patrol.md)"
            )
        self.rng = np.random.default_rng([spec.seed, 2])
        self.cand_x, self.cand_y = goal_cells(self.world)
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

    def start(self) -> None:
        from jackson.experiments.stage3 import world_grid

        out = self.out
        out.mkdir(parents=True, exist_ok=True)
        horizon = (
            self.spec.robot_hours * 3600.0
            if self.spec.robot_hours is not None
            else self.spec.goals * 60.0
        )
        world_file = patrol_world(self.spec, self.world, horizon)
        world_grid(self.world).save(out / "map.yaml")
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
        second = self._goal(n, "preempt", x2, y2, t0)
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
            rss_mb(self.daemon.pid),
            rss_mb(self.sim.pid),
            _cpu_s(self.daemon.pid),
            _cpu_s(self.sim.pid),
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

    def write(self) -> dict[str, Any]:
        self._write_outcomes()
        summary = summarise(self.spec, self.result)
        (self.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        plot_patrol(self.out / "patrol.png", self, summary)
        return summary


def _slope_per_hour(hours: list[float], values: list[float]) -> float:
    """Least-squares slope of ``values`` over robot-hours (nan with fewer than 3 points)."""
    pts = [(h, v) for h, v in zip(hours, values, strict=True) if math.isfinite(v)]
    if len(pts) < 3 or pts[-1][0] - pts[0][0] <= 0:
        return math.nan
    h, v = np.array(pts).T
    return float(np.polyfit(h, v, 1)[0])


def summarise(spec: PatrolSpec, r: PatrolResult) -> dict[str, Any]:
    """The patrol's figures (``summary.json``)."""
    by_kind: dict[str, dict[str, int]] = {}
    for o in r.outcomes:
        k = by_kind.setdefault(o.kind, {"sent": 0, "ok": 0})
        k["sent"] += 1
        k["ok"] += int(o.ok)
    reach = [o for o in r.outcomes if o.kind in ("goal", "preempt")]
    unreach = [o for o in r.outcomes if o.kind == "unreachable"]
    s = r.samples
    robot_h = [x.robot_s / 3600.0 for x in s]
    later = [k for k, h in enumerate(robot_h) if h >= 1.0]
    out: dict[str, Any] = {
        "world": spec.world,
        "seed": spec.seed,
        "steps": len(r.outcomes),
        "by_kind": by_kind,
        "reachable_reached": f"{sum(o.ok for o in reach)}/{len(reach)}",
        "unreachable_answered": f"{sum(o.ok for o in unreach)}/{len(unreach)}",
        "unreachable_answer_max_s": max((o.answered_s for o in unreach), default=None),
        "truth_error_max_m": max(
            (o.truth_error_m for o in reach if math.isfinite(o.truth_error_m)), default=None
        ),
        "contacts": r.contacts,
        "sensor_exclusions": len(r.exclusions),
        "sensor_suspicions": r.suspicions,
        "daemon_exit": r.daemon_exit,
        "failure": r.failure,
        "robot_hours": robot_h[-1] if robot_h else 0.0,
        "wall_hours": s[-1].wall_s / 3600.0 if s else 0.0,
    }
    if s:
        out["daemon_rss_mb"] = {"first": s[0].daemon_rss_mb, "last": s[-1].daemon_rss_mb}
        out["twin_rss_mb"] = {"first": s[0].twin_rss_mb, "last": s[-1].twin_rss_mb}
        out["disk_mb"] = {"last": s[-1].disk_mb, "max": max(x.disk_mb for x in s),
                          "budget": spec.budget_mb}  # fmt: skip
        if len(s) >= 2 and s[-1].robot_s > s[0].robot_s:
            span = s[-1].robot_s - s[0].robot_s
            out["daemon_cpu_per_robot_s"] = (s[-1].daemon_cpu_s - s[0].daemon_cpu_s) / span
            out["twin_cpu_per_robot_s"] = (s[-1].twin_cpu_s - s[0].twin_cpu_s) / span
    if len(later) >= 3:
        idx = later
        out["after_first_hour"] = {
            "daemon_rss_mb_per_robot_hour": _slope_per_hour(
                [robot_h[k] for k in idx], [s[k].daemon_rss_mb for k in idx]
            ),
            "twin_rss_mb_per_robot_hour": _slope_per_hour(
                [robot_h[k] for k in idx], [s[k].twin_rss_mb for k in idx]
            ),
        }
        cpu = []
        for a, b in itertools.pairwise(idx):
            d = s[b].robot_s - s[a].robot_s
            if d > 0:
                cpu.append((robot_h[b], (s[b].daemon_cpu_s - s[a].daemon_cpu_s) / d))
        if len(cpu) >= 3:
            out["after_first_hour"]["daemon_cpu_per_robot_s_slope_per_hour"] = _slope_per_hour(
                [c[0] for c in cpu], [c[1] for c in cpu]
            )
    return out


def plot_patrol(png: Path, patrol: Patrol, summary: dict[str, Any]) -> None:
    """The floor with every goal by outcome; with samples, memory and CPU over robot-hours."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    r = patrol.result
    world = patrol.world
    soak = len(r.samples) >= 3
    fig, axes = plt.subplots(1, 3 if soak else 1, figsize=(18 if soak else 8, 6))
    ax = axes[0] if soak else axes
    for x0, y0, x1, y1 in world.walls:
        ax.plot([x0, x1], [y0, y1], color="0.2", lw=1.2)
    for c in world.cylinders:
        ax.add_patch(Circle((c.x, c.y), c.radius, color="0.2"))
    if world.patrol is not None:
        for k, (x, y) in enumerate(world.patrol.drop_spots):
            ax.plot(x, y, "s", color="tab:purple", ms=7, mfc="none",
                    label="drop spot" if k == 0 else None)  # fmt: skip
    colours = {"goal": "tab:green", "preempt": "tab:blue", "cancel": "tab:orange",
               "teleop": "tab:cyan", "unreachable": "tab:brown"}  # fmt: skip
    for kind, colour in colours.items():
        os_ = [o for o in r.outcomes if o.kind == kind]
        good = [o for o in os_ if o.ok]
        bad = [o for o in os_ if not o.ok]
        if good:
            ax.plot([o.x for o in good], [o.y for o in good],
                    "D" if kind == "unreachable" else "o", color=colour, ms=4,
                    label=f"{kind} ({len(good)})")  # fmt: skip
        if bad:
            ax.plot([o.x for o in bad], [o.y for o in bad], "x", color="red", ms=8,
                    label=f"{kind} failed ({len(bad)})")  # fmt: skip
    sx, sy, _ = world.start_pose
    ax.plot(sx, sy, "k^", ms=9, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(
        f"{world.name}: {summary['reachable_reached']} reached,\n"
        f"{summary['unreachable_answered']} unreachable answered, "
        f"{summary['contacts']} contacts"
    )
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    if soak:
        h = [x.robot_s / 3600.0 for x in r.samples]
        axes[1].plot(h, [x.daemon_rss_mb for x in r.samples], label="daemon")
        axes[1].plot(h, [x.twin_rss_mb for x in r.samples], label="twin")
        axes[1].set_xlabel("robot time [h]")
        axes[1].set_ylabel("resident memory [MB]")
        axes[1].legend()
        axes[1].set_title("memory")
        ax2 = axes[2]
        hh, dc, tc = [], [], []
        for a, b in zip(r.samples, r.samples[1:], strict=False):
            d = b.robot_s - a.robot_s
            if d > 0:
                hh.append(b.robot_s / 3600.0)
                dc.append((b.daemon_cpu_s - a.daemon_cpu_s) / d)
                tc.append((b.twin_cpu_s - a.twin_cpu_s) / d)
        ax2.plot(hh, dc, label="daemon")
        ax2.plot(hh, tc, label="twin")
        ax2.set_xlabel("robot time [h]")
        ax2.set_ylabel("CPU-s per robot-second")
        ax2.legend()
        ax2b = ax2.twinx()
        ax2b.plot(h, [x.disk_mb for x in r.samples], "k:", label="recordings [MB]")
        ax2b.set_ylabel("recordings [MB] (dotted)")
        ax2.set_title("CPU and disk")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
