"""The fault matrix: each fault the robot meets in service, injected into the twin while the real
host daemon drives the Stage 1 square, and what became of the motors, the host and the data.

Each row starts a lockstep twin (:class:`~jackson.sim.runner.TwinRunner`, in a thread of this
process, its serial port behind a fixed symlink so a replugged port comes back at the same path)
and ``jackson daemon --mission square`` as its own process, as on the robot. At ``FAULT_AT_S`` of
MCU time, with the robot driving its first side, the fault is injected:

- host **SIGKILL**, **SIGSTOP** (for ``STOP_WALL_S`` of wall time, then SIGCONT) and **crash**
  (SIGSEGV), with the PCA9685 or the MCU driving the motors;
- the twin's **I2C server restarted** (its socket closed and served anew at the same path);
- a **foreign MODE1 write** (another I2C client puts the PCA9685 to sleep);
- the serial port **unplugged and replugged** (the pty removed for ``UNPLUG_WALL_S``);
- an **MCU reset** (the firmware core boots again: new boot_id, counts from 0, no session);
- the **IMU dying** (no IMU_OK from then on: the health monitor excludes it and the square goes
  on with the wheels' yaw rate, ``health.imu_lost: continue``);
- **5 % of telemetry frames lost** on the line, and **5 % of frames with a corrupted byte**;
- navigating the maze by the LiDAR instead of driving the square: the host **SIGSTOP**ped (the
  LiDAR's bytes then wait with the frames: its silence is the daemon's), and **garbage bytes
  instead of revolutions** on the LiDAR's line (every revolution's bytes replaced by as many
  random ones).

What each row reports, from the twin's side (ground truth, on MCU time) and the host's:

- *braked*: the motors received no drive (the H-bridges' average drive is 0) at some instant
  after the fault, with the delay from the fault and the distance the robot travelled after it;
- *host*: alive or not at the end, its exit status, and whether frames flowed again after the
  fault (reconnected);
- *data*: the run folder's CSV rows and whether its files agree (consistent): the CSVs end at
  the same frame, and the bag's last message (flushed with them, on MCU time) within a second
  and a frame of it;
- *told*: what the daemon said to the operator (its ``daemon:`` lines, health.json problems).

A row passes when the motors stopped driving within ``failsafe + one period`` of the fault
wherever the host could not command them (a dead, stopped or blind host, a broken motor path),
the daemon survived every fault but its own death, the data on disk is consistent, and the
operator was told the right cause (a row's ``cause``, and none of its ``blame``).
"""

from __future__ import annotations

import itertools
import json
import math
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from jackson.sim.runner import TwinRunner
    from jackson.sim.twin import Twin

FAULT_AT_S = 6.0  # [s] MCU time: the robot drives the square's first side
WINDOW_S = 4.0  # [s] MCU time watched after the fault
FAILSAFE_S = 0.2  # [s] the MCU's heartbeat failsafe and interlock (the host's failsafe_ms)
PERIOD_S = 0.05  # [s] one telemetry period at 20 Hz
FLUSH_S = 1.0  # [s] MCU time between the run folder's joint flushes (recording.FLUSH_PERIOD_S)
STOP_WALL_S = 2.5  # [s] SIGSTOP lasts this long (the twin waits 1 s before it runs on alone)
UNPLUG_WALL_S = 0.3  # [s] the port is gone this long at each unplug
ACTUATION_LATENCY_S = 0.05  # [s] the twin robot's command-to-motor latency (robots/jackson.yaml)
BRAKE_LIMIT_S = FAILSAFE_S + PERIOD_S + ACTUATION_LATENCY_S  # must-brake rows stop within this
HOLD_S = 0.3  # [s] a stop counts when no drive lasts this long
LOSS_P = 0.05  # probability of a lost / corrupted telemetry frame
JACKSON = str(Path(sys.executable).parent / "jackson")
STALL_TOLD = "daemon: daemon stalled "  # the daemon's line for its own stall
LIDAR_TOLD = "health: lidar "  # any verdict on the LiDAR (blame, when the daemon stalled)
FOREIGN_TOLD = "PCA9685 registers rewritten by someone else"  # and the mission aborted
NAV_WORLD = "maze"  # the LiDAR rows navigate this world from its start to its goal


@dataclass(frozen=True)
class Fault:
    """One row of the matrix."""

    name: str
    actuator: str = "pca9685"  # "pca9685" (the host drives) or "mcu" (MOTOR_PWM)
    repeat: int = 1
    must_brake: bool = False  # the host cannot command the motors: they must stop
    lidar: bool = False  # navigate the maze by the twin's LiDAR instead of driving the square
    cause: str = ""  # the daemon's lines must name this (the right cause)
    blame: str = ""  # ... and none of them this (a wrong cause)


@dataclass
class FaultRow:
    """What happened in one row."""

    fault: str
    actuator: str
    repeat: int
    braked: bool
    brake_delay_s: float | None  # MCU time from the fault to the first instant without drive
    distance_after_m: float  # ground truth travelled in the window after the fault
    host_alive: bool
    exit_status: int | None
    reconnected: bool  # frames reached the host again after the fault
    rows: dict[str, int] = field(default_factory=dict)
    consistent: bool = False
    told: list[str] = field(default_factory=list)
    passed: bool = False
    note: str = ""
    trace: list[tuple[float, float]] = field(default_factory=list)  # (s from the fault, m/s)


def matrix(short: bool) -> list[Fault]:
    """The rows: every fault once (``short``: the repeated ones fewer times)."""
    n_i2c, n_unplug = (2, 3) if short else (10, 100)
    return [
        Fault("host SIGKILL", "pca9685", must_brake=True),
        Fault("host SIGKILL", "mcu", must_brake=True),
        Fault("host SIGSTOP", "pca9685", must_brake=True, cause=STALL_TOLD),
        Fault("host SIGSTOP", "mcu", must_brake=True, cause=STALL_TOLD),
        Fault(
            "host SIGSTOP navigating",
            "pca9685",
            must_brake=True,
            lidar=True,
            cause=STALL_TOLD,
            blame=LIDAR_TOLD,
        ),
        Fault("host crash (SIGSEGV)", "pca9685", must_brake=True),
        Fault("host crash (SIGSEGV)", "mcu", must_brake=True),
        Fault("I2C server restart", "pca9685", repeat=n_i2c),
        Fault("foreign MODE1 write", "pca9685", cause=FOREIGN_TOLD),
        Fault("serial unplug/replug", "pca9685", repeat=n_unplug),
        Fault("MCU reset", "pca9685", must_brake=True),
        Fault("IMU death", "pca9685"),  # excluded: the square goes on, wheel-only yaw
        Fault("5 % frames lost", "pca9685"),
        Fault("5 % frames corrupted", "pca9685"),
        Fault("mute device", "mcu"),  # a port with no firmware behind it: nothing to drive
        Fault(
            "LiDAR garbage bytes",
            "pca9685",
            must_brake=True,  # held at once, then the LiDAR excluded: the navigation aborts
            lidar=True,
            cause="garbage on the line",
            blame="no scan for",
        ),
    ]


class _Watch:
    """Runs in the twin's thread after every advance: samples the motors, fires injections."""

    def __init__(self) -> None:
        self.samples: list[tuple[float, bool, float, float]] = []  # t, driving, x, y
        self.actions: list[tuple[float, Callable[[], None]]] = []  # (MCU time, action)
        self.lock = threading.Lock()
        self.fault_s: float | None = None
        self.pace_from: tuple[float, float] | None = None  # (wall, MCU) to pace from

    def at(self, t_s: float, action: Callable[[], None]) -> None:
        with self.lock:
            self.actions.append((t_s, action))
            self.actions.sort(key=lambda a: a[0])

    def __call__(self, twin: Any) -> None:
        left, right = twin._drive
        r = twin.robot
        self.samples.append((twin.t_s, left.drive != 0.0 or right.drive != 0.0, r.x, r.y))
        with self.lock:
            due = [a for a in self.actions if a[0] <= twin.t_s]
            self.actions = [a for a in self.actions if a[0] > twin.t_s]
        for _, action in due:
            action()
        if self.pace_from is not None:  # nobody paces a twin without a session: do it here
            wall0, sim0 = self.pace_from
            ahead = (twin.t_s - sim0) - (time.monotonic() - wall0)
            if ahead > 0:
                threading.Event().wait(ahead)

    def now(self) -> float:
        return self.samples[-1][0] if self.samples else 0.0


def _wait(cond: Callable[[], bool], timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    ev = threading.Event()
    while not cond():
        if time.monotonic() > deadline:
            return False
        ev.wait(0.01)
    return True


def _config(folder: Path, actuator: str) -> Path:
    from jackson.host.config import DEFAULT_CONFIG

    text = Path(DEFAULT_CONFIG).read_text()
    if actuator == "mcu":
        lines = ["actuator: mcu" if ln.startswith("actuator:") else ln for ln in text.splitlines()]
        text = "\n".join(lines) + "\n"
    path = folder / f"host-{actuator}.yaml"
    path.write_text(text)
    return path


def _daemon_argv(folder: Path, fault: Fault, port: str, run_dir: Path, *more: str) -> list[str]:
    """``jackson daemon`` driving the square on ``port`` with the row's actuator; a LiDAR row
    navigates :data:`NAV_WORLD` instead, from its start to its goal on the world's own map, by
    the twin's LiDAR at ``folder/lidar``."""
    config = str(_config(folder, fault.actuator))
    mission = ["--mission", "square"]
    if fault.lidar:
        from jackson.experiments.stage3 import world_goals, world_grid
        from jackson.sim.config import load_world

        world = load_world(NAV_WORLD)
        world_grid(world).save(folder / "map.yaml")
        goal = world_goals(world)[0]
        x, y, yaw = world.start_pose
        mission = [
            *("--lidar", str(folder / "lidar"), "--map", str(folder / "map.yaml")),
            *("--start", f"{x},{y},{yaw}", "--goal", f"{goal.x},{goal.y}"),
        ]
    run = ["--run-dir", str(run_dir)]
    return [JACKSON, "daemon", "--config", config, "--port", port, *mission, *run, *more]


MUTE_WALL_S = 5.0  # [s] the daemon runs this long against a mute device
MUTE_TOLD_S = 2.0  # [s] from its first HELLO: the operator is told by then


def _mute_row(fault: Fault, folder: Path) -> FaultRow:
    """A port with no firmware behind it (a pty that never answers): the daemon must say so in
    one line within :data:`MUTE_TOLD_S` of its first HELLO, and keep asking (visible retries).
    The row's ``brake_delay_s`` is that delay, on the wall clock."""
    import tty

    from jackson.protocol import FrameDecoder, Hello

    master, slave = os.openpty()
    tty.setraw(slave)
    run_dir = folder / "run"
    proc = subprocess.Popen(
        _daemon_argv(folder, fault, os.ttyname(slave), run_dir, "--max-seconds", str(MUTE_WALL_S)),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines: list[tuple[float, str]] = []

    def read_lines() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append((time.monotonic(), line.rstrip("\n")))

    reader = threading.Thread(target=read_lines, daemon=True)
    reader.start()
    hellos: list[float] = []
    decoder = FrameDecoder()
    os.set_blocking(master, False)
    try:
        while proc.poll() is None:
            try:
                data = os.read(master, 4096)
            except BlockingIOError:
                data = b""
            now = time.monotonic()
            hellos += [now for f in decoder.feed(data) if f.type == Hello.TYPE]
            threading.Event().wait(0.01)  # polls the pty and the process until it ends
        reader.join(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        os.close(master)
        os.close(slave)
    told_at = next((t for t, line in lines if "no answer on" in line), None)
    delay = None if told_at is None or not hellos else told_at - hellos[0]
    told = [line.removeprefix("daemon: ") for _, line in lines if line.startswith("daemon:")]
    row = FaultRow(
        fault=fault.name,
        actuator=fault.actuator,
        repeat=fault.repeat,
        braked=True,  # nothing was ever driven
        brake_delay_s=None if delay is None else round(delay, 3),
        distance_after_m=0.0,
        host_alive=False,
        exit_status=proc.returncode,
        reconnected=False,
        rows={"hellos": len(hellos)},
        consistent=True,
        told=told,
    )
    row.passed = bool(delay is not None and delay <= MUTE_TOLD_S and len(hellos) >= 3)
    row.note = (
        ""
        if row.passed
        else (f"told after {delay} s" if delay is not None else "the operator was not told")
        + f", {len(hellos)} HELLOs"
    )
    return row


def run_row(fault: Fault, folder: Path, seed: int = 0) -> FaultRow:
    """Run one row in ``folder`` (twin thread + daemon process) and measure it."""
    if fault.name == "mute device":
        folder.mkdir(parents=True, exist_ok=True)
        return _mute_row(fault, folder)
    from jackson.sim.config import load_robot, load_world
    from jackson.sim.runner import TwinRunner
    from jackson.sim.twin import Twin

    folder.mkdir(parents=True, exist_ok=True)
    rng = random.Random(seed)
    watch = _Watch()
    world = load_world(NAV_WORLD if fault.lidar else "square_room")
    twin = Twin(world, load_robot("jackson"), lidar=fault.lidar, seed=seed)
    sock = folder / "i2c.sock"
    link = folder / "serial"
    runner = TwinRunner(
        twin,
        i2c_path=sock,
        mcu_motors=fault.actuator == "mcu",
        serial_link=str(link),
        observer=watch,
        lidar=fault.lidar,
        lidar_link=str(folder / "lidar") if fault.lidar else None,
    )
    stop = threading.Event()
    thread = threading.Thread(target=runner.run, args=(None, stop), daemon=True)
    thread.start()
    run_dir = folder / "run"
    proc = subprocess.Popen(
        _daemon_argv(folder, fault, str(link), run_dir, "--i2c", f"unix:{sock}"),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    mcu = runner.mcu
    assert mcu is not None
    frames_at_fault = [0]
    killed = False

    def mark() -> None:
        watch.fault_s = watch.now()
        frames_at_fault[0] = mcu.heartbeats

    watch.at(FAULT_AT_S, mark)
    end_s, main_thread_action = _schedule(fault, watch, runner, twin, sock, rng)
    name = fault.name
    output = ""
    try:
        if not _wait(lambda: watch.fault_s is not None or proc.poll() is not None, 120):
            raise RuntimeError(f"{name}: the twin never reached {FAULT_AT_S} s of MCU time")
        if main_thread_action:
            watch.fault_s = watch.now()  # the fault is the signal, not the request for it
            killed = _host_fault(name, proc, sock, twin.robot_spec.wiring.pca9685_address)
        _wait(lambda: watch.now() >= end_s or (proc.poll() is not None and killed), 300)
        if killed:
            _wait(lambda: watch.now() >= end_s, 60)
    finally:
        alive = proc.poll() is None
        if alive:
            proc.send_signal(signal.SIGTERM)
        try:
            output, _ = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            output, _ = proc.communicate()
        stop.set()
        thread.join(timeout=30)
        runner.close()
    return _measure(fault, watch, run_dir, alive, proc.returncode, output, frames_at_fault[0], mcu)


def _schedule(
    fault: Fault, watch: _Watch, runner: TwinRunner, twin: Twin, sock: Path, rng: random.Random
) -> tuple[float, list[str]]:
    """Schedule the row's fault on the twin's MCU clock, from :data:`FAULT_AT_S` on.

    Faults of the twin (its I2C server, serial port, MCU, IMU, line) run in the twin's thread
    when due; a fault of the host (a signal) or of another I2C client is put, when due, in the
    list returned, for the main thread to inject.

    Returns
    -------
    tuple
        The MCU time the row watches until [s], and that list.
    """
    from jackson.sim.i2c_server import I2cSocketServer
    from jackson.sim.mcu import SensorSample

    mcu = runner.mcu
    assert mcu is not None

    def restart_i2c() -> None:
        runner._sel.unregister(runner.i2c)
        runner.i2c.close()
        runner.i2c = I2cSocketServer(sock, {twin.robot_spec.wiring.pca9685_address: runner.pca})
        runner._sel.register(runner.i2c, 1, "i2c")  # selectors.EVENT_READ

    def reset_mcu() -> None:
        # the same MCU boots again: a new boot_id, no session, the PCNT counters back at 0
        mcu.reset(twin.t_us, (mcu.boot_id + 0x9E3779B9) & 0xFFFFFFFF or 1)
        runner._actuate()  # the line fell with the reset
        watch.pace_from = (time.monotonic(), twin.t_s)  # a rebooting MCU takes real time

    def kill_imu() -> None:
        real = mcu.sensors

        def dead() -> SensorSample:
            s = real()
            return SensorSample(s.enc_left, s.enc_right, False, s.accel, s.temp, s.gyro)

        mcu.sensors = dead

    def lose_frames() -> None:
        runner.drop_telemetry = lambda n: rng.random() < LOSS_P

    def lidar_garbage() -> None:
        # every revolution's bytes replaced by as many random ones, from now on
        lidar = runner.lidar
        assert lidar is not None

        def garbage(data: bytes) -> None:
            lidar.link.write(rng.randbytes(len(data)))

        lidar._write = garbage  # type: ignore[method-assign]

    def corrupt_frames() -> None:
        real = mcu.write

        def noisy(frame: bytes) -> bool:
            if rng.random() < LOSS_P:
                b = bytearray(frame)
                b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
                frame = bytes(b)
            return real(frame)

        mcu.write = noisy

    main_thread_action: list[str] = []
    name = fault.name
    end_s = FAULT_AT_S + WINDOW_S
    if name.startswith("host"):
        watch.at(FAULT_AT_S, lambda: main_thread_action.append(name))
    elif name == "foreign MODE1 write":
        # the daemon reads the chip back every second of wall time: the twin keeps real time
        watch.at(FAULT_AT_S, lambda: main_thread_action.append(name))
        watch.at(FAULT_AT_S, lambda: setattr(watch, "pace_from", (time.monotonic(), twin.t_s)))
    elif name == "I2C server restart":
        for k in range(fault.repeat):
            watch.at(FAULT_AT_S + k * 1.0, restart_i2c)
        end_s += fault.repeat
    elif name == "serial unplug/replug":
        for k in range(fault.repeat):
            watch.at(FAULT_AT_S + k * 1.0, lambda: runner.request_outage(UNPLUG_WALL_S))
        end_s += fault.repeat
    elif name == "MCU reset":
        watch.at(FAULT_AT_S, reset_mcu)
    elif name == "IMU death":
        watch.at(FAULT_AT_S, kill_imu)
    elif name == "LiDAR garbage bytes":
        watch.at(FAULT_AT_S, lidar_garbage)
    elif name == "5 % frames lost":
        watch.at(FAULT_AT_S, lose_frames)
        end_s += 20.0
    elif name == "5 % frames corrupted":
        watch.at(FAULT_AT_S, corrupt_frames)
        end_s += 20.0
    return end_s, main_thread_action


def _host_fault(name: str, proc: subprocess.Popen[str], sock: Path, pca9685_address: int) -> bool:
    """Inject a fault of the host from the main thread: a signal to the daemon, or another I2C
    client putting the PCA9685 to sleep. True when it killed the daemon."""
    if name == "host SIGKILL":
        proc.send_signal(signal.SIGKILL)
        return True
    if name.startswith("host crash"):
        proc.send_signal(signal.SIGSEGV)
        return True
    if name.startswith("host SIGSTOP"):
        proc.send_signal(signal.SIGSTOP)
        threading.Event().wait(STOP_WALL_S)
        proc.send_signal(signal.SIGCONT)
    elif name == "foreign MODE1 write":
        from jackson.host.actuation.i2c import SocketI2cBus

        with SocketI2cBus(sock) as bus:
            bus.write_byte_data(pca9685_address, 0x00, 0x11)
    return False


def _measure(
    fault: Fault,
    watch: _Watch,
    run_dir: Path,
    alive: bool,
    status: int | None,
    output: str,
    heartbeats_at_fault: int,
    mcu: Any,
) -> FaultRow:
    t_f = watch.fault_s if watch.fault_s is not None else FAULT_AT_S
    after = [s for s in watch.samples if s[0] >= t_f]
    delay = _brake_delay(after, t_f)
    window = [s for s in after if s[0] <= t_f + WINDOW_S]
    dist = sum(math.hypot(b[2] - a[2], b[3] - a[3]) for a, b in itertools.pairwise(window))
    rows, consistent = _run_folder(run_dir)
    told = [
        ln.strip() for ln in output.splitlines() if ln.startswith(("daemon:", "mission", "jackson"))
    ]
    told = [t for t in told if not t.startswith("daemon: /")]
    named = not fault.cause or any(fault.cause in t for t in told)
    blamed = [t for t in told if fault.blame and fault.blame in t]
    # the right cause first: it, and what was said wrongly, lead the lines kept
    told = [t for t in told if fault.cause and fault.cause in t] + blamed + told
    told = list(dict.fromkeys(told))[:12]
    health = run_dir / "health.json"
    if health.exists():
        try:
            told += [f"health: {p}" for p in json.loads(health.read_text()).get("problems", [])]
        except ValueError:
            told.append("health.json unreadable")
    killed = fault.name.startswith(("host SIGKILL", "host crash"))
    braked = delay is not None
    brake_ok = not fault.must_brake or (braked and delay is not None and delay <= BRAKE_LIMIT_S)
    host_ok = killed or (alive or status in (0, 1))
    row = FaultRow(
        fault=fault.name,
        actuator=fault.actuator,
        repeat=fault.repeat,
        braked=braked,
        brake_delay_s=None if delay is None else round(delay, 3),
        distance_after_m=round(dist, 3),
        host_alive=alive,
        exit_status=status,
        reconnected=mcu.heartbeats > heartbeats_at_fault + 1,
        rows=rows,
        consistent=consistent,
        told=told,
    )
    row.trace = _speed_trace(watch.samples, t_f)
    row.passed = bool(brake_ok and host_ok and consistent and named and not blamed)
    notes = []
    if not named:
        notes.append(f"the cause ({fault.cause!r}) not told")
    if blamed:
        notes.append(f"blamed: {blamed[0]}")
    if not brake_ok:
        notes.append("motors not stopped in time")
    if not host_ok:
        notes.append("the daemon died")
    if not consistent:
        notes.append("run folder inconsistent")
    row.note = "; ".join(notes)
    return row


def _speed_trace(
    samples: list[tuple[float, bool, float, float]], t_f: float
) -> list[tuple[float, float]]:
    """Ground-truth speed from 1 s before the fault to 3 s after it, every 20 ms or so."""
    out: list[tuple[float, float]] = []
    span = [x for x in samples if t_f - 1.0 <= x[0] <= t_f + 3.0]
    for a, b in itertools.pairwise(span):
        if b[0] > a[0] and (not out or b[0] - t_f - out[-1][0] >= 0.02):
            speed = math.hypot(b[2] - a[2], b[3] - a[3]) / (b[0] - a[0])
            out.append((round(b[0] - t_f, 4), round(speed, 4)))
    return out


def plot_brakes(rows: list[FaultRow], path: Path) -> None:
    """Ground-truth speed around each fault the motors must be stopped for, with the limit."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    must = {f.name for f in matrix(short=True) if f.must_brake}
    shown = [r for r in rows if r.trace and r.fault in must]
    if not shown:
        return
    cols = 2 if len(shown) > 1 else 1
    nrows = (len(shown) + cols - 1) // cols
    fig, axes = plt.subplots(
        nrows, cols, figsize=(5 * cols, 2.2 * nrows + 0.6), dpi=150, sharex=True, squeeze=False
    )
    for ax, r in zip(axes.flat, shown, strict=False):
        t, v = zip(*r.trace, strict=True)
        ax.plot(t, [x * 100 for x in v], lw=1.4, color="C0")
        ax.axvline(0.0, color="k", lw=0.8)
        ax.axvline(FAILSAFE_S, color="r", ls="--", lw=1.0)
        ax.axvline(BRAKE_LIMIT_S, color="r", ls=":", lw=1.0)
        delay = "no brake" if r.brake_delay_s is None else f"stopped {r.brake_delay_s:.3f} s"
        ax.set_title(f"{r.fault} ({r.actuator}): {delay}", fontsize=8)
        ax.set_ylabel("speed [cm/s]", fontsize=7)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(shown) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("MCU time from the fault [s]", fontsize=7)
    fig.suptitle(
        f"Ground-truth speed around each fault that must stop the robot "
        f"(dashed: failsafe {FAILSAFE_S:.1f} s, dotted: limit {BRAKE_LIMIT_S:.2f} s)",
        fontsize=9,
    )
    fig.tight_layout()
    from jackson.common.figures import save_figure

    save_figure(fig, path)


def _brake_delay(after: list[tuple[float, bool, float, float]], t_f: float) -> float | None:
    """MCU time from the fault to the start of the first span without drive that lasts
    ``HOLD_S`` (or to the end of the record): a corner's momentary zero is not a brake."""
    start: float | None = None
    for t, driving, _, _ in after:
        if driving:
            start = None
        elif start is None:
            start = t
        elif t - start >= HOLD_S:
            return start - t_f
    return None if start is None else start - t_f


def _run_folder(run_dir: Path) -> tuple[dict[str, int], bool]:
    """Rows per CSV, and whether odometry and commands end at the same frame."""
    rows: dict[str, int] = {}
    last: dict[str, float] = {}
    for name in ("odometry.csv", "commands.csv", "ekf.csv"):
        path = run_dir / name
        try:
            lines = path.read_text().splitlines()
        except OSError:
            rows[name] = -1
            continue
        complete = [ln for ln in lines[1:] if ln.count(",") >= 5]
        rows[name] = len(complete)
        try:
            last[name] = float(complete[-1].split(",")[0]) if complete else 0.0
        except ValueError:
            last[name] = -1.0
    odo, cmd, ekf = (rows.get(n, -1) for n in ("odometry.csv", "commands.csv", "ekf.csv"))
    # one odometry and one command row per frame, EKF outputs at 30 Hz up to the same frame
    consistent = (
        odo >= 0
        and odo == cmd
        and (odo == 0 or last["odometry.csv"] == last["commands.csv"])
        and (
            ekf <= 0 or odo == 0 or abs(last["odometry.csv"] - last["ekf.csv"]) <= PERIOD_S + 1 / 30
        )
    )
    bag_s = _bag_end_s(run_dir)
    rows["bag_end_ms"] = -1 if bag_s is None else round(1e3 * bag_s)
    if bag_s is not None and odo > 0:
        consistent = consistent and abs(bag_s - last["odometry.csv"]) <= FLUSH_S + PERIOD_S
    return rows, consistent


def _bag_end_s(run_dir: Path) -> float | None:
    """MCU time [s] of the last message that reached the disk in the run's bag (None without
    one): what a killed daemon's bag holds, read as its repair reads it."""
    from mcap.records import Message as McapMessage

    from jackson.host.ros.bag import BagError, whole_records

    last: int | None = None
    for file in sorted((run_dir / "bag").glob("*.mcap")):
        try:
            for record in whole_records(file):
                if isinstance(record, McapMessage):
                    last = record.log_time if last is None else max(last, record.log_time)
        except BagError:
            continue
    return None if last is None else last / 1e9


def run_matrix(
    out: Path, short: bool = False, progress: Callable[[str], None] | None = None
) -> list[FaultRow]:
    """Every row of :func:`matrix`, one after the other; writes faults.json, report.md and a
    plot into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    rows: list[FaultRow] = []
    faults = matrix(short)
    for k, fault in enumerate(faults):
        if progress is not None:
            progress(f"[{k + 1}/{len(faults)}] {fault.name} ({fault.actuator})")
        slug = (
            f"{k:02d}-"
            + "".join(c if c.isalnum() else "-" for c in fault.name)
            + f"-{fault.actuator}"
        )
        with tempfile.TemporaryDirectory(prefix="jf-", dir=os.environ.get("TMPDIR")) as tmp:
            # the I2C socket path must stay short (108 bytes); the run folder is kept in out
            row = run_row(fault, Path(tmp), seed=k)
            kept = out / slug
            src = Path(tmp) / "run"
            if src.exists():
                import shutil

                shutil.copytree(src, kept, dirs_exist_ok=True)
        rows.append(row)
    (out / "faults.json").write_text(json.dumps([asdict(r) for r in rows], indent=2) + "\n")
    (out / "report.md").write_text(report_markdown(rows))
    plot_brakes(rows, out / "brakes.png")
    return rows


def report_markdown(rows: list[FaultRow]) -> str:
    head = (
        "| fault | actuator | n | braked | delay [s] | distance after [m] | host | exit | "
        "reconnected | rows odo/cmd/ekf | consistent | told | pass |\n"
        "|---|---|---:|---|---:|---:|---|---:|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        told = "; ".join(r.told[:4]).replace("|", "/") or "nothing"
        lines.append(
            f"| {r.fault} | {r.actuator} | {r.repeat} | {'yes' if r.braked else 'no'} | "
            f"{'' if r.brake_delay_s is None else f'{r.brake_delay_s:.3f}'} | "
            f"{r.distance_after_m:.3f} | {'alive' if r.host_alive else 'gone'} | "
            f"{r.exit_status} | {'yes' if r.reconnected else 'no'} | "
            f"{r.rows.get('odometry.csv')}/{r.rows.get('commands.csv')}/{r.rows.get('ekf.csv')} | "
            f"{'yes' if r.consistent else 'no'} | {told} | {'✔' if r.passed else '✘ ' + r.note} |"
        )
    passed = sum(r.passed for r in rows)
    return (
        "# Fault matrix\n\n"
        f"{passed} of {len(rows)} rows pass. Fault at {FAULT_AT_S} s of MCU time; delays and "
        f"distances on MCU time from the fault; must-brake rows pass within "
        f"{BRAKE_LIMIT_S:.2f} s (failsafe, one frame, the motors' latency).\n\n"
        + head
        + "\n".join(lines)
        + "\n"
    )
