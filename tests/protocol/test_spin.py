"""Brief busy-polling before blocking (jackson.common.spin)."""

from __future__ import annotations

import os
import socket
import time
from pathlib import Path

from jackson.common.spin import peer_is_this_process, spin_poll


def test_a_ready_poll_returns_at_once_without_spinning() -> None:
    calls = []
    assert spin_poll(lambda: calls.append(1) or ["event"], 1.0) == ["event"]
    assert len(calls) == 1


def test_polls_until_something_arrives() -> None:
    calls = []

    def poll() -> list[str]:
        calls.append(1)
        return ["event"] if len(calls) == 5 else []

    assert spin_poll(poll, 1.0) == ["event"]
    assert len(calls) == 5


def test_gives_up_after_spin_s_with_the_last_falsy_result() -> None:
    t0 = time.perf_counter()
    assert spin_poll(lambda: [], 0.002) == []
    elapsed = time.perf_counter() - t0
    assert 0.002 <= elapsed < 0.5


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
