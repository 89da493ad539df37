"""systemd notifications over a real datagram socket, as systemd receives them."""

from __future__ import annotations

import os
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from jackson.host.sdnotify import SystemdNotifier, notifier_from_env, watchdog_period_s


@pytest.fixture
def notify_socket(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[socket.socket]:
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(tmp_path / "notify"))
    sock.settimeout(5)
    monkeypatch.setenv("NOTIFY_SOCKET", str(tmp_path / "notify"))
    monkeypatch.delenv("WATCHDOG_USEC", raising=False)
    yield sock
    sock.close()


def received(sock: socket.socket) -> list[str]:
    """Every datagram waiting on ``sock``."""
    sock.setblocking(False)
    got = []
    try:
        while True:
            got.append(sock.recv(256).decode())
    except BlockingIOError:
        return got
    finally:
        sock.settimeout(5)


def test_ready_watchdog_stopping_arrive(notify_socket: socket.socket) -> None:
    n = notifier_from_env()
    assert n is not None
    n.ready()
    n.watchdog()
    n.watchdog()  # within ping_s of the first: not sent
    n.status("driving the square\nleg 2")
    n.stopping()
    got = [notify_socket.recv(256).decode() for _ in range(4)]
    assert got == ["READY=1", "WATCHDOG=1", "STATUS=driving the square leg 2", "STOPPING=1"]
    assert received(notify_socket) == []


def test_pings_once_per_ping_period(
    notify_socket: socket.socket, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("WATCHDOG_USEC", "2000000")
    monkeypatch.setenv("WATCHDOG_PID", str(os.getpid()))
    n = notifier_from_env()
    assert n is not None and n.ping_s == 0.5
    now = [100.0]
    monkeypatch.setattr("jackson.host.sdnotify.time.monotonic", lambda: now[0])
    pings = 0
    for _ in range(200):  # 2 s of loop turns every 10 ms
        n.watchdog()
        pings += len(received(notify_socket))
        now[0] += 0.01
    assert pings == 4  # at 0, 0.5, 1.0 and 1.5 s: a quarter of WATCHDOG_USEC


def test_watchdog_period_from_the_environment() -> None:
    assert SystemdNotifier(2.0).ping_s == 0.5
    env = {"NOTIFY_SOCKET": "/x", "WATCHDOG_USEC": "2000000", "WATCHDOG_PID": str(os.getpid())}
    assert watchdog_period_s(env) == 2.0
    assert watchdog_period_s({**env, "WATCHDOG_PID": "1"}) is None  # meant for another process
    assert watchdog_period_s({"WATCHDOG_USEC": "0"}) is None
    assert watchdog_period_s({"WATCHDOG_USEC": "2s"}) is None


def test_no_notifier_outside_systemd(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("NOTIFY_SOCKET", raising=False)
    assert notifier_from_env() is None


def test_a_vanished_socket_never_raises(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NOTIFY_SOCKET", str(tmp_path / "gone"))
    n = notifier_from_env()
    assert n is not None
    n.ready()
    n.watchdog()
    n.stopping()
