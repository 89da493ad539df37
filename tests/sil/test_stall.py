"""A lockstep that stands still ends, with one line naming who waited for what; a slow one does
not.

The twin and the host hand the turn back and forth every telemetry frame. When one of them stops
(a stopped process, a frame that never arrives) the other waits for ever; each end now gives up
after its stall limit of waiting. These tests stop the other end for real (SIGSTOP of a ``jackson
sim`` process, a frame swallowed on the pty inside a campaign trial) and check the line, the exit,
the brake and what the run folder and ``jackson replay`` say; and that a host working slowly on a
frame, or a twin answering late, is never taken for a stopped one.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import re
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

from jackson.common.liveness import STALL_EXIT
from jackson.experiments.stall_retry import stall_lines
from jackson.experiments.trial import TrialSpec, cut_reason, run_trial
from jackson.host.core import CoreListener, FrameResult
from jackson.host.replay import replay
from jackson.sim.link import PtyLink
from jackson.sim.runner import read_truth

from .harness import JACKSON, TwinThread, in_process_daemon, wait_for

HOST_LINE = re.compile(
    r"lockstep stalled: the host waited (\d+\.\d) s for a telemetry frame after frame (\d+) "
    r"\(MCU time (\d+\.\d\d) s\): the twin (process is stopped|process is gone|did no work)"
)
TWIN_LINE = re.compile(
    r"lockstep stalled: the twin waited (\d+\.\d) s for the host's HEARTBEAT after frame (\d+) "
    r"\(sim time (\d+\.\d\d) s\): the host (process is stopped|process is gone|did no work)"
)


def _sim(*args: str) -> tuple[subprocess.Popen[str], str, str]:
    """``jackson sim ARGS`` and where a host connects: its serial pty and I2C socket."""
    twin = subprocess.Popen(
        [JACKSON, "sim", "--no-lidar", "--world", "square_room", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert twin.stdout is not None
    serial_path = twin.stdout.readline().split(": ", 1)[1].strip()
    i2c = twin.stdout.readline().split(": ", 1)[1].strip()
    return twin, serial_path, i2c


def _daemon(serial_path: str, i2c: str, run: Path) -> subprocess.Popen[str]:
    """``jackson daemon`` driving the square against the twin, recording into ``run``."""
    args = ["--port", serial_path, "--i2c", i2c, "--mission", "square", "--run-dir", str(run)]
    return subprocess.Popen(
        [JACKSON, "daemon", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def test_a_stopped_twin_process_ends_the_daemon_braked_and_replay_calls_the_run_cut(
    tmp_path: Path,
) -> None:
    """``jackson sim`` and ``jackson daemon`` as a user runs them; the twin is stopped mid-square.
    The daemon gives up after its default limit (10 s), on the abort path: one line, exit 75, the
    brake written to the PCA9685 (it lands when the twin runs again) and SHUTDOWN said."""
    truth = tmp_path / "truth.csv"
    run = tmp_path / "run"
    twin, serial_path, i2c = _sim("--truth", str(truth))
    daemon = _daemon(serial_path, i2c, run)
    stopped = False
    try:
        # the robot drives the square's first side (it starts after 2 s standing still)
        wait_for(lambda: read_truth(truth).x_m[-1] > 0.3, timeout_s=120, what="the robot moving")
        os.kill(twin.pid, signal.SIGSTOP)
        stopped = True
        t_stop = time.monotonic()
        t_sim = read_truth(truth).t_us[-1] / 1e6
        out, err = daemon.communicate(timeout=120)
        waited_wall = time.monotonic() - t_stop
        assert daemon.returncode == STALL_EXIT, err
        assert "Traceback" not in err and err == ""
        lines = [ln for ln in out.splitlines() if "lockstep stalled" in ln]
        said = HOST_LINE.search(lines[0])
        assert lines[0].startswith("daemon: lockstep stalled: ") and said is not None, out
        assert 10.0 <= float(said[1]) < 11.0 and said[4] == "process is stopped"
        assert abs(float(said[3]) - t_sim) <= 0.05  # the last frame it had
        assert waited_wall >= 10.0
        # the abort path: the usual abort line names the stall and says braked
        assert any(ln.startswith("mission square aborted: lockstep stalled") for ln in lines)
        health = json.loads((run / "health.json").read_text())
        assert health["abort_reason"].startswith("lockstep stalled: the host waited")
        # the twin runs again: the brake the daemon wrote (and its SHUTDOWN) stop the robot
        os.kill(twin.pid, signal.SIGCONT)
        stopped = False
        wait_for(
            lambda: read_truth(truth).t_us[-1] / 1e6 > t_sim + 1.0,
            timeout_s=60,
            what="the twin running on after SIGCONT",
        )
        track = read_truth(truth)
        t = track.t_us / 1e6
        after = (t >= t_sim + 0.2) & (t <= t_sim + 1.0)
        moved = math.hypot(
            track.x_m[after][-1] - track.x_m[after][0], track.y_m[after][-1] - track.y_m[after][0]
        )
        assert moved < 1e-3  # standing still from 0.2 s after the last frame the host had
    finally:
        if stopped:
            os.kill(twin.pid, signal.SIGCONT)
        if daemon.poll() is None:
            daemon.kill()
            daemon.communicate()
        twin.send_signal(signal.SIGTERM)
        twin.communicate(timeout=30)
    r = replay(run, tmp_path / "replay")
    assert not r.complete and r.cut_reason is not None
    assert HOST_LINE.fullmatch(r.cut_reason) and r.how().startswith("cut (lockstep stalled: ")
    assert not r.differ  # every row the run kept is reproduced


def test_a_stopped_daemon_ends_a_twin_that_waits_for_it(tmp_path: Path) -> None:
    """``jackson sim`` waiting without a heartbeat timeout (``--heartbeat-timeout`` longer than
    ``--stall-timeout``) gives up 2 s after the daemon was stopped: one line on stderr, exit 75."""
    twin, serial_path, i2c = _sim("--heartbeat-timeout", "3600", "--stall-timeout", "2")
    run = tmp_path / "run"
    daemon = _daemon(serial_path, i2c, run)
    try:
        wait_for(
            lambda: len((run / "odometry.csv").read_text().splitlines()) > 40,
            timeout_s=120,
            what="the daemon's first 2 s",
        )
        os.kill(daemon.pid, signal.SIGSTOP)
        t_stop = time.monotonic()
        out, err = twin.communicate(timeout=120)
        waited_wall = time.monotonic() - t_stop
    finally:
        os.kill(daemon.pid, signal.SIGCONT)
        daemon.kill()
        daemon.communicate()
    assert twin.returncode == STALL_EXIT
    assert err.count("\n") == 1 and "Traceback" not in err
    said = TWIN_LINE.fullmatch(err.strip().removeprefix("jackson sim: "))
    assert said is not None, err
    assert 2.0 <= float(said[1]) < 3.0 and int(said[2]) > 40
    assert said[4] == "process is stopped"
    assert waited_wall >= 2.0
    assert "telemetry frames" in out  # the summary first, as on any way out


def _swallow_telemetry_frame(monkeypatch: pytest.MonkeyPatch, n: int) -> None:
    """Telemetry frame ``n`` goes missing on the pty and nobody knows (the twin waits for its
    HEARTBEAT, the host for a frame): the deadlock a campaign met under heavy load."""
    real = PtyLink.write
    count = itertools.count()

    def write(self: PtyLink, frame: bytes) -> bool:
        if frame[3] == 0x01 and next(count) == n:
            return True
        return real(self, frame)

    monkeypatch.setattr(PtyLink, "write", write)


def test_a_trial_in_deadlock_is_cut_with_its_reason_and_replay_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _swallow_telemetry_frame(monkeypatch, 160)  # 8 s into the square: it drives
    out = tmp_path / "run"
    t0 = time.monotonic()
    spec = TrialSpec("square", 0, 3, "jackson", "square_room", out, stall_s=2.0)
    r = run_trial(spec, retry_stall=False)
    assert time.monotonic() - t0 < 120
    assert not r["completed"]
    reason = r["failure"]
    assert reason.startswith("not ended: lockstep stalled: "), reason
    line = reason.removeprefix("not ended: ")
    said = TWIN_LINE.fullmatch(line) or HOST_LINE.fullmatch(line)
    assert said is not None, reason
    assert 2.0 <= float(said[1]) < 4.0  # the limit, then two looks at the other's thread
    assert said[4] == "did no work"  # both ends alive, neither working: a deadlock
    assert abs(float(said[3]) - 8.0) <= 0.1  # where the frame went missing
    assert json.loads((out / "metrics.json").read_text())["failure"] == reason
    # the host ended on the abort path too, and its log says why
    health = json.loads((out / "health.json").read_text())
    assert health["abort_reason"].startswith("lockstep stalled: the host waited")
    rep = replay(out, tmp_path / "replay")
    assert rep.cut_reason == health["abort_reason"] and not rep.complete and not rep.differ


class _SlowHost(CoreListener):
    """A host that takes ``seconds`` of wall time over frame ``at`` (a long replan; a process the
    machine keeps from running): the behaviour under test, not a wait of the test's."""

    def __init__(self, at: int, seconds: float) -> None:
        self.at, self.seconds = at, seconds
        self.slow_done = threading.Event()

    def on_result(self, result: FrameResult) -> None:
        if result.frame == self.at:
            threading.Event().wait(self.seconds)
            self.slow_done.set()


def test_a_host_in_the_same_process_working_slowly_is_not_a_stall(tmp_path: Path) -> None:
    """Wired as a campaign trial wires them (each end sees whether the other waits or works),
    a host that spends 3 s on one frame stalls neither end at a 1 s limit."""
    twin = TwinThread(tmp_path, world="open_floor", heartbeat_timeout_s=math.inf, stall_s=None)
    daemon = in_process_daemon(twin)
    transport = daemon.transport
    transport.peer_waiting = lambda: twin.runner.waiting_since
    twin.runner.host_waiting = lambda: transport.waiting_since
    transport.stall_s = twin.runner.stall_s = 1.0  # both ends wired first, as twin_session does
    slow = _SlowHost(at=20, seconds=3.0)
    daemon.core.listeners.append(slow)
    status: list[int] = []
    thread = threading.Thread(target=lambda: status.append(daemon.run(max_s=120.0)), daemon=True)
    thread.start()
    try:
        wait_for(slow.slow_done.is_set, timeout_s=60, what="the slow frame")
        wait_for(lambda: daemon.core.frames >= 60, timeout_s=60, what="40 frames more")
    finally:
        daemon.stop.set()
        thread.join(timeout=30)
        transport.close()
        twin.stop()
    assert twin.runner.stalled is None and daemon.stalled is None
    assert status == [0]


def test_a_trial_stopped_by_the_wall_clock_backstop_says_so(tmp_path: Path) -> None:
    """The daemon's wall-clock limit (a trial's backstop) ends a run with a reason, not None."""
    twin = TwinThread(tmp_path, world="open_floor")
    daemon = in_process_daemon(twin)
    try:
        status = daemon.run(max_s=1.0)
    finally:
        daemon.transport.close()
        twin.stop()
    assert status == 0 and daemon.wall_limit_hit and daemon.stalled is None
    t = daemon.core.t_s  # None when a busy machine let no frame through in that second
    at = "before the first frame" if t is None else f"at {t:.2f} s of MCU time"
    assert cut_reason(daemon, "navigate") == (
        f"not ended: wall-clock backstop: 1800 s of wall time passed {at} "
        "(the mission's limit is 180 s of MCU time)"
    )
    assert cut_reason(daemon, "navigate", "lockstep stalled: x") == (
        "not ended: lockstep stalled: x"
    )


_BUSY_DAEMON = """
import sys, time
from jackson.host.daemon import Daemon
from jackson.main import main

real = Daemon._on_frame
def on_frame(self, frame, rx_ns):
    if self.core.frames == 40 and not getattr(self, "burnt", False):
        self.burnt = True
        end = time.process_time() + {burn_s}  # {burn_s} CPU-seconds on one frame, then on
        while time.process_time() < end:
            sum(range(1000))
        print("daemon: burnt", flush=True)
    return real(self, frame, rx_ns)
Daemon._on_frame = on_frame
sys.exit(main(sys.argv[1:]))
"""


def _busy_daemon(serial_path: str, i2c: str, run: Path, burn_s: float) -> subprocess.Popen[str]:
    """``jackson daemon --mission square`` that burns ``burn_s`` CPU-seconds on frame 40."""
    import sys

    args = ["daemon", "--port", serial_path, "--i2c", i2c, "--mission", "square"]
    return subprocess.Popen(
        [sys.executable, "-c", _BUSY_DAEMON.format(burn_s=burn_s), *args, "--run-dir", str(run)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _past_the_busy_frame(daemon: subprocess.Popen[str], run: Path) -> None:
    """Until the daemon has burnt its CPU-seconds and 40 more frames are in its run."""
    assert daemon.stdout is not None
    for line in daemon.stdout:
        if line.startswith("daemon: burnt"):
            break
    wait_for(
        lambda: len((run / "odometry.csv").read_text().splitlines()) > 80,
        timeout_s=120,
        what="40 frames after the busy one",
    )


def test_a_host_process_busy_far_past_the_limit_is_waited_for_and_a_killed_one_is_a_stall(
    tmp_path: Path,
) -> None:
    """``jackson sim`` with a 1 s stall limit, and a daemon that burns 4 CPU-seconds on one
    frame (a start-up, a long replan on a busy machine): the twin waits, the square drives on.
    The daemon is then killed: the twin tells it as a stall (the host gone) within a second of
    its limit, exit status 75."""

    twin, serial_path, i2c = _sim("--heartbeat-timeout", "3600", "--stall-timeout", "1")
    run = tmp_path / "run"
    daemon = _busy_daemon(serial_path, i2c, run, burn_s=4.0)
    try:
        _past_the_busy_frame(daemon, run)
        assert twin.poll() is None  # waited for the busy host, 4 times its limit
        daemon.kill()
        daemon.wait(timeout=30)
        killed = time.monotonic()
        _, err = twin.communicate(timeout=120)
        waited_wall = time.monotonic() - killed
    finally:
        if daemon.poll() is None:
            daemon.kill()
        daemon.communicate()
        if twin.poll() is None:
            twin.kill()
            twin.communicate()
    assert twin.returncode == STALL_EXIT, err
    said = TWIN_LINE.fullmatch(err.strip().removeprefix("jackson sim: "))
    assert said is not None, err
    assert said[4] == "process is gone" and int(said[2]) > 80
    assert 1.0 <= float(said[1]) < 3.0 and waited_wall < 30


def test_a_stalled_trial_is_run_once_more_and_told_apart(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A campaign's trial cut by a stall (one frame lost, once) is run again: the retry's result
    counts, and it says which stall it replaced."""
    _swallow_telemetry_frame(monkeypatch, 160)  # the first attempt only
    out = tmp_path / "run"
    r = run_trial(TrialSpec("square", 0, 3, "jackson", "square_room", out, stall_s=2.0))
    assert r["completed"] and not r["stalled"], r.get("failure")
    assert r["stall_retried"].startswith("not ended: lockstep stalled: ")
    assert json.loads((out / "metrics.json").read_text())["stall_retried"] == r["stall_retried"]
    assert stall_lines([r], lambda _: "R01") == [
        "",
        "Runs retried after a lockstep stall (the retry counts):",
        "",
        f"- R01: {r['stall_retried']}",
    ]


def test_a_host_busy_past_the_heartbeat_timeout_keeps_the_twin_in_lockstep(
    tmp_path: Path,
) -> None:
    """``jackson sim --heartbeat-timeout 0.5`` and a daemon that burns 2 CPU-seconds on one
    frame: the host is slow, not gone, so the twin waits in lockstep instead of running on in
    real time; the MCU never sees the host lost, and every frame reaches the host."""

    from jackson.host.recording import KIND_RX, read_log
    from jackson.protocol import Telemetry, TelemetryFlags

    twin, serial_path, i2c = _sim("--heartbeat-timeout", "0.5", "--stall-timeout", "3600")
    run = tmp_path / "run"
    daemon = _busy_daemon(serial_path, i2c, run, burn_s=2.0)
    try:
        _past_the_busy_frame(daemon, run)
        daemon.send_signal(signal.SIGINT)
        daemon.communicate(timeout=60)
    finally:
        if daemon.poll() is None:
            daemon.kill()
            daemon.communicate()
        twin.send_signal(signal.SIGINT)
        try:
            twin.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            twin.kill()
            twin.communicate()
    frames = [
        Telemetry.unpack(r.payload[2:])
        for r in read_log(run)
        if r.kind == KIND_RX and r.payload[0] == Telemetry.TYPE
    ]
    assert len(frames) > 80
    lost = TelemetryFlags.HOST_LOST | TelemetryFlags.FAILSAFE_ACTIVE
    assert not any(t.flags & lost for t in frames[1:80])  # the first one: before any HEARTBEAT
    steps = {b.t_us - a.t_us for a, b in itertools.pairwise(frames[:80])}
    assert steps == {50_000}  # no frame lost while the host was busy
