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
    yield sock
    sock.close()


def test_ready_watchdog_stopping_arrive(notify_socket: socket.socket) -> None:
    n = notifier_from_env({"NOTIFY_SOCKET": os.environ["NOTIFY_SOCKET"]})
    assert n is not None
    n.ready()
    n.watchdog()
    n.watchdog()  # within ping_s of the first: not sent
    n.status("driving the square")
    n.stopping()
    got = [notify_socket.recv(256).decode() for _ in range(4)]
    assert got == ["READY=1", "WATCHDOG=1", "STATUS=driving the square", "STOPPING=1"]


def test_pings_at_a_quarter_of_the_watchdog_period() -> None:
    assert SystemdNotifier(2.0).ping_s == 0.5
    env = {"NOTIFY_SOCKET": "/x", "WATCHDOG_USEC": "2000000", "WATCHDOG_PID": str(os.getpid())}
    assert watchdog_period_s(env) == 2.0
    assert watchdog_period_s({**env, "WATCHDOG_PID": "1"}) is None  # meant for another process
    assert watchdog_period_s({"WATCHDOG_USEC": "0"}) is None


def test_no_notifier_outside_systemd() -> None:
    assert notifier_from_env({}) is None
