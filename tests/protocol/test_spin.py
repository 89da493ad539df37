"""Brief busy-polling before blocking (jackson.common.spin)."""

from __future__ import annotations

import os
import socket
import time
from pathlib import Path

import pytest

from jackson.common import spin
from jackson.common.spin import peer_is_this_process, spin_poll


def test_a_ready_poll_returns_at_once_without_spinning() -> None:
    calls = []
    assert spin_poll(lambda: calls.append(1) or ["event"], 1.0) == ["event"]
    assert len(calls) == 1


class SteadyCore:
    """A core nobody else wants: a clock that moves 1 us per reading, yields that return at
    once (so another process's load on the test machine cannot end a spin early)."""

    def __init__(self) -> None:
        self.now = 0.0

    def perf_counter(self) -> float:
        self.now += 1e-6
        return self.now


@pytest.fixture
def steady(monkeypatch: pytest.MonkeyPatch) -> SteadyCore:
    core = SteadyCore()
    monkeypatch.setattr(spin, "contention", spin._Contention())
    monkeypatch.setattr(spin.time, "perf_counter", core.perf_counter)
    monkeypatch.setattr(spin.os, "sched_yield", lambda: None)
    return core


def test_polls_until_something_arrives(steady: SteadyCore) -> None:
    calls = []

    def poll() -> list[str]:
        calls.append(1)
        return ["event"] if len(calls) == 5 else []

    assert spin_poll(poll, 1.0) == ["event"]
    assert len(calls) == 5


def test_gives_up_after_spin_s_with_the_last_falsy_result(steady: SteadyCore) -> None:
    calls = []
    t0 = steady.now
    assert spin_poll(lambda: calls.append(1) or [], 0.002) == []
    assert 0.002 <= steady.now - t0 < 0.003  # one clock reading per poll after the first
    assert 1900 <= len(calls) <= 2002


def test_really_spins_for_spin_s_on_an_idle_core(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(spin, "contention", spin._Contention())
    t0 = time.perf_counter()
    assert spin_poll(lambda: [], 0.002) == []
    elapsed = time.perf_counter() - t0
    # at least the spin, unless a yield was stolen (a busy test machine): then it stops early
    assert elapsed >= 0.002 or spin.contention.stolen == 1
    assert elapsed < 0.5


def test_zero_spin_polls_once() -> None:
    calls = []
    assert spin_poll(lambda: calls.append(1) or None, 0.0) is None
    assert len(calls) == 1


def test_peer_in_this_process(tmp_path: Path) -> None:
    path = str(tmp_path / "s.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(path)
    server.listen()
    with server, socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:
        client.connect(path)
        conn, _ = server.accept()
        with conn:
            assert peer_is_this_process(client)
            assert peer_is_this_process(conn)


def test_peer_in_another_process(tmp_path: Path) -> None:
    a, b = socket.socketpair()
    with a, b:
        assert peer_is_this_process(a)  # a socketpair's ends are both this process
    path = str(tmp_path / "s.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(path)
    server.listen()
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        c = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        c.connect(path)
        os.read(r, 1)  # hold the connection until the parent has looked
        os._exit(0)
    try:
        conn, _ = server.accept()
        with conn:
            assert not peer_is_this_process(conn)
    finally:
        os.write(w, b"x")
        os.waitpid(pid, 0)
        server.close()


def test_not_a_unix_socket() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        assert not peer_is_this_process(s)


def test_a_stolen_yield_stops_the_spin_and_the_next_waits_block_at_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(spin, "contention", spin._Contention())
    clock = [0.0]  # a clock that moves 1 us per reading, and 2 ms over a stolen yield
    stolen = [True]

    def perf_counter() -> float:
        clock[0] += 1e-6
        return clock[0]

    def sched_yield() -> None:
        if stolen[0]:  # another process had the core
            clock[0] += 2 * spin.STOLEN_S

    monkeypatch.setattr(spin.time, "perf_counter", perf_counter)
    monkeypatch.setattr(spin.os, "sched_yield", sched_yield)
    calls = []
    assert spin_poll(lambda: calls.append(1) or [], 1.0) == []
    assert len(calls) == 2  # the first poll, one yield (stolen), one poll: then it gave up
    assert spin.contention.stolen == 1
    assert spin.contention.backoff == spin.BACKOFF_WAITS
    stolen[0] = False
    for _ in range(spin.BACKOFF_WAITS):  # each wait polls once and blocks
        calls.clear()
        assert spin_poll(lambda: calls.append(1) or [], 1.0) == []
        assert len(calls) == 1
    calls.clear()
    ready = spin_poll(lambda: calls.append(1) or (["event"] if len(calls) == 3 else []), 1.0)
    assert ready == ["event"]  # the backoff is over: it spins again
    assert len(calls) == 3
    assert spin.contention.stolen == 1


def test_the_cpu_time_spent_spinning_is_counted(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(spin, "contention", spin._Contention())
    assert spin_poll(lambda: [], 0.005) == []
    assert 0.0 < spin.contention.spun_s < 1.0
    before = spin.contention.spun_s
    assert spin_poll(lambda: ["event"], 0.005) == ["event"]  # ready at once: no spin
    assert spin.contention.spun_s == before
