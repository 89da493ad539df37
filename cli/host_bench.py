"""Benchmarks of the host daemon (run by ``jackson bench``).

- CPU time per telemetry frame (the thread's CPU clock, so a preemption by another process
  does not count): decoding, odometry, EKF (30 Hz outputs, wheel and gyro
  updates), the square mission, the actuation chain and the PCA9685 block write, measured on
  the frames of a 60 s square in the twin. The I2C bus here is an in-memory register file, so
  the figure is the host's own work. Beside each pass, interleaved, a bare EKF
  (:class:`jackson.host.ekf.Ekf`) takes the same frames' wheel and gyro updates alone. Figures:
  the median and p99 as shares of the 5 ms frame period at 200 Hz (targets 2 % and 6 %, 100 and
  300 us) and the median over the EKF update's median (target 3x: the filter is most of the
  work). Best of 5 passes each.
- Command latency: from a new velocity command to the completed PCA9685 register write, over
  the twin's I2C socket (a real Unix socket to a server in another thread), in lockstep;
  interleaved sample by sample with a one-byte register write on the same bus, the transport's
  floor. Figures: median and p99 as shares of the 5 ms frame period (target 20 %, 1 ms; the
  paper saw about 50 ms of command transport on the robot) and the median over the one-byte
  write's (target 2x).
"""

from __future__ import annotations

import statistics
import tempfile
import threading
import time
from collections.abc import Sequence
from pathlib import Path

from jackson.common.bench import BenchResult, reference_loop_us
from jackson.host.actuation.output import Pca9685Output
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import HostConfig
from jackson.host.control import SquareMission
from jackson.host.core import CoreListener, FrameResult, HostCore
from jackson.host.ekf import Ekf
from jackson.host.i2c import SocketI2cBus
from jackson.protocol import FrameDecoder, Message, encode_frame
from jackson.protocol.units import yaw_rate_rad_s
from jackson.sim.config import load_robot, load_world
from jackson.sim.i2c_server import I2cSocketServer
from jackson.sim.mcu import McuEmulator
from jackson.sim.robot import WheelDrive
from jackson.sim.twin import Twin


class MemoryBus:
    """An I2C bus that only stores what is written (the host's cost without the transfer)."""

    def __init__(self) -> None:
        self.regs = bytearray(256)

    def write_byte_data(self, i2c_addr: int, register: int, value: int) -> None:
        self.regs[register] = value

    def read_byte_data(self, i2c_addr: int, register: int) -> int:
        return self.regs[register]

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: Sequence[int]) -> None:
        self.regs[register : register + len(data)] = bytes(data)

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int) -> list[int]:
        return list(self.regs[register : register + length])

    def close(self) -> None:
        pass


def telemetry_stream(seconds: float) -> list[bytes]:
    """The MCU's frames of a robot driving arcs in the twin (HELLO answered, 20 Hz)."""
    twin = Twin(load_world("open_floor"), load_robot("jackson"), lidar=False, seed=2)
    out: list[bytes] = []

    def write(frame: bytes) -> bool:
        out.append(frame)
        return True

    mcu = McuEmulator(write, twin.sensors)
    from jackson.protocol import hello

    mcu.receive(encode_frame(hello(), 0), 0)
    twin.command(WheelDrive(0.4, 1.0), WheelDrive(0.5, 1.0))
    for _ in range(round(seconds * 20)):
        twin.advance(0.05)
        mcu.tick(twin.t_us)
    return out


class _EkfInputs(CoreListener):
    """The wheel speed and yaw rate the core had at each frame."""

    def __init__(self) -> None:
        self.inputs: list[tuple[float, float, float]] = []

    def on_result(self, core: HostCore, result: FrameResult) -> None:
        self.inputs.append((result.t_s, result.odometry.v_m_s, yaw_rate_rad_s(result.telemetry)))


def cpu_per_frame(
    frames: list[bytes], inputs: list[tuple[float, float, float]] | None = None
) -> list[float]:
    """A fresh host's CPU time for each of ``frames`` [s].

    Parameters
    ----------
    frames : list[bytes]
        The MCU's frames, one telemetry frame each (from :func:`telemetry_stream`).
    inputs : list or None
        When given, filled with each frame's (t_s, wheel speed, yaw rate) for :func:`ekf_alone`.

    Returns
    -------
    list[float]
        CPU time of this thread decoding and handling each frame [s] (time spent preempted by
        other processes is not counted).
    """
    cfg = HostConfig()
    pca = Pca9685(MemoryBus())
    output = Pca9685Output(pca, cfg.pca9685.left, cfg.pca9685.right)
    sent: list[Message] = []
    core = HostCore(cfg, output, sent.append, mission=SquareMission())
    if inputs is not None:
        recorder = _EkfInputs()
        core.listeners.append(recorder)
        inputs.clear()
    decoder = FrameDecoder()
    times: list[float] = []
    for raw in frames:
        t0 = time.thread_time()
        for frame in decoder.feed(raw):
            core.on_frame(frame)
        times.append(time.thread_time() - t0)
    if inputs is not None:
        inputs.extend(recorder.inputs)
    return times


def ekf_alone(inputs: list[tuple[float, float, float]]) -> list[float]:
    """A bare EKF's time for each frame's wheel and gyro updates [s].

    Parameters
    ----------
    inputs : list[tuple[float, float, float]]
        Per frame: MCU time [s], the wheels' speed [m/s] and the yaw rate [rad/s].

    Returns
    -------
    list[float]
        CPU time of this thread for each frame's two updates [s].
    """
    ekf = Ekf(HostConfig().ekf)
    times: list[float] = []
    for t_s, v_m_s, wz in inputs:
        t0 = time.thread_time()
        ekf.update_wheel(t_s, v_m_s, 0.0)
        ekf.update_gyro(t_s, wz)
        times.append(time.thread_time() - t0)
    return times


def command_latency(samples: int) -> tuple[list[float], list[float]]:
    """New velocity command -> PCA9685 registers written on the twin's socket bus.

    Parameters
    ----------
    samples : int
        Commands sent (duties alternating 0.3 and 0.7).

    Returns
    -------
    command_s : list[float]
        Latency of each command [s].
    floor_s : list[float]
        Latency of a one-byte register write on the same bus after each command [s].
    """
    tmp = tempfile.TemporaryDirectory()
    path = Path(tmp.name) / "i2c.sock"
    server = I2cSocketServer(path)
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            server.service(0.01)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    cfg = HostConfig()
    bus = SocketI2cBus(path)
    pca = Pca9685(bus, cfg.pca9685.address)
    output = Pca9685Output(pca, cfg.pca9685.left, cfg.pca9685.right)
    out: list[float] = []
    floor: list[float] = []
    mode1 = 0x00
    try:
        for k in range(samples):
            duty = 0.3 + 0.4 * (k % 2)
            t0 = time.perf_counter()
            output.set(duty, duty)  # returns once the server has applied the block write
            out.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            bus.write_byte_data(cfg.pca9685.address, mode1, 0x20)  # MODE1 as set: AI on
            floor.append(time.perf_counter() - t0)
    finally:
        stop.set()
        thread.join()
        server.close()
        tmp.cleanup()
    return out, floor


PASSES = 5
FRAME_PERIOD_S = 1.0 / 200  # the 200 Hz frame period [s]
CPU_P50_SHARE_TARGET = 100e-6 / FRAME_PERIOD_S
CPU_P99_SHARE_TARGET = 300e-6 / FRAME_PERIOD_S
CPU_OVER_EKF_TARGET = 3.0
COMMAND_SHARE_TARGET = 1e-3 / FRAME_PERIOD_S
COMMAND_OVER_FLOOR_TARGET = 2.0


def _p(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))]


def run(quick: bool = False) -> list[BenchResult]:
    """The host's figures for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        A 20 s run and 200 commands per pass instead of 60 s and 1000.

    Returns
    -------
    list[BenchResult]
        CPU per frame against the frame period and the EKF alone; command latency against the
        frame period and the bus's one-byte write.
    """
    frames = telemetry_stream(20.0 if quick else 60.0)
    # Whole passes, each a fresh host over the same frames (skipping the start-up frames of the
    # gyro-bias window), interleaved with passes of the EKF alone; each statistic is the best
    # over the passes (as timeit takes its best run): another tenant's load on a shared machine
    # slows whole passes by up to 60 %, and its preemptions make the tail of any one pass.
    inputs: list[tuple[float, float, float]] = []
    cpu_passes: list[list[float]] = []
    ekf_passes: list[list[float]] = []
    lat_passes: list[tuple[list[float], list[float]]] = []
    loop_us = float("inf")
    for _ in range(PASSES):
        cpu_passes.append(cpu_per_frame(frames, inputs)[20:])
        ekf_passes.append(ekf_alone(inputs)[20:])
        lat_passes.append(command_latency(200 if quick else 1000))
        loop_us = min(loop_us, reference_loop_us(3))

    def best(passes: list[list[float]]) -> tuple[float, float]:
        p50 = min(statistics.median(p) for p in passes)
        return p50 * 1e6, min(_p(p, 0.99) for p in passes) * 1e6

    cpu_p50, cpu_p99 = best(cpu_passes)
    ekf_p50, ekf_p99 = best(ekf_passes)
    lat_p50, lat_p99 = best([lat for lat, _ in lat_passes])
    floor_p50, floor_p99 = best([floor for _, floor in lat_passes])
    period_us = FRAME_PERIOD_S * 1e6

    def fig(
        name: str,
        value: float,
        unit: str,
        target: float,
        reference: str,
        ours: float,
        theirs: float | None,
    ) -> BenchResult:
        return BenchResult(
            name, value, unit, target, "lower", reference, ours, "us", theirs, loop_us
        )

    period = "the 5 ms frame period at 200 Hz"
    return [
        fig(
            "host.cpu_per_frame_p50_share",
            cpu_p50 / period_us,
            "of 5 ms",
            CPU_P50_SHARE_TARGET,
            period,
            cpu_p50,
            None,
        ),
        fig(
            "host.cpu_per_frame_p99_share",
            cpu_p99 / period_us,
            "of 5 ms",
            CPU_P99_SHARE_TARGET,
            period,
            cpu_p99,
            None,
        ),
        fig(
            "host.cpu_per_frame_p50_over_ekf",
            cpu_p50 / ekf_p50,
            "x the EKF update's time",
            CPU_OVER_EKF_TARGET,
            "a bare EKF's wheel and gyro updates on the same frames",
            cpu_p50,
            ekf_p50,
        ),
        fig(
            "host.cpu_per_frame_p99_over_ekf",
            cpu_p99 / ekf_p99,
            "x the EKF update's time",
            CPU_OVER_EKF_TARGET,
            "the bare EKF's p99 on the same frames",
            cpu_p99,
            ekf_p99,
        ),
        fig(
            "host.command_to_pca9685_p50_share",
            lat_p50 / period_us,
            "of 5 ms",
            COMMAND_SHARE_TARGET,
            period,
            lat_p50,
            None,
        ),
        fig(
            "host.command_to_pca9685_p99_share",
            lat_p99 / period_us,
            "of 5 ms",
            COMMAND_SHARE_TARGET,
            period,
            lat_p99,
            None,
        ),
        fig(
            "host.command_to_pca9685_p50_over_bus_write",
            lat_p50 / floor_p50,
            "x a one-byte write's time",
            COMMAND_OVER_FLOOR_TARGET,
            "a one-byte register write on the same socket bus, interleaved",
            lat_p50,
            floor_p50,
        ),
        fig(
            "host.command_to_pca9685_p99_over_bus_write",
            lat_p99 / floor_p99,
            "x a one-byte write's time",
            COMMAND_OVER_FLOOR_TARGET,
            "the one-byte write's p99",
            lat_p99,
            floor_p99,
        ),
    ]
