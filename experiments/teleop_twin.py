"""A teleop drive of the twin, recorded by the daemon and mapped from its recording.

What a user with a joystick does, scripted so that it can be repeated:

1. ``jackson sim --realtime --truth FILE`` runs the twin on the wall clock and streams its
   ground truth (:mod:`jackson.sim.truth`);
2. ``jackson daemon --ros --lidar ...`` without a mission, goal or map records a run folder
   (its bag: /scan, /odometry/filtered, /wheel/odom, /tf_static) and drives by ``/cmd_vel``;
   ``-p use_sim_time:=true`` stamps the bag with MCU time, the twin's clock, so that the run
   and the truth file share one clock;
3. a ROS 2 node of this process publishes ``geometry_msgs/Twist`` on ``/cmd_vel`` at 10 Hz of
   wall time, as teleop_twist_keyboard or teleop_twist_joy do. Its "driver" steers by pure
   pursuit along a route on the twin's true pose (what a person watching the robot steers by),
   at a fixed speed, turning on the spot where the route turns sharply;
4. :func:`attach_truth` makes the run folder a twin run the map report judges: the truth as
   ``ground_truth.csv``, and in ``meta.json`` the world, the robot and the robot's pose at the
   start as ``navigate.start`` (the pose ``jackson map --from`` anchors the odometry at, so that
   the map lands in the world's frame; a teleop run has no navigation of its own);
5. ``jackson map --from RUN --out MAP`` maps the recording and writes its report.

The route and the driver are :mod:`jackson.experiments.teleop_route`'s: by default the survey
``jackson map --world`` drives (the world's survey waypoints, then back to the start), planned
on the world's raster so that the driver keeps to the middle of corridors and doorways.

    python -m jackson.experiments.teleop_twin drive --world partition_lshape --out OUT
    python -m jackson.experiments.teleop_twin attach RUN --truth truth.csv

``drive`` writes into ``OUT``: ``run/`` (the daemon's run folder, truth attached), ``map/``
(``jackson map --from``'s map and report), ``truth.csv``, ``sim.log``, ``daemon.log``,
``map.log`` and ``teleop.json`` (the drive's figures and the map's).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from jackson.common.args import float_upto, int_in, nonneg_int, output_folder, pose_text
from jackson.common.errors import JacksonError
from jackson.common.geometry import wrap_angle
from jackson.experiments.teleop_route import (
    PurePursuit,
    survey_via,
    teleop_route,
)

if TYPE_CHECKING:
    from jackson.sim.config import WorldSpec
    from jackson.sim.truth import TruthTrack

JACKSON = str(Path(sys.executable).parent / "jackson")
CMD_PERIOD_S = 0.1  # [s] of wall time: /cmd_vel at 10 Hz, as teleop_twist_keyboard's repeat
STAND_S = 3.0  # [s] of robot time standing still before (the gyro bias) and after the drive
SPEED_RANGE_M_S = (0.05, 0.5)  # [m/s] --speed
STALL_WALL_S = 30.0  # [s] of wall time without the twin's clock moving: the twin is stuck
READY_WALL_S = 120.0  # [s] of wall time for the twin and the daemon to come up
STOP_WALL_S = 120.0  # [s] of wall time for the daemon to finish its run folder
TRUTH_NAME = "ground_truth.csv"
TRUTH_SLACK_S = 0.1  # [s] a run's last frame may lie this far past the truth's last row
START_TOLERANCE_M = 0.1  # [m] a navigation's given start against the truth's


class TeleopError(JacksonError):
    """What the drive or the attaching of a truth cannot do (one line, exit status 2)."""


# ------------------------------------------------------------------------- the truth file


class TruthTail:
    """The newest row of the file ``jackson sim --truth`` writes while it grows."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._file: IO[str] | None = None
        self._partial = ""
        self.t_s = math.nan
        self.pose = (math.nan, math.nan, math.nan)

    def poll(self) -> bool:
        """Read what was appended; whether a new row came."""
        if self._file is None:
            if not self.path.exists():
                return False
            self._file = self.path.open(encoding="ascii")
        lines = (self._partial + self._file.read()).split("\n")
        self._partial = lines.pop()  # a row still being written
        for line in reversed(lines):
            if line and line[0].isdigit():
                _, t_s, x, y, yaw = (float(v) for v in line.split(","))
                self.t_s, self.pose = t_s, (x, y, yaw)
                return True
        return False

    def close(self) -> None:
        if self._file is not None:
            self._file.close()


def truth_header(path: Path) -> dict[str, str]:
    """The session a truth file names in its first line: ``boot_id``, ``robot``, ``world``."""
    with path.open(encoding="ascii", errors="replace") as f:
        first = f.readline()
    _, _, named = first.partition(":")
    out = {}
    for part in named.split(","):
        key, _, value = part.strip().partition(" ")
        if key and value:
            out[key] = value.strip()
    return out


@dataclass(frozen=True)
class TwinRun:
    """What :func:`attach_truth` wrote into a run folder.

    Attributes
    ----------
    run : Path
        The run folder.
    world, robot : str
        The twin's world and robot, as ``meta.json`` now names them.
    start : tuple of float
        The robot's true pose when the run's odometry began (x, y [m], yaw [rad]).
    truth_rows : int
        Rows of ``ground_truth.csv``.
    """

    run: Path
    world: str
    robot: str
    start: tuple[float, float, float]
    truth_rows: int


def attach_truth(
    run: Path, truth: Path, world: str | None = None, robot: str | None = None
) -> TwinRun:
    """Make a daemon's run folder on the twin a twin run that ``jackson map --from`` judges.

    Writes ``RUN/ground_truth.csv`` (``t_s, x_m, y_m, yaw_rad``: the truth file's rows) and adds
    to ``RUN/meta.json`` ``world`` and ``robot`` (default: those the truth file names) and, when
    the run has no navigation of its own, ``navigate.start``: the true pose at the run's first
    odometry message, where its odometry frame lies in the world. Attaching again (another
    truth file) replaces all three.

    Parameters
    ----------
    run : Path
        The run folder (``jackson daemon --run-dir``), recorded on the twin's clock.
    truth : Path
        The file ``jackson sim --truth`` wrote during that run.
    world, robot : str, optional
        Override the names in the truth file (a world given by a path, say).

    Raises
    ------
    TeleopError
        A run without a readable bag or odometry, an unreadable truth file, a world or robot
        that does not load, a run of another twin session (its MCU's boot_id) or not on the
        truth's clock, or a navigation run whose start the truth contradicts.
    """
    from jackson.sim.config import load_robot, load_world
    from jackson.sim.truth import TruthFileError, read_truth

    try:
        track = read_truth(truth)
    except TruthFileError as exc:
        raise TeleopError(str(exc)) from exc
    named = truth_header(truth)
    world = world or named.get("world")
    robot = robot or named.get("robot")
    if not world or not robot:
        raise TeleopError(f"{truth}: names no world or robot: give them")
    try:
        load_world(world)
        load_robot(robot)
    except JacksonError as exc:
        raise TeleopError(str(exc)) from exc
    t0 = run_on_truth_clock(run, track)
    t = track.t_us * 1e-6
    start = (
        float(np.interp(t0, t, track.x_m)),
        float(np.interp(t0, t, track.y_m)),
        wrap_angle(float(np.interp(t0, t, track.yaw_rad))),
    )
    meta_path = run / "meta.json"
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    nav = meta.get("navigate")
    if isinstance(nav, dict) and set(nav) != {"start"}:  # a navigation's own start
        given = [float(v) for v in nav.get("start", (0.0, 0.0, 0.0))]
        if math.hypot(given[0] - start[0], given[1] - start[1]) > START_TOLERANCE_M:
            raise TeleopError(
                f"{run}: its navigation started at ({given[0]:.2f}, {given[1]:.2f}), the twin's "
                f"truth puts the robot at ({start[0]:.2f}, {start[1]:.2f}): not this run's truth, "
                "or --start was wrong"
            )
    else:
        meta["navigate"] = {"start": list(start)}
    rows = np.column_stack((t, track.x_m, track.y_m, track.yaw_rad))
    header = "t_s,x_m,y_m,yaw_rad"
    np.savetxt(run / TRUTH_NAME, rows, fmt="%.6f", delimiter=",", header=header, comments="")
    meta.update(world=world, robot=robot)
    meta_path.write_text(json.dumps(meta, indent=2) + "\n")
    return TwinRun(run, world, robot, start, len(rows))


def run_on_truth_clock(run: Path, track: TruthTrack) -> float:
    """The run's first odometry stamp [s], checked to be on the truth's clock: the run's MCU
    reported the truth's boot_id, and its bag's odometry and its telemetry lie within the
    truth's time span.

    Raises
    ------
    TeleopError
        Naming what does not match.
    """
    from jackson.calibration.runs.folders import run_boot_ids
    from jackson.host.nav.offline import plan_recording
    from jackson.host.nav.offline.recording import messages

    try:  # RecordingMapError, CalibrationError: one line each
        plan = plan_recording(run)
        first = next(messages(plan.bags, (plan.odometry_topic,)), None)
        boot_ids = run_boot_ids(run)
    except JacksonError as exc:
        raise TeleopError(str(exc)) from exc
    if track.boot_id is not None and boot_ids and track.boot_id not in boot_ids:
        ids = ", ".join(f"{b:#010x}" for b in sorted(boot_ids))
        raise TeleopError(
            f"{run}: recorded on a twin with boot_id {ids}, {track.path} is the truth of boot_id "
            f"{track.boot_id:#010x}: give the truth file of that twin session"
        )
    if first is None:
        raise TeleopError(f"{run}: no {plan.odometry_topic} message")
    stamp = first[1].header.stamp
    t0 = float(stamp.sec + stamp.nanosec * 1e-9)
    t_end = last_telemetry_s(run)
    t = track.t_us * 1e-6
    if not t[0] <= t0 <= t[-1]:
        raise TeleopError(
            f"{run}: its odometry starts at {t0:.3f} s, outside the truth's {t[0]:.3f}-"
            f"{t[-1]:.3f} s: not recorded on the twin's clock (jackson daemon --ros needs the "
            "twin's /clock, or --ros-args -p use_sim_time:=true)"
        )
    if t_end > t[-1] + TRUTH_SLACK_S:
        raise TeleopError(
            f"{run}: runs to {t_end:.3f} s of MCU time, the truth ends at {t[-1]:.3f} s: not "
            "this run's truth"
        )
    return t0


def last_telemetry_s(run: Path) -> float:
    """The MCU time of the run's last odometry row (``odometry.csv``) [s]; 0 without one."""
    path = run / "odometry.csv"
    if not path.is_file():
        return 0.0
    with path.open("rb") as f:
        f.seek(max(0, path.stat().st_size - 4096))
        rows = f.read().decode("ascii", "replace").strip().splitlines()
    try:
        return float(rows[-1].split(",")[0])
    except (IndexError, ValueError):
        return 0.0


# ------------------------------------------------------------------------- the processes


def ros_environment(domain: int | None, log_dir: Path) -> dict[str, str]:
    """The ROS settings of this process and its children: the domain asked for, discovery on
    this machine only (the twin, the daemon and the driver all run here)."""
    env: dict[str, str] = {} if domain is None else {"ROS_DOMAIN_ID": str(domain)}
    for key, value in (
        ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST"),
        ("ROS_STATIC_PEERS", "127.0.0.1"),
        ("ROS_LOG_DIR", str(log_dir)),
    ):
        if key not in os.environ:
            env[key] = value
    return env


@contextlib.contextmanager
def started(args: Sequence[str], log: Path, env: dict[str, str]) -> Iterator[subprocess.Popen[str]]:
    """A child process writing into ``log``; stopped (SIGINT, then SIGKILL) on the way out."""
    with log.open("w") as out:
        proc = subprocess.Popen(
            list(args), stdout=out, stderr=subprocess.STDOUT, text=True, env={**os.environ, **env}
        )
        try:
            yield proc
        finally:
            stop(proc, STOP_WALL_S)


def stop(proc: subprocess.Popen[str], timeout_s: float) -> int:
    """Stop a child as Ctrl-C does and wait for it (killed after ``timeout_s``)."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return int(proc.returncode)


def twin_ports(log: Path, proc: subprocess.Popen[str]) -> dict[str, str]:
    """The serial pty, I2C socket and LiDAR pty the twin prints, once it has."""
    deadline = time.monotonic() + READY_WALL_S
    while time.monotonic() < deadline:
        ports = dict(line.split(": ", 1) for line in log.read_text().splitlines() if ": " in line)
        if {"serial", "i2c", "lidar", "truth"} <= ports.keys():
            return {k: v.strip() for k, v in ports.items()}
        if proc.poll() is not None:
            raise TeleopError(f"jackson sim ended (status {proc.returncode}): {tail(log)}")
        time.sleep(0.1)
    raise TeleopError(f"jackson sim printed no ports in {READY_WALL_S:g} s: {tail(log)}")


def tail(log: Path, lines: int = 3) -> str:
    return " | ".join(log.read_text(errors="replace").strip().splitlines()[-lines:])


# ------------------------------------------------------------------------------ the drive


@dataclass(frozen=True)
class DriveResult:
    """The drive's figures (``teleop.json``'s ``drive``).

    Attributes
    ----------
    route_m, driven_m : float
        The route's length and the true path's [m].
    robot_s, wall_s : float
        Robot time from the first move to the route's end [s]; wall time of the whole drive,
        start-up and shut-down included [s].
    commands : int
        /cmd_vel messages published.
    closest_wall_m : float
        The true path's closest approach to a wall or cylinder (the axle midpoint) [m].
    collisions : int
        Collisions the twin counted (-1: it did not say).
    daemon_status : int
        The daemon's exit status after Ctrl-C.
    """

    route_m: float
    driven_m: float
    robot_s: float
    wall_s: float
    commands: int
    closest_wall_m: float
    collisions: int
    daemon_status: int


def follow(
    pursuit: PurePursuit,
    tail_of: TruthTail,
    daemon: subprocess.Popen[str],
    daemon_log: Path,
) -> tuple[int, float]:
    """Publish /cmd_vel at 10 Hz of wall time along the route, on the twin's true pose: stand
    :data:`STAND_S` once the daemon listens and the twin's clock runs, drive, stand again.
    Returns the commands sent and the robot time driven [s]. A driver that has not reached the
    route's end in three times its length at its speed (plus a minute) gives up."""
    import rclpy
    from geometry_msgs.msg import Twist
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    rclpy.init()
    node: Any = rclpy.create_node("jackson_teleop")  # untyped in some rclpy releases
    profile: Any = QoSProfile
    qos = profile(
        history=HistoryPolicy.KEEP_LAST,
        depth=1,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
    )
    pub = node.create_publisher(Twist, "/cmd_vel", qos)
    sent = 0

    def publish(v: float, w: float) -> None:
        nonlocal sent
        msg = Twist()
        msg.linear.x, msg.angular.z = float(v), float(w)
        pub.publish(msg)
        sent += 1

    def alive() -> None:
        if daemon.poll() is not None:
            raise TeleopError(
                f"jackson daemon ended (status {daemon.returncode}): {tail(daemon_log)}"
            )

    try:
        deadline = time.monotonic() + READY_WALL_S
        while pub.get_subscription_count() == 0 or not tail_of.poll() or tail_of.t_s <= 0.0:
            alive()
            if time.monotonic() > deadline:
                raise TeleopError(
                    f"no /cmd_vel subscriber or the twin's clock still in {READY_WALL_S:g} s: "
                    f"{tail(daemon_log)}"
                )
            rclpy.spin_once(node, timeout_sec=CMD_PERIOD_S)
        phase, t_phase = "stand", tail_of.t_s
        t_drive = math.nan
        # three times the route at the driver's speed, as a survey's limit (host/control/guard)
        limit_s = 3.0 * pursuit.length_m / pursuit.speed_m_s + 60.0
        seen_wall, seen_t = time.monotonic(), tail_of.t_s
        next_cmd = next_say = time.monotonic()
        while True:
            alive()
            now = time.monotonic()
            if tail_of.poll() and tail_of.t_s > seen_t:
                seen_wall, seen_t = now, tail_of.t_s
            if now - seen_wall > STALL_WALL_S:
                raise TeleopError(f"the twin's clock stood still for {STALL_WALL_S:g} s")
            if now >= next_cmd:
                next_cmd = max(next_cmd + CMD_PERIOD_S, now)  # no burst after a late wake-up
                x, y, yaw = tail_of.pose
                if phase == "stand" and tail_of.t_s - t_phase >= STAND_S:
                    phase, t_drive = "drive", tail_of.t_s
                if phase == "drive" and tail_of.t_s - t_drive > limit_s:
                    raise TeleopError(
                        f"the driver did not reach the route's end in {limit_s:.0f} s of robot "
                        f"time ({pursuit.progress_m:.1f} of {pursuit.length_m:.1f} m)"
                    )
                if phase == "drive" and pursuit.arrived(x, y):
                    phase, t_phase = "end", tail_of.t_s
                    t_drive = tail_of.t_s - t_drive
                if phase == "end" and tail_of.t_s - t_phase >= STAND_S:
                    publish(0.0, 0.0)
                    return sent, t_drive
                publish(*(pursuit.command(x, y, yaw) if phase == "drive" else (0.0, 0.0)))
            if now >= next_say:
                next_say += 10.0
                print(
                    f"teleop: {pursuit.progress_m:.1f} of {pursuit.length_m:.1f} m of the route, "
                    f"{tail_of.t_s:.0f} s of robot time",
                    file=sys.stderr,
                    flush=True,
                )
            rclpy.spin_once(node, timeout_sec=max(0.0, min(next_cmd - time.monotonic(), 0.05)))
    finally:
        node.destroy_node()
        rclpy.shutdown()


def drive(
    world: str,
    out: Path,
    robot: str = "jackson_physical",
    speed_m_s: float = 0.2,
    seed: int = 0,
    via: Sequence[tuple[float, float]] | None = None,
    ros_domain: int | None = None,
) -> DriveResult:
    """Drive the twin along the survey route by /cmd_vel while the daemon records ``OUT/run``
    (module docstring, steps 1-4).

    Raises
    ------
    TeleopError
        A route that cannot be planned, a process that fails, or a twin that collided.
    """
    from jackson.sim.config import load_world

    spec = load_world(world)
    route = teleop_route(spec, via if via is not None else survey_via(world, robot))
    pursuit = PurePursuit(route, speed_m_s)
    out.mkdir(parents=True, exist_ok=True)
    truth, run = out / "truth.csv", out / "run"
    env = ros_environment(ros_domain, out / "ros-log")
    os.environ.update(env)  # this process's node too
    print(
        f"teleop: {world}, a {pursuit.length_m:.1f} m route at {speed_m_s:g} m/s "
        f"(about {pursuit.length_m / speed_m_s / 60:.0f} min of driving in real time)",
        file=sys.stderr,
        flush=True,
    )
    wall0 = time.monotonic()
    sim_args = [JACKSON, "sim", "--world", world, "--robot", robot, "--realtime"]
    sim_args += ["--seed", str(seed), "--truth", str(truth)]
    with started(sim_args, out / "sim.log", env) as sim:
        ports = twin_ports(out / "sim.log", sim)
        daemon_args = [JACKSON, "daemon", "--ros", "--port", ports["serial"], "--i2c"]
        daemon_args += [ports["i2c"], "--lidar", ports["lidar"], "--run-dir", str(run)]
        daemon_args += ["--ros-args", "-p", "use_sim_time:=true"]
        with started(daemon_args, out / "daemon.log", env) as daemon:
            tail_of = TruthTail(truth)
            try:
                sent, robot_s = follow(pursuit, tail_of, daemon, out / "daemon.log")
            finally:
                tail_of.close()
            daemon_status = stop(daemon, STOP_WALL_S)
        stop(sim, STOP_WALL_S)
    collisions = twin_collisions(out / "sim.log")
    driven, closest = path_figures(spec, truth)
    result = DriveResult(
        route_m=pursuit.length_m,
        driven_m=driven,
        robot_s=robot_s,
        wall_s=time.monotonic() - wall0,
        commands=sent,
        closest_wall_m=closest,
        collisions=collisions,
        daemon_status=daemon_status,
    )
    if daemon_status != 0:
        raise TeleopError(
            f"jackson daemon ended with status {daemon_status}: {tail(out / 'daemon.log')}"
        )
    if collisions:
        raise TeleopError(f"the twin collided {collisions} times: see {out / 'sim.log'}")
    return result


def twin_collisions(log: Path) -> int:
    """The collisions the twin's last line counts (-1: no such line)."""
    for line in reversed(log.read_text(errors="replace").splitlines()):
        if line.startswith("twin: ") and " collisions" in line:
            return int(line.split(" collisions")[0].rsplit(" ", 1)[1])
    return -1


def path_figures(world: WorldSpec, truth: Path) -> tuple[float, float]:
    """The true path's length [m] and its closest approach to a wall or cylinder (the axle
    midpoint to the nearest occupied cell of the world's 1 cm raster) [m]."""
    from scipy import ndimage

    from jackson.sim.raster import raster
    from jackson.sim.truth import read_truth

    track = read_truth(truth)
    xy = np.column_stack((track.x_m, track.y_m))
    length = float(np.hypot(*np.diff(xy, axis=0).T).sum())
    resolution = 0.01
    occupied, ox, oy = raster(world, resolution)
    distance = ndimage.distance_transform_edt(~occupied) * resolution
    col = np.clip(((xy[:, 0] - ox) / resolution).astype(int), 0, occupied.shape[1] - 1)
    row = np.clip(((xy[:, 1] - oy) / resolution).astype(int), 0, occupied.shape[0] - 1)
    return length, float(distance[row, col].min())


def map_run(run: Path, out: Path, log: Path) -> dict[str, Any]:
    """``jackson map --from RUN --out OUT`` (its output into ``log`` and this terminal's stderr);
    the report's figures."""
    with log.open("w") as f:
        done = subprocess.run(
            [JACKSON, "map", "--from", str(run), "--out", str(out)],
            stdout=f,
            stderr=subprocess.STDOUT,
            text=True,
        )
    if done.returncode != 0:
        raise TeleopError(f"jackson map --from {run} failed ({done.returncode}): {tail(log)}")
    figures: dict[str, Any] = json.loads((out / "map_quality.json").read_text())
    return figures


# ------------------------------------------------------------------------------- the CLI


def _via(text: str) -> tuple[float, float]:
    x, y = (float(v) for v in pose_text(text).split(",")[:2])
    return x, y


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m jackson.experiments.teleop_twin",
        description="a teleop drive of the twin recorded by the daemon, then mapped from its "
        "recording (jackson map --from); or attach a twin's truth to a run folder",
    )
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("drive", help="drive the twin by /cmd_vel, record, map the recording")
    d.add_argument("--world", required=True, help="the twin's world (name or YAML path)")
    d.add_argument("--robot", default="jackson_physical", help="the twin's robot")
    d.add_argument("--out", type=Path, required=True, help="a new folder for everything")
    d.add_argument(
        "--speed",
        type=float_upto(SPEED_RANGE_M_S[1], SPEED_RANGE_M_S[0]),
        default=0.2,
        help="forward speed [m/s] (default 0.2)",
    )
    d.add_argument("--seed", type=nonneg_int, default=0, help="the twin's noise seed")
    d.add_argument(
        "--via",
        action="append",
        type=_via,
        metavar="X,Y",
        help="the route's waypoints after the start, repeatable (default: the survey of "
        "jackson map --world: the world's survey waypoints, then back to the start)",
    )
    d.add_argument("--ros-domain", type=int_in(0, 232), help="ROS_DOMAIN_ID (default: inherited)")
    d.add_argument("--no-map", action="store_true", help="record only; do not map")
    a = sub.add_parser("attach", help="make a daemon's run folder on the twin a judged twin run")
    a.add_argument("run", type=Path, help="the run folder (jackson daemon --run-dir)")
    a.add_argument("--truth", type=Path, required=True, help="the file jackson sim --truth wrote")
    a.add_argument("--world", help="the world (default: the one the truth file names)")
    a.add_argument("--robot", help="the robot (default: the one the truth file names)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        if args.command == "attach":
            r = attach_truth(args.run, args.truth, args.world, args.robot)
            print(
                f"attached: {r.run / TRUTH_NAME} ({r.truth_rows} rows); meta.json names world "
                f"{r.world}, robot {r.robot}, start ({r.start[0]:.3f}, {r.start[1]:.3f}, "
                f"{r.start[2]:.3f})"
            )
            return 0
        out: Path = args.out
        try:
            output_folder(out)
        except ValueError as exc:
            raise TeleopError(str(exc)) from exc
        result = drive(
            args.world, out, args.robot, args.speed, args.seed, args.via, args.ros_domain
        )
        twin = attach_truth(out / "run", out / "truth.csv", args.world, args.robot)
        report: dict[str, Any] = {
            "world": args.world,
            "robot": args.robot,
            "seed": args.seed,
            "speed_m_s": args.speed,
            "start": list(twin.start),
            "drive": asdict(result),
        }
        print(
            f"teleop: drove {result.driven_m:.1f} m in {result.robot_s:.0f} s of robot time "
            f"({result.wall_s:.0f} s of wall time), {result.commands} /cmd_vel, "
            f"{result.collisions} collisions, closest to a wall {result.closest_wall_m:.2f} m"
        )
        if not args.no_map:
            report["map"] = map_run(out / "run", out / "map", out / "map.log")
            print((out / "map.log").read_text().rstrip())
        (out / "teleop.json").write_text(json.dumps(report, indent=2) + "\n")
        return 0
    except JacksonError as exc:
        print(f"teleop_twin: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
