"""Real-time factor of the lockstep loop over the pty (run by ``jackson bench``).

Starts ``jackson sim --no-lidar`` (the twin and its MCU emulator in their own process, lockstep,
200 Hz physics) and drives it with the minimal scripted host: per telemetry frame one PCA9685
block write over the I2C socket and one HEARTBEAT. Target: 200x real time; the figure is the
best of 3 runs.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

from jackson.common.bench import BenchResult
from jackson.host.scripted import ScriptedHost


def lockstep_rtf(frames: int) -> float:
    exe = Path(sys.executable).parent / "jackson"
    proc = subprocess.Popen([str(exe), "sim", "--no-lidar"], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    serial_path = proc.stdout.readline().split(": ", 1)[1].strip()
    i2c = proc.stdout.readline().split(": ", 1)[1].strip()
    host = ScriptedHost(serial_path, i2c)
    try:
        host.connect()
        host.run(20, lambda t: (0.4, 0.45))  # warm up
        t0 = time.perf_counter()
        tel = host.run(frames, lambda t: (0.4, 0.45))
        wall = time.perf_counter() - t0
        sim = (tel[-1].t_us - tel[0].t_us) / 1e6 + 0.05
    finally:
        host.close()
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=20)
    return sim / wall


RUNS = 3


def run(quick: bool = False) -> list[BenchResult]:
    # best of 3 runs, each a fresh twin: a shared machine's load slows whole runs
    return [
        BenchResult(
            "sim.lockstep_rtf_pty_no_lidar",
            max(lockstep_rtf(400 if quick else 2000) for _ in range(RUNS)),
            "x real time",
            200,
            "higher",
        )
    ]
