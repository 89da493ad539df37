"""A lockstep end judges the other by its liveness, not by how long it takes.

The verdicts of :class:`~jackson.common.liveness.PeerWatch` on real processes: one that burns
CPU is working however long it takes, a stopped or dead one is told at the first look, one that
sleeps is idle only after its backstop; and the processes behind a pty are found.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import pytest

from jackson.common.liveness import (
    PROBE_S,
    Peer,
    PeerWatch,
    ProcessPeer,
    ThreadPeer,
    pty_peers,
)
from jackson.host.transport import StallWatch

BURN = "import time\nwhile True:\n    sum(range(10000))\n"
SLEEP = "import time\ntime.sleep(600)\n"


@pytest.fixture
def child() -> Iterator[list[subprocess.Popen[bytes]]]:
    procs: list[subprocess.Popen[bytes]] = []
    yield procs
    for p in procs:
        if p.poll() is None:
            os.kill(p.pid, signal.SIGCONT)
            p.kill()
            p.wait()


def _spawn(procs: list[subprocess.Popen[bytes]], code: str) -> subprocess.Popen[bytes]:
    p = subprocess.Popen([sys.executable, "-c", code])
    procs.append(p)
    return p


def _looks(watch: PeerWatch, n: int) -> list[object]:
    """``n`` looks, each a probe interval after the last."""
    out: list[object] = []
    for _ in range(n):
        out.append(watch.verdict(time.monotonic()))
        time.sleep(PROBE_S * 1.2)
    return out


def test_a_process_burning_cpu_is_working_and_never_a_stall(
    child: list[subprocess.Popen[bytes]],
) -> None:
    p = _spawn(child, BURN)
    watch = PeerWatch(Peer.of(ProcessPeer(p.pid)), backstop_s=1.0)
    verdicts = _looks(watch, 6)
    assert verdicts[0] is None  # a first look cannot tell
    assert verdicts[1:].count("working") >= 4, verdicts
    assert not {"gone", "stopped", "idle"} & set(verdicts)


def test_a_sleeping_process_is_idle_only_after_its_backstop(
    child: list[subprocess.Popen[bytes]],
) -> None:
    p = _spawn(child, SLEEP)
    time.sleep(0.5)  # past its start-up
    watch = PeerWatch(Peer.of(ProcessPeer(p.pid)), backstop_s=2.0)
    t0 = time.monotonic()
    verdict = None
    while verdict is None and time.monotonic() - t0 < 30:
        verdict = watch.verdict(time.monotonic())
        time.sleep(0.05)
    assert verdict == "idle"
    assert 2.0 <= time.monotonic() - t0 < 5.0
    # said to wait too (a host in this process): idle at the second look
    watch = PeerWatch(Peer.of(ProcessPeer(p.pid)), backstop_s=60.0)
    assert watch.verdict(time.monotonic(), peer_waits=True) is None
    time.sleep(PROBE_S * 1.2)
    assert watch.verdict(time.monotonic(), peer_waits=True) == "idle"


def test_a_stopped_then_killed_process_is_told_at_the_first_look(
    child: list[subprocess.Popen[bytes]],
) -> None:
    p = _spawn(child, BURN)
    watch = PeerWatch(Peer.of(ProcessPeer(p.pid)))
    os.kill(p.pid, signal.SIGSTOP)
    time.sleep(0.2)
    assert watch.verdict(time.monotonic()) == "stopped"
    p.kill()
    p.wait()
    assert watch.verdict(time.monotonic()) == "gone"


def test_a_thread_of_this_process_is_judged_by_its_own_cpu_time() -> None:
    stop = threading.Event()

    def burn() -> None:
        while not stop.is_set():
            sum(range(10000))

    burner = threading.Thread(target=burn, daemon=True)
    sleeper = threading.Thread(target=stop.wait, daemon=True)
    burner.start()
    sleeper.start()
    try:
        assert burner.native_id is not None and sleeper.native_id is not None
        hot = PeerWatch(Peer.of(ThreadPeer(burner.native_id)))
        cold = PeerWatch(Peer.of(ThreadPeer(sleeper.native_id)), backstop_s=1.0)
        hot_v = [hot.verdict(time.monotonic()) for _ in range(1)]
        cold_v = [cold.verdict(time.monotonic())]
        for _ in range(4):
            time.sleep(PROBE_S * 1.2)
            hot_v.append(hot.verdict(time.monotonic()))
            cold_v.append(cold.verdict(time.monotonic()))
    finally:
        stop.set()
        burner.join()
        sleeper.join()
    assert hot_v[1:].count("working") >= 3, hot_v
    assert "working" not in cold_v and cold_v[-1] == "idle", cold_v
    # join() returns just before the kernel's thread ends: its entry goes a moment later
    gone = PeerWatch(Peer.of(ThreadPeer(sleeper.native_id)))
    deadline = time.monotonic() + 30
    while gone.verdict(time.monotonic()) != "gone" and time.monotonic() < deadline:
        gone.reset()
        time.sleep(0.01)
    assert gone.verdict(time.monotonic()) == "gone"


def test_the_processes_behind_a_pty_are_found(child: list[subprocess.Popen[bytes]]) -> None:
    master, slave = os.openpty()
    name = os.ttyname(slave)
    os.close(slave)
    try:
        assert pty_peers(name, master=True) is None  # this process holds the master itself
        code = f"import os, time\nos.open({name!r}, os.O_RDWR | os.O_NOCTTY)\ntime.sleep(600)\n"
        p = _spawn(child, code)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not pty_peers(name, master=False):
            time.sleep(0.05)
        assert pty_peers(name, master=False) == [ProcessPeer(p.pid)]
        p.kill()
        p.wait()
        assert pty_peers(name, master=False) == []  # the other end is gone
        assert pty_peers("/nonexistent/pts/9", master=False) is None
    finally:
        os.close(master)


def test_a_device_that_never_answers_the_hello_is_not_a_stall() -> None:
    """Before the session the host waits for an INFO: silence, not a lockstep stall."""
    watch = StallWatch()
    watch.limit_s = 0.1
    watch.peer = PeerWatch(None, backstop_s=0.0)
    watch.waiting()
    time.sleep(0.2)
    for _ in range(3):
        assert watch.check(time.monotonic_ns(), in_session=False) is None
    assert watch.check(time.monotonic_ns(), in_session=True) is None  # judged: one more read
    event = watch.check(time.monotonic_ns(), in_session=True)
    assert event is not None and event.kind == "stalled"
    assert event.detail.endswith(": the twin did no work")
