"""The host against link trouble: lost frames, command silence, the port unplugged, replay."""

from __future__ import annotations

import csv
import math
import signal
import subprocess
import threading
import time
from pathlib import Path

from jackson.host.replay import replay
from jackson.sim.tb6612 import BridgeMode, bridge_outputs

from .harness import JACKSON, TwinThread, in_process_daemon, run_daemon_cli, wait_for


def odometry_rows(run: Path) -> list[dict[str, float]]:
    with (run / "odometry.csv").open() as f:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]


def test_dropped_telemetry_frames_lose_no_distance(tmp_path: Path) -> None:
    twin = TwinThread(tmp_path, world="open_floor", drop_telemetry=lambda n: n % 7 == 3)
    try:
        out = run_daemon_cli(twin, "--mission", "square", "--run-dir", str(tmp_path / "run"))
    finally:
        twin.stop()
    assert out.returncode == 0, out.stderr
    assert len(twin.runner.dropped) > 100
    rows = odometry_rows(tmp_path / "run")
    last = rows[-1]
    # the host's distance comes from cumulative counts: every tick of the twin's encoders is in
    # its last odometry row, whatever frames were lost on the way
    r = twin.twin.robot
    assert last["enc_left"] == math.floor(r.angle_l / (2 * math.pi) * 621)
    assert last["enc_right"] == math.floor(r.angle_r / (2 * math.pi) * 621)
    truth = twin.twin.truth_log
    assert math.hypot(truth[-1].x, truth[-1].y) < 0.05  # and the square still closed


def test_command_silence_brakes_within_0_6_s_plus_one_tick(tmp_path: Path) -> None:
    twin = TwinThread(tmp_path, world="open_floor")
    daemon = in_process_daemon(twin, run_folder=tmp_path / "run")
    core = daemon.core
    runner = threading.Thread(target=daemon.run, kwargs={"max_s": 30.0}, daemon=True)
    runner.start()
    try:
        deadline = time.monotonic() + 10
        while core.t_s is None or core.gyro_bias.bias_rad_s is None:  # wait for start-up
            assert time.monotonic() < deadline
            time.sleep(0.01)
        core.submit_velocity(0.15, 0.0)  # one command, then silence
        while core.braked and time.monotonic() < deadline:  # it drives...
            time.sleep(0.001)
        while not core.braked and time.monotonic() < deadline:  # ...then brakes
            time.sleep(0.001)
        # ...through the PCA9685: both bridges short-braked once the output stage has run
        wait_for(
            lambda: all(b.mode == BridgeMode.SHORT_BRAKE for b in bridge_outputs(twin.runner.pca)),
            timeout_s=5,
            what="both bridges short-braked",
        )
    finally:
        daemon.stop.set()
        runner.join(timeout=10)
        daemon.transport.close()
        twin.stop()
    # from the run's command log (MCU time): the command took effect at the first driving frame
    with (tmp_path / "run" / "commands.csv").open() as f:
        rows = [(float(r["t_s"]), r["braked"] == "1") for r in csv.DictReader(f)]
    first_drive = next(i for i, (_, braked) in enumerate(rows) if not braked)
    braked_again = next(i for i in range(first_drive, len(rows)) if rows[i][1])
    silence = rows[braked_again][0] - rows[first_drive][0]
    assert 0.6 - 1e-6 <= silence <= 0.6 + 0.05 + 1e-6, silence


def test_port_removed_mid_run_is_survived_with_the_motors_braked(tmp_path: Path) -> None:
    link = str(tmp_path / "robot")
    twin = TwinThread(tmp_path, world="open_floor", serial_link=link, heartbeat_timeout_s=0.3)
    daemon = in_process_daemon(twin, port=link)
    core = daemon.core
    runner = threading.Thread(target=daemon.run, kwargs={"max_s": 60.0}, daemon=True)
    runner.start()
    try:
        deadline = time.monotonic() + 20
        while core.gyro_bias.bias_rad_s is None:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        for _ in range(40):  # keep commanding: the daemon must brake because of the link
            core.submit_velocity(0.15, 0.0)
            time.sleep(0.005)
        frames_before = core.frames
        twin.runner.request_outage(1.0)
        while daemon.link_downs == 0:
            core.submit_velocity(0.15, 0.0)
            assert time.monotonic() < deadline
            time.sleep(0.005)
        # back again: the transport reopens the same path and says HELLO
        while core.frames < frames_before + 40:
            core.submit_velocity(0.15, 0.0)
            assert time.monotonic() < deadline, "no telemetry after the port came back"
            time.sleep(0.005)
        assert daemon.transport.reconnects >= 1
        # at the end of the outage the host had short-braked both bridges through the PCA9685
        left, right = twin.runner.outage_outputs[-1]
        assert left.mode == BridgeMode.SHORT_BRAKE and right.mode == BridgeMode.SHORT_BRAKE
        assert runner.is_alive()
    finally:
        daemon.stop.set()
        runner.join(timeout=10)
        daemon.transport.close()
        twin.stop()


def test_replay_reproduces_the_live_run_bit_for_bit(tmp_path: Path) -> None:
    twin = TwinThread(tmp_path, robot="jackson_physical")
    try:
        out = run_daemon_cli(
            twin, "--mission", "figure8", "--run-dir", str(tmp_path / "run"), "--max-seconds", "3"
        )
    finally:
        twin.stop()
    assert "figure8" in out.stdout
    r = replay(tmp_path / "run", tmp_path / "replayed")
    assert r.differ == []
    assert r.complete  # the end record of a clean close
    assert r.frames == len(odometry_rows(tmp_path / "run"))
    assert (tmp_path / "replayed" / "ekf.csv").read_bytes() == (
        tmp_path / "run" / "ekf.csv"
    ).read_bytes()
    assert len(odometry_rows(tmp_path / "run")) > 20


def test_a_killed_run_replays_as_far_as_it_was_kept(tmp_path: Path) -> None:
    """SIGKILL mid-mission: the run folder's files agree up to the last flush, and replay says
    how far the log goes and reproduces every row the run kept."""
    twin = TwinThread(tmp_path, robot="jackson_physical")
    run = tmp_path / "run"
    cmd = [JACKSON, "daemon", "--port", twin.serial, "--i2c", twin.i2c, "--run-dir", str(run)]
    daemon = subprocess.Popen([*cmd, "--mission", "figure8"], stdout=subprocess.DEVNULL)
    try:
        wait_for(lambda: len(odometry_rows(run)) >= 300, timeout_s=120, what="300 flushed rows")
        daemon.send_signal(signal.SIGKILL)
        daemon.wait(timeout=10)
    finally:
        if daemon.poll() is None:
            daemon.kill()
            daemon.wait()
        twin.stop()
    r = replay(run, tmp_path / "replayed")
    assert not r.complete
    assert r.differ == []
    kept, made = r.rows["odometry.csv"]
    assert kept >= 300 and made >= kept
    assert r.frames == made
    out = subprocess.run([JACKSON, "replay", str(run)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "cut (no end record" in out.stdout
    assert f"replayed {r.frames} telemetry frames" in out.stdout
    assert "(--out DIR keeps the outputs)" in out.stdout  # its temporary outputs not kept
