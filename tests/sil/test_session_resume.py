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
from jackson.host.transport import LinkEvent, SerialTransport
from jackson.protocol import Heartbeat, Info, Telemetry, TelemetryFlags, decode_message

from .harness import JACKSON, TwinThread, wait_for

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


def test_a_new_session_releases_the_twin_from_the_last_frame_of_the_one_before(
    tmp_path: Path,
) -> None:
    """One host's session ends without a HEARTBEAT for the last frame it was sent (a
    calibration's run ends; the next run of the same process opens the port at once). The new
    session's HELLO must release the lockstep twin: it streams the new session's telemetry at
    once, without judging any host gone (which a host still busy in the same process never is).
    """
    twin = TwinThread(tmp_path, heartbeat_timeout_s=600.0, stall_s=None)
    try:

        def session(frames: int, ack_last: bool) -> int:
            """Open the port, take ``frames`` telemetry frames (a HEARTBEAT for each but,
            unless ``ack_last``, the last), close it; the last frame's MCU time [us]."""
            link = SerialTransport(twin.serial)
            link.open(reader_thread=False)
            got, t_us = 0, 0
            try:
                while got < frames:
                    item = link.get(120.0)  # a far backstop: the twin answers in microseconds
                    assert item is not None, f"no telemetry after {got} frames"
                    if isinstance(item, LinkEvent):
                        continue
                    msg = decode_message(item[1])
                    if isinstance(msg, Telemetry):
                        got += 1
                        t_us = msg.t_us
                        if got < frames or ack_last:
                            link.send(Heartbeat(ack_seq=item[1].seq))
            finally:
                link.close()
            return t_us

        first_end = session(10, ack_last=False)  # the twin now waits for frame 10's HEARTBEAT
        wait_for(
            lambda: twin.runner.watch.waiting_since is not None,
            timeout_s=120.0,
            what="the twin to wait for the first session's last HEARTBEAT",
        )
        second_end = session(5, ack_last=True)
        assert twin.runner.watch.timeouts == 0  # nobody was judged gone: the HELLO released it
        assert second_end > first_end
    finally:
        twin.stop()


_HOST = """
import sys, time
from jackson.host.transport import LinkEvent, SerialTransport
from jackson.protocol import Heartbeat, Telemetry, TelemetryFlags, decode_message

LOST = TelemetryFlags.HOST_LOST | TelemetryFlags.FAILSAFE_ACTIVE
port, frames, busy_at, busy_s = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
link = SerialTransport(port)
link.open(reader_thread=False)
got, lost, times = 0, 0, []
while got < frames:
    item = link.get(120.0)  # a far backstop
    if item is None:
        sys.exit(f"no telemetry after {got} frames")
    if isinstance(item, LinkEvent):
        continue
    msg = decode_message(item[1])
    if not isinstance(msg, Telemetry):
        continue
    got += 1
    times.append(msg.t_us)
    # the session's first frame is before any HEARTBEAT (the interlock waits for one)
    lost += got > 1 and bool(msg.flags & LOST)
    if got == busy_at:  # a long computation on this frame: working on it, not answering
        end = time.monotonic() + busy_s
        while time.monotonic() < end:
            sum(range(1000))
    if got < frames:
        link.send(Heartbeat(ack_seq=item[1].seq))
link.close()
gaps = sorted({b - a for a, b in zip(times[1:], times[2:])})
print(lost, *gaps)
"""


def _host(port: str, frames: int, busy_at: int = 0, busy_s: float = 0.0) -> list[int]:
    """A host process on the twin's port: ``frames`` telemetry frames, each answered but the
    last; on frame ``busy_at`` it computes for ``busy_s`` of wall time first. The frames that
    carried the MCU's host-lost or failsafe flag, then the distinct gaps between frames [us]."""
    done = subprocess.run(
        [sys.executable, "-c", _HOST, port, str(frames), str(busy_at), str(busy_s)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    return [int(w) for w in done.stdout.split()]


def test_a_later_host_process_busy_on_a_frame_is_waited_for_not_judged_gone(
    tmp_path: Path,
) -> None:
    """Each run of ``jackson calibrate`` (or a restarted daemon) is a new process on the twin's
    pty. The twin must judge the host there now: judging the first one it found, gone since,
    made any later host that took longer than ``--heartbeat-timeout`` on a frame count as gone,
    and the twin ran on in real time under it (a step then started late on the MCU's clock)."""
    stderr = tmp_path / "sim.err"
    with stderr.open("w") as err:
        twin = subprocess.Popen(
            [JACKSON, "sim", "--no-lidar", "--heartbeat-timeout", "1"],
            stdout=subprocess.PIPE,
            stderr=err,
            text=True,
        )
    try:
        assert twin.stdout is not None
        port = twin.stdout.readline().split(": ", 1)[1].strip()
        twin.stdout.readline()  # i2c
        # the first host leaves without answering its last frame: the twin judges it gone
        assert _host(port, 10)[0] == 0
        wait_for(
            lambda: "no HEARTBEAT" in stderr.read_text(),
            timeout_s=120.0,
            what="the twin to judge the first host gone",
        )
        # the second works 3 s (three heartbeat timeouts) on its 20th frame
        lost, *gaps = _host(port, 40, busy_at=20, busy_s=3.0)
        assert lost == 0 and gaps == [50_000], (lost, gaps, stderr.read_text())
        # the third is slow to start: 2 s on its session's first frame, before any HEARTBEAT.
        # Its HELLO shows it is there: the twin, which judged the second gone when it left,
        # waits for it in lockstep instead of streaming the session on in real time
        wait_for(
            lambda: stderr.read_text().count("no HEARTBEAT") >= 2,
            timeout_s=120.0,
            what="the twin to judge the second host gone",
        )
        lost, *gaps = _host(port, 20, busy_at=1, busy_s=2.0)
        assert lost == 0 and gaps == [50_000], (lost, gaps, stderr.read_text())
    finally:
        twin.send_signal(signal.SIGINT)
        twin.communicate(timeout=60)
    lines = stderr.read_text().splitlines()
    # told: the first host gone (and how it was found), then the second's first HEARTBEAT;
    # nothing while the second worked on its frame (a line at its end may follow)
    assert lines[0].startswith("jackson sim: no HEARTBEAT for 1.0 s after frame 10 "), lines
    assert lines[0].endswith(
        "and the host is gone: the twin runs on in real time until the host answers"
    )
    assert lines[1].startswith(
        "jackson sim: the host is back (a HEARTBEAT or a new session's HELLO) at sim time "
    ), lines
    assert lines[1].endswith(" s in real time: lockstep again"), lines
    assert not any("frame 3" in ln for ln in lines[2:]), lines
    assert sum(ln.startswith("jackson sim: the host is back") for ln in lines) == 2, lines
