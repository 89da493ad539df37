"""Benchmarks of the firmware core (run by ``jackson bench``).

Builds the native core without sanitizers (``-O2``, in build/bench-native), then measures, best
of 3 runs with the machine's reference loop timed between them:

- CPU time of the core per telemetry period at its top rate, 200 Hz (SET_RATE 200; per 5 ms
  period 5 loop ticks of 1 ms, the IMU samples at 100 Hz, 1 telemetry frame, a heartbeat and a
  motor command received), mean and p99, against that 5 ms period. Target: 10 % (500 us; on
  the 240 MHz ESP32-S3 expect several times this figure).
- Size of the core's object code (text + data of the static library, x86-64 here), a proxy
  for the flash it needs, against a 64 KiB budget, a small share of the 16 MB flash.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

from jackson.common.bench import BenchResult, reference_loop_us

ROOT = Path(__file__).resolve().parents[1]
BUILD = ROOT / "build" / "bench-native"
PERIOD_200HZ_US = 5000.0
SHARE_TARGET = 0.1
SIZE_BUDGET_KIB = 64.0
RUNS = 3


def _build() -> None:
    subprocess.run(
        [
            "cmake",
            "-S",
            str(ROOT),
            "-B",
            str(BUILD),
            "-DCMAKE_BUILD_TYPE=Release",
            "-DJACKSON_SANITIZE=OFF",
        ],
        check=True,
        capture_output=True,
    )
    subprocess.run(
        ["cmake", "--build", str(BUILD), "-j", "2", "--target", "bench_firmware_core"],
        check=True,
        capture_output=True,
    )


def _object_size(lib: Path) -> int:
    size = shutil.which("size")
    if size is None:
        return lib.stat().st_size
    out = subprocess.run([size, "-t", str(lib)], capture_output=True, text=True, check=True)
    total = [ln for ln in out.stdout.splitlines() if ln.rstrip().endswith("(TOTALS)")]
    text, data = (int(x) for x in re.split(r"\s+", total[0].strip())[:2])
    return text + data


def run(quick: bool = False) -> list[BenchResult]:
    """The firmware's figures for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        Unused: the native bench takes about a second.

    Returns
    -------
    list[BenchResult]
        The core's mean and p99 time per period against the 5 ms budget, its size against
        64 KiB.
    """
    _build()
    runs: list[dict[str, float]] = []
    loop_us = float("inf")
    for _ in range(RUNS):
        out = subprocess.run(
            [str(BUILD / "firmware" / "bench_firmware_core")],
            capture_output=True,
            text=True,
            check=True,
        )
        runs.append(json.loads(out.stdout))
        loop_us = min(loop_us, reference_loop_us(3))
    r = min(runs, key=lambda x: x["mean_us"])
    lib = BUILD / "firmware" / "libjackson_fw_core.a"
    size_kib = _object_size(lib) / 1024
    if r["telemetry_periods"] != r["periods"]:
        raise RuntimeError("firmware bench: the core did not send a frame every 5 ms")
    budget = "the 5 ms telemetry period at 200 Hz"
    return [
        BenchResult(
            "firmware.core_mean_share_of_200Hz_period",
            r["mean_us"] / PERIOD_200HZ_US,
            "of 5 ms",
            SHARE_TARGET,
            "lower",
            budget,
            r["mean_us"],
            "us",
            None,
            loop_us,
        ),
        BenchResult(
            "firmware.core_p99_share_of_200Hz_period",
            r["p99_us"] / PERIOD_200HZ_US,
            "of 5 ms",
            SHARE_TARGET,
            "lower",
            budget,
            r["p99_us"],
            "us",
            None,
            loop_us,
        ),
        BenchResult(
            "firmware.core_object_size_share_of_budget",
            size_kib / SIZE_BUDGET_KIB,
            "of 64 KiB",
            1.0,
            "lower",
            "a 64 KiB flash budget (text + data, x86-64)",
            size_kib,
            "KiB",
            None,
            loop_us,
        ),
    ]
