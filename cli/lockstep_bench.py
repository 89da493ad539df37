"""Real-time factor of the lockstep loop over the pty (run by ``jackson bench``).

Starts ``jackson sim --no-lidar`` (the twin and its MCU emulator in their own process, lockstep,
200 Hz physics) and drives it with the host daemon itself (:class:`jackson.host.daemon.Daemon`)
with constant wheel duties as its command source: per telemetry frame the whole host pipeline
(odometry, EKF, listeners), one PCA9685 block write over the I2C socket and one HEARTBEAT, as
when a user runs ``jackson daemon`` against the twin. Beside each run, interleaved, the twin
alone (:mod:`jackson.sim.bench`'s figure-eight, no LiDAR) runs for the same simulated time in
this process. Figure: the twin alone's real-time factor over the lockstep's, best of 3 rounds
each (what the pty, the second process and the host cost); target 5x (the twin alone's 1000x
real time against the lockstep's 200x).
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


def lockstep_rtf(frames: int) -> float:
    """MCU seconds per wall second over ``frames`` frames of the daemon against a fresh twin.

    Parameters
    ----------
    frames : int
        Frames timed after the warm-up.

    Returns
    -------
    float
        The lockstep's real-time factor.
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
        transport.open()

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
        proc.communicate(timeout=20)
    if clock.first is None or clock.last is None:
        raise RuntimeError(f"lockstep bench: the twin sent {clock.frames} frames")
    return (clock.last[1] - clock.first[1]) / (clock.last[0] - clock.first[0])


RUNS = 3
LOCKSTEP_OVER_TWIN_TARGET = 5.0
TELEMETRY_HZ = 20


def run(quick: bool = False) -> list[BenchResult]:
    """The lockstep figure for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        400 frames per run instead of 2000.

    Returns
    -------
    list[BenchResult]
        The twin alone's real-time factor over the lockstep's.
    """
    from jackson.sim.bench import real_time_factor

    frames = 400 if quick else 2000
    sim_s = frames / TELEMETRY_HZ
    # interleaved rounds, best of each: a shared machine's load slows whole runs
    lockstep, twin, loop_us = 0.0, 0.0, float("inf")
    for _ in range(RUNS):
        lockstep = max(lockstep, lockstep_rtf(frames))
        twin = max(twin, real_time_factor(False, sim_s))
        loop_us = min(loop_us, reference_loop_us(3))
    return [
        BenchResult(
            "sim.lockstep_over_twin_pty_no_lidar",
            twin / lockstep,
            "x the twin alone's time",
            LOCKSTEP_OVER_TWIN_TARGET,
            "lower",
            "the twin alone on the figure-eight for the same simulated time, same run",
            lockstep,
            "x real time",
            twin,
            loop_us,
        )
    ]
