"""Benchmarks of the firmware core (run by ``jackson bench``).

Builds the native core without sanitizers (``-O2``, in build/bench-native), then measures:

- CPU time of the core per 20 Hz telemetry period on this machine (50 loop ticks of 1 ms,
  5 IMU samples, 1 telemetry frame, a heartbeat and a motor command received). Target: 500 us,
  1 % of the 50 ms period. On the 240 MHz ESP32-S3 expect several times this figure.
- Size of the core's object code (text + data of the static library, x86-64 here), a proxy
  for the flash it needs. Target: 64 KiB, a small share of the 16 MB flash.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

from jackson.common.bench import BenchResult

ROOT = Path(__file__).resolve().parents[1]
BUILD = ROOT / "build" / "bench-native"


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
    _build()
    out = subprocess.run(
        [str(BUILD / "firmware" / "bench_firmware_core")],
        capture_output=True,
        text=True,
        check=True,
    )
    r = json.loads(out.stdout)
    lib = BUILD / "firmware" / "libjackson_fw_core.a"
    return [
        BenchResult("firmware.core_us_per_period_mean", r["mean_us"], "us", 500, "lower"),
        BenchResult("firmware.core_us_per_period_p99", r["p99_us"], "us", 500, "lower"),
        BenchResult("firmware.core_object_size", _object_size(lib) / 1024, "KiB", 64, "lower"),
    ]
