"""The lockstep loop over the pty against the work it carries (run by ``jackson bench``).

Starts ``jackson sim --no-lidar`` (the twin and its MCU, the firmware core, in their own
process, lockstep, 200 Hz physics) and drives it with the host daemon itself
(:class:`jackson.host.daemon.Daemon`) with constant wheel duties as its command source: per
telemetry frame the whole host pipeline (odometry, EKF, listeners), one PCA9685 block write
over the I2C socket and one HEARTBEAT, as when a user runs ``jackson daemon`` against the twin.
In the same run each end's own work is timed: the daemon thread's CPU time and the twin
process's (it prints it on exit), each less the time it spent polling for the other end
(jackson.common.spin); and, interleaved, the twin alone (:mod:`jackson.sim.bench`'s
figure-eight, no LiDAR, no MCU) runs for the same simulated time in this process. Five rounds
(a round takes about 3 s); the lockstep's wall time is cut into slices of 50 frames and each
slice's best time over the rounds is kept (a preemption spoils one slice of one round, as for
the other suites); the work and the twin alone are the best of the rounds. Figures:

- the twin alone's real-time factor over the lockstep's: how much slower the twin runs with the
  real host on its pty than alone (same physics rate, no LiDAR); target 20x, the ratio a square
  at 100x real time inside ``jackson run`` needs on a machine where the twin alone runs at
  2000x;
- the lockstep's wall time per frame over the work both ends do per frame, for information (the
  two ends take turns, so it is about 1 by construction);
- the twin process's work per frame over the twin alone's, for information: what the
  firmware core, the I2C server and the lockstep loop add to the physics and the sensors.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from jackson.common.bench import BenchResult, reference_loop_us
from jackson.common.spin import contention
from jackson.host.actuation.i2c import open_bus
from jackson.host.actuation.output import MotorOutput, Pca9685Output
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import DEFAULT_CONFIG, load_config
from jackson.host.core.results import CoreListener, FrameResult
from jackson.host.daemon import Daemon, with_port
from jackson.host.transport import SerialTransport
from jackson.protocol import Message

WARMUP_FRAMES = 20
DUTIES = (0.4, 0.45)


class ConstantDuties:
    """A :class:`jackson.host.core.DutySource`: the same duties for ``frames`` frames."""

    def __init__(self, frames: int, left: float, right: float) -> None:
        self.frames = frames
        self.duties = (left, right)
        self.taken = 0
        self.done = False

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        self.taken += 1
        self.done = self.taken >= self.frames
        return self.duties


class _Clock(CoreListener):
    """Wall time, MCU time and the daemon thread's CPU time (less its spinning waits) at each
    frame from the end of the warm-up on. Called on the daemon's thread."""

    def __init__(self) -> None:
        self.frames = 0
        self.first: tuple[float, float, float] | None = None  # (wall s, MCU s, work CPU s)
        self.last: tuple[float, float, float] | None = None
        self.wall_s: list[float] = []  # of the warm-up's last frame and of each timed frame

    def on_result(self, result: FrameResult) -> None:
        self.frames += 1
        if self.frames < WARMUP_FRAMES:
            return
        now = time.perf_counter()
        self.wall_s.append(now)
        mark = (now, result.t_s, time.thread_time() - contention.spun_s)
        if self.frames == WARMUP_FRAMES:
            self.first = mark
        else:
            self.last = mark


def lockstep_round(frames: int) -> _Round:
    """The daemon against a fresh twin for ``frames`` timed frames after a warm-up.

    Parameters
    ----------
    frames : int
        Frames timed after the warm-up.

    Returns
    -------
    _Round
        The lockstep's real-time factor; the host's own work per frame: the CPU time of the
        daemon's thread (reading and decoding the port, :meth:`HostCore.on_frame`, the
        PCA9685 write, the HEARTBEAT) less the time it spent polling in a wait
        (jackson.common.spin); the twin's own work per frame: its process's CPU time (the
        physics, the sensors, the firmware core, the I2C server) less its polling, as it prints
        on exit; and the wall time of each slice of :data:`SLICE_FRAMES` timed frames.
    """
    exe = Path(sys.executable).parent / "jackson"
    proc = subprocess.Popen([str(exe), "sim", "--no-lidar"], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    serial_path = proc.stdout.readline().split(": ", 1)[1].strip()
    i2c = proc.stdout.readline().split(": ", 1)[1].strip()
    cfg = with_port(load_config(DEFAULT_CONFIG), serial_path)
    cfg = dataclasses.replace(cfg, pca9685=dataclasses.replace(cfg.pca9685, bus=i2c))
    p = cfg.pca9685
    bus = open_bus(p.bus)
    pca = Pca9685(bus, p.address)
    transport = SerialTransport(cfg.serial.port, cfg.serial.baudrate)
    clock = _Clock()
    try:
        pca.init(p.frequency_hz)
        transport.open(reader_thread=False)

        def output(send: Callable[[Message], object]) -> MotorOutput:
            return Pca9685Output(pca, p.left, p.right, p.stby_channel)

        daemon = Daemon(
            cfg, output, transport, duty_source=ConstantDuties(WARMUP_FRAMES + frames, *DUTIES)
        )
        daemon.core.listeners.append(clock)
        daemon.run(max_s=120.0)
    finally:
        transport.close()
        bus.close()
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=20)
    if clock.first is None or clock.last is None:
        raise RuntimeError(f"lockstep bench: the twin sent {clock.frames} frames")
    summary = _TWIN_SUMMARY.search(out)
    if summary is None:
        raise RuntimeError(f"lockstep bench: no summary line from the twin in {out!r}")
    twin_frames, twin_cpu, twin_spun = int(summary[1]), float(summary[2]), float(summary[3])
    timed = clock.frames - WARMUP_FRAMES
    marks = clock.wall_s[::SLICE_FRAMES]
    return _Round(
        (clock.last[1] - clock.first[1]) / (clock.last[0] - clock.first[0]),
        (clock.last[2] - clock.first[2]) / max(1, timed),
        (twin_cpu - twin_spun) / max(1, twin_frames),
        [b - a for a, b in itertools.pairwise(marks)],
    )


# the twin's last line: "twin: ... s simulated in ..., N telemetry frames, ..., CPU X s (Y s of
# it polling for the host)"
_TWIN_SUMMARY = re.compile(
    r"(\d+) telemetry frames, .*CPU ([0-9.]+) s \(([0-9.]+) s of it polling for the host\)"
)


@dataclasses.dataclass(frozen=True)
class _Round:
    """One lockstep run's figures."""

    rtf: float  # MCU seconds per wall second over the timed frames
    host_s: float  # the daemon thread's CPU per timed frame, less its spinning [s]
    twin_s: float  # the twin process's CPU per frame since the HELLO, less its spinning [s]
    slices_s: list[float]  # wall time of each run of SLICE_FRAMES timed frames, in order [s]


RUNS = 5
SLICE_FRAMES = 50
# the lockstep at most 20x slower than the twin alone: with the twin alone at 2000-3300x real
# time on a 2-core machine, the square's 100x inside jackson run
LOCKSTEP_OVER_TWIN_TARGET = 20.0
TELEMETRY_HZ = 20


@dataclasses.dataclass(frozen=True)
class Timed:
    """The best of :data:`RUNS` interleaved rounds of the lockstep and the twin alone.

    Attributes
    ----------
    slices_s : list of float
        Each 50-frame slice's best time over the rounds [s].
    host_s, twin_s : float
        The daemon thread's and the twin process's best CPU time per frame [s].
    twin_rtf : float
        The twin alone's best real-time factor on the same simulated time.
    loop_us : float
        The machine's reference loop, best between the rounds [us].
    """

    slices_s: list[float]
    host_s: float
    twin_s: float
    twin_rtf: float
    loop_us: float


def measure(frames: int) -> Timed:
    """The lockstep over ``frames`` telemetry frames and the twin alone, round by round."""
    from jackson.sim.bench import real_time_factor

    sim_s = frames / TELEMETRY_HZ
    # interleaved rounds: the lockstep's figure is the sum over its 50-frame slices of each
    # slice's best time over the rounds (a preemption spoils one slice of one round, as in
    # jackson.common.bench.interleaved_slices); the twin alone and the host's CPU time are the
    # best of the rounds
    slices: list[float] | None = None
    twin, host_s, twin_s, loop_us = 0.0, float("inf"), float("inf"), float("inf")
    for _ in range(RUNS):
        r = lockstep_round(frames)
        host_s, twin_s = min(host_s, r.host_s), min(twin_s, r.twin_s)
        if slices is None:
            slices = r.slices_s
        slices = [min(a, b) for a, b in zip(slices, r.slices_s, strict=False)]
        twin = max(twin, real_time_factor(False, sim_s))
        loop_us = min(loop_us, reference_loop_us(3))
    if not slices:
        raise RuntimeError("lockstep bench: no whole slice of frames was timed")
    return Timed(slices, host_s, twin_s, twin, loop_us)


def run(quick: bool = False) -> list[BenchResult]:
    """The lockstep figures for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        400 frames per run instead of 2000.

    Returns
    -------
    list[BenchResult]
        The lockstep's speed over the twin alone's (target 20x), and for information its
        time per frame over the work both ends do and the twin process's work over the twin
        alone's.
    """
    m = measure(400 if quick else 2000)
    slices, host_s, twin_s, twin, loop_us = m.slices_s, m.host_s, m.twin_s, m.twin_rtf, m.loop_us
    period_s = 1.0 / TELEMETRY_HZ
    lock_us = 1e6 * math.fsum(slices) / (SLICE_FRAMES * len(slices))
    lockstep = 1e6 * period_s / lock_us
    work_us = 1e6 * (twin_s + host_s)
    twin_us = 1e6 * period_s / twin
    return [
        BenchResult(
            "sim.lockstep_over_twin_and_host_no_lidar",
            lock_us / work_us,
            "x the work's time",
            None,
            "lower",
            "the work both ends do per frame in the same lockstep: the twin process's CPU "
            "time (physics, sensors, the firmware core, I2C server) plus the daemon thread's, each "
            "less its polling waits (for information: the two ends take turns, so this is "
            "about 1 by construction)",
            lock_us,
            "us per frame",
            work_us,
            loop_us,
        ),
        BenchResult(
            "sim.lockstep_twin_process_over_twin_alone_no_lidar",
            1e6 * twin_s / twin_us,
            "x the twin alone's time",
            None,
            "lower",
            "the twin alone on the figure-eight per frame, same run (for information: what "
            "the firmware core, the I2C server and the lockstep loop add to the physics and "
            "sensors in the twin process)",
            1e6 * twin_s,
            "us per frame",
            twin_us,
            loop_us,
        ),
        BenchResult(
            "sim.lockstep_over_twin_pty_no_lidar",
            twin / lockstep,
            "x the twin alone's time",
            LOCKSTEP_OVER_TWIN_TARGET,
            "lower",
            "the twin alone (no LiDAR, 200 Hz physics, the figure-eight) for the same "
            "simulated time, same run: how much slower the twin runs with the real host "
            "daemon on its pty (the firmware core, the I2C server, the pty, the whole host)",
            lockstep,
            "x real time",
            twin,
            loop_us,
        ),
    ]
