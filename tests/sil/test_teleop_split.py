"""A daemon driven by velocity commands for hours splits its recording every ``split_s`` of MCU
time: the daemon's own classes in this process (to inject the commands), the twin in a thread;
every folder replays bit for bit, the commands each in the folder of the frame that took it."""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

from jackson.host.actuation.i2c import open_bus
from jackson.host.actuation.output import Pca9685Output
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import HostConfig
from jackson.host.daemon import Daemon
from jackson.host.recording import KIND_CMD, read_log
from jackson.host.replay import replay
from jackson.host.transport import SerialTransport

from .harness import TwinThread, host_config, wait_for


def _daemon(twin: TwinThread, cfg: HostConfig, run: Path) -> Daemon:
    """The daemon as ``jackson daemon`` makes it: splitting and keeping the budget."""
    pca = Pca9685(open_bus(cfg.pca9685.bus), cfg.pca9685.address)
    pca.init(cfg.pca9685.frequency_hz)
    transport = SerialTransport(twin.serial, cfg.serial.baudrate)
    transport.open(reader_thread=False)

    def output(send: Callable[..., object]) -> Pca9685Output:
        return Pca9685Output(pca, cfg.pca9685.left, cfg.pca9685.right, cfg.pca9685.stby_channel)

    return Daemon(cfg, output, transport, run_folder=run, meta={"mission": None}, rotate=True)


def _drive_until(daemon: Daemon, t_end_s: float) -> None:
    """Run the daemon, turning on the spot by velocity commands, to MCU time ``t_end_s``."""
    core = daemon.core
    runner = threading.Thread(target=daemon.run, daemon=True)
    runner.start()
    try:
        wait_for(lambda: core.gyro_bias.bias_rad_s is not None, timeout_s=60, what="the bias")
        k = 0

        def driven() -> bool:
            nonlocal k
            k += 1
            core.submit_velocity(0.05, 0.4 if k % 2 else 0.3)  # 50 Hz of wall time
            return (core.t_s or 0.0) >= t_end_s

        wait_for(driven, timeout_s=300, what=f"MCU time {t_end_s} s")
    finally:
        daemon.stop.set()
        runner.join(timeout=60)
        daemon.transport.close()


def test_a_teleop_daemon_splits_every_split_s_and_each_folder_replays(tmp_path: Path) -> None:
    twin = TwinThread(tmp_path, world="open_floor")
    cfg = host_config(twin.i2c, recording_split="duration", recording_split_s=2.0)
    try:
        daemon = _daemon(twin, cfg, tmp_path / "runs" / "run")
        _drive_until(daemon, 7.5)
    finally:
        twin.stop()
    folders = [tmp_path / "runs" / "run", *sorted((tmp_path / "runs").glob("run-*"))]
    assert len(folders) >= 3, [f.name for f in folders]
    for k, folder in enumerate(folders):
        result = replay(folder, tmp_path / f"out{k}")
        assert result.complete and result.differ == [], (folder, result.differ)
        assert (result.snapshot is not None) == (k > 0)
        taken = sum(1 for r in read_log(folder) if r.kind == KIND_CMD)
        assert result.commands == taken
        if 0 < k < len(folders) - 1:  # a whole folder: split_s of MCU time, driven
            assert result.t0_s is not None and result.t1_s is not None
            assert abs(result.t1_s - result.t0_s - 2.0) <= 0.05 + 1e-9
            assert taken > 0


def test_a_core_that_cannot_be_pickled_goes_on_unsplit_with_one_line(tmp_path: Path) -> None:
    twin = TwinThread(tmp_path, world="open_floor")
    cfg = host_config(twin.i2c, recording_split="duration", recording_split_s=1.0)
    try:
        daemon = _daemon(twin, cfg, tmp_path / "runs" / "run")
        daemon.core.frontend.lock = threading.Lock()  # type: ignore[attr-defined]
        _drive_until(daemon, 3.0)
    finally:
        twin.stop()
    assert [p.name for p in (tmp_path / "runs").iterdir()] == ["run"]
    (line,) = (e for e in daemon.events if e.startswith("recording: "))
    assert "cannot split (TypeError: cannot pickle '_thread.lock' object)" in line
    assert line.endswith("unsplit")
    result = replay(tmp_path / "runs" / "run", tmp_path / "out")
    assert result.complete and result.differ == [] and (result.t1_s or 0.0) >= 3.0
