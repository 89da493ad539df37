"""A twin kept from running past the host's silence limit resumes its session: the run is the
one an idle machine gives.

In lockstep a twin starved of CPU sends nothing for a while. The host cannot tell that silence
from a reset MCU's, so after ``silence_s`` it sends HELLO again; that HELLO carries the
connection's session id (protocol/spec.md §6.3), and the MCU, still in that session, answers it
without restarting anything. Before, the HELLO restarted the session: the interlock dropped until
the next HEARTBEAT and telemetry started over one period later, so a run on a busy machine
differed from the same run on an idle one. These tests burn CPU in a real ``jackson sim``
process on one frame (two CPU-seconds: four times the daemon's 0.5 s silence limit) and compare
every file the daemon writes with a run of the same twin that was never held up.
"""

from __future__ import annotations

import itertools
import signal
import subprocess
import sys
from pathlib import Path

from jackson.host.recording import KIND_LINK, KIND_RX, read_log
from jackson.protocol import Info, Telemetry, TelemetryFlags

from .harness import JACKSON

_BUSY_SIM = """
import sys, time
from jackson.main import main
from jackson.sim.runner import TwinRunner

real = TwinRunner._advance
def advance(self, deadline_us, now_us, end_s):
    if self.frames == 60 and not getattr(self, "burnt", False):
        self.burnt = True
        end = time.process_time() + 2.0  # 2 CPU-seconds before the twin moves on
        while time.process_time() < end:
            sum(range(1000))
    return real(self, deadline_us, now_us, end_s)
TwinRunner._advance = advance
sys.exit(main(sys.argv[1:]))
"""

FILES = ("odometry.csv", "commands.csv", "ekf.csv", "health.csv")


def _square(tmp_path: Path, name: str, *, busy: bool) -> Path:
    """A ``jackson daemon`` square against ``jackson sim`` (busy: the twin burns 2 CPU-seconds
    on frame 60); the run folder."""
    sim_args = ["sim", "--no-lidar", "--world", "square_room", "--seed", "3"]
    cmd = [sys.executable, "-c", _BUSY_SIM, *sim_args] if busy else [JACKSON, *sim_args]
    twin = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    run = tmp_path / name
    try:
        assert twin.stdout is not None
        serial_path = twin.stdout.readline().split(": ", 1)[1].strip()
        i2c = twin.stdout.readline().split(": ", 1)[1].strip()
        args = ["--port", serial_path, "--i2c", i2c, "--mission", "square", "--run-dir", str(run)]
        daemon = subprocess.run(
            [JACKSON, "daemon", *args],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert daemon.returncode == 0, daemon.stdout + daemon.stderr
    finally:
        twin.send_signal(signal.SIGINT)
        try:
            twin.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            twin.kill()
            twin.communicate()
    return run


def test_a_twin_held_up_past_the_silence_limit_resumes_and_the_run_is_the_idle_one(
    tmp_path: Path,
) -> None:
    idle = _square(tmp_path, "idle", busy=False)
    busy = _square(tmp_path, "busy", busy=True)
    records = list(read_log(busy))
    # the host heard nothing for its silence limit and said HELLO again: two INFOs answered
    infos = [r for r in records if r.kind == KIND_RX and r.payload[0] == Info.TYPE]
    assert len(infos) >= 2
    assert any(r.kind == KIND_LINK and b"silent" in r.payload for r in records)
    # the MCU never saw its host lost, and its telemetry kept the session's schedule
    frames = [
        Telemetry.unpack(r.payload[2:])
        for r in records
        if r.kind == KIND_RX and r.payload[0] == Telemetry.TYPE
    ]
    lost = TelemetryFlags.HOST_LOST | TelemetryFlags.FAILSAFE_ACTIVE
    assert not any(t.flags & lost for t in frames[1:])
    assert {b.t_us - a.t_us for a, b in itertools.pairwise(frames)} == {50_000}
    assert all(t.flags & TelemetryFlags.MOTOR_ENABLE for t in frames[1:])
    # and what the daemon made of it is the idle run's, byte for byte
    for name in FILES:
        assert (busy / name).read_bytes() == (idle / name).read_bytes(), name
