"""How long ``jackson brake`` takes, idle or with the machine busy (the figure README quotes).

Starts an emulated PCA9685 on a Unix socket (the twin's I2C server, answering in a thread of
this process as the twin's does), then runs ``jackson brake --i2c unix:SOCK`` ``--starts``
times, one after the other, each against a chip driven as a killed daemon leaves it (set up,
both wheels forward), each in a fresh environment as systemd or a shell starts it (the ROS 2
wheels' start-up hook, which re-executes the interpreter once, is not skipped as it is for a
child of an interpreter that already ran it). Per start: the wall time from spawning the
command to its exit (what systemd's ``ExecStopPost`` waits for), the time the command itself
reports from its process's start to the brake read back, and its time on the bus. With
``--busy N``, N processes spin on the CPU beside it at normal priority for the whole
measurement (as ``busy -n N`` of the shared tools does: the load of a shared laptop, a CI
runner, a Jetson running other nodes).

Writes ``runs.json`` into ``--out`` (one record per start: ``wall_s``, ``reported_s``,
``bus_ms``), which ``tools/docs_check.py`` reads as it reads a campaign's, and prints the
median and the range.

    .venv/bin/python tools/brake_timing.py --starts 20 --out build/brake
    .venv/bin/python tools/brake_timing.py --starts 20 --busy 4 --out build/brake-busy
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from jackson.bench.host import serving
from jackson.host.actuation.i2c import open_bus
from jackson.host.actuation.output import Pca9685Output
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.actuation.settings import Pca9685Settings
from jackson.sim.i2c_server import I2cSocketServer

JACKSON = str(Path(sys.executable).parent / "jackson")
REPORT = re.compile(r"(?P<age>[0-9.]+) s after the command started, (?P<bus>[0-9.]+) ms on the bus")
SPIN = "while True:\n    pass\n"


def drive(spec: str) -> None:
    """What a killed daemon leaves: the chip set up and both wheels driven forward."""
    p = Pca9685Settings(bus=spec)
    pca = Pca9685(open_bus(spec), p.address)
    try:
        pca.init(p.frequency_hz)
        Pca9685Output(pca, p.left, p.right).set(0.6, 0.6)
    finally:
        pca.bus.close()


def measure(starts: int, busy: int) -> list[dict[str, Any]]:
    """``starts`` runs of ``jackson brake`` against an emulated PCA9685, ``busy`` spinning
    processes beside them."""
    runs: list[dict[str, Any]] = []
    env = {k: v for k, v in os.environ.items() if k != "_ROS_WHEELS_BOOTSTRAP_COMPLETE"}
    hogs = [subprocess.Popen([sys.executable, "-c", SPIN]) for _ in range(busy)]
    try:
        with tempfile.TemporaryDirectory(prefix="jackson-brake-") as tmp:
            server = I2cSocketServer(Path(tmp) / "i2c.sock")
            spec = f"unix:{server.path}"
            with serving(server):
                for k in range(starts):
                    drive(spec)
                    t0 = time.perf_counter()
                    done = subprocess.run(
                        [JACKSON, "brake", "--i2c", spec], capture_output=True, text=True, env=env
                    )
                    wall_s = time.perf_counter() - t0
                    said = REPORT.search(done.stdout)
                    if done.returncode != 0 or said is None:
                        raise RuntimeError(f"jackson brake failed: {done.stdout}{done.stderr}")
                    runs.append(
                        {
                            "start": k,
                            "busy": busy,
                            "wall_s": wall_s,
                            "reported_s": float(said["age"]),
                            "bus_ms": float(said["bus"]),
                        }
                    )
            server.close()
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    return runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=20, help="runs of jackson brake (20)")
    ap.add_argument("--busy", type=int, default=0, help="spinning processes beside it (0)")
    ap.add_argument("--out", type=Path, required=True, help="folder for runs.json")
    args = ap.parse_args(argv)
    if args.starts < 1 or args.busy < 0:
        ap.error("--starts must be >= 1 and --busy >= 0")
    runs = measure(args.starts, args.busy)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "runs.json").write_text(json.dumps(runs, indent=1) + "\n", encoding="utf-8")
    for key, unit, scale in (("wall_s", "s", 1.0), ("reported_s", "s", 1.0), ("bus_ms", "ms", 1)):
        values = [r[key] * scale for r in runs]
        print(
            f"{key}: median {statistics.median(values):.3f} {unit}, "
            f"{min(values):.3f}-{max(values):.3f} {unit} over {len(values)} starts "
            f"({args.busy} busy)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
