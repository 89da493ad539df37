"""The ``daemon`` suite's frame latency: how long ``jackson daemon`` takes from a telemetry
frame's bytes read off the port to the HEARTBEAT written after that frame's motor command
(health.json's ``latency``, :class:`jackson.host.daemon_latency.LatencyMeter`).

The daemon navigates the maze as on a robot: ``jackson sim --realtime`` paces the twin on the
wall clock at 20 Hz telemetry (not lockstep, where the twin would wait for the host), with the
twin's RPLIDAR in its densest mode and recording on. The MCU drives the motors (``actuator:
mcu``, MOTOR_PWM on the serial link): with the PCA9685 on the twin's I2C socket each write
waits for the twin's process to answer, and on a loaded machine that process waits for a core
like any other (a PCA9685 on the Jetson's bus answers from the kernel's driver), so the figure
would be the twin's as much as the host's. Four runs: idle and with two busy processes per core
beside it (pure CPU loops at normal priority, as ``busy`` in the shared tools starts them),
each at the normal policy (before) and with ``--realtime`` (after: the frame thread under
SCHED_FIFO, every other thread normal). Median, p99 and max, each over the 50 ms telemetry
period: a frame answered late drives the wheels on the previous command for that long. A
loaded run at the normal policy may end its mission aborted (a LiDAR starved of the CPU); its
figures still count.

Targets: at the normal policy the loaded figures are reported for information (they measure
the machine's load, which the daemon cannot control); idle, and loaded with ``--realtime``,
the median within a tenth of the period, the p99 within 0.3 of it and the worst frame within
half of it (the MCU's failsafe is longer). Under SCHED_FIFO the latency is the frame's own CPU
(whose p99 the suite holds within half the period), about 3 ms median and 10 ms p99 here.
"""

from __future__ import annotations

import os
import subprocess
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from jackson.common.bench import BenchResult

TELEMETRY_HZ = 20.0
BUSY_PER_CORE = 2
TARGETS = {"median": 0.1, "p99": 0.3, "max": 0.5}  # of the 50 ms period
REALTIME_SET = "realtime: frame thread SCHED_FIFO"  # the daemon's line when it got the policy


@contextmanager
def busy(n: int) -> Iterator[list[subprocess.Popen[bytes]]]:
    """``n`` busy processes (``sh`` loops at normal priority) for the body's duration."""
    procs = [
        subprocess.Popen(["sh", "-c", "while :; do :; done"], stdout=subprocess.DEVNULL)
        for _ in range(n)
    ]
    try:
        yield procs
    finally:
        for proc in procs:
            proc.kill()
        for proc in procs:
            proc.wait(timeout=10)


def mcu_config(folder: Path) -> Path:
    """The shipped host config with the MCU driving the motors (``actuator: mcu``)."""
    import yaml

    from jackson.host.config import DEFAULT_CONFIG

    data = yaml.safe_load(Path(DEFAULT_CONFIG).read_text())
    data["actuator"] = "mcu"
    path = folder / "jackson_mcu.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _figures(
    latency: dict[str, Any], label: str, realtime: bool, loaded: bool, loop_us: float
) -> list[BenchResult]:
    period_ms = 1e3 / TELEMETRY_HZ
    when = "with two busy processes per core beside it" if loaded else "idle"
    policy = "the frame thread SCHED_FIFO (--realtime)" if realtime else "the normal policy"
    judged = realtime or not loaded
    aborted = ", the mission aborted" if latency["status"] else ""
    return [
        BenchResult(
            f"daemon.latency_{stat}_{label}",
            float(latency["share_of_period"][stat]),
            f"of the {period_ms:g} ms frame period",
            TARGETS[stat] if judged else None,
            "lower",
            f"the telemetry period: the {stat} of the daemon's frame latency (telemetry bytes "
            f"read to the HEARTBEAT after the motor command written), navigating the maze "
            f"against jackson sim --realtime at {TELEMETRY_HZ:g} Hz, {when}, {policy} "
            f"({latency['frames']} frames{aborted}; MCU-driven motors; load average "
            f"{latency['load']:.1f} at the end)",
            float(latency["us"][stat]) / 1e3,
            "ms",
            period_ms,
            loop_us,
        )
        for stat in ("median", "p99", "max")
    ]


def measure(
    folder: Path,
    nav_args: list[str],
    loop_us: float,
    daemon_run: Callable[..., dict[str, Any]],
) -> list[BenchResult]:
    """The four runs' figures: idle and loaded, before and after ``--realtime``.
    ``daemon_run`` is :func:`jackson.bench.daemon.daemon_run`."""
    results: list[BenchResult] = []
    nav_args = [*nav_args, "--config", str(mcu_config(folder))]
    sim_args = ("--realtime", "--mcu-motors")
    for loaded in (False, True):
        for realtime in (False, True):
            label = ("loaded" if loaded else "idle") + ("_realtime" if realtime else "")
            out = folder / f"latency_{label}"
            out.mkdir()
            args = [*nav_args, *(["--realtime"] if realtime else [])]
            with busy(BUSY_PER_CORE * (os.cpu_count() or 1) if loaded else 0):
                latency = daemon_run("maze", args, out, sim_args, "latency", aborted_ok=True)
                latency["load"] = os.getloadavg()[0]  # the machine's other work shows here
            got_policy = REALTIME_SET in latency["said"]
            results += _figures(latency, label, realtime and got_policy, loaded, loop_us)
    return results
