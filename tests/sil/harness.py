"""Software in the loop: the twin in a thread of the test, the host as the user runs it.

The twin (``TwinRunner``) serves a real pty and a real I2C socket in lockstep; the host is the
daemon, either the ``jackson daemon`` command in its own process or the same ``Daemon`` class
in-process when a test must inject velocity commands. The test reads the twin's ground truth
afterwards.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from jackson.host.actuation.i2c import open_bus
from jackson.host.actuation.output import Pca9685Output
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import HostConfig
from jackson.host.daemon import Daemon
from jackson.host.transport import SerialTransport
from jackson.sim.config import RobotSpec, WorldSpec, load_robot, load_world
from jackson.sim.runner import RunnerStats, TwinRunner
from jackson.sim.twin import Twin

JACKSON = str(Path(sys.executable).parent / "jackson")


class TwinThread:
    """A lockstep twin running in a background thread until ``stop()``."""

    def __init__(
        self,
        tmp: Path,
        world: str | WorldSpec = "square_room",
        robot: str | RobotSpec = "jackson",
        *,
        lidar: bool = False,
        **runner: Any,
    ) -> None:
        w = load_world(world) if isinstance(world, str) else world
        r = load_robot(robot) if isinstance(robot, str) else robot
        self.twin = Twin(w, r, lidar=lidar, seed=1)
        self.i2c = f"unix:{tmp / 'i2c.sock'}"
        self.runner = TwinRunner(self.twin, i2c_path=tmp / "i2c.sock", **runner)
        self.serial = self.runner.serial_path
        self.lidar = self.runner.lidar_path  # the emulated RPLIDAR's pty (None without)
        self._stop = threading.Event()
        self.stats: RunnerStats | None = None
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        self.stats = self.runner.run(None, self._stop)

    def stop(self) -> None:
        self._stop.set()
        self.thread.join(timeout=30)
        self.runner.close()


def wait_for(condition: Callable[[], bool], *, timeout_s: float, what: str) -> None:
    """Poll ``condition`` until it holds; fail naming ``what`` after a generous deadline."""
    deadline = time.monotonic() + timeout_s
    tick = threading.Event()
    while True:
        try:
            if condition():
                return
        except (OSError, ValueError):  # a file not written yet, a row half written
            pass
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}")
        tick.wait(0.02)


def run_daemon_cli(
    twin: TwinThread, *args: str, timeout: float = 240
) -> subprocess.CompletedProcess[str]:
    """``jackson daemon`` against the twin, to completion."""
    return subprocess.run(
        [JACKSON, "daemon", "--port", twin.serial, "--i2c", twin.i2c, *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def host_config(i2c: str, **changes: Any) -> HostConfig:
    cfg = HostConfig()
    cfg = dataclasses.replace(cfg, pca9685=dataclasses.replace(cfg.pca9685, bus=i2c))
    return dataclasses.replace(cfg, **changes)


def in_process_daemon(
    twin: TwinThread,
    cfg: HostConfig | None = None,
    run_folder: Path | None = None,
    port: str | None = None,
) -> Daemon:
    """The daemon's own classes in this process (for tests that inject commands)."""
    cfg = cfg or host_config(twin.i2c)
    pca = Pca9685(open_bus(cfg.pca9685.bus), cfg.pca9685.address)
    pca.init(cfg.pca9685.frequency_hz)
    transport = SerialTransport(port or twin.serial, cfg.serial.baudrate)
    transport.open(reader_thread=False)

    def output(send: Callable[..., object]) -> Pca9685Output:
        return Pca9685Output(pca, cfg.pca9685.left, cfg.pca9685.right, cfg.pca9685.stby_channel)

    return Daemon(cfg, output, transport, run_folder=run_folder, meta={"mission": None})


def start_service(
    tmp: Path,
    world: str,
    start: str,
    seed: int,
    run_dir: Path,
    config: Path | None = None,
    truth: bool = False,
) -> tuple[subprocess.Popen[str], subprocess.Popen[bytes], Path]:
    """``jackson sim`` and ``jackson daemon`` in service mode (``--lidar``, ``--map`` of the
    world's raster saved in ``tmp``) as processes, lockstep waiting up to 120 s for each other;
    returned once the daemon's control socket answers: (twin, daemon, socket)."""
    from jackson.experiments.stage3 import world_grid
    from jackson.host.service.control import ControlError, ask

    world_grid(load_world(world)).save(tmp / "map.yaml")
    sim = subprocess.Popen(
        [
            JACKSON, "sim", "--world", world, "--seed", str(seed), "--link", str(tmp / "mcu"),
            "--lidar-link", str(tmp / "lidar"), "--i2c", str(tmp / "i2c.sock"),
            "--heartbeat-timeout", "120", "--stall-timeout", "120",
            *(["--truth", str(tmp / "truth.csv")] if truth else []),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )  # fmt: skip
    assert sim.stdout is not None
    for line in sim.stdout:
        if "waiting for HELLO" in line:
            break
    sock = tmp / "daemon.sock"
    log = (tmp / "daemon.log").open("wb")
    daemon = subprocess.Popen(
        [
            JACKSON, "daemon", *(["--config", str(config)] if config is not None else []),
            "--port", str(tmp / "mcu"), "--i2c", f"unix:{tmp / 'i2c.sock'}",
            "--lidar", str(tmp / "lidar"), "--map", str(tmp / "map.yaml"), "--start", start,
            "--socket", str(sock), "--run-dir", str(run_dir), "--stall-timeout", "120",
        ],
        stdout=log,
        stderr=subprocess.STDOUT,
    )  # fmt: skip

    def up() -> bool:
        assert daemon.poll() is None, (tmp / "daemon.log").read_text()
        try:
            return bool(next(ask(sock, {"op": "status"}))["ok"])
        except ControlError:
            return False

    wait_for(up, timeout_s=180, what="the daemon's control socket")
    return sim, daemon, sock
