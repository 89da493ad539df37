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
    WORK_SHARE,
    Peer,
    PeerWatch,
    ProcessPeer,
    ThreadPeer,
    pty_peers,
    read_stat,
)
from jackson.host.transport import StallWatch

from ..sil.harness import wait_for

BURN = "import time\nwhile True:\n    sum(range(10000))\n"
SLEEP = "import time\nprint('asleep', flush=True)\ntime.sleep(600)\n"


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
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE)
    procs.append(p)
    return p


def _cpu_s(path: str) -> float:
    return read_stat(path).cpu_s


def _burnt(path: str, cpu_s: float) -> None:
    """Until the process or thread at ``path`` has used ``cpu_s`` more CPU time."""
    start = _cpu_s(path)
    wait_for(lambda: _cpu_s(path) - start >= cpu_s, timeout_s=60, what=f"{cpu_s} CPU-s burnt")


STEP_S = PROBE_S * 1.2  # the looks' spacing, on the watch's own clock (the ``now`` it is given)


def _looks(watch: PeerWatch, n: int, path: str) -> list[object]:
    """``n`` looks a probe interval apart; between two, the peer at ``path`` burns more than a
    working peer must in that interval."""
    t0, out = time.monotonic(), []
    for k in range(n):
        out.append(watch.verdict(t0 + k * STEP_S))
        _burnt(path, 2 * WORK_SHARE * STEP_S)
    return out


def test_a_process_burning_cpu_is_working_and_never_a_stall(
    child: list[subprocess.Popen[bytes]],
) -> None:
    p = _spawn(child, BURN)
    watch = PeerWatch(Peer.of(ProcessPeer(p.pid)), backstop_s=1.0)
    verdicts = _looks(watch, 6, f"/proc/{p.pid}/stat")
    assert verdicts[0] is None  # a first look cannot tell
    assert verdicts[1:].count("working") >= 4, verdicts
    assert not {"gone", "stopped", "idle"} & set(verdicts)


def test_a_sleeping_process_is_idle_only_after_its_backstop(
    child: list[subprocess.Popen[bytes]],
) -> None:
    p = _spawn(child, SLEEP)
    assert p.stdout is not None and p.stdout.readline() == b"asleep\n"  # past its start-up
    watch = PeerWatch(Peer.of(ProcessPeer(p.pid)), backstop_s=2.0)
    t0 = time.monotonic()
    looks = [(k * 0.05, watch.verdict(t0 + k * 0.05)) for k in range(200)]
    idle = next(t for t, v in looks if v is not None)
    assert dict(looks)[idle] == "idle" and 2.0 <= idle < 2.0 + STEP_S
    # said to wait too (a host in this process): idle at the second look
    watch = PeerWatch(Peer.of(ProcessPeer(p.pid)), backstop_s=60.0)
    assert watch.verdict(t0, peer_waits=True) is None
    assert watch.verdict(t0 + STEP_S, peer_waits=True) == "idle"


def test_a_stopped_then_killed_process_is_told_at_the_first_look(
    child: list[subprocess.Popen[bytes]],
) -> None:
    p = _spawn(child, BURN)
    watch = PeerWatch(Peer.of(ProcessPeer(p.pid)))
    os.kill(p.pid, signal.SIGSTOP)
    wait_for(lambda: read_stat(f"/proc/{p.pid}/stat").stopped, timeout_s=30, what="stopped")
    assert watch.verdict(time.monotonic()) == "stopped"
    p.kill()
    p.wait()
    assert watch.verdict(time.monotonic()) == "gone"


def test_a_new_host_process_on_the_port_is_found_and_judged_by_its_own_cpu(
    child: list[subprocess.Popen[bytes]],
) -> None:
    """Each ``jackson calibrate`` run is a new process on the twin's pty: the watch must look at
    the one there now, not at the first it found (gone since, which would make any slow frame
    of a later run count as its host gone)."""
    first = _spawn(child, BURN)
    holders = [ProcessPeer(first.pid)]
    finds: list[int] = []

    def find() -> list[ProcessPeer]:
        finds.append(len(holders))
        return list(holders)

    watch = PeerWatch(Peer(find))
    path = f"/proc/{first.pid}/stat"
    t0 = time.monotonic()
    assert watch.busy(t0) is None  # a first look
    _burnt(path, 2 * WORK_SHARE * STEP_S)
    assert watch.busy(t0 + STEP_S) is True
    first.kill()
    first.wait()
    second = _spawn(child, BURN)  # the next run's host
    holders[:] = [ProcessPeer(second.pid)]
    # within the same wait: the old peer is dead, the new one is found; its CPU time is not
    # compared with the old one's (a first look at it), then it is judged by its own
    assert watch.busy(t0 + 2 * STEP_S) is None
    _burnt(f"/proc/{second.pid}/stat", 2 * WORK_SHARE * STEP_S)
    assert watch.busy(t0 + 3 * STEP_S) is True
    # a new wait finds the peers again even when those found are alive
    n = len(finds)
    watch.reset()
    assert watch.busy(t0 + 4 * STEP_S) is None and len(finds) == n + 1
    second.kill()
    second.wait()
    holders.clear()  # nobody holds the port: gone
    assert watch.busy(t0 + 5 * STEP_S) is False
    assert watch.verdict(t0 + 6 * STEP_S) == "gone"


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
        t0 = time.monotonic()
        hot_v, cold_v = [], []
        for k in range(5):
            hot_v.append(hot.verdict(t0 + k * STEP_S))
            cold_v.append(cold.verdict(t0 + k * STEP_S))
            _burnt(f"/proc/self/task/{burner.native_id}/stat", 2 * WORK_SHARE * STEP_S)
    finally:
        stop.set()
        burner.join()
        sleeper.join()
    assert hot_v[1:].count("working") >= 3, hot_v
    assert "working" not in cold_v and cold_v[-1] == "idle", cold_v
    # join() returns just before the kernel's thread ends: its entry goes a moment later
    gone = PeerWatch(Peer.of(ThreadPeer(sleeper.native_id)))
    wait_for(
        lambda: not read_stat(f"/proc/self/task/{sleeper.native_id}/stat").alive,
        timeout_s=30,
        what="the thread's entry gone",
    )
    assert gone.verdict(time.monotonic()) == "gone"


def test_the_processes_behind_a_pty_are_found(child: list[subprocess.Popen[bytes]]) -> None:
    master, slave = os.openpty()
    name = os.ttyname(slave)
    os.close(slave)
    try:
        assert pty_peers(name, master=True) is None  # this process holds the master itself
        code = f"import os, time\nos.open({name!r}, os.O_RDWR | os.O_NOCTTY)\ntime.sleep(600)\n"
        p = _spawn(child, code)
        wait_for(lambda: bool(pty_peers(name, master=False)), timeout_s=30, what="the pty held")
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
    later_ns = time.monotonic_ns() + 200_000_000  # 0.2 s on, past the 0.1 s limit
    for _ in range(3):
        assert watch.check(later_ns, in_session=False) is None
    assert watch.check(later_ns, in_session=True) is None  # judged: one more read
    event = watch.check(later_ns, in_session=True)
    assert event is not None and event.kind == "stalled"
    assert event.detail.endswith(": the twin did no work")
