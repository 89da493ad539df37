"""The lockstep loop over the pty against the work it carries (run by ``jackson bench``).

Starts ``jackson sim --no-lidar`` (the twin and its MCU emulator in their own process, lockstep,
200 Hz physics) and drives it with the host daemon itself (:class:`jackson.host.daemon.Daemon`)
with constant wheel duties as its command source: per telemetry frame the whole host pipeline
(odometry, EKF, listeners), one PCA9685 block write over the I2C socket and one HEARTBEAT, as
when a user runs ``jackson daemon`` against the twin. In the same run the host's own work is
timed (the CPU time of ``HostCore.on_frame`` on the daemon's thread) and, interleaved, the twin
alone (:mod:`jackson.sim.bench`'s figure-eight, no LiDAR) runs for the same simulated time in
this process. Figures, best of 5 rounds each (a round takes about 3 s):

- the lockstep's wall time per frame over the twin alone's plus the host's work: what the
  coupling (the pty, the I2C socket, the second process, the daemon's reader thread) adds to
  the work it carries; target 2x;
- the twin alone's real-time factor over the lockstep's, for information (its reference is the
  twin alone, which gets faster on its own: the figure would worsen when the twin improves).
"""

from __future__ import annotations

import dataclasses
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from jackson.common.bench import BenchResult, reference_loop_us
from jackson.host.actuation.output import MotorOutput, Pca9685Output
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import DEFAULT_CONFIG, load_config
from jackson.host.core import CoreListener, FrameResult, HostCore
from jackson.host.daemon import Daemon, with_port
from jackson.host.i2c import open_bus
from jackson.host.transport import SerialTransport
from jackson.protocol import Frame, Message

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
    """Wall and MCU time of each frame after the warm-up."""

    def __init__(self) -> None:
        self.frames = 0
        self.first: tuple[float, float] | None = None  # (wall s, MCU s)
        self.last: tuple[float, float] | None = None

    def on_result(self, core: HostCore, result: FrameResult) -> None:
        self.frames += 1
        if self.frames == WARMUP_FRAMES:
            self.first = (time.perf_counter(), result.t_s)
        elif self.frames > WARMUP_FRAMES:
            self.last = (time.perf_counter(), result.t_s)


class _HostWork:
    """The CPU time the daemon's thread spends in :meth:`HostCore.on_frame` (the host's work)."""

    def __init__(self, core: HostCore, clock: _Clock) -> None:
        self.cpu_s = 0.0
        inner = core.on_frame

        def on_frame(frame: Frame, host_time_ns: int = 0) -> None:
            t0 = time.thread_time()
            inner(frame, host_time_ns)
            if clock.first is not None:  # after the warm-up
                self.cpu_s += time.thread_time() - t0

        core.on_frame = on_frame  # type: ignore[method-assign]


def lockstep_rtf(frames: int) -> tuple[float, float]:
    """MCU seconds per wall second over ``frames`` frames of the daemon against a fresh twin.

    Parameters
    ----------
    frames : int
        Frames timed after the warm-up.

    Returns
    -------
    rtf : float
        The lockstep's real-time factor.
    host_cpu_s : float
        The host's own work per frame: the CPU time of :meth:`HostCore.on_frame` on the
        daemon's thread, averaged over the timed frames [s].
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
        work = _HostWork(daemon.core, clock)
        daemon.run(max_s=120.0)
    finally:
        transport.close()
        bus.close()
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=20)
    if clock.first is None or clock.last is None:
        raise RuntimeError(f"lockstep bench: the twin sent {clock.frames} frames")
    timed = clock.frames - WARMUP_FRAMES
    rtf = (clock.last[1] - clock.first[1]) / (clock.last[0] - clock.first[0])
    return rtf, work.cpu_s / max(1, timed)


RUNS = 5
COUPLING_TARGET = 2.0
TELEMETRY_HZ = 20


def run(quick: bool = False) -> list[BenchResult]:
    """The lockstep figures for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        400 frames per run instead of 2000.

    Returns
    -------
    list[BenchResult]
        The lockstep's time per frame over the twin alone's plus the host's own work
        (target 2x: the pty, the second process and the daemon's threads at most double the
        work), and over the twin alone's (for information).
    """
    from jackson.sim.bench import real_time_factor

    frames = 400 if quick else 2000
    sim_s = frames / TELEMETRY_HZ
    # interleaved rounds, best of each: a shared machine's load slows whole runs
    lockstep, twin, host_s, loop_us = 0.0, 0.0, float("inf"), float("inf")
    for _ in range(RUNS):
        rtf, host = lockstep_rtf(frames)
        lockstep, host_s = max(lockstep, rtf), min(host_s, host)
        twin = max(twin, real_time_factor(False, sim_s))
        loop_us = min(loop_us, reference_loop_us(3))
    period_s = 1.0 / TELEMETRY_HZ
    lock_us, twin_us, host_us = 1e6 * period_s / lockstep, 1e6 * period_s / twin, 1e6 * host_s
    return [
        BenchResult(
            "sim.lockstep_over_twin_and_host_no_lidar",
            lock_us / (twin_us + host_us),
            "x the work's time",
            COUPLING_TARGET,
            "lower",
            "the twin alone per frame (same run) plus the host's own work per frame in the "
            "lockstep (HostCore.on_frame's CPU time): what the coupling costs",
            lock_us,
            "us per frame",
            twin_us + host_us,
            loop_us,
        ),
        BenchResult(
            "sim.lockstep_over_twin_pty_no_lidar",
            twin / lockstep,
            "x the twin alone's time",
            None,
            "lower",
            "the twin alone on the figure-eight for the same simulated time, same run "
            "(for information: what the pty and the whole host cost)",
            lockstep,
            "x real time",
            twin,
            loop_us,
        ),
    ]
